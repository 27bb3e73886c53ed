//! Staggering an edge's bubbles against the nodes of a nearby edge across a
//! narrow face.
//!
//! The thesis meshes every edge on its own (§4.1.1, §4.2). Where two edges
//! of one face run closer than about half the spacing (a chamfer, a narrow
//! land between a hole and an outer wall, a fillet's crescent), the face
//! between them has no room for interior bubbles, and its triangles join the
//! two edges' nodes directly. Two chains with the same spacing put their
//! nodes side by side: a strip of width w·d between rungs a spacing d apart
//! splits into triangles whose smallest angle is atan(w). Nodes half a
//! spacing apart across the strip make triangles of base d and height w·d,
//! smallest angle atan(2w): 6.3° → 12.5° at w = 0.11. In the bubble
//! picture, the later edge's bubbles overlap the earlier one's across the
//! face and are pushed into the gaps between them.
//!
//! Here the nodes of edges meshed earlier that share a face with this one
//! and lie closer than [`REACH`]·d to its curve are *ghosts* at their foot
//! points. The edge's nodes are then placed by dynamic programming on its
//! weighted length s = ∫ ds/d (the coordinate of eq. 4.7.1), minimising
//!
//!   Σ_segments (Δs − 1)² + Σ_nodes Σ_ghosts λ_g · (1 − 2|s − s_g|)₊²,
//!   λ_g = [`STRENGTH`] · (1 − w_g / [`REACH`]),
//!
//! so every segment stays near the spacing and every node keeps half a
//! spacing from the ghosts, the more so the narrower the strip. An edge
//! without ghosts keeps the equidistribution and the chain relaxation.
//!
//! A node is a ghost only where the strip is one: the face lies between
//! the two edges (its surface path to the foot point is short, and it is on
//! the face's side of the edge: not a slit, not a blend folding back,
//! [`across`]); the strip is wider than the chords bow (or staggered
//! chords would cross, [`ghost_of`]); it does not taper to a point (a
//! staggered tip has obtuse triangles); and at least two nodes of the other
//! edge lie along it. The engine asks for ghosts on surface meshes only:
//! tetrahedra on the obtuse triangles of a staggered strip came out flatter
//! (docs/decisions.md, session 25).

use crate::error::MeshError;
use crate::geom::{Curve, P3};
use crate::mesh::Mesh;
use crate::model::{EntityRef, Face, Model};

use super::placement::weighted_table;

/// A node of another edge closer than [`REACH`]·d to this edge's curve,
/// `d` the spacing at that node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ghost {
    /// The curve parameter of the node's foot point, strictly inside the
    /// edge's parameter range.
    pub t: f64,
    /// The distance from the node to its foot point, in units of the
    /// spacing at the node; below [`REACH`].
    pub width: f64,
}

/// Nodes closer than this many spacings to an edge are ghosts. At 0.6 a
/// side-by-side pair already gives triangles below 31°, staggered 50°;
/// wider faces place interior bubbles of their own.
pub(crate) const REACH: f64 = 0.6;

/// λ of a ghost at width 0: a node beside it costs 2, eight times a
/// segment half a spacing off, so a strip of two or more nodes staggers at
/// the price of its end segments.
const STRENGTH: f64 = 2.0;

/// Grid steps per spacing of the dynamic programme: positions are found to
/// 1/64 of a spacing.
const STEPS: f64 = 32.0;

/// Segments between this and [`LONGEST`] spacings are allowed.
const SHORTEST: f64 = 0.3;
/// See [`SHORTEST`].
const LONGEST: f64 = 1.8;

/// Edges longer than this many spacings keep the equidistribution: the
/// programme grows with the length times the steps per spacing squared.
const MAX_UNITS: f64 = 4096.0;

/// A ghost whose neighbour along its own edge is nearer the edge than
/// this fraction of its width (or is a vertex both edges share) is on a
/// tapering strip, and is not kept.
const TAPER: f64 = 0.5;

/// Samples of the curve for the bounding box and the first guess of a foot
/// point.
const SAMPLES: usize = 64;

/// The curve `[t0, t1]` sampled for [`ghost_of`]: its points and their
/// bounding box.
pub(crate) struct Sampled {
    ts: Vec<f64>,
    pts: Vec<P3>,
    lo: P3,
    hi: P3,
}

impl Sampled {
    /// Samples `curve` at [`SAMPLES`] + 1 equal parameter steps.
    pub(crate) fn new(curve: &dyn Curve, t0: f64, t1: f64) -> Sampled {
        let ts: Vec<f64> = (0..=SAMPLES)
            .map(|k| t0 + (t1 - t0) * k as f64 / SAMPLES as f64)
            .collect();
        let pts: Vec<P3> = ts.iter().map(|&t| curve.point(t)).collect();
        let (lo, hi) = crate::geom::bounds(&pts);
        Sampled { ts, pts, lo, hi }
    }

    /// Whether `p` is within `r` of the samples' bounding box.
    pub(crate) fn near_box(&self, p: &P3, r: f64) -> bool {
        (0..3).all(|k| p[k] >= self.lo[k] - r && p[k] <= self.hi[k] + r)
    }
}

/// The ghost of a node at `p` with spacing `d` on the curve, if its foot
/// point is inside the range, nearer than [`REACH`]·d, and farther than
/// the chords bow: (κ_node + κ_foot)·d/4 spacings, twice the sagitta
/// κd²/8 of a segment a spacing long on each side (`kappa` the curvature
/// of the node's own edge there, 0 at a vertex). Closer than that, a chord
/// of one edge passes beyond the other edge's nodes when they are
/// staggered, and the face's boundary segments would cross. The nearest
/// segment of the samples gives the first guess, Newton's method on
/// (C(t) − p)·C'(t) = 0 the foot.
pub(crate) fn ghost_of(
    curve: &dyn Curve,
    s: &Sampled,
    p: &P3,
    d: f64,
    kappa: f64,
) -> Option<Ghost> {
    if !(d > 0.0) || !s.near_box(p, REACH * d) {
        return None;
    }
    let (mut best, mut t) = (f64::INFINITY, s.ts[0]);
    for k in 0..SAMPLES {
        let (a, b) = (s.pts[k], s.pts[k + 1]);
        let ab = b - a;
        let l2 = ab.norm_squared();
        let f = if l2 > 0.0 {
            ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let dist = (a + ab * f - p).norm();
        if dist < best {
            best = dist;
            t = s.ts[k] + f * (s.ts[k + 1] - s.ts[k]);
        }
    }
    if best > 2.0 * REACH * d {
        return None;
    }
    let (t0, t1) = (s.ts[0], s.ts[SAMPLES]);
    for _ in 0..8 {
        let (c, c1, c2) = curve.derivs(t);
        let g = (c - p).dot(&c1);
        let dg = c1.norm_squared() + (c - p).dot(&c2);
        if !(dg > 0.0) {
            break;
        }
        let next = (t - g / dg).clamp(t0, t1);
        let done = (next - t).abs() <= 1e-12 * (t1 - t0).abs();
        t = next;
        if done {
            break;
        }
    }
    let margin = 1e-6 * (t1 - t0).abs();
    if t <= t0.min(t1) + margin || t >= t0.max(t1) - margin {
        return None;
    }
    let (c, c1, c2) = curve.derivs(t);
    let width = (c - p).norm() / d;
    let bow = (kappa + curvature(&c1, &c2)) * d / 4.0;
    (width < REACH && width > bow).then_some(Ghost { t, width })
}

/// The curvature |C' × C''| / |C'|³ of a curve with derivatives `c1`,
/// `c2` (0 where C' vanishes).
pub(crate) fn curvature(c1: &crate::geom::V3, c2: &crate::geom::V3) -> f64 {
    let n = c1.norm();
    if n > 0.0 {
        c1.cross(c2).norm() / (n * n * n)
    } else {
        0.0
    }
}

/// The interior node parameters of the open edge `[t0, t1]` placed against
/// `ghosts` (see the module docs), sorted; `None` when the edge is too long
/// for the programme (the caller equidistributes).
pub(crate) fn place(
    curve: &dyn Curve,
    t0: f64,
    t1: f64,
    ghosts: &[Ghost],
    d_at: &mut dyn FnMut(f64, &P3) -> Result<f64, MeshError>,
) -> Result<Option<Vec<f64>>, MeshError> {
    let (ts, cum) = weighted_table(curve, t0, t1, d_at)?;
    let total = cum[cum.len() - 1];
    if total > MAX_UNITS {
        return Ok(None);
    }
    // the weighted position of a parameter, and back, on the table
    let s_of = |t: f64| -> f64 {
        let f = (t - t0) / (t1 - t0) * (ts.len() - 1) as f64;
        let k = (f.floor() as usize).min(ts.len() - 2);
        cum[k] + (f - k as f64) * (cum[k + 1] - cum[k])
    };
    let t_of = |s: f64| -> f64 {
        let k = cum.partition_point(|&c| c < s).clamp(1, cum.len() - 1) - 1;
        let f = (s - cum[k]) / (cum[k + 1] - cum[k]).max(f64::MIN_POSITIVE);
        ts[k] + f.clamp(0.0, 1.0) * (ts[k + 1] - ts[k])
    };
    let n = ((STEPS * total).ceil() as usize).max(1);
    let h = total / n as f64;
    // the ghosts' cost at each grid position
    let mut node_cost = vec![0.0; n + 1];
    for g in ghosts {
        let sg = s_of(g.t);
        let lambda = STRENGTH * (1.0 - g.width / REACH).max(0.0);
        let lo = ((sg - 0.5) / h).ceil().max(1.0) as usize;
        let hi = (((sg + 0.5) / h).floor() as usize).min(n - 1);
        for (j, c) in node_cost.iter_mut().enumerate().take(hi + 1).skip(lo) {
            let x = 1.0 - 2.0 * (j as f64 * h - sg).abs();
            if x > 0.0 {
                *c += lambda * x * x;
            }
        }
    }
    let (lo_steps, hi_steps) = (
        ((SHORTEST / h).ceil() as usize).max(1),
        (LONGEST / h).floor() as usize,
    );
    let mut best = vec![f64::INFINITY; n + 1];
    let mut from = vec![usize::MAX; n + 1];
    best[0] = 0.0;
    for j in 1..=n {
        let first = j.saturating_sub(hi_steps);
        let last = j.saturating_sub(lo_steps);
        for i in first..=last.min(j - 1) {
            if !best[i].is_finite() {
                continue;
            }
            let seg = (j - i) as f64 * h - 1.0;
            let c = best[i] + seg * seg;
            if c < best[j] {
                best[j] = c;
                from[j] = i;
            }
        }
        if j < n {
            best[j] += node_cost[j];
        }
    }
    if from[n] == usize::MAX {
        // shorter than the shortest segment: no interior node
        return Ok(Some(Vec::new()));
    }
    let mut out = Vec::new();
    let mut j = from[n];
    while j > 0 {
        out.push(t_of(j as f64 * h));
        j = from[j];
    }
    out.reverse();
    Ok(Some(out))
}

/// For every edge, the edges of lower index that bound a face with it
/// (loops and embedded edges), with that face: the edges whose nodes can be
/// its ghosts. Sorted by edge, then face.
pub(crate) fn earlier_neighbours(model: &Model) -> Vec<Vec<(u32, u32)>> {
    let mut out: Vec<Vec<(u32, u32)>> = vec![Vec::new(); model.edges.len()];
    for (fi, f) in model.faces.iter().enumerate() {
        let mut es: Vec<u32> = f
            .loops
            .iter()
            .flat_map(|l| l.edges.iter().map(|u| u.edge))
            .chain(f.embedded_edges.iter().copied())
            .collect();
        es.sort_unstable();
        es.dedup();
        for (k, &b) in es.iter().enumerate() {
            if let Some(row) = out.get_mut(b as usize) {
                row.extend(es[..k].iter().map(|&a| (a, fi as u32)));
            }
        }
    }
    for row in &mut out {
        row.sort_unstable();
        row.dedup();
    }
    out
}

/// Whether the node at `p` faces the edge's curve at `t` across `face`:
/// the shortest way from `p` to the foot point C(t) runs over the face's
/// surface (the path along the straight (u,v) segment between their
/// inverses, the nearer copy across a period, is at most [`DETOUR`] times
/// their distance), on the face's side of the edge (`left` > 0 where the
/// face lies left of the loop's direction in (u,v), < 0 right of it, 0 where
/// unknown, [`face_side`]; `forward` is the edge's direction in the loop).
/// Two edges of one face
/// can be close in space with the face far around between them (a blend
/// that folds back) or not between them at all (a slit narrower than the
/// spacing); their nodes do not face each other across it.
fn across(face: &Face, curve: &dyn Curve, (forward, left): (bool, f64), p: &P3, t: f64) -> bool {
    let surface = face.surface.as_ref();
    let q = curve.point(t);
    let Some(a) = surface.inverse(p, None) else {
        return false;
    };
    let Some(b) = surface.inverse(&q, Some(a)) else {
        return false;
    };
    let near = |mut x: [f64; 2]| {
        for (c, period) in surface.periods().into_iter().enumerate() {
            if let Some(per) = period {
                x[c] = b[c] + ((x[c] - b[c]) - per * ((x[c] - b[c]) / per).round());
            }
        }
        x
    };
    let a = near(a);
    let direct = (q - p).norm();
    let at = |f: f64| surface.point(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
    let (mut prev, mut path) = (at(0.0), 0.0);
    if (prev - p).norm() > 0.25 * direct || (at(1.0) - q).norm() > 0.25 * direct {
        return false;
    }
    for k in 1..=PATH_PIECES {
        let next = at(k as f64 / PATH_PIECES as f64);
        path += (next - prev).norm();
        prev = next;
    }
    if path > DETOUR * direct {
        return false;
    }
    if left == 0.0 {
        return true;
    }
    // the edge's direction in the loop at the foot, in (u,v)
    let (t0, t1) = curve.interval();
    let dt = 1e-4 * (t1 - t0);
    let (Some(u0), Some(u1)) = (
        surface.inverse(&curve.point((t - dt).max(t0)), Some(b)),
        surface.inverse(&curve.point((t + dt).min(t1)), Some(b)),
    ) else {
        return false;
    };
    let (u0, u1) = (near(u0), near(u1));
    let sign = if forward { 1.0 } else { -1.0 };
    let dir = [sign * (u1[0] - u0[0]), sign * (u1[1] - u0[1])];
    let side = dir[0] * (a[1] - b[1]) - dir[1] * (a[0] - b[0]);
    side * left > 0.0
}

/// Which side of loop `li` of `face` the face lies on in (u,v): 1.0 left
/// of the loop's direction, -1.0 right of it, 0.0 unknown (a periodic
/// surface, whose loops may close only across a period, or a point that
/// does not map back). The loops' (u,v) polygons from their edges sampled
/// at [`LOOP_SAMPLES`] points each: the outer loop is the one of largest
/// area, the face lies inside it and outside the others. This reads no
/// convention of the adapter's on the loops' directions (a STEP face of
/// reversed sense may list its outer loop clockwise in (u,v)).
pub(crate) fn face_side(model: &Model, face: &Face, li: usize) -> f64 {
    let surface = face.surface.as_ref();
    if surface.periods().iter().any(Option::is_some) {
        return 0.0;
    }
    let mut areas = Vec::with_capacity(face.loops.len());
    for l in &face.loops {
        let mut poly: Vec<[f64; 2]> = Vec::new();
        for u in &l.edges {
            let edge = &model.edges[u.edge as usize];
            for k in 0..LOOP_SAMPLES {
                let f = k as f64 / LOOP_SAMPLES as f64;
                let f = if u.forward { f } else { 1.0 - f };
                let p = edge.curve.point(edge.t0 + f * (edge.t1 - edge.t0));
                match surface.inverse(&p, poly.last().copied()) {
                    Some(x) => poly.push(x),
                    None => return 0.0,
                }
            }
        }
        let n = poly.len();
        let twice: f64 = (0..n)
            .map(|k| {
                let (a, b) = (poly[k], poly[(k + 1) % n]);
                a[0] * b[1] - a[1] * b[0]
            })
            .sum();
        areas.push(twice);
    }
    let outer = (0..areas.len())
        .max_by(|&x, &y| areas[x].abs().total_cmp(&areas[y].abs()))
        .unwrap_or(0);
    let ccw = areas.get(li).copied().unwrap_or(0.0).signum();
    if li == outer {
        ccw
    } else {
        -ccw
    }
}

/// Samples per edge of a loop's polygon in [`face_side`].
const LOOP_SAMPLES: usize = 8;

/// See [`across`].
const DETOUR: f64 = 1.5;
/// Pieces of the path in [`across`].
const PATH_PIECES: usize = 8;

/// The ghosts of edge `ei` among the nodes of the already meshed edges
/// `earlier` (edge, shared face; `edge_nodes[a]` from start to end vertex),
/// its own end vertices excluded; sorted by parameter.
/// `sides` keeps [`face_side`] per (face, loop) from one edge to the next.
pub(crate) fn ghosts_of_edge(
    model: &Model,
    ei: usize,
    earlier: &[(u32, u32)],
    edge_nodes: &[Vec<u32>],
    mesh: &Mesh,
    node_d: &[f64],
    sides: &mut std::collections::HashMap<(u32, usize), f64>,
) -> Vec<Ghost> {
    let edge = &model.edges[ei];
    if edge.start == edge.end || earlier.is_empty() {
        return Vec::new();
    }
    let curve = edge.curve.as_ref();
    let mut sampled: Option<Sampled> = None;
    let mut out: Vec<Ghost> = Vec::new();
    // nodes already ghosts through another shared face
    let mut seen: rustc_hash::FxHashSet<u32> = Default::default();
    for &(a, fi) in earlier {
        let Some(ids) = edge_nodes.get(a as usize) else {
            continue;
        };
        let face = &model.faces[fi as usize];
        // the edge's one use in the face's loops (a seam, used twice, has
        // the face on both sides)
        let mut uses = face.loops.iter().enumerate().flat_map(|(li, l)| {
            l.edges
                .iter()
                .filter(|u| u.edge as usize == ei)
                .map(move |u| (li, u.forward))
        });
        let (Some((li, forward)), None) = (uses.next(), uses.next()) else {
            continue;
        };
        // each node's ghost, and its width for the taper test: 0 at a
        // vertex the two edges share, unbounded where it is no ghost
        let mut found: Vec<(Option<Ghost>, f64)> = Vec::with_capacity(ids.len());
        for &v in ids {
            if v == edge.start || v == edge.end {
                found.push((None, 0.0));
                continue;
            }
            let node = &mesh.nodes[v as usize];
            let (p, d) = (node.pos, node_d[v as usize]);
            let kappa = if node.entity == EntityRef::new(1, a) {
                let (_, c1, c2) = model.edges[a as usize].curve.derivs(node.params[0]);
                curvature(&c1, &c2)
            } else {
                0.0
            };
            let s = sampled.get_or_insert_with(|| Sampled::new(curve, edge.t0, edge.t1));
            let g = ghost_of(curve, s, &p, d, kappa);
            found.push((g, g.map_or(f64::INFINITY, |g| g.width)));
        }
        let mut kept: Vec<(u32, Ghost)> = Vec::new();
        for (k, &v) in ids.iter().enumerate() {
            let Some(g) = found[k].0 else {
                continue;
            };
            // a strip that narrows to a point (a wedge, a tangent tip)
            // keeps the nodes side by side near it: staggered there, its
            // triangles turn obtuse and the tetrahedra on them flat
            let taper = [k.checked_sub(1), Some(k + 1)]
                .into_iter()
                .flatten()
                .filter_map(|j| found.get(j))
                .any(|&(_, w)| w < TAPER * g.width);
            if taper || seen.contains(&v) {
                continue;
            }
            let left = *sides
                .entry((fi, li))
                .or_insert_with(|| face_side(model, face, li));
            if across(
                face,
                curve,
                (forward, left),
                &mesh.nodes[v as usize].pos,
                g.t,
            ) {
                kept.push((v, g));
            }
        }
        // one node beside the edge is a strip's end or a bend, not a
        // strip: at least two are
        if kept.len() >= 2 {
            for (v, g) in kept {
                out.push(g);
                seen.insert(v);
            }
        }
    }
    out.sort_by(|x, y| x.t.total_cmp(&y.t));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::V3;

    /// The segment from (0,0,0) to (len,0,0), C(t) = (t, 0, 0).
    #[derive(Debug)]
    struct Line(f64);

    impl Curve for Line {
        fn interval(&self) -> (f64, f64) {
            (0.0, self.0)
        }
        fn point(&self, t: f64) -> P3 {
            P3::new(t, 0.0, 0.0)
        }
        fn d1(&self, _t: f64) -> V3 {
            V3::new(1.0, 0.0, 0.0)
        }
        fn d2(&self, _t: f64) -> V3 {
            V3::zeros()
        }
    }

    /// A strip of width 0.1 between two lines of length 6 at spacing 1: the
    /// nodes of the earlier line at 1, ..., 5 are ghosts, and the later
    /// line's nodes fall between them (one between each two neighbours,
    /// at least 0.4 from every ghost) instead of beside them, so the
    /// strip's triangles get about atan(0.2) instead of atan(0.1).
    #[test]
    fn nodes_across_a_narrow_strip_fall_between_the_ghosts() {
        let line = Line(6.0);
        let s = Sampled::new(&line, 0.0, 6.0);
        let ghosts: Vec<Ghost> = (1..6)
            .filter_map(|k| ghost_of(&line, &s, &P3::new(k as f64, 0.1, 0.0), 1.0, 0.0))
            .collect();
        assert_eq!(ghosts.len(), 5);
        for (k, g) in ghosts.iter().enumerate() {
            assert!((g.t - (k + 1) as f64).abs() < 1e-9 && (g.width - 0.1).abs() < 1e-9);
        }
        let ts = place(&line, 0.0, 6.0, &ghosts, &mut |_, _| Ok(1.0))
            .unwrap()
            .unwrap();
        for w in ghosts.windows(2) {
            let between = ts.iter().filter(|&&t| t > w[0].t && t < w[1].t).count();
            assert_eq!(between, 1, "{ts:?}");
        }
        for t in &ts {
            let gap = ghosts
                .iter()
                .map(|g| (g.t - t).abs())
                .fold(f64::INFINITY, f64::min);
            assert!(gap >= 0.4, "{ts:?}");
        }
    }

    /// Nodes farther than REACH·d, or whose foot point is an end of the
    /// edge (a line continuing it, an edge across its end), are not ghosts;
    /// without ghosts the programme spaces the nodes evenly.
    #[test]
    fn far_nodes_and_feet_at_the_ends_are_not_ghosts() {
        let line = Line(4.0);
        let s = Sampled::new(&line, 0.0, 4.0);
        assert!(ghost_of(&line, &s, &P3::new(2.0, 0.7, 0.0), 1.0, 0.0).is_none());
        assert!(ghost_of(&line, &s, &P3::new(4.3, 0.0, 0.0), 1.0, 0.0).is_none());
        assert!(ghost_of(&line, &s, &P3::new(-0.2, 0.1, 0.0), 1.0, 0.0).is_none());
        assert!(ghost_of(&line, &s, &P3::new(2.0, 0.5, 0.0), 1.0, 0.0).is_some());
        let ts = place(&line, 0.0, 4.0, &[], &mut |_, _| Ok(1.0))
            .unwrap()
            .unwrap();
        assert_eq!(ts.len(), 3);
        for (k, t) in ts.iter().enumerate() {
            assert!((t - (k + 1) as f64).abs() <= 1.0 / 32.0, "{ts:?}");
        }
    }
}
