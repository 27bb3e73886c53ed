//! A face's geometry from its boundary loops, shared by the STEP and
//! truck-modeling paths: the loops are sampled and mapped onto the surface
//! (inverse search with a hint), unwrapped across periodic seams, and the
//! face gets a [`FaceView`] of its surface: periodic only where a loop wraps
//! around, its (u,v) box otherwise, turned where the face runs past its
//! wrapping loop to the top of its range.

use std::sync::Arc;

use bubblemesh_core::geom::{bisect_steps, nearest_turn, Surface, P3, V3};
use bubblemesh_core::model::{Face, Loop, Model};

use crate::face_view::FaceView;

fn errs(m: impl Into<String>) -> String {
    m.into()
}

/// Whether a face's loops are known to keep the face on their left (seen
/// from the face's normal), which tells a face outside all of its loops (a
/// sphere less a cap) from one inside them.
#[derive(Clone, Copy, Debug)]
pub(crate) enum LoopSense {
    /// Not known (the truck modeling path): the largest loop is the outer
    /// one.
    Unknown,
    /// Known (STEP: loops with the face on their left, `same_sense`
    /// relating the face's normal to the surface's); `sphere` (centre,
    /// radius) when the surface is a sphere, which a face outside its
    /// loops is built on turned into its largest loop.
    Oriented { sphere: Option<(P3, f64)> },
}

/// The face on `base` bounded by `loops` (model edges, each loop closed,
/// oriented with the face on its left seen from the face's normal, which is
/// S_u × S_v of `base` when `same_sense`), with `embedded` vertices (poles,
/// apexes). `planar`: `base` is a plane (the face keeps it as is). `extent`:
/// the model's size, for the distance checks (boundary points must lie
/// within 1e-3 × extent of the surface). Errors are messages about the
/// face (the caller names it).
#[allow(clippy::too_many_arguments)]
pub(crate) fn face_from_loops(
    base: Arc<dyn Surface>,
    planar: bool,
    same_sense: bool,
    loops: Vec<Loop>,
    embedded: Vec<u32>,
    model: &Model,
    extent: f64,
    name: String,
) -> Result<Face, String> {
    face_from_loops_within(
        base,
        planar,
        same_sense,
        loops,
        embedded,
        model,
        1e-3 * extent,
        name,
        LoopSense::Unknown,
    )
    .map(|(f, _)| f)
}

/// The closest point of `s` to `p` by sampling: the best of a 48 × 48 grid
/// over the surface's (finite) domain, refined by halving a 3 × 3 pattern
/// around it. A fallback where Newton's inversion does not converge (a
/// point well off the surface, a hint far from the answer); `None` on an
/// infinite domain.
pub(crate) fn closest_by_search(s: &dyn Surface, p: &P3) -> Option<[f64; 2]> {
    let (u, v) = s.domain();
    if ![u[0], u[1], v[0], v[1]].iter().all(|x| x.is_finite()) {
        return None;
    }
    const N: usize = 48;
    let dist = |x: [f64; 2]| {
        let d = (s.point(x[0], x[1]) - p).norm_squared();
        if d.is_finite() {
            d
        } else {
            f64::INFINITY
        }
    };
    let mut best = ([u[0], v[0]], f64::INFINITY);
    for i in 0..=N {
        for j in 0..=N {
            let x = [
                u[0] + (u[1] - u[0]) * i as f64 / N as f64,
                v[0] + (v[1] - v[0]) * j as f64 / N as f64,
            ];
            let d = dist(x);
            if d < best.1 {
                best = (x, d);
            }
        }
    }
    if !best.1.is_finite() {
        return None;
    }
    let mut h = [(u[1] - u[0]) / N as f64, (v[1] - v[0]) / N as f64];
    for _ in 0..60 {
        let mut moved = false;
        for du in [-1.0, 0.0, 1.0] {
            for dv in [-1.0, 0.0, 1.0] {
                let x = [
                    (best.0[0] + du * h[0]).clamp(u[0], u[1]),
                    (best.0[1] + dv * h[1]).clamp(v[0], v[1]),
                ];
                let d = dist(x);
                if d < best.1 {
                    best = (x, d);
                    moved = true;
                }
            }
        }
        if !moved {
            h = [0.5 * h[0], 0.5 * h[1]];
        }
    }
    Some(best.0)
}

/// [`face_from_loops`] accepting boundary points up to `far` off the surface
/// (they are projected onto it); also returns the largest such gap.
#[allow(clippy::too_many_arguments)]
pub(crate) fn face_from_loops_within(
    base: Arc<dyn Surface>,
    planar: bool,
    same_sense: bool,
    loops: Vec<Loop>,
    embedded: Vec<u32>,
    model: &Model,
    far: f64,
    name: String,
    sense: LoopSense,
) -> Result<(Face, f64), String> {
    // boundary samples in the base surface's (u,v), each loop unwrapped
    let mut hint: Option<[f64; 2]> = None;
    let mut loops_uv: Vec<Vec<[f64; 2]>> = Vec::new();
    let gap = std::cell::Cell::new(0.0f64);
    let invert = |p: &P3, hint: Option<[f64; 2]>, what: &str| -> Result<[f64; 2], String> {
        let off = |uv: [f64; 2]| (base.point(uv[0], uv[1]) - p).norm();
        let mut found = base.inverse(p, hint).map(|uv| (uv, off(uv)));
        // Newton from the hint lost its way or stopped far off: a global
        // search, by the surface's own seeds, then by sampling
        if !found.is_some_and(|(_, d)| d <= far) {
            let more = [
                hint.and_then(|_| base.inverse(p, None)),
                closest_by_search(base.as_ref(), p),
            ];
            for uv in more.into_iter().flatten() {
                let d = off(uv);
                if d.is_finite() && found.map_or(true, |(_, b)| d < b) {
                    found = Some((uv, d));
                }
            }
        }
        let (uv, d) = found.ok_or_else(|| {
            format!(
                "{what} ({:.6}, {:.6}, {:.6}) cannot be mapped onto its surface",
                p.x, p.y, p.z
            )
        })?;
        if !(d <= far) {
            return Err(format!(
                "{what} ({:.6}, {:.6}, {:.6}) lies {d:.3e} off its surface (at most {far:.3e} accepted)",
                p.x, p.y, p.z
            ));
        }
        gap.set(gap.get().max(d));
        Ok(uv)
    };
    const K: usize = 8;
    let periods = base.periods();
    // a step between samples that turns a periodic coordinate by more than
    // a quarter of its period is bisected (a whole circle in one edge is
    // sampled in eighths): a loop passing near a pole turns u by almost half
    // a turn within a short arc, a step across it could be unwrapped the
    // wrong way round, and the loops' net turns decide whether the face
    // wraps around its surface (the engine checks its own nodes' steps the
    // same way, `FaceJob::check_steps_around_poles`)
    let jumps = |a: [f64; 2], b: [f64; 2]| {
        (0..2).any(|c| periods[c].is_some_and(|p| nearest_turn(b[c] - a[c], p).abs() > p / 4.0))
    };
    for l in &loops.iter().map(|l| l.edges.clone()).collect::<Vec<_>>() {
        let mut pts: Vec<[f64; 2]> = Vec::new();
        for u in l {
            let e = &model.edges[u.edge as usize];
            let at = |s: f64| edge_point(e, u.forward, s);
            // (edge parameter fraction, (u,v)), the edge's end included
            let mut samples: Vec<(f64, [f64; 2])> = Vec::with_capacity(K + 1);
            for k in 0..=K {
                let s = k as f64 / K as f64;
                let uv = invert(&at(s), hint, "boundary point")?;
                hint = Some(uv);
                samples.push((s, uv));
            }
            bisect_steps(&mut samples, 64 * K, jumps, |sm, a| {
                invert(&at(sm), Some(a), "boundary point")
            })?;
            // the edge's last point is the next edge's first
            samples.pop();
            pts.extend(samples.into_iter().map(|(_, uv)| uv));
        }
        loops_uv.push(pts);
    }
    let (bu, bv) = base.domain();
    let bdom = [bu, bv];
    let mut keep = [false, false];
    // each loop's net displacement in the periodic directions
    let mut nets: Vec<[f64; 2]> = Vec::with_capacity(loops_uv.len());
    for l in loops_uv.iter_mut() {
        let mut net = [0.0f64; 2];
        for k in 1..=l.len() {
            let prev = l[k - 1];
            let cur = if k < l.len() { l[k] } else { l[0] };
            for c in 0..2 {
                if let Some(p) = periods[c] {
                    let d = nearest_turn(cur[c] - prev[c], p);
                    net[c] += d;
                    if k < l.len() {
                        l[k][c] = prev[c] + d;
                    }
                }
            }
        }
        for c in 0..2 {
            if let Some(p) = periods[c] {
                if net[c].abs() > 0.5 * p {
                    keep[c] = true;
                }
            }
        }
        nets.push(net);
    }
    if loops_uv.is_empty() {
        keep = [periods[0].is_some(), periods[1].is_some()];
    }
    // A face none of whose loops wraps around its periodic surface, with
    // the face outside the largest (on its right, seen from the face's
    // normal), is the closed surface minus the loops' insides: a sphere
    // with a dimple or a second, overlapping void cut out (OpenCascade
    // writes it with a VERTEX_LOOP at a pole it keeps). Its (u,v) box would
    // read it as the inside of the loop, the cut-out cap. On a sphere the
    // poles are moved into the largest loop (the axis along the loop's
    // vector area): the loop then wraps around the axis and the face runs
    // from it to the far pole like any cap, the other loops holes in it.
    // Other closed surfaces are refused rather than meshed as the wrong
    // side.
    let oriented = match sense {
        LoopSense::Unknown => None,
        LoopSense::Oriented { sphere } => Some(sphere),
    };
    const OUTSIDE: &str =
        "its loops are all holes in its closed surface (the face is the surface minus their insides)";
    // the axis to turn the sphere to, and whether the face cannot be read
    // without the turn
    let mut turn: Option<(P3, f64, V3, bool)> = None;
    if let (Some(sphere), [false, false], false, true) = (
        oriented,
        keep,
        loops_uv.is_empty(),
        periods.iter().any(|p| p.is_some()),
    ) {
        let sense = if same_sense { 1.0 } else { -1.0 };
        let largest = (0..loops_uv.len())
            .max_by(|&i, &j| area(&loops_uv[i]).total_cmp(&area(&loops_uv[j])))
            .unwrap_or(0);
        if signed_area(&loops_uv[largest]) * sense < 0.0 {
            let Some((centre, radius)) = sphere else {
                return Err(errs(format!("{OUTSIDE}: supported on spheres only")));
            };
            // the other holes stay holes on the turned sphere (a second
            // void's cap and a drilled hole: rp_1_030, now a test)
            let pts = loop_points(model, &loops[largest], K);
            let mut vector_area = V3::zeros();
            for k in 0..pts.len() {
                vector_area += (pts[k] - centre).cross(&(pts[(k + 1) % pts.len()] - centre));
            }
            turn = Some((centre, radius, vector_area, true));
        }
    }
    // A sphere face with a loop that passes very close by a pole, not
    // through it: a step of its nodes there turns u by nearly half a turn,
    // which the engine can only follow with nodes far finer than the
    // spacing (a void pierced by a hole 0.001 off its poles, r/2900, was
    // refused after every refinement). The sphere is turned so that the
    // pole lies amid that loop (the axis through the mean of its points),
    // far from it. Not for loops a few hundredths of r off: the engine's
    // refinement meshes those (rp_4_009, 0.034 r: two rounds at half the
    // spacing), where on the turned sphere of radius below the spacing
    // the other hole fell into the far pole's cap (six rounds). A face that
    // runs to a pole with a loop farther off, up to a quarter of the
    // radius, is turned below.
    if let (None, Some(Some((centre, radius))), false) = (turn, oriented, loops_uv.is_empty()) {
        let poles = base.singular_points();
        let clearance = |l: &[[f64; 2]]| {
            l.iter()
                .flat_map(|uv| {
                    let p = base.point(uv[0], uv[1]);
                    poles.iter().map(move |q| (p - q).norm())
                })
                .fold(f64::INFINITY, f64::min)
        };
        let grazed = (0..loops_uv.len())
            .map(|i| (clearance(&loops_uv[i]), i))
            .filter(|&(c, _)| c > 1e-6 * radius && c < POLE_CLEARANCE * radius)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((_, i)) = grazed {
            let pts = loop_points(model, &loops[i], K);
            let mean = pts.iter().fold(V3::zeros(), |a, p| a + (p - centre)) / pts.len() as f64;
            turn = Some((centre, radius, mean, false));
        }
    }
    // the face read again on its sphere turned to `axis` (the loops, the
    // embedded vertices and the name copied: only a turned face pays for
    // it); an error where that sphere cannot be made
    let read_turned = |centre: P3, radius: f64, axis: V3| {
        let turned = bubblemesh_analytic::Frame::new(centre, axis)
            .and_then(|f| bubblemesh_analytic::Sphere::with_frame(f, radius))?;
        Ok::<_, bubblemesh_analytic::surfaces::SurfaceError>(face_from_loops_within(
            Arc::new(turned),
            planar,
            same_sense,
            loops.clone(),
            embedded.clone(),
            model,
            far,
            name.clone(),
            LoopSense::Oriented { sphere: None },
        ))
    };
    if let Some((centre, radius, axis, needed)) = turn {
        match read_turned(centre, radius, axis) {
            Ok(face) => return face,
            Err(e) if needed => {
                return Err(errs(format!(
                    "{OUTSIDE}: its sphere cannot be turned ({e})"
                )))
            }
            Err(_) => {}
        }
    }
    // other loops (and embedded vertices) moved next to the first loop
    let centre = |l: &[[f64; 2]]| {
        let n = l.len().max(1) as f64;
        [
            l.iter().map(|x| x[0]).sum::<f64>() / n,
            l.iter().map(|x| x[1]).sum::<f64>() / n,
        ]
    };
    let c0 = loops_uv.first().map(|l| centre(l));
    let mut extra: Vec<[f64; 2]> = Vec::new();
    for &v in &embedded {
        let p = model.vertices[v as usize].point;
        extra.push(invert(&p, hint, "vertex")?);
    }
    if let Some(c0) = c0 {
        for l in loops_uv.iter_mut().skip(1) {
            let c = centre(l);
            for k in 0..2 {
                if let (Some(p), false) = (periods[k], keep[k]) {
                    let s = p * ((c0[k] - c[k]) / p).round();
                    for x in l.iter_mut() {
                        x[k] += s;
                    }
                }
            }
        }
        for x in extra.iter_mut() {
            for k in 0..2 {
                if let (Some(p), false) = (periods[k], keep[k]) {
                    x[k] += p * ((c0[k] - x[k]) / p).round();
                }
            }
        }
    }
    if planar {
        let mut order: Vec<usize> = (0..loops.len()).collect();
        order.sort_by(|&i, &j| area(&loops_uv[j]).total_cmp(&area(&loops_uv[i])));
        return Ok((
            Face {
                surface: base,
                loops: order.iter().map(|&i| loops[i].clone()).collect(),
                embedded_edges: vec![],
                embedded_vertices: embedded,
                name: Some(name),
            },
            gap.get(),
        ));
    }
    if keep[0] && keep[1] && !loops.is_empty() {
        return Err(errs("a face with boundary loops that wraps around its surface in both directions is not supported",
        ));
    }
    // A face that wraps around in one direction c may run from its
    // wrapping loops to an end of the other direction o where the surface
    // collapses (a cap to a sphere's pole): which end follows from the
    // loops' sense. A loop keeps the face on its left, seen from the face's
    // normal (S_u × S_v when same_sense): running +u it has the face at +v,
    // running +v it has the face at −u. `open_end` is Some(1) when the face
    // reaches the +o end, Some(0) the −o end, None when wrapping loops
    // bound it on both sides (a band).
    let mut open_end: Option<usize> = None;
    let wrap_dir = match keep {
        [true, false] => Some(0),
        [false, true] => Some(1),
        _ => None,
    };
    if let (Some(c), false) = (wrap_dir, loops_uv.is_empty()) {
        let p = periods[c].expect("a kept direction is periodic");
        let sense = if same_sense { 1 } else { -1 };
        let towards_plus: i32 = nets
            .iter()
            .filter(|n| n[c].abs() > 0.5 * p)
            .map(|n| if n[c] > 0.0 { 1 } else { -1 })
            .sum::<i32>()
            * sense
            * if c == 0 { 1 } else { -1 };
        open_end = match towards_plus {
            0 => None,
            1 => Some(1),
            -1 => Some(0),
            k => {
                return Err(errs(format!(
                    "its boundary wraps around its surface {k} times more one way than the other"
                )))
            }
        };
    }
    // A face that runs to a sphere's pole with a loop passing near that
    // pole: turned so that its poles are far from every loop (see
    // `clearer_axis`).
    if let (Some(_), Some(Some((centre, radius)))) = (open_end, oriented) {
        if let Some(axis) = clearer_axis(model, &loops, &base.singular_points(), centre, radius) {
            if let Ok(face) = read_turned(centre, radius, axis) {
                return face;
            }
        }
    }
    // the view's box
    let mut dom = bdom;
    for c in 0..2 {
        if keep[c] {
            continue;
        }
        // a face without edge loops (a whole sphere bounded only by the
        // VERTEX_LOOP at its pole) spans the surface's whole range: its
        // pole points alone would collapse the range to a line
        let vals: Vec<f64> = if loops_uv.iter().any(|l| !l.is_empty()) {
            loops_uv
                .iter()
                .flatten()
                .chain(&extra)
                .map(|x| x[c])
                .collect()
        } else {
            Vec::new()
        };
        if vals.is_empty() {
            if !(bdom[c][0].is_finite() && bdom[c][1].is_finite()) {
                return Err(errs("a face with no boundary on an unbounded surface"));
            }
            continue;
        }
        let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        // exactly the boundary's range: on a periodic view the engine reads
        // the ends of the domain as where the face ends (or caps at a pole)
        let (mut a, mut b) = (lo, hi);
        if periods[c].is_none() {
            a = a.max(bdom[c][0]);
            b = b.min(bdom[c][1]);
        } else if let Some(p) = periods[c] {
            if b - a > p {
                let m = 0.5 * (a + b);
                a = m - 0.5 * p;
                b = m + 0.5 * p;
            }
        }
        dom[c] = [a, b];
        // the face runs on past its loops to a collapsed end in c: the
        // surface's end where it has one (whatever vertices lie between: a
        // VERTEX_LOOP's vertex inside a turned sphere's face is no pole),
        // else the pole or apex vertex the file gives (the range already
        // reaches it)
        let loop_lo = loops_uv
            .iter()
            .flatten()
            .map(|x| x[c])
            .fold(f64::INFINITY, f64::min);
        let loop_hi = loops_uv
            .iter()
            .flatten()
            .map(|x| x[c])
            .fold(f64::NEG_INFINITY, f64::max);
        let reached = |end: usize| {
            // not `clamp`: a NaN width gives the tolerance of width 1e6
            #[allow(clippy::manual_clamp)]
            let tol = 1e-9 * (bdom[c][1] - bdom[c][0]).abs().min(1e6).max(1.0);
            if end == 1 {
                dom[c][1] > loop_hi + tol
            } else {
                dom[c][0] < loop_lo - tol
            }
        };
        if let Some(end) = open_end.filter(|_| wrap_dir == Some(1 - c)) {
            let e = bdom[c][end];
            if e.is_finite() {
                dom[c][end] = e;
            } else if !reached(end) {
                return Err(errs(
                    "it is bounded on one side only by its loops around an unbounded surface",
                ));
            }
        }
    }
    let view_periods = [
        periods[0].filter(|_| keep[0]),
        periods[1].filter(|_| keep[1]),
    ];
    let mut view = FaceView::new(base, (dom[0], dom[1]), view_periods);
    if open_end == Some(1) {
        // the engine reads the far (+) end of the wrapped face's range as
        // outside: turn the view so the face's open end is at the near end
        view = view.turned();
    }
    let loops = if view_periods.iter().all(|p| p.is_none()) {
        let mut order: Vec<usize> = (0..loops.len()).collect();
        order.sort_by(|&i, &j| area(&loops_uv[j]).total_cmp(&area(&loops_uv[i])));
        order.iter().map(|&i| loops[i].clone()).collect()
    } else {
        loops
    };
    let surface: Arc<dyn Surface> = Arc::new(view);
    Ok((
        Face {
            surface,
            loops,
            embedded_edges: vec![],
            embedded_vertices: embedded,
            name: Some(name),
        },
        gap.get(),
    ))
}

/// A loop passing closer than this many radii to a sphere's pole (and not
/// through it) has its sphere turned (see `face_from_loops_within`).
const POLE_CLEARANCE: f64 = 0.01;

/// A sphere face that runs to a pole and whose loops pass within this
/// many radii of it is turned to the axis whose poles are farthest from
/// every loop, where that is at least twice as far ([`clearer_axis`]).
const POLE_NEAR: f64 = 0.25;

/// For a sphere face (`centre`, `radius`) that runs to one of its `poles`
/// and whose `loops` come within [`POLE_NEAR`] radii of them: the axis,
/// out of a few hundred spread evenly over the sphere, whose two poles are
/// farthest from every loop point, if that distance is at least twice the
/// poles' now. A cap
/// near a loop is connected in its tangent plane with the loop's nodes
/// around it; where the loop passes a fraction of the radius off the pole
/// the fill does not close at any spacing (rp_6_033: a dimple of r 3.9
/// whose pole is 0.5 from a drilled hole's edge was refused after eight
/// rounds of refinement, where Gmsh meshes it). A pole off the face (in a
/// hole, or beyond a band's loops) needs no cap, and turning such spheres
/// gave worse meshes (rp_2_015, rp_2_028) or none (rp_4_009: a band whose
/// loops then wrap around no pole). `None`: keep the axis.
fn clearer_axis(
    model: &Model,
    loops: &[Loop],
    poles: &[P3],
    centre: P3,
    radius: f64,
) -> Option<V3> {
    const DENSE: usize = 64;
    const AXES: usize = 400;
    let pts: Vec<P3> = loops
        .iter()
        .flat_map(|l| loop_points(model, l, DENSE))
        .collect();
    let clearance = |qs: &[P3]| {
        pts.iter()
            .flat_map(|p| qs.iter().map(move |q| (p - q).norm()))
            .fold(f64::INFINITY, f64::min)
    };
    let now = clearance(poles);
    if !(now < POLE_NEAR * radius) || pts.is_empty() {
        return None;
    }
    // Fibonacci points on the half sphere: an axis and its opposite have
    // the same poles
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let (axis, best) = (0..AXES)
        .map(|k| {
            let z = 1.0 - (k as f64 + 0.5) / AXES as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * k as f64;
            let dir = V3::new(r * a.cos(), r * a.sin(), z);
            let c = clearance(&[centre + dir * radius, centre - dir * radius]);
            (dir, c)
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (best >= 2.0 * now).then_some(axis)
}

/// `k` points per edge along loop `lp`, in the loop's direction.
fn loop_points(model: &Model, lp: &Loop, k: usize) -> Vec<P3> {
    lp.edges
        .iter()
        .flat_map(|u| {
            let e = &model.edges[u.edge as usize];
            (0..k).map(move |j| edge_point(e, u.forward, j as f64 / k as f64))
        })
        .collect()
}

/// The point of edge `e` at fraction `s` of its parameter range, counted
/// from its start if `forward`, else from its end (as a loop uses it).
fn edge_point(e: &bubblemesh_core::model::Edge, forward: bool, s: f64) -> P3 {
    let s = if forward { s } else { 1.0 - s };
    e.curve.point(e.t0 + (e.t1 - e.t0) * s)
}

/// |signed area| of a closed polygon in (u,v).
fn area(l: &[[f64; 2]]) -> f64 {
    signed_area(l).abs()
}

/// Signed area of a closed polygon in (u,v), positive counter-clockwise.
fn signed_area(l: &[[f64; 2]]) -> f64 {
    let n = l.len();
    // relative to the first point (no cancellation far from the origin)
    let o = l.first().copied().unwrap_or([0.0, 0.0]);
    (0..n)
        .map(|k| {
            let (a, b) = (l[k], l[(k + 1) % n]);
            let (a, b) = ([a[0] - o[0], a[1] - o[1]], [b[0] - o[0], b[1] - o[1]]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        * 0.5
}
