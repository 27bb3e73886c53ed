//! At least `n` nodes per full turn of a curved edge (Gmsh's
//! `Mesh.MinimumCirclePoints`, whose default 7 is ours too).
//!
//! Where the requested spacing d is larger than 2πρ/n (ρ the radius of
//! curvature of an edge that turns at least [`MIN_TURNING`]), the edge
//! takes c = 2πρ/n, and every point within reach grows from it at the
//! gradient [`GRADE`]:
//!
//! d'(x) = min(d(x), min_k (c_k + GRADE·|x − p_k|)),
//!
//! over samples p_k every c_k/2 along the capped stretches of the edges.
//! Vertices, edges and faces take d'; volumes keep d (the engine packs
//! them with the requested spacing, whose uniformity their lattice start
//! needs), so only the volume's boundary is finer near such edges.
//!
//! Why: at the sizes engineers ask for (a part's diagonal / 20 to / 25), a
//! hole of radius r < n·d/2π got one or two segments per half circle. Both
//! halves of the hole then lay on one chord (two faces sharing a mesh edge
//! on no model edge), the final check refused them and the faces were
//! meshed again at an eighth of the spacing; where they passed, the hole's
//! faces were slabs, the enclosed volume off by the hole's cross-section.
//! A mesh that departs from the requested spacing here says so: the
//! capped edges and the faces they grade are in the report
//! ([`CirclePoints::report`]).
//!
//! Faces that turn as far along their own lines take the cap too: a face
//! whose u or v lines turn at least [`MIN_TURNING`] (a cylinder's hole or
//! pin, a pipe, a cone) takes 2πρ/n inside, ρ the radius of curvature
//! along those lines, and grades its neighbours from samples along its
//! edges. Why: the edges' cap grades back to d a few spacings into the
//! face, so the inside of a hole or pipe longer than that went back to
//! three or four nodes per turn (pipe_sweep at diag/20: the tetrahedra
//! enclosed 4.5 % more than the part; capped faces: see [`FaceCap`]).
//!
//! Short edges grade the same way: an edge shorter than [`SHORT_EDGE`]·d
//! is one segment whose ends are nodes, and the spacing around it grows
//! from c = max(its length, [`SHORT_EDGE_FLOOR`]·d) at [`GRADE`] (a small
//! square hole, a narrow step: without it the triangles joining such a
//! segment to neighbours at d were needles — as_40mm_capot.stp mean radius
//! ratio 0.747, Gmsh 0.798; graded 0.85). A short edge that is one of
//! a cusp's two edges closes a tip, and grades from c = max(its length,
//! [`TIP_EDGE_FLOOR`]·d): the first node on the tip's other edge then
//! stands about its length from the tip. `n` = 0 turns both off.
//!
//! Cusps keep the requested spacing: where two edges of a face leave a
//! vertex tangentially or nearly so (`cusp_ends`, within [`CUSP_ANGLE`]),
//! the vertex and those edges within the requested spacing of it are not
//! graded, because nodes close to such a tip make its triangles thinner,
//! not better (see `CirclePoints::at_cusp`). Only where both edges are at
//! least the spacing long.
//!
//! A face the graded spacing cannot mesh is released
//! ([`CirclePoints::release`]): on it, its edges and their vertices the
//! requested spacing applies again (the engine does this before refining
//! it); where a released face fails again the engine drops the cap for the
//! whole model (`CirclePointsReport::dropped`).
//!
//! Invariant: d' ≤ d everywhere, d' > 0 and finite where d is; d' = d
//! farther than (d − c)/GRADE from every capped edge, in volumes and inside
//! released faces.

use crate::curvature::curve_curvature;
use crate::geom::{bounds, P3};
use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};

/// How fast the spacing grows away from a capped edge, per unit of
/// distance (0.4: a spacing of c reaches 2c at 2.5c from the edge).
pub const GRADE: f64 = 0.4;

/// Edges turning less than this (radians, ∫κ ds) are not capped: one chord
/// across a quarter arc (a fillet's end) stays a fair approximation, while
/// capping it put nodes on the tight bend of narrow fillet faces that
/// then folded (as_tie_rod.step). A half circle, the edge a hole is made
/// of, turns π, and one chord across it collapses the hole.
pub const MIN_TURNING: f64 = 0.75 * std::f64::consts::PI;

/// Samples per spacing along a capped stretch: the spacing between them
/// is c/2, so d' on the edge is within GRADE·c/4 (10 %) of its cap.
const SAMPLES_PER_CAP: f64 = 2.0;

/// The most samples one edge gets (a very long edge with a tiny cap is
/// sampled more coarsely along its length; its cap stays exact at the
/// samples).
const MAX_SAMPLES_PER_EDGE: usize = 4096;

/// An edge shorter than this fraction of the requested spacing grades the
/// spacing around it from its length (floored at [`SHORT_EDGE_FLOOR`]·d):
/// its ends are nodes a segment apart however coarse d is, and triangles
/// that join a segment of 0.3·d to neighbours at d are needles (a small
/// square hole in a plate, as_40mm_capot.stp). Gmsh's frontal insertion
/// grades there by construction.
pub const SHORT_EDGE: f64 = 0.6;

/// The least spacing a short edge grades from, as a fraction of the
/// requested one: an edge of CAD dust (a sliver's end, 10⁻³·d) makes poor
/// triangles whatever the spacing around it, so it is not worth refining a
/// region for.
pub const SHORT_EDGE_FLOOR: f64 = 1.0 / 6.0;

/// The least spacing a short edge at a tip grades from (one of the two
/// edges of a cusp, `cusp_ends`), as a fraction of the requested one.
/// The tip's triangle joins the short edge to the first node on the other
/// edge; that node a spacing c from the tip leaves the triangle the angle
/// (l·θ + w)/c at it (l the short edge's length, θ the chords' angle, w how
/// far the short edge's end stands off the other edge), so c is brought
/// down to l: as_0050's 0.033-long edge closes a 0.0014-wide spike, and
/// graded from d/6 its tip triangle had 0.29° and its tetrahedra 0.286°.
pub const TIP_EDGE_FLOOR: f64 = 0.01;

/// Samples (every c/2) of an edge from `t0` to `t1` shorter than
/// [`SHORT_EDGE`] times the least requested spacing d `looks` saw on it,
/// with the cap c = max(length, [`SHORT_EDGE_FLOOR`]·d); and its length, c
/// and d. `None` for any other edge.
fn short_edge(
    curve: &dyn crate::geom::Curve,
    t0: f64,
    t1: f64,
    looks: &[(P3, f64, f64, f64)],
    floor: f64,
) -> Option<(Vec<Sample>, f64, f64, f64)> {
    let d = looks.iter().map(|l| l.1).fold(f64::INFINITY, f64::min);
    if !(d > 0.0 && d.is_finite()) {
        return None;
    }
    let length = crate::geom::length_between(curve, t0, t1);
    if !(length < SHORT_EDGE * d) {
        return None;
    }
    let c = length.max(floor * d);
    let m = (SAMPLES_PER_CAP * length / c).ceil().max(1.0) as usize;
    let samples = (0..=m)
        .map(|k| Sample {
            p: curve.point(t0 + (t1 - t0) * k as f64 / m as f64),
            c,
            reach: 1.5 * (d - c) / GRADE,
        })
        .collect();
    Some((samples, length, c, d))
}

/// The cusps of `model`'s faces: consecutive edges of a face loop whose
/// tangents leave their common vertex at most [`CUSP_ANGLE`] apart (the
/// two curves meet tangentially and the face between them tapers to a
/// point). Returns the two edges (lower id first) and the vertex of each.
pub(crate) fn cusp_ends(model: &Model) -> Vec<([u32; 2], u32)> {
    // the unit tangent of edge `e` leaving vertex `at` (one of its ends)
    let leaving = |e: u32, at: u32| -> Option<crate::geom::V3> {
        let me = &model.edges[e as usize];
        let (t, sign) = if me.start == at {
            (me.t0, 1.0)
        } else {
            (me.t1, -1.0)
        };
        let d = me.curve.d1(t) * sign;
        let n = d.norm();
        (n > 0.0 && n.is_finite()).then(|| d / n)
    };
    let mut out = Vec::new();
    for f in &model.faces {
        for l in &f.loops {
            let k = l.edges.len();
            if k < 2 {
                continue;
            }
            for i in 0..k {
                let (a, b) = (l.edges[i], l.edges[(i + 1) % k]);
                if a.edge == b.edge {
                    continue;
                }
                let ea = &model.edges[a.edge as usize];
                // the vertex where use a ends and use b starts
                let v = if a.forward { ea.end } else { ea.start };
                let (Some(ta), Some(tb)) = (leaving(a.edge, v), leaving(b.edge, v)) else {
                    continue;
                };
                if ta.angle(&tb) <= CUSP_ANGLE {
                    out.push(([a.edge.min(b.edge), a.edge.max(b.edge)], v));
                }
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Per edge the points of its cusp vertices, per vertex whether it is
/// one: the cusps of [`cusp_ends`] whose two edges are both at least the
/// requested spacing `inner` long at the vertex (an edge shorter than the
/// spacing is one piece whatever it is asked for, and the requested spacing
/// at its ends would only make its neighbours' triangles coarser there).
fn cusps(
    model: &Model,
    ends: &[([u32; 2], u32)],
    inner: &dyn Spacing,
) -> (Vec<Vec<P3>>, Vec<bool>) {
    let mut cusp_edges = vec![Vec::new(); model.edges.len()];
    let mut cusp_vertices = vec![false; model.vertices.len()];
    for &(edges, v) in ends {
        let point = model.vertices[v as usize].point;
        let d = inner.spacing(&SpacingQuery {
            point,
            entity: EntityRef::new(0, v),
            params: [0.0, 0.0],
        });
        let long = edges.iter().all(|&e| {
            let me = &model.edges[e as usize];
            crate::geom::length_between(me.curve.as_ref(), me.t0, me.t1) >= d
        });
        if long {
            for e in edges {
                cusp_edges[e as usize].push(point);
            }
            cusp_vertices[v as usize] = true;
        }
    }
    (cusp_edges, cusp_vertices)
}

/// Tangents at most this far apart (radians, 8.6°) make a cusp
/// ([`cusp_ends`]). The tip's triangle has the angle θ + s·Δκ/2 between
/// the chords to the first nodes at distance s (θ the tangents' angle, Δκ
/// the curves' difference of curvature), so while θ is small the first
/// nodes' distance decides it: as_0087's 6.8° tip between a line and a
/// capped fillet edge gave 7.9° with the fillet's spacing there (first
/// nodes 1.8 from the tip) and 13.4° with the requested one (Gmsh 10.8°);
/// at 0.05 rad only tangent tips (as_0042) were cusps.
pub(crate) const CUSP_ANGLE: f64 = 0.15;

/// A point of a capped edge and the spacing there.
#[derive(Clone, Copy, Debug)]
struct Sample {
    p: P3,
    /// The cap 2πρ/n at `p`.
    c: f64,
    /// Beyond this distance c + GRADE·dist exceeds the requested spacing
    /// (with a margin for a spacing that grows away from `p`).
    reach: f64,
}

/// A face whose u or v lines turn at least [`MIN_TURNING`] (see the module
/// docs): queries on it take 2π/(n·κ), κ the larger normal curvature along
/// the lines that turn so far.
struct FaceCap {
    surface: std::sync::Arc<dyn crate::geom::Surface>,
    /// Whether the u lines (v fixed) and the v lines turn far enough.
    along: [bool; 2],
}

impl FaceCap {
    /// 2π/(n·κ) at (u,v), +∞ where the lines are straight or the
    /// parametrization is singular.
    fn cap(&self, uv: [f64; 2], n: u32) -> f64 {
        let k = crate::curvature::parameter_line_curvature(
            &self.surface.derivs(uv[0], uv[1]),
            self.along,
        );
        if k > 0.0 && k.is_finite() {
            std::f64::consts::TAU / (n as f64 * k)
        } else {
            f64::INFINITY
        }
    }
}

/// A face whose cap falls below this fraction of the requested spacing
/// anywhere on its boundary is not capped (its curved edges still are): n
/// nodes per turn along the whole length of a wire or a thread of radius
/// 10⁻³·d would be thousands of bubbles for a feature the spacing does not
/// resolve (pyocc_11752.stp: 434 such faces, 1 s → 106 s).
const FACE_CAP_FLOOR: f64 = 1.0 / 6.0;

/// A face shorter than this many requested spacings across its turning
/// lines (a half cylinder a spacing long) is not capped inside: its capped
/// edges grade it already, and a middle row at exactly 2πρ/n did not match
/// its arcs, whose pieces are rounded (as_0042's four half cylinders, 1.18
/// spacings long: three pieces per arc, four in the middle row, mean
/// radius ratio 0.912 → 0.867). 2 spacings also left out b3d_flange's bolt
/// holes (1.38 spacings, full circles of seven pieces), whose volume error
/// then went back from +1.14 % to +1.46 % (Gmsh +1.01 %); the value is set
/// between the two, measured, not derived.
const FACE_CAP_MIN_LENGTH: f64 = 1.25;

/// Lines per direction and samples per line with which
/// [`turning_lines`] measures a face's turning.
const TURN_LINES: usize = 5;
const TURN_SAMPLES: usize = 32;

/// Which of face `fi`'s parameter lines turn at least [`MIN_TURNING`]
/// (Σ of the angles between the normals of consecutive samples, the
/// largest over [`TURN_LINES`] lines across the box of its boundary's
/// (u,v)), and the longest of its u lines and of its v lines in model
/// units (polylines through the samples); lines of a trimmed face may
/// leave it, so these are estimates.
fn turning_lines(model: &Model, fi: usize) -> ([bool; 2], [f64; 2]) {
    let face = &model.faces[fi];
    let surface = face.surface.as_ref();
    if surface.is_planar() {
        return ([false, false], [0.0, 0.0]);
    }
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let (periods, (du, dv)) = (surface.periods(), surface.domain());
    let origin = [du[0], dv[0]];
    for u in face.loops.iter().flat_map(|l| l.edges.iter()) {
        let e = &model.edges[u.edge as usize];
        let mut hint = None;
        for k in 0..=8 {
            let t = e.t0 + (e.t1 - e.t0) * k as f64 / 8.0;
            let uv = crate::curvature::edge_point_uv_near(model, fi as u32, u.edge, t, hint);
            // in the fundamental domain, as an inversion without a hint
            // gives it (a hint walks on across a seam)
            let wrapped = uv.map(|q| crate::geom::wrap_periodic(q, periods, origin));
            if let Some(q) = wrapped {
                for c in 0..2 {
                    lo[c] = lo[c].min(q[c]);
                    hi[c] = hi[c].max(q[c]);
                }
            }
            hint = uv.or(hint);
        }
    }
    if !(lo[0] < hi[0] && lo[1] < hi[1]) {
        return ([false, false], [0.0, 0.0]);
    }
    // the point and unit normal (None where singular) at (u,v)
    let at = |u: f64, v: f64| {
        let d = surface.derivs(u, v);
        let n = d.su.cross(&d.sv);
        let l = n.norm();
        (d.p, (l > 0.0 && l.is_finite()).then(|| n / l))
    };
    let mut along = [false, false];
    let mut length = [0.0f64; 2];
    for w in 0..2 {
        let o = 1 - w;
        for j in 0..TURN_LINES {
            let across = lo[o] + (hi[o] - lo[o]) * (j as f64 + 0.5) / TURN_LINES as f64;
            let (mut turned, mut long) = (0.0, 0.0);
            let mut last: Option<(P3, Option<crate::geom::V3>)> = None;
            for k in 0..=TURN_SAMPLES {
                let x = lo[w] + (hi[w] - lo[w]) * k as f64 / TURN_SAMPLES as f64;
                let (u, v) = if w == 0 { (x, across) } else { (across, x) };
                let (p, n) = at(u, v);
                if let Some((q, m)) = last {
                    long += (p - q).norm();
                    if let (Some(m), Some(n)) = (m, n) {
                        turned += m.dot(&n).clamp(-1.0, 1.0).acos();
                    }
                }
                last = Some((p, n));
            }
            along[w] |= turned >= MIN_TURNING;
            length[w] = length[w].max(long);
        }
    }
    (along, length)
}

/// One edge (or face, in [`CirclePointsReport::capped_faces`]) whose
/// spacing was capped, for the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CappedEdge {
    /// The edge (or face) id.
    pub edge: u32,
    /// Its name in the input, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Its smallest radius of curvature, in model units.
    pub radius: f64,
    /// The spacing it takes there (2πρ/n), in model units.
    pub d: f64,
    /// The requested spacing there.
    pub requested: f64,
}

/// An edge shorter than [`SHORT_EDGE`] times the spacing, from which the
/// spacing grades, for the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ShortEdge {
    /// The edge id.
    pub edge: u32,
    /// Its name in the input, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Its length, in model units.
    pub length: f64,
    /// The spacing the region around it grades from (its length, at
    /// least [`SHORT_EDGE_FLOOR`] times the requested spacing).
    pub d: f64,
    /// The requested spacing there.
    pub requested: f64,
}

/// What the minimum of nodes per turn and the grading from short edges
/// changed (the run's report).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct CirclePointsReport {
    /// Nodes per full turn asked for.
    pub n: u32,
    /// Curved edges meshed finer than the requested spacing.
    pub edges: Vec<CappedEdge>,
    /// Edges shorter than [`SHORT_EDGE`] times the spacing, from which the
    /// spacing around grades.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub short_edges: Vec<ShortEdge>,
    /// Faces whose own lines turn at least [`MIN_TURNING`] and that are
    /// meshed finer than requested for it (see [`FaceCap`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub capped_faces: Vec<CappedEdge>,
    /// Faces whose spacing grows from a capped or short edge somewhere
    /// (finer than requested near it).
    pub faces: Vec<u32>,
    /// Faces that failed with the graded spacing and were meshed with the
    /// requested one inside (their capped edges kept), with the error.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub released: Vec<ReleasedFace>,
    /// Set when a released face failed again: the whole model was then
    /// meshed without the cap (the error it gave).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dropped: Option<String>,
}

/// A face meshed with the requested spacing inside after failing with the
/// graded one.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ReleasedFace {
    /// The face id.
    pub face: u32,
    /// The error it gave with the graded spacing.
    pub reason: String,
}

/// The requested spacing with at least `n` nodes per turn of every curved
/// edge (see the module docs).
pub struct CirclePoints<'a> {
    inner: &'a dyn Spacing,
    /// The samples, in the order of `tree`'s leaves.
    samples: Vec<Sample>,
    tree: ConeTree,
    /// Tells this instance's cells from another's in the per-thread
    /// [`CELLS`].
    id: u64,
    /// Per face: its own cap, where its lines turn far enough.
    face_caps: Vec<Option<FaceCap>>,
    n: u32,
    /// Per face and per edge: whether some sample's reach meets it.
    face_graded: Vec<bool>,
    edge_graded: Vec<bool>,
    /// Per face and per edge: whether queries on it take the requested
    /// spacing.
    face_released: Vec<bool>,
    edge_released: Vec<bool>,
    vertex_released: Vec<bool>,
    /// Per edge: the points of its cusp vertices ([`cusp_ends`]); per
    /// vertex: whether it is one.
    cusp_edges: Vec<Vec<P3>>,
    cusp_vertices: Vec<bool>,
    report: CirclePointsReport,
}

impl<'a> CirclePoints<'a> {
    /// The spacing `inner` of `model` capped to `n` nodes per turn and
    /// graded from short edges; `None` when no edge needs it (or `n` is 0),
    /// so that the caller keeps `inner` as it is.
    pub fn new(model: &Model, inner: &'a dyn Spacing, n: u32) -> Option<Self> {
        if n == 0 {
            return None;
        }
        let mut samples = Vec::new();
        let mut report = CirclePointsReport {
            n,
            ..Default::default()
        };
        // the edges of a cusp: a short one among them closes a tip
        let ends = cusp_ends(model);
        let tips: std::collections::HashSet<u32> = ends.iter().flat_map(|&(e, _)| e).collect();
        for (ei, e) in model.edges.iter().enumerate() {
            let entity = EntityRef::new(1, ei as u32);
            // (point, requested d, cap, curvature) at parameter t
            let at = |t: f64| -> (P3, f64, f64, f64) {
                let p = e.curve.point(t);
                let d = inner.spacing(&SpacingQuery {
                    point: p,
                    entity,
                    params: [t, 0.0],
                });
                let k = curve_curvature(e.curve.as_ref(), t);
                let cap = if k > 0.0 && k.is_finite() {
                    std::f64::consts::TAU / (n as f64 * k)
                } else {
                    f64::INFINITY
                };
                (p, d, cap, k)
            };
            // a first look: does the cap bind anywhere, how finely must the
            // edge be sampled there, and how far does it turn (∫κ ds by the
            // trapezoid rule)?
            let probe = 64;
            let looks: Vec<_> = (0..=probe)
                .map(|k| at(e.t0 + (e.t1 - e.t0) * k as f64 / probe as f64))
                .collect();
            // an edge much shorter than the spacing is one segment whose
            // ends are nodes: the spacing grows from its length around it
            // (see SHORT_EDGE)
            let floor = if tips.contains(&(ei as u32)) {
                TIP_EDGE_FLOOR
            } else {
                SHORT_EDGE_FLOOR
            };
            if let Some((short, length, c, d)) =
                short_edge(e.curve.as_ref(), e.t0, e.t1, &looks, floor)
            {
                samples.extend(short);
                report.short_edges.push(ShortEdge {
                    edge: ei as u32,
                    name: e.name.clone(),
                    length,
                    d: c,
                    requested: d,
                });
                continue;
            }
            let least = looks
                .iter()
                .filter(|&&(_, d, cap, _)| cap < d && d.is_finite() && d > 0.0)
                .map(|l| l.2)
                .fold(f64::INFINITY, f64::min);
            if !(least > 0.0 && least.is_finite()) {
                continue;
            }
            let turning: f64 = looks
                .windows(2)
                .map(|w| {
                    let k = 0.5 * (w[0].3 + w[1].3);
                    if k.is_finite() {
                        k * (w[1].0 - w[0].0).norm()
                    } else {
                        0.0
                    }
                })
                .sum();
            if turning < MIN_TURNING {
                continue;
            }
            let at = |t: f64| {
                let (p, d, cap, _) = at(t);
                (p, d, cap)
            };
            let worst = sample_capped(e, least, probe, n, &at, &mut samples);
            report.edges.extend(worst.map(|w| CappedEdge {
                edge: ei as u32,
                name: e.name.clone(),
                ..w
            }));
        }
        let face_caps = face_caps(model, inner, n, &mut samples, &mut report);
        let (cusp_edges, cusp_vertices) = cusps(model, &ends, inner);
        if samples.is_empty() && face_caps.iter().all(Option::is_none) {
            return None;
        }
        let tree = ConeTree::new(&mut samples);
        let mut cp = CirclePoints {
            inner,
            tree,
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            samples,
            face_caps,
            n,
            face_graded: Vec::new(),
            edge_graded: Vec::new(),
            face_released: vec![false; model.faces.len()],
            edge_released: vec![false; model.edges.len()],
            vertex_released: vec![false; model.vertices.len()],
            cusp_edges,
            cusp_vertices,
            report,
        };
        cp.edge_graded = model
            .edges
            .iter()
            .map(|e| {
                let pts: Vec<P3> = (0..=16)
                    .map(|k| e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 16.0))
                    .collect();
                cp.reaches_box(&pts)
            })
            .collect();
        cp.face_graded = model
            .faces
            .iter()
            .map(|f| {
                let pts: Vec<P3> = f
                    .loops
                    .iter()
                    .flat_map(|l| l.edges.iter().map(|u| u.edge))
                    .chain(f.embedded_edges.iter().copied())
                    .flat_map(|ei| {
                        let e = &model.edges[ei as usize];
                        (0..=16).map(move |k| e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 16.0))
                    })
                    .collect();
                // a face without edges (a whole sphere) is not graded
                !pts.is_empty() && cp.reaches_box(&pts)
            })
            .collect();
        for (g, c) in cp.face_graded.iter_mut().zip(&cp.face_caps) {
            *g |= c.is_some();
        }
        cp.report.faces = (0..model.faces.len() as u32)
            .filter(|&f| cp.face_graded[f as usize])
            .collect();
        Some(cp)
    }

    /// What the cap changed.
    pub fn report(&self) -> &CirclePointsReport {
        &self.report
    }

    /// Lets face `face` of `model` and its edges take the requested spacing
    /// after it failed with `reason`; false when the cap does not grade it
    /// or it was released already.
    pub fn release(&mut self, model: &Model, face: u32, reason: &str) -> bool {
        let f = face as usize;
        if !self.face_graded.get(f).copied().unwrap_or(false) || self.face_released[f] {
            return false;
        }
        self.face_released[f] = true;
        let mf = &model.faces[f];
        for e in mf
            .loops
            .iter()
            .flat_map(|l| l.edges.iter().map(|u| u.edge))
            .chain(mf.embedded_edges.iter().copied())
        {
            if let Some(r) = self.edge_released.get_mut(e as usize) {
                *r = true;
            }
            let me = &model.edges[e as usize];
            for v in [me.start, me.end] {
                if let Some(r) = self.vertex_released.get_mut(v as usize) {
                    *r = true;
                }
            }
        }
        self.report.released.push(ReleasedFace {
            face,
            reason: reason.to_string(),
        });
        true
    }

    /// Whether face `face` was released.
    pub fn is_released(&self, face: u32) -> bool {
        self.face_released
            .get(face as usize)
            .copied()
            .unwrap_or(false)
    }

    /// Whether the requested spacing applies again on edge `edge` (an edge
    /// of a released face).
    pub fn is_edge_released(&self, edge: u32) -> bool {
        self.edge_released
            .get(edge as usize)
            .copied()
            .unwrap_or(false)
    }

    /// Whether query `q` (requested spacing `d` there) is at a cusp vertex
    /// or on one of its two edges closer than `d` to it: there the
    /// requested spacing applies.
    ///
    /// Why: where two edges meet tangentially, the triangle at the tip has
    /// an angle of about s·Δκ/2 (s the distance to the first nodes, Δκ the
    /// curves' difference of curvature), and the strip between the next
    /// nodes a width of s²·Δκ/2: nodes close to the tip make both thin.
    /// A short edge or a capped edge graded them there (as_0042 at
    /// diag/25: first nodes 3.6 from the tip, triangles of 5.5° and 3.7°;
    /// Gmsh's at 7–8, 12°).
    fn at_cusp(&self, q: &SpacingQuery, d: f64) -> bool {
        let id = q.entity.id as usize;
        match q.entity.dim {
            0 => self.cusp_vertices.get(id).copied().unwrap_or(false),
            1 => self
                .cusp_edges
                .get(id)
                .is_some_and(|vs| vs.iter().any(|v| (q.point - v).norm() < d)),
            _ => false,
        }
    }

    /// Whether the cap applies to a query on `e`.
    fn applies(&self, e: EntityRef) -> bool {
        match e.dim {
            0 | 1 => true,
            2 => !self
                .face_released
                .get(e.id as usize)
                .copied()
                .unwrap_or(false),
            _ => false,
        }
    }

    /// min(`bound`, min_k c_k + GRADE·|p − p_k|): the graded cap at `p`
    /// where it is below `bound` (the requested spacing there).
    ///
    /// Bubbles ask at nearly the same place step after step, so the
    /// answer comes from the samples that can be least anywhere in the
    /// query's cell of a grid of `bound`/[`CELL_FRACTION`] (the cell's
    /// [`ConeTree::candidates`], kept per thread): the same minimum, bit
    /// for bit, as the tree's search, at a few samples' cost.
    fn cap_below(&self, p: &P3, bound: f64) -> f64 {
        if !(bound > 0.0 && bound.is_finite()) || self.samples.is_empty() {
            return self.tree.least_cone(&self.samples, p, bound);
        }
        // cells a power of two in size, so that nearby queries of slightly
        // different bounds share them
        let level = (bound / CELL_FRACTION).log2().floor();
        let h = level.exp2();
        let cell = [p.x, p.y, p.z].map(|x| (x / h).floor());
        if cell.iter().any(|c| c.abs() > 1e15) {
            return self.tree.least_cone(&self.samples, p, bound);
        }
        let key = (level as i32, cell.map(|c| c as i64));
        CELLS.with(|cells| {
            let (owner, cells) = &mut *cells.borrow_mut();
            if *owner != self.id || cells.len() > MAX_CELLS {
                *owner = self.id;
                cells.clear();
            }
            let cands = cells.entry(key).or_insert_with(|| {
                let lo = P3::new(cell[0] * h, cell[1] * h, cell[2] * h);
                let hi = P3::new(lo.x + h, lo.y + h, lo.z + h);
                // every bound of this level is below 2·CELL_FRACTION·h
                self.tree
                    .candidates(&self.samples, &lo, &hi, 2.0 * CELL_FRACTION * h)
            });
            let mut best = bound;
            for &i in cands.iter() {
                let s = &self.samples[i as usize];
                best = best.min(s.c + GRADE * (p - s.p).norm());
            }
            best
        })
    }

    /// Whether a sample's reach meets the bounding box of `pts` grown by a
    /// tenth of its diagonal (a curved face bulges past its edges).
    fn reaches_box(&self, pts: &[P3]) -> bool {
        if pts.is_empty() {
            return false;
        }
        let (lo, hi) = bounds(pts.iter());
        let grow = crate::geom::V3::repeat(0.1 * (hi - lo).norm());
        let (lo, hi) = (lo - grow, hi + grow);
        self.samples
            .iter()
            .any(|s| box_distance(&lo, &hi, &s.p) <= s.reach)
    }
}

/// Samples every c/2 (at least `probe` + 1) along edge `e` where its cap
/// `at(t)` = (point, requested d, cap c) is below d, into `out`; `least`
/// is the smallest such cap a first look found. Returns the finest sample
/// for the report, with the caller's id and name still to fill in.
fn sample_capped(
    e: &crate::model::Edge,
    least: f64,
    probe: usize,
    n: u32,
    at: &dyn Fn(f64) -> (P3, f64, f64),
    out: &mut Vec<Sample>,
) -> Option<CappedEdge> {
    let length = crate::geom::length_between(e.curve.as_ref(), e.t0, e.t1);
    let m = ((SAMPLES_PER_CAP * length / least).ceil() as usize).clamp(probe, MAX_SAMPLES_PER_EDGE);
    let mut finest: Option<CappedEdge> = None;
    for k in 0..=m {
        let (p, d, c) = at(e.t0 + (e.t1 - e.t0) * k as f64 / m as f64);
        if !(c < d && d.is_finite()) {
            continue;
        }
        out.push(Sample {
            p,
            c,
            reach: 1.5 * (d - c) / GRADE,
        });
        if finest.as_ref().is_none_or(|w| c < w.d) {
            finest = Some(CappedEdge {
                edge: 0,
                name: None,
                radius: c * n as f64 / std::f64::consts::TAU,
                d: c,
                requested: d,
            });
        }
    }
    finest
}

/// Per face, its [`FaceCap`] where its lines turn at least
/// [`MIN_TURNING`] and the cap is below the requested spacing somewhere on
/// its boundary; for those, samples every c/2 along their edges (so that
/// the edges and the neighbouring faces grade from the cap) go into
/// `samples`, and the face into the report.
fn face_caps(
    model: &Model,
    inner: &dyn Spacing,
    n: u32,
    samples: &mut Vec<Sample>,
    report: &mut CirclePointsReport,
) -> Vec<Option<FaceCap>> {
    let mut caps = Vec::with_capacity(model.faces.len());
    for (fi, face) in model.faces.iter().enumerate() {
        if face.loops.is_empty() && !face.surface.is_planar() {
            caps.push(closed_face_cap(model, fi, inner, n, samples, report));
            continue;
        }
        let (along, length) = turning_lines(model, fi);
        if along == [false, false] {
            caps.push(None);
            continue;
        }
        let fc = FaceCap {
            surface: face.surface.clone(),
            along,
        };
        let mut worst: Option<CappedEdge> = None;
        let mut face_samples = Vec::new();
        for u in face.loops.iter().flat_map(|l| l.edges.iter()) {
            let e = &model.edges[u.edge as usize];
            // (point, requested d, cap) at parameter t of the edge
            let at = |t: f64| {
                let p = e.curve.point(t);
                let d = inner.spacing(&SpacingQuery {
                    point: p,
                    entity: EntityRef::new(1, u.edge),
                    params: [t, 0.0],
                });
                let c = crate::curvature::edge_point_uv(model, fi as u32, u.edge, t)
                    .map_or(f64::INFINITY, |uv| fc.cap(uv, n));
                (p, d, c)
            };
            let probe = 16;
            let least = (0..=probe)
                .map(|k| at(e.t0 + (e.t1 - e.t0) * k as f64 / probe as f64))
                .filter(|&(_, d, c)| c < d && d.is_finite())
                .map(|l| l.2)
                .fold(f64::INFINITY, f64::min);
            if !(least > 0.0 && least.is_finite()) {
                continue;
            }
            let finest = sample_capped(e, least, probe, n, &at, &mut face_samples);
            if let Some(f) = finest.filter(|f| worst.as_ref().is_none_or(|w| f.d < w.d)) {
                worst = Some(CappedEdge {
                    edge: fi as u32,
                    name: face.name.clone(),
                    ..f
                });
            }
        }
        match worst {
            // a wire or a thread far below the spacing keeps its edges'
            // caps only (see FACE_CAP_FLOOR), and so does a face short
            // across its turning lines (see FACE_CAP_MIN_LENGTH)
            Some(w)
                if w.d >= FACE_CAP_FLOOR * w.requested
                    && (0..2).any(|k| {
                        along[k] && length[1 - k] >= FACE_CAP_MIN_LENGTH * w.requested
                    }) =>
            {
                samples.append(&mut face_samples);
                report.capped_faces.push(w);
                caps.push(Some(fc));
            }
            _ => caps.push(None),
        }
    }
    caps
}

/// Samples per direction of the (u,v) grid [`closed_face_cap`] probes.
const CLOSED_PROBE: usize = 16;

/// A closed face capped at n nodes per turn may have at most about this
/// many nodes (a ring torus of wire radius 10⁻³·d would have hundreds of
/// thousands; a sphere has about 20 whatever its radius).
const CLOSED_CAP_MAX_NODES: f64 = 20_000.0;

/// The cap of a face without boundary (a whole sphere, a torus): it has no
/// edges to measure on, so its (u,v) domain is probed on a grid, and where
/// the cap is below the requested spacing the face takes it and samples go
/// into `samples` (its embedded vertices, a sphere's poles, grade from
/// them). Without it a sphere of radius below the spacing got no bubble
/// (its pole vertex's bubble of diameter d covered it) and no triangle.
fn closed_face_cap(
    model: &Model,
    fi: usize,
    inner: &dyn Spacing,
    n: u32,
    samples: &mut Vec<Sample>,
    report: &mut CirclePointsReport,
) -> Option<FaceCap> {
    let face = &model.faces[fi];
    let surface = face.surface.as_ref();
    let (du, dv) = surface.domain();
    if ![du[0], du[1], dv[0], dv[1]].iter().all(|x| x.is_finite()) {
        return None;
    }
    let fc = FaceCap {
        surface: face.surface.clone(),
        along: [true, true],
    };
    let (hu, hv) = (
        (du[1] - du[0]) / CLOSED_PROBE as f64,
        (dv[1] - dv[0]) / CLOSED_PROBE as f64,
    );
    let mut found = Vec::new();
    let (mut area, mut finest): (f64, Option<CappedEdge>) = (0.0, None);
    for i in 0..CLOSED_PROBE {
        for j in 0..CLOSED_PROBE {
            // cell centres: never on a pole
            let uv = [du[0] + (i as f64 + 0.5) * hu, dv[0] + (j as f64 + 0.5) * hv];
            let s = surface.derivs(uv[0], uv[1]);
            area += s.su.cross(&s.sv).norm() * hu * hv;
            let p = surface.point(uv[0], uv[1]);
            let d = inner.spacing(&SpacingQuery {
                point: p,
                entity: EntityRef::new(2, fi as u32),
                params: uv,
            });
            let c = fc.cap(uv, n);
            if !(c < d && d.is_finite() && c > 0.0) {
                continue;
            }
            found.push(Sample {
                p,
                c,
                reach: 1.5 * (d - c) / GRADE,
            });
            if finest.as_ref().is_none_or(|w| c < w.d) {
                finest = Some(CappedEdge {
                    edge: fi as u32,
                    name: face.name.clone(),
                    radius: c * n as f64 / std::f64::consts::TAU,
                    d: c,
                    requested: d,
                });
            }
        }
    }
    let w = finest?;
    // nodes ≈ triangles / 2, a triangle of side c having area 0.433 c²
    if area / (0.433 * w.d * w.d) / 2.0 > CLOSED_CAP_MAX_NODES {
        return None;
    }
    samples.append(&mut found);
    report.capped_faces.push(w);
    Some(fc)
}

/// Distance from `p` to the box [lo, hi] (0 inside).
fn box_distance(lo: &P3, hi: &P3, p: &P3) -> f64 {
    let mut d2 = 0.0;
    for i in 0..3 {
        let g = (lo[i] - p[i]).max(p[i] - hi[i]).max(0.0);
        d2 += g * g;
    }
    d2.sqrt()
}

/// A bounding-volume tree over the samples for the query
/// min_k (c_k + GRADE·|x − p_k|) below a bound.
///
/// Written here because the nearest-neighbour crates answer the nearest
/// point, not the least of cones with different apex heights c_k. A node
/// is skipped when its least c plus GRADE times the distance from x to its
/// box is not below the best value so far; starting from the requested
/// spacing, points out of every sample's reach visit only the root.
struct ConeTree {
    nodes: Vec<ConeNode>,
}

/// A node: its box, the least cap below it, and either two children or a
/// range of samples.
struct ConeNode {
    lo: P3,
    hi: P3,
    least_c: f64,
    /// Leaf: samples[first..first + count]; inner: children at `first` and
    /// `first + 1` in `nodes`, `count` = 0.
    first: u32,
    count: u32,
}

/// Samples per leaf.
const LEAF: usize = 8;

/// The cells of [`CirclePoints::cap_below`] are about bound/8 wide: the
/// candidates are then the samples within about GRADE·√3·bound/4 of the
/// least, a few along a capped edge.
const CELL_FRACTION: f64 = 8.0;

/// Cells kept per thread before the cache starts afresh (each about 64
/// bytes and a few sample indices: some 10 MB at most).
const MAX_CELLS: usize = 1 << 15;

/// A fresh id per [`CirclePoints`], for the per-thread cell cache (ids
/// start at 1; 0 is no instance's).
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// A cell of [`CirclePoints::cap_below`]: (level, cell index).
type CellKey = (i32, [i64; 3]);
thread_local! {
    /// Per thread: the instance whose cells these are, and each cell's
    /// candidate samples; another instance's query starts afresh.
    static CELLS: std::cell::RefCell<(u64, rustc_hash::FxHashMap<CellKey, Vec<u32>>)> =
        Default::default();
}

impl ConeTree {
    /// Builds the tree, reordering `samples` so that each leaf's are
    /// contiguous (median split on the box's longest axis).
    fn new(samples: &mut [Sample]) -> Self {
        let mut tree = ConeTree { nodes: Vec::new() };
        tree.nodes.push(ConeNode::over(samples, 0));
        let mut stack = vec![(0usize, 0usize, samples.len())];
        while let Some((node, start, end)) = stack.pop() {
            if end - start <= LEAF {
                continue;
            }
            let n = &tree.nodes[node];
            let ext = n.hi - n.lo;
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = (start + end) / 2;
            samples[start..end]
                .select_nth_unstable_by(mid - start, |a, b| a.p[axis].total_cmp(&b.p[axis]));
            let left = tree.nodes.len();
            tree.nodes.push(ConeNode::over(&samples[start..mid], start));
            tree.nodes.push(ConeNode::over(&samples[mid..end], mid));
            tree.nodes[node].first = left as u32;
            tree.nodes[node].count = 0;
            stack.push((left, start, mid));
            stack.push((left + 1, mid, end));
        }
        tree
    }

    /// The samples that can give the least cone c + GRADE·|x − p| below
    /// `bound` at some x in the box `lo`..`hi`: U is the least over the
    /// samples of their largest value in the box, and a sample whose
    /// smallest value in the box exceeds U or `bound` is never the least
    /// below it there. (Kept with a relative margin of 1e-9, so that
    /// rounding never drops the least one.)
    fn candidates(&self, samples: &[Sample], lo: &P3, hi: &P3, bound: f64) -> Vec<u32> {
        let far = |q: &P3| -> f64 {
            let mut d2 = 0.0;
            for i in 0..3 {
                let g = (q[i] - lo[i]).abs().max((q[i] - hi[i]).abs());
                d2 += g * g;
            }
            d2.sqrt()
        };
        let near_node = |n: &ConeNode| -> f64 {
            let mut d2 = 0.0;
            for i in 0..3 {
                let g = (n.lo[i] - hi[i]).max(lo[i] - n.hi[i]).max(0.0);
                d2 += g * g;
            }
            d2.sqrt()
        };
        // U, by a search like `least_cone`'s with the box's farthest point
        let mut u = bound;
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            if n.least_c + GRADE * near_node(n) >= u {
                continue;
            }
            if n.count > 0 {
                for s in &samples[n.first as usize..(n.first + n.count) as usize] {
                    u = u.min(s.c + GRADE * far(&s.p));
                }
            } else {
                stack.push(n.first);
                stack.push(n.first + 1);
            }
        }
        let limit = u.min(bound) * (1.0 + 1e-9);
        let mut out = Vec::new();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            if n.least_c + GRADE * near_node(n) > limit {
                continue;
            }
            if n.count > 0 {
                for k in n.first..n.first + n.count {
                    let s = &samples[k as usize];
                    if s.c + GRADE * box_distance(lo, hi, &s.p) <= limit {
                        out.push(k);
                    }
                }
            } else {
                stack.push(n.first);
                stack.push(n.first + 1);
            }
        }
        out
    }

    fn least_cone(&self, samples: &[Sample], p: &P3, bound: f64) -> f64 {
        // a spacing that is not a positive number is the caller's to report
        if !(bound > 0.0) {
            return bound;
        }
        let mut best = bound;
        // a node's children are pushed together, so the stack never holds
        // more than one node per level beside the one being expanded: the
        // tree's depth (log2(samples/LEAF) + 1) is far below 64
        let mut stack = [0u32; 128];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let i = stack[top];
            let n = &self.nodes[i as usize];
            if n.least_c + GRADE * n.distance(p) >= best {
                continue;
            }
            if n.count > 0 {
                let (a, b) = (n.first as usize, (n.first + n.count) as usize);
                for s in &samples[a..b] {
                    best = best.min(s.c + GRADE * (p - s.p).norm());
                }
            } else {
                // the nearer child last, so that it is visited first and
                // tightens `best` before the farther one is tested
                let (a, b) = (n.first, n.first + 1);
                let da =
                    self.nodes[a as usize].least_c + GRADE * self.nodes[a as usize].distance(p);
                let db =
                    self.nodes[b as usize].least_c + GRADE * self.nodes[b as usize].distance(p);
                let (first, second) = if da < db { (b, a) } else { (a, b) };
                stack[top] = first;
                stack[top + 1] = second;
                top += 2;
            }
        }
        best
    }
}

impl ConeNode {
    fn over(samples: &[Sample], first: usize) -> Self {
        let (lo, hi) = bounds(samples.iter().map(|s| &s.p));
        ConeNode {
            lo,
            hi,
            least_c: samples.iter().map(|s| s.c).fold(f64::INFINITY, f64::min),
            first: first as u32,
            count: samples.len() as u32,
        }
    }

    /// Distance from `p` to the box (0 inside).
    fn distance(&self, p: &P3) -> f64 {
        box_distance(&self.lo, &self.hi, p)
    }
}

impl CirclePoints<'_> {
    /// The cap at query `q` below the requested spacing `d` there.
    fn capped(&self, q: &SpacingQuery, d: f64) -> f64 {
        if !self.applies(q.entity) || self.at_cusp(q, d) {
            return d;
        }
        let own = match (q.entity.dim, self.face_caps.get(q.entity.id as usize)) {
            (2, Some(Some(fc))) => fc.cap(q.params, self.n),
            _ => f64::INFINITY,
        };
        self.cap_below(&q.point, d.min(own))
    }
}

impl Spacing for CirclePoints<'_> {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        let d = self.inner.spacing(q);
        self.capped(q, d)
    }
    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        self.inner.spacing_batch(qs, out);
        for (q, o) in qs.iter().zip(out.iter_mut()) {
            *o = self.capped(q, *o);
        }
    }
    fn constant(&self) -> Option<f64> {
        None
    }
    fn constant_on(&self, e: EntityRef) -> Option<f64> {
        // a released entity takes the requested spacing as it is
        if e.dim < 3 && !self.applies(e) {
            return self.inner.constant_on(e);
        }
        let graded = match e.dim {
            1 => self.edge_graded.get(e.id as usize).copied().unwrap_or(true),
            2 => self.face_graded.get(e.id as usize).copied().unwrap_or(true),
            3 => false,
            _ => true,
        };
        if graded {
            None
        } else {
            self.inner.constant_on(e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Curve, V3};
    use crate::model::{Edge, Vertex};
    use crate::spacing::Constant;
    use std::sync::Arc;

    /// A circle of radius `r` in the xy plane, t in [0, 2π).
    #[derive(Debug)]
    struct Circle(f64);

    impl Curve for Circle {
        fn interval(&self) -> (f64, f64) {
            (0.0, std::f64::consts::TAU)
        }
        fn point(&self, t: f64) -> P3 {
            P3::new(self.0 * t.cos(), self.0 * t.sin(), 0.0)
        }
        fn d1(&self, t: f64) -> V3 {
            V3::new(-self.0 * t.sin(), self.0 * t.cos(), 0.0)
        }
        fn d2(&self, t: f64) -> V3 {
            V3::new(-self.0 * t.cos(), -self.0 * t.sin(), 0.0)
        }
    }

    fn circle_model(r: f64) -> Model {
        let mut m = Model::default();
        m.vertices.push(Vertex {
            point: P3::new(r, 0.0, 0.0),
            name: None,
        });
        m.edges.push(Edge {
            curve: Arc::new(Circle(r)),
            t0: 0.0,
            t1: std::f64::consts::TAU,
            start: 0,
            end: 0,
            name: None,
        });
        m
    }

    fn at(p: P3, dim: u8) -> SpacingQuery {
        SpacingQuery {
            point: p,
            entity: EntityRef::new(dim, 0),
            params: [0.0, 0.0],
        }
    }

    /// A circle of radius 5 at d = 12 takes 2π·5/7 on the edge, grows at
    /// GRADE away from it, and is the requested d far away and in volumes.
    #[test]
    fn a_small_circle_takes_seven_nodes_and_grades_away() {
        let m = circle_model(5.0);
        let d = Constant(12.0);
        let cp = CirclePoints::new(&m, &d, 7).expect("the cap binds");
        let cap = std::f64::consts::TAU * 5.0 / 7.0;
        let on = cp.spacing(&at(P3::new(0.0, 5.0, 0.0), 1));
        assert!(on <= cap * 1.11 && on >= cap, "{on} on the edge, cap {cap}");
        let off = cp.spacing(&at(P3::new(0.0, 5.0, 5.0), 2));
        assert!(
            (off - (cap + GRADE * 5.0)).abs() < 0.05 * cap,
            "{off} at 5 from it"
        );
        assert_eq!(cp.spacing(&at(P3::new(0.0, 5.0, 100.0), 2)), 12.0);
        assert_eq!(cp.spacing(&at(P3::new(0.0, 5.0, 0.0), 3)), 12.0);
        assert_eq!(cp.report().edges.len(), 1);
        assert!((cp.report().edges[0].radius - 5.0).abs() < 1e-9);
        assert_eq!(cp.constant_on(EntityRef::new(3, 0)), Some(12.0));
        assert_eq!(cp.constant_on(EntityRef::new(1, 0)), None);
    }

    /// A face between a quarter circle of radius `r` and the line x = r,
    /// tangent to it at (r, 0): a cusp there, and a short edge at the cusp
    /// (a wire from (r, 0, 0) to (r, 0, 1)) from which the spacing grades.
    fn cusp_model(r: f64) -> Model {
        use crate::geom::{Plane, Segment};
        use crate::model::{EdgeUse, Face, Loop};
        let mut m = Model::default();
        for p in [
            [r, 0.0, 0.0],
            [0.0, r, 0.0],
            [r, 2.0 * r, 0.0],
            [r, 0.0, 1.0],
        ] {
            m.vertices.push(Vertex {
                point: P3::new(p[0], p[1], p[2]),
                name: None,
            });
        }
        let seg = |a: usize, b: usize| -> Arc<dyn Curve> {
            Arc::new(Segment(m.vertices[a].point, m.vertices[b].point))
        };
        let curves: [(Arc<dyn Curve>, f64); 4] = [
            (Arc::new(Circle(r)), std::f64::consts::FRAC_PI_2),
            (seg(1, 2), 1.0),
            (seg(2, 0), 1.0),
            (seg(0, 3), 1.0),
        ];
        for (k, (curve, t1)) in curves.into_iter().enumerate() {
            let (start, end) = [(0, 1), (1, 2), (2, 0), (0, 3)][k];
            m.edges.push(Edge {
                curve,
                t0: 0.0,
                t1,
                start,
                end,
                name: None,
            });
        }
        let uses = [0, 1, 2].map(|e| EdgeUse {
            edge: e,
            forward: true,
        });
        m.faces.push(Face {
            surface: Arc::new(Plane::xy()),
            loops: vec![Loop {
                edges: uses.to_vec(),
            }],
            embedded_edges: vec![],
            embedded_vertices: vec![],
            name: None,
        });
        m
    }

    /// A spike: the face between a line 10 long and a line back from its
    /// end, closed by an edge 0.1 long whose end stands 0.005 off the
    /// first line (the edges at the tip leave it 2.9° apart: a cusp).
    fn spike_model() -> Model {
        use crate::geom::{Plane, Segment};
        use crate::model::{EdgeUse, Face, Loop};
        let mut m = Model::default();
        for p in [[0.0, 0.0], [10.0, 0.0], [9.9, 0.005]] {
            m.vertices.push(Vertex {
                point: P3::new(p[0], p[1], 0.0),
                name: None,
            });
        }
        for (start, end) in [(0u32, 1u32), (1, 2), (2, 0)] {
            let [a, b] = [start, end].map(|v| m.vertices[v as usize].point);
            m.edges.push(Edge {
                curve: Arc::new(Segment(a, b)),
                t0: 0.0,
                t1: 1.0,
                start,
                end,
                name: None,
            });
        }
        m.faces.push(Face {
            surface: Arc::new(Plane::xy()),
            loops: vec![Loop {
                edges: (0..3)
                    .map(|edge| EdgeUse {
                        edge,
                        forward: true,
                    })
                    .collect(),
            }],
            embedded_edges: vec![],
            embedded_vertices: vec![],
            name: None,
        });
        m
    }

    /// A short edge that closes a tip grades from its own length (0.1001),
    /// not from [`SHORT_EDGE_FLOOR`]·d (1/3 at d = 2), so the tip's first
    /// node on the long edge comes about 0.1 from it.
    #[test]
    fn a_short_edge_at_a_tip_grades_from_its_length() {
        let m = spike_model();
        // (the far end, where the long edges meet, is a cusp too)
        assert_eq!(cusp_ends(&m), vec![([0, 1], 1), ([0, 2], 0)]);
        let d = Constant(2.0);
        let cp = CirclePoints::new(&m, &d, 7).expect("the short edge grades");
        let short = &cp.report().short_edges;
        assert_eq!(short.len(), 1);
        let l = 0.1f64.hypot(0.005);
        assert!((short[0].length - l).abs() < 1e-9);
        assert_eq!(short[0].d, short[0].length);
        let at_tip = cp.spacing(&SpacingQuery {
            point: P3::new(10.0, 0.0, 0.0),
            entity: EntityRef::new(1, 0),
            params: [1.0, 0.0],
        });
        assert!((at_tip - l).abs() < 1e-9, "spacing at the tip {at_tip}");
    }

    /// At a cusp (`cusp_model(20)`, d = 12) the short edge's grading does
    /// not reach the cusp's two edges within d of the cusp, nor the cusp
    /// vertex: the requested d applies there; inside the face and farther
    /// along the line the graded spacing does. An arc shorter than d
    /// (radius 5) leaves the cusp graded.
    #[test]
    fn a_cusp_keeps_the_requested_spacing_on_its_edges() {
        let m = cusp_model(20.0);
        assert_eq!(cusp_ends(&m), vec![([0, 2], 0)]);
        let d = Constant(12.0);
        let cp = CirclePoints::new(&m, &d, 7).expect("the short edge grades");
        let q = |p: P3, dim: u8, id: u32, t: f64| SpacingQuery {
            point: p,
            entity: EntityRef::new(dim, id),
            params: [t, 0.0],
        };
        assert_eq!(cp.spacing(&q(Circle(20.0).point(0.2), 1, 0, 0.2)), 12.0);
        assert_eq!(cp.spacing(&q(P3::new(20.0, 4.0, 0.0), 1, 2, 0.9)), 12.0);
        assert_eq!(cp.spacing(&q(m.vertices[0].point, 0, 0, 0.0)), 12.0);
        assert!(cp.cusp_edges[1].is_empty(), "edge 1 makes no cusp");
        // graded (from SHORT_EDGE_FLOOR·d = 2, not the short edge's length)
        let graded = |p: P3| SHORT_EDGE_FLOOR * 12.0 + GRADE * (p - P3::new(20.0, 0.0, 0.0)).norm();
        let inside = P3::new(19.9, 3.0, 0.0);
        assert!(cp.spacing(&q(inside, 2, 0, 0.0)) <= graded(inside) + 1e-9);
        let far = P3::new(20.0, 14.0, 0.0);
        assert!(cp.spacing(&q(far, 1, 2, 0.65)) < 12.0);
        // an arc shorter than the spacing (7.9 < 12): graded as before
        let cp = CirclePoints::new(&cusp_model(5.0), &d, 7).expect("graded");
        assert!(cp.cusp_edges[0].is_empty());
        assert!(cp.spacing(&q(Circle(5.0).point(0.2), 1, 0, 0.2)) < 12.0);
    }

    /// The tree's pruned query is the brute-force minimum over the samples
    /// (samples on a helix with caps that vary, points near and far).
    #[test]
    fn the_cone_tree_finds_the_least_cone() {
        let mut samples: Vec<Sample> = (0..500)
            .map(|k| {
                let t = k as f64 * 0.05;
                Sample {
                    p: P3::new(t.cos(), t.sin(), 0.1 * t),
                    c: 0.05 + 0.04 * (3.0 * t).sin().abs(),
                    reach: 1.0,
                }
            })
            .collect();
        let tree = ConeTree::new(&mut samples);
        let mut next = crate::bubbles::testing::uniform(7);
        for _ in 0..2000 {
            let p = P3::new(4.0 * next() - 2.0, 4.0 * next() - 2.0, 3.0 * next() - 0.5);
            let bound = 0.3 + next();
            let brute = samples
                .iter()
                .map(|s| s.c + GRADE * (p - s.p).norm())
                .fold(bound, f64::min);
            let fast = tree.least_cone(&samples, &p, bound);
            assert_eq!(fast, brute, "at {p:?}");
        }
    }

    /// A circle already finer than 2πr/n, a straight model, or n = 0 leave
    /// the spacing as it was.
    #[test]
    fn no_cap_where_the_spacing_is_fine_enough() {
        let m = circle_model(5.0);
        assert!(CirclePoints::new(&m, &Constant(4.0), 7).is_none());
        assert!(CirclePoints::new(&m, &Constant(12.0), 0).is_none());
    }

    /// The cells' candidates give the tree search's minimum bit for bit:
    /// 2,000 cones (caps 0.05–1 spread over a unit cube and along a line,
    /// where many are nearly tied), queried in cells of several sizes at
    /// random points, with bounds that bind and that do not.
    #[test]
    fn cell_candidates_give_the_least_cone_bit_for_bit() {
        let mut rnd = crate::bubbles::testing::uniform(7);
        let mut samples: Vec<Sample> = (0..2000)
            .map(|k| {
                let p = if k % 2 == 0 {
                    P3::new(rnd(), rnd(), rnd())
                } else {
                    P3::new(rnd(), 0.5, 0.5)
                };
                Sample {
                    p,
                    c: 0.05 + 0.95 * rnd(),
                    reach: 1.0,
                }
            })
            .collect();
        let tree = ConeTree::new(&mut samples);
        for h in [0.01, 0.05, 0.3] {
            for _ in 0..200 {
                let cell = [rnd(), rnd(), rnd()].map(|x| (x * 1.2 / h).floor() - 0.1 / h);
                let lo = P3::new(cell[0] * h, cell[1] * h, cell[2] * h);
                let hi = P3::new(lo.x + h, lo.y + h, lo.z + h);
                for bound in [0.06, 0.3, 10.0] {
                    let cands = tree.candidates(&samples, &lo, &hi, bound);
                    for _ in 0..5 {
                        let p = P3::new(lo.x + h * rnd(), lo.y + h * rnd(), lo.z + h * rnd());
                        let by_tree = tree.least_cone(&samples, &p, bound);
                        let by_cell = cands.iter().fold(bound, |b, &i| {
                            let s = &samples[i as usize];
                            b.min(s.c + GRADE * (p - s.p).norm())
                        });
                        assert_eq!(by_tree.to_bits(), by_cell.to_bits(), "{p:?} {h} {bound}");
                    }
                }
            }
        }
    }
}
