//! Improvement of the connected mesh: relaxation of the bubbles along the
//! mesh edges, then Delaunay edge flips, repeated.
//!
//! The thesis connects the packed bubbles by Delaunay triangulation and
//! stops (§5.1: "no post-processes ... were applied"). Measured on the
//! benchmark cases, the worst triangles sit where the packing left a
//! five/seven-valent pair: there the cubic force of stage 2 still acts across
//! a quadrilateral's long diagonal (1.3–1.5 r0, inside the 1.5 r0 cutoff) and
//! shears the triangles. Restricted to *mesh edges*, the balance is exactly
//! "every edge as close to r0 as the topology allows":
//!
//! - **edge relaxation**: the linear inter-bubble force of eq. 4.2.1 acting
//!   along mesh edges only, as a damped Jacobi step Δx = ω f / k with
//!   k = (deg/2)·k0; only bubbles within two rings of a triangle below
//!   `active_q` move (so a uniform lattice costs nothing), and a move that
//!   would invert an incident triangle in (u,v) is halved, then dropped;
//! - **Delaunay flips** (Lawson): an edge whose opposite vertex lies inside
//!   the circumcircle in (u,v) is flipped (exact `robust::incircle`), never
//!   a boundary or embedded edge; so the result is again the constrained
//!   Delaunay triangulation of the moved bubbles without a global rebuild.
//!
//! - **lifting the worst**: the few bubbles at corners of triangles still
//!   below `lift_q` are moved (pattern search) to maximise the smallest
//!   radius ratio around them, followed by Delaunay flips again;
//! - **lifting the mean**: the bubbles at corners of triangles below
//!   `mean_q` are moved the same way to maximise the *sum* of the radius
//!   ratios around them, never letting the smallest drop below
//!   min(its value, `lift_q`); then flips. Around the five/seven pairs a
//!   graded packing needs, this spreads the distortion over more triangles
//!   (case B: mean 0.982 -> 0.986).
//! - **lifting the angle** (last, [`lift_angle`]): the free corners of the
//!   few triangles with the face's smallest angles are moved to raise the
//!   smallest angle around them, the radius ratios kept (within a small
//!   slack of their sum).
//!
//! Valence-driven flips were tried and dropped: a five/seven pair is stable
//! under flips (every flip that fixes the seven makes two new sevens), so
//! they changed nothing on cases A–C.
//!
//! Invariants kept: triangles stay counter-clockwise in (u,v); constraint
//! edges are never flipped; fixed bubbles never move.

use std::collections::HashSet;

use crate::geom::{P3, V3};

use crate::bubbles::constraint::Carrier;
use crate::bubbles::dynamics::K0;
use crate::bubbles::system::System;
use crate::error::MeshError;

/// The 2D improvement's tuning.
#[derive(Clone, Copy, Debug)]
pub struct ImproveParams {
    /// Damping of the Jacobi relaxation step.
    pub omega: f64,
    /// Triangles below this radius ratio make their bubbles (and two rings
    /// around them) move in the edge relaxation.
    pub active_q: f64,
    /// Triangles below this radius ratio have their free corners moved to
    /// raise the worst incident triangle (the worst lift).
    pub lift_q: f64,
    /// Triangles below this radius ratio have their free corners moved to
    /// raise the sum of the radius ratios around them (the mean lift).
    pub mean_q: f64,
    /// [`lift_mean`] keeps edge lengths L/d inside [band_lo, band_hi] (well
    /// inside the [1/√2, √2] a mesher is judged by) with a penalty of
    /// band_weight·(log of the excess)² per edge (research: F in
    /// `bench/research/defects_2d/README.md`).
    pub band_lo: f64,
    /// See `band_lo`.
    pub band_hi: f64,
    /// See `band_lo`.
    pub band_weight: f64,
    /// [`lift_angle`] moves the free corners of triangles whose smallest
    /// angle is within this many radians of the face's smallest.
    pub angle_margin: f64,
    /// ... letting the sum of the radius ratios around a moved bubble fall
    /// by at most this much (and its smallest not at all).
    pub angle_slack: f64,
    /// ... and only the corners of this many of the face's triangles with
    /// the smallest angles per round.
    pub angle_count: usize,
}

impl ImproveParams {
    /// The values in use.
    pub const DEFAULT: ImproveParams = ImproveParams {
        omega: 0.6,
        active_q: 0.95,
        lift_q: 0.9,
        mean_q: 0.98,
        band_lo: 0.76,
        band_hi: 1.32,
        band_weight: 10.0,
        angle_margin: 3.0 * std::f64::consts::PI / 180.0,
        angle_slack: 0.01,
        angle_count: 4,
    };
}

impl Default for ImproveParams {
    fn default() -> Self {
        ImproveParams::DEFAULT
    }
}

/// The improvement's settings.
const PRM: ImproveParams = ImproveParams::DEFAULT;

pub(crate) use crate::measure::triangle_radius_ratio as radius_ratio;

fn orient_uv(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    robust::orient2d(
        robust::Coord { x: a[0], y: a[1] },
        robust::Coord { x: b[0], y: b[1] },
        robust::Coord { x: c[0], y: c[1] },
    )
}

/// Improves `tris` (counter-clockwise, indices into `sys`) in place.
/// `constraints` are the undirected edges that must stay.
pub fn improve<C: Carrier>(
    sys: &mut System<'_, C>,
    tris: &mut [[usize; 3]],
    constraints: &[[usize; 2]],
    rounds: usize,
) -> Result<(), MeshError> {
    improve_where(sys, tris, constraints, rounds, None)
}

/// [`improve`] moving only the bubbles `movable` marks (all with `None`):
/// a few bubbles added to an improved mesh are settled among their
/// neighbours without running the passes over the whole face again.
pub fn improve_where<C: Carrier>(
    sys: &mut System<'_, C>,
    tris: &mut [[usize; 3]],
    constraints: &[[usize; 2]],
    rounds: usize,
    movable: Option<&[bool]>,
) -> Result<(), MeshError> {
    let fixed = undirected(constraints);
    for _ in 0..rounds {
        let moved = relax_edges(sys, tris, 10, movable)?;
        if moved.is_empty() || delaunay_flips(sys, tris, &fixed, &moved) == 0 {
            break;
        }
    }
    for (lift, below) in [(Lift::Worst, PRM.lift_q), (Lift::Mean, PRM.mean_q)] {
        for _ in 0..rounds {
            let moved = lift_bubbles(sys, tris, lift, below, 0.0, movable)?;
            if moved.is_empty() || delaunay_flips(sys, tris, &fixed, &moved) == 0 {
                break;
            }
        }
    }
    Ok(())
}

/// The constraint edges as undirected pairs (lower index first).
fn undirected(constraints: &[[usize; 2]]) -> HashSet<(usize, usize)> {
    constraints
        .iter()
        .map(|e| (e[0].min(e[1]), e[0].max(e[1])))
        .collect()
}

/// The last pass of a face, `rounds` times: the free corners of the
/// triangles whose smallest angle is within
/// [`ImproveParams::angle_margin`] of the face's smallest (and below 45°)
/// are moved (the pattern search of [`lift_bubbles`]) to raise the
/// smallest angle around them, never lowering the smallest radius ratio
/// there, the sum by at most [`ImproveParams::angle_slack`], nor moving an
/// edge out of the spacing band [1/√2, √2]; then flips. The radius-ratio
/// objectives leave the smallest angle where a kink of their max–min stops
/// the search (a cube corner's 38° on as_wavy-cube, docs/decisions.md
/// session 36).
pub fn lift_angle<C: Carrier>(
    sys: &mut System<'_, C>,
    tris: &mut [[usize; 3]],
    constraints: &[[usize; 2]],
    rounds: usize,
) -> Result<(), MeshError> {
    let fixed = undirected(constraints);
    for _ in 0..rounds {
        let mut angles: Vec<f64> = tris
            .iter()
            .map(|t| {
                crate::measure::triangle_min_angle(&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]])
            })
            .collect();
        if angles.is_empty() {
            break;
        }
        let k = PRM.angle_count.min(angles.len()) - 1;
        let (fewer, kth, _) = angles.select_nth_unstable_by(k, f64::total_cmp);
        let kth = *kth;
        let least = fewer.iter().copied().fold(kth, f64::min);
        let below = (least + PRM.angle_margin)
            .min(std::f64::consts::FRAC_PI_4)
            .min(kth.next_up());
        let moved = lift_bubbles(sys, tris, Lift::Angle, below, 0.0, None)?;
        if moved.is_empty() {
            break;
        }
        delaunay_flips(sys, tris, &fixed, &moved);
    }
    Ok(())
}

/// More rounds of [`Lift::Mean`] over the bubbles of every triangle below
/// `below` (with flips after each), for a mesh whose connectivity is already
/// good, so that only the node positions are left to settle.
pub fn lift_mean<C: Carrier>(
    sys: &mut System<'_, C>,
    tris: &mut [[usize; 3]],
    constraints: &[[usize; 2]],
    below: f64,
    rounds: usize,
) -> Result<(), MeshError> {
    let fixed = undirected(constraints);
    for _ in 0..rounds {
        let moved = lift_bubbles(sys, tris, Lift::Mean, below, PRM.band_weight, None)?;
        if moved.is_empty() {
            break;
        }
        delaunay_flips(sys, tris, &fixed, &moved);
    }
    Ok(())
}

/// Whether the triangle (a, b, c), with bubble `i` moved to (`p`, `uv`),
/// is positively oriented: in (u,v) with exact predicates on a plane, along
/// the surface normal at the moved bubble otherwise.
fn oriented<C: Carrier>(
    sys: &System<'_, C>,
    t: [usize; 3],
    i: usize,
    p: &P3,
    uv: [f64; 2],
) -> bool {
    if sys.carrier.planar() {
        let q = |x: usize| if x == i { uv } else { sys.params[x] };
        orient_uv(q(t[0]), q(t[1]), q(t[2])) > 0.0
    } else {
        let n = sys
            .carrier
            .normal(if t.contains(&i) { uv } else { sys.params[t[0]] });
        turns_about(sys, t, i, p, &n)
    }
}

/// Whether triangle `t`, with bubble `i` at `p`, turns positively about
/// the surface normal `n` (the curved-surface case of [`oriented`]).
fn turns_about<C: Carrier>(sys: &System<'_, C>, t: [usize; 3], i: usize, p: &P3, n: &V3) -> bool {
    let at = |x: usize| if x == i { *p } else { sys.pos[x] };
    (at(t[1]) - at(t[0])).cross(&(at(t[2]) - at(t[0]))).dot(n) > 0.0
}

/// Whether the edge (a,b) of the triangles (a,b,c), (b,a,d) should flip to
/// be Delaunay: the in-circle test in (u,v) on a plane, the opposite-angle
/// sum measured in model space on a curved surface.
fn not_delaunay<C: Carrier>(sys: &System<'_, C>, a: usize, b: usize, c: usize, d: usize) -> bool {
    if sys.carrier.planar() {
        let p = &sys.params;
        incircle_uv(p[a], p[b], p[c], p[d]) > 0.0
    } else {
        let x = &sys.pos;
        let ang = |o: usize| (x[a] - x[o]).angle(&(x[b] - x[o]));
        ang(c) + ang(d) > std::f64::consts::PI + 1e-12
    }
}

fn incircle_uv(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    let k = |p: [f64; 2]| robust::Coord { x: p[0], y: p[1] };
    robust::incircle(k(a), k(b), k(c), k(d))
}

/// Lawson flips until every non-constraint edge is locally Delaunay in
/// (u,v). Returns the number of flips.
fn delaunay_flips<C: Carrier>(
    sys: &System<'_, C>,
    tris: &mut [[usize; 3]],
    fixed: &HashSet<(usize, usize)>,
    moved: &[usize],
) -> usize {
    let mut inc = Incidence::new(sys.n(), tris);
    let mut flips = 0;
    // only triangles around moved bubbles can have lost the Delaunay property
    let mut stack: Vec<usize> = moved
        .iter()
        .flat_map(|&v| inc.of(v).iter().map(|&t| t as usize))
        .collect();
    stack.sort_unstable();
    stack.dedup();
    let limit = 20 * tris.len() + 100;
    while let Some(ti) = stack.pop() {
        for k in 0..3 {
            let Some((a, b, c, d, tj)) = pair(tris, &inc, ti, k) else {
                continue;
            };
            if fixed.contains(&(a.min(b), a.max(b))) {
                continue;
            }
            if not_delaunay(sys, a, b, c, d)
                && try_flip(sys, tris, &mut inc, (ti, tj), [a, b, c, d])
            {
                flips += 1;
                stack.push(ti);
                stack.push(tj);
                break;
            }
        }
        if flips > limit {
            break;
        }
    }
    flips
}

/// Triangles around each bubble, for neighbour lookups in the flip pass:
/// compressed rows built once, with the few rows a flip changes copied into
/// an overlay (no per-vertex allocation: this runs on 10⁶ triangles).
struct Incidence {
    start: Vec<u32>,
    tri: Vec<u32>,
    changed: std::collections::HashMap<usize, Vec<u32>>,
}

impl Incidence {
    fn new(n: usize, tris: &[[usize; 3]]) -> Self {
        let (start, tri) = crate::incidence::node_elements(n, tris, |v| v);
        Incidence {
            start,
            tri,
            changed: Default::default(),
        }
    }
    fn of(&self, v: usize) -> &[u32] {
        match self.changed.get(&v) {
            Some(x) => x,
            None => &self.tri[self.start[v] as usize..self.start[v + 1] as usize],
        }
    }
    fn row(&mut self, v: usize) -> &mut Vec<u32> {
        let (s, e) = (self.start[v] as usize, self.start[v + 1] as usize);
        let tri = &self.tri;
        self.changed.entry(v).or_insert_with(|| tri[s..e].to_vec())
    }
    /// The triangle other than `ti` holding the directed edge (b, a).
    fn across(&self, tris: &[[usize; 3]], ti: usize, a: usize, b: usize) -> Option<(usize, usize)> {
        for &tj in self.of(a) {
            let tj = tj as usize;
            if tj == ti {
                continue;
            }
            let t = tris[tj];
            for k in 0..3 {
                if t[k] == b && t[(k + 1) % 3] == a {
                    return Some((tj, k));
                }
            }
        }
        None
    }
}

/// The flip candidate across edge k of triangle ti: returns (a, b, c, d, tj)
/// where (a,b) is the shared edge, c opposite in ti, d opposite in tj.
fn pair(
    tris: &[[usize; 3]],
    inc: &Incidence,
    ti: usize,
    k: usize,
) -> Option<(usize, usize, usize, usize, usize)> {
    let t = tris[ti];
    let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
    let (tj, kj) = inc.across(tris, ti, a, b)?;
    let d = tris[tj][(kj + 2) % 3];
    Some((a, b, c, d, tj))
}

/// Replaces (a,b,c),(b,a,d) by (c,a,d),(d,b,c) if the quadrilateral
/// c,a,d,b is strictly convex in (u,v) (triangles `ti`, `tj`). Returns
/// whether it flipped.
fn try_flip<C: Carrier>(
    sys: &System<'_, C>,
    tris: &mut [[usize; 3]],
    inc: &mut Incidence,
    (ti, tj): (usize, usize),
    [a, b, c, d]: [usize; 4],
) -> bool {
    let p = &sys.params;
    let ok = if sys.carrier.planar() {
        orient_uv(p[c], p[a], p[d]) > 0.0 && orient_uv(p[d], p[b], p[c]) > 0.0
    } else {
        oriented(sys, [c, a, d], c, &sys.pos[c], p[c])
            && oriented(sys, [d, b, c], d, &sys.pos[d], p[d])
    };
    if !ok {
        return false;
    }
    tris[ti] = [c, a, d];
    tris[tj] = [d, b, c];
    // a leaves tj, b leaves ti; c joins tj, d joins ti
    inc.row(a).retain(|&x| x as usize != tj);
    inc.row(b).retain(|&x| x as usize != ti);
    inc.row(c).push(tj as u32);
    inc.row(d).push(ti as u32);
    true
}

/// What [`lift_bubbles`] maximises.
#[derive(Clone, Copy, PartialEq)]
enum Lift {
    /// The smallest radius ratio of the bubble's triangles (bubbles of
    /// triangles below `lift_q`).
    Worst,
    /// Their sum, the smallest kept at least min(its value, `lift_q`)
    /// (bubbles of triangles below `mean_q`).
    Mean,
    /// The smallest angle of the bubble's triangles (radians), the
    /// smallest radius ratio kept at least its value (bubbles of the
    /// triangles whose smallest angle is below `below`, in radians).
    Angle,
}

/// For each free bubble at a corner of a triangle below `lift_q` (or
/// `mean_q`), a pattern search in its tangent plane (8 directions, step
/// halved 10 times from 0.15 d) for the position that maximises the
/// [`Lift`] objective of its triangles. Only bubbles around poor triangles
/// move, so the edge lengths elsewhere keep what the packing gave them.
/// Returns the bubbles moved.
fn lift_bubbles<C: Carrier>(
    sys: &mut System<'_, C>,
    tris: &[[usize; 3]],
    lift: Lift,
    below: f64,
    band: f64,
    movable: Option<&[bool]>,
) -> Result<Vec<usize>, MeshError> {
    let n = sys.n();
    let nf = sys.n_fixed;
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut poor = vec![false; n];
    for (ti, t) in tris.iter().enumerate() {
        let (a, b, c) = (&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]]);
        let q = match lift {
            Lift::Angle => crate::measure::triangle_min_angle(a, b, c),
            _ => radius_ratio(a, b, c),
        };
        for &v in t {
            incident[v].push(ti);
            if q < below {
                poor[v] = true;
            }
        }
    }
    let (ln_lo, ln_hi) = (PRM.band_lo.ln(), PRM.band_hi.ln());
    // the eight trial directions, k·45° from the frame's first tangent
    let turns: [(f64, f64); 8] = std::array::from_fn(|k| {
        let a = k as f64 * std::f64::consts::FRAC_PI_4;
        (a.cos(), a.sin())
    });
    let mut moved = Vec::new();
    let mut ring = Ring::default();
    for i in nf..n {
        if !poor[i] || movable.is_some_and(|m| !m[i]) {
            continue;
        }
        ring.gather(sys, tris, &incident[i], i);
        // the objective; -1 for an inverted triangle or, lifting the mean,
        // a smallest radius ratio below the floor
        let worst_at = |sys: &System<'_, C>,
                        ring: &mut Ring,
                        p: &P3,
                        uv: [f64; 2],
                        floor: f64,
                        floor_sum: f64,
                        most_out: usize|
         -> f64 {
            if !ring.oriented(sys, i, p, uv) {
                return -1.0;
            }
            ring.measure(sys, p);
            if lift == Lift::Angle && ring.out_of_band(sys, i) > most_out {
                return -1.0;
            }
            let (mut w, mut sum, mut angle) = (f64::INFINITY, 0.0, f64::INFINITY);
            for r in &ring.tris {
                let q = ring.radius_ratio(r);
                w = w.min(q);
                sum += q;
                if lift == Lift::Angle {
                    angle = angle.min(ring.min_angle(r));
                }
                if band > 0.0 {
                    // each edge at i is in two of its triangles: half weight per triangle;
                    // inside the band the penalty is zero, so the logarithm (the
                    // costliest part of a trial, 6 % of case B) is taken outside only
                    for (k, &j) in r.t.iter().enumerate() {
                        if j != i {
                            let l = ring.len[r.slot[k]] / (0.5 * (sys.d[i] + sys.d[j]));
                            if (PRM.band_lo..=PRM.band_hi).contains(&l) {
                                continue;
                            }
                            let r = l.ln();
                            let out = (r - ln_hi).max(0.0) + (ln_lo - r).max(0.0);
                            sum -= 0.5 * band * out * out;
                        }
                    }
                }
            }
            match lift {
                Lift::Worst => w,
                Lift::Angle if sum < floor_sum => -1.0,
                Lift::Mean | Lift::Angle if w < floor => -1.0,
                Lift::Mean => sum,
                Lift::Angle => angle,
            }
        };
        let (floor, floor_sum) = floors(sys, tris, &incident[i], lift);
        // lifting the angle, no more of the bubble's edges may leave the
        // spacing band [1/√2, √2] than are outside it now
        let most_out = if lift == Lift::Angle {
            ring.measure(sys, &sys.pos[i]);
            ring.out_of_band(sys, i)
        } else {
            usize::MAX
        };
        let mut best = worst_at(
            sys,
            &mut ring,
            &sys.pos[i],
            sys.params[i],
            floor,
            floor_sum,
            most_out,
        );
        let start = best;
        let mut step = 0.15 * sys.d[i];
        // the frame changes only where the bubble moved
        let mut frame = sys.carrier.frame(sys.params[i]);
        for _ in 0..10 {
            let (t1, t2) = frame;
            let mut improved = false;
            for &(cos, sin) in &turns {
                let dir = t1 * cos + t2 * sin;
                let Some((p, uv)) = sys
                    .carrier
                    .advance(&sys.pos[i], sys.params[i], &(dir * step))
                else {
                    continue;
                };
                let w = worst_at(sys, &mut ring, &p, uv, floor, floor_sum, most_out);
                if w > best + 1e-12 {
                    best = w;
                    sys.pos[i] = p;
                    sys.params[i] = uv;
                    improved = true;
                }
            }
            if improved {
                frame = sys.carrier.frame(sys.params[i]);
            } else {
                step *= 0.5;
            }
        }
        if best > start {
            if sys.uniform().is_none() {
                sys.d[i] = sys.spacing_at(&sys.pos[i], sys.params[i])?;
            }
            moved.push(i);
        }
    }
    Ok(moved)
}

/// The least value of the smallest radius ratio and of the sum of the
/// radius ratios around a bubble (its triangles `incident`) that a move
/// may leave, for [`lift_bubbles`]: lifting the mean, the smallest kept at
/// min(its value, `lift_q`); lifting the angle, the smallest kept and the
/// sum kept within `angle_slack`; lifting the worst, no bound.
fn floors<C: Carrier>(
    sys: &System<'_, C>,
    tris: &[[usize; 3]],
    incident: &[usize],
    lift: Lift,
) -> (f64, f64) {
    let qs = incident.iter().map(|&ti| {
        let t = tris[ti];
        radius_ratio(&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]])
    });
    let least = || qs.clone().fold(f64::INFINITY, f64::min);
    match lift {
        Lift::Worst => (f64::NEG_INFINITY, f64::NEG_INFINITY),
        Lift::Mean => (least().min(PRM.lift_q), f64::NEG_INFINITY),
        Lift::Angle => (least(), qs.clone().sum::<f64>() - PRM.angle_slack),
    }
}

/// A bubble's triangles for [`lift_bubbles`]' trials: the bubble moves,
/// its neighbours do not, so each neighbour's distance is taken once per
/// trial and each triangle's edge opposite the bubble once per search.
/// Every length is the same floating-point expression as in
/// [`radius_ratio`] (|x − y| and |y − x| round alike), so the objective is
/// the one of the triangles' radius ratios bit for bit.
#[derive(Default)]
struct Ring {
    /// The distinct neighbours (the triangles' other corners).
    nodes: Vec<usize>,
    /// Their distances to the trial position.
    len: Vec<f64>,
    tris: Vec<RingTri>,
}

struct RingTri {
    t: [usize; 3],
    /// The bubble's corner of `t`.
    at: usize,
    /// Each corner's index into `Ring::nodes` (the bubble's: unused).
    slot: [usize; 3],
    /// The length of the edge opposite the bubble.
    opposite: f64,
}

impl Ring {
    fn gather<C: Carrier>(
        &mut self,
        sys: &System<'_, C>,
        tris: &[[usize; 3]],
        incident: &[usize],
        i: usize,
    ) {
        self.nodes.clear();
        self.tris.clear();
        for &ti in incident {
            let t = tris[ti];
            let at = t
                .iter()
                .position(|&x| x == i)
                .expect("an incident triangle");
            let mut slot = [usize::MAX; 3];
            for (k, &x) in t.iter().enumerate() {
                if x != i {
                    slot[k] = match self.nodes.iter().position(|&y| y == x) {
                        Some(s) => s,
                        None => {
                            self.nodes.push(x);
                            self.nodes.len() - 1
                        }
                    };
                }
            }
            let (b, c) = (t[(at + 1) % 3], t[(at + 2) % 3]);
            self.tris.push(RingTri {
                t,
                at,
                slot,
                opposite: (sys.pos[c] - sys.pos[b]).norm(),
            });
        }
        self.len.resize(self.nodes.len(), 0.0);
    }

    /// Whether every triangle is positively oriented with the bubble `i`
    /// at (`p`, `uv`) ([`oriented`]; on a curved surface the normal at
    /// `uv` is taken once).
    fn oriented<C: Carrier>(&self, sys: &System<'_, C>, i: usize, p: &P3, uv: [f64; 2]) -> bool {
        if sys.carrier.planar() {
            return self.tris.iter().all(|r| oriented(sys, r.t, i, p, uv));
        }
        let n = sys.carrier.normal(uv);
        self.tris.iter().all(|r| turns_about(sys, r.t, i, p, &n))
    }

    /// The neighbours' distances to `p`.
    fn measure<C: Carrier>(&mut self, sys: &System<'_, C>, p: &P3) {
        for (l, &j) in self.len.iter_mut().zip(&self.nodes) {
            *l = (sys.pos[j] - p).norm();
        }
    }

    /// How many of the measured edges from bubble `i` have a length
    /// outside [1/√2, √2] of the mean of their ends' spacings (the band a
    /// mesher is judged by).
    fn out_of_band<C: Carrier>(&self, sys: &System<'_, C>, i: usize) -> usize {
        self.nodes
            .iter()
            .zip(&self.len)
            .filter(|&(&j, &l)| {
                let r = l / (0.5 * (sys.d[i] + sys.d[j]));
                !(std::f64::consts::FRAC_1_SQRT_2..=std::f64::consts::SQRT_2).contains(&r)
            })
            .count()
    }

    /// The smallest angle of `r` (radians) from the measured lengths.
    fn min_angle(&self, r: &RingTri) -> f64 {
        let s = |k: usize| self.len[r.slot[k]];
        let (la, lb, lc) = match r.at {
            0 => (r.opposite, s(2), s(1)),
            1 => (s(2), r.opposite, s(0)),
            _ => (s(1), s(0), r.opposite),
        };
        crate::measure::min_angle_of_lengths(la, lb, lc)
    }

    /// [`radius_ratio`] of `r` from the measured lengths. (The lengths are
    /// picked here as in `min_angle`, not by a shared helper: the pattern
    /// search calls this for every triangle of every trial, and with the
    /// helper as_40mm_capot's surfaces took 10–15 % longer, inlined or not.)
    fn radius_ratio(&self, r: &RingTri) -> f64 {
        let s = |k: usize| self.len[r.slot[k]];
        // la = |c − b|, lb = |a − c|, lc = |b − a| as in radius_ratio
        let (la, lb, lc) = match r.at {
            0 => (r.opposite, s(2), s(1)),
            1 => (s(2), r.opposite, s(0)),
            _ => (s(1), s(0), r.opposite),
        };
        crate::measure::radius_ratio_of_lengths(la, lb, lc)
    }
}

/// The bubbles `mark` marks and those within `k` rings of them (joined to
/// a marked one by an edge of `tris`, k times over).
pub(crate) fn within_rings(mut mark: Vec<bool>, tris: &[[usize; 3]], k: usize) -> Vec<bool> {
    for _ in 0..k {
        let mut next = mark.clone();
        for t in tris {
            if t.iter().any(|&v| mark[v]) {
                for &v in t {
                    next[v] = true;
                }
            }
        }
        mark = next;
    }
    mark
}

/// Relaxation along mesh edges with the linear force of eq. 4.2.1; a move
/// that would invert an incident triangle in (u,v) is halved, then dropped.
/// Returns the bubbles that may have moved.
fn relax_edges<C: Carrier>(
    sys: &mut System<'_, C>,
    tris: &[[usize; 3]],
    iters: usize,
    movable: Option<&[bool]>,
) -> Result<Vec<usize>, MeshError> {
    let n = sys.n();
    let nf = sys.n_fixed;
    // vertex -> triangles (the triangles do not change here)
    let inc = Incidence::new(n, tris);
    let incident = |v: usize| inc.of(v);
    let neighbours = |v: usize| -> Vec<usize> {
        let mut out: Vec<usize> = incident(v)
            .iter()
            .flat_map(|&t| tris[t as usize])
            .filter(|&x| x != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    };
    // bubbles within two rings of a poor triangle
    let mut poor = vec![false; n];
    for t in tris {
        if radius_ratio(&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]]) < PRM.active_q {
            for &v in t {
                poor[v] = true;
            }
        }
    }
    let active = within_rings(poor, tris, 2);
    let movers: Vec<usize> = (nf..n)
        .filter(|&i| active[i] && movable.is_none_or(|m| m[i]))
        .collect();
    let nbrs: Vec<Vec<usize>> = movers.iter().map(|&i| neighbours(i)).collect();
    for _ in 0..iters {
        for (m, &i) in movers.iter().enumerate() {
            if nbrs[m].is_empty() {
                continue;
            }
            let mut f = V3::zeros();
            for &j in &nbrs[m] {
                let delta = sys.pos[i] - sys.pos[j];
                let r = delta.norm();
                let r0 = 0.5 * (sys.d[i] + sys.d[j]);
                if r > 0.0 {
                    f += delta * (K0 * (r0 - r) / r);
                }
            }
            let k = 0.5 * nbrs[m].len() as f64 * K0;
            let mut step = f * (PRM.omega / k);
            for _attempt in 0..3 {
                let Some((p, uv)) = sys.carrier.advance(&sys.pos[i], sys.params[i], &step) else {
                    step *= 0.5;
                    continue;
                };
                let ok = incident(i)
                    .iter()
                    .all(|&ti| oriented(sys, tris[ti as usize], i, &p, uv));
                if ok {
                    sys.pos[i] = p;
                    sys.params[i] = uv;
                    if sys.uniform().is_none() {
                        sys.d[i] = sys.spacing_at(&p, uv)?;
                    }
                    break;
                }
                step *= 0.5;
            }
        }
    }
    Ok(movers)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bubbles::testing::{hex_fill, square_system};
    use crate::face::connect::triangulate;
    use crate::spacing::Constant;

    fn quality(sys: &System<'_, impl Carrier>, tris: &[[usize; 3]]) -> (f64, f64) {
        let q: Vec<f64> = tris
            .iter()
            .map(|t| radius_ratio(&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]]))
            .collect();
        let min = q.iter().copied().fold(f64::INFINITY, f64::min);
        (min, q.iter().sum::<f64>() / q.len() as f64)
    }

    /// The unit square's boundary bubbles at spacing `s`, a hexagonal fill
    /// jittered by up to a quarter spacing (seeded), and their constrained
    /// Delaunay triangulation: the system, its boundary segments, the
    /// triangles.
    fn jittered_square(
        s: &Constant,
        seed: u64,
    ) -> (
        System<'_, crate::bubbles::testing::Square>,
        Vec<[usize; 2]>,
        Vec<[usize; 3]>,
    ) {
        let mut sys = square_system(s);
        let nf = sys.n_fixed;
        hex_fill(&mut sys, s.0, s.0, |_, _| false);
        let mut uniform = crate::bubbles::testing::uniform(seed);
        let mut jitter = || (uniform() - 0.5) * 0.5 * s.0;
        for i in nf..sys.n() {
            let (dx, dy) = (jitter(), jitter());
            sys.params[i] = [sys.params[i][0] + dx, sys.params[i][1] + dy];
            sys.pos[i] = P3::new(sys.params[i][0], sys.params[i][1], 0.0);
        }
        let boundary: Vec<[usize; 2]> = (0..nf).map(|k| [k, (k + 1) % nf]).collect();
        let tris = triangulate(&sys.params, &boundary, &boundary, |c| {
            (0.0..=1.0).contains(&c[0]) && (0.0..=1.0).contains(&c[1])
        })
        .unwrap();
        (sys, boundary, tris)
    }

    fn least_angle(sys: &System<'_, impl Carrier>, tris: &[[usize; 3]]) -> f64 {
        tris.iter()
            .map(|t| {
                crate::measure::triangle_min_angle(&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]])
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// After the improvement's radius-ratio lifts, the angle lift still
    /// raises the smallest angle of a jittered lattice, without lowering the
    /// smallest radius ratio, lowering the mean by more than its slack
    /// allows, or turning a triangle over.
    #[test]
    fn the_angle_lift_raises_the_smallest_angle_the_ratio_lifts_left() {
        let s = Constant(0.1);
        let (mut sys, boundary, mut tris) = jittered_square(&s, 0x2545_f491_4f6c_dd1d);
        improve(&mut sys, &mut tris, &boundary, 6).unwrap();
        let (min0, mean0) = quality(&sys, &tris);
        let angle0 = least_angle(&sys, &tris);
        lift_angle(&mut sys, &mut tris, &boundary, 3).unwrap();
        let (min1, mean1) = quality(&sys, &tris);
        let angle1 = least_angle(&sys, &tris);
        assert!(
            angle1 > angle0 + 1e-3,
            "smallest angle {}° -> {}°",
            angle0.to_degrees(),
            angle1.to_degrees()
        );
        assert!(min1 >= min0, "worst radius ratio {min0} -> {min1}");
        let budget = 3.0 * 3.0 * PRM.angle_count as f64 * PRM.angle_slack / tris.len() as f64;
        assert!(mean1 >= mean0 - budget, "mean {mean0} -> {mean1}");
        for t in &tris {
            let [a, b, c] = t.map(|k| sys.params[k]);
            assert!(orient_uv(a, b, c) > 0.0, "triangle {t:?} turned over");
        }
    }

    /// On a jittered lattice in the unit square, the improvement raises
    /// both the worst and the mean radius ratio, keeps every triangle
    /// counter-clockwise in (u,v), keeps the boundary bubbles where they
    /// are and the boundary segments as edges.
    #[test]
    fn improvement_raises_the_worst_and_the_mean_and_keeps_the_mesh_valid() {
        let s = Constant(0.1);
        let (mut sys, boundary, mut tris) = jittered_square(&s, 0x9e37_79b9_7f4a_7c15);
        let nf = sys.n_fixed;
        let fixed_before: Vec<P3> = sys.pos[..nf].to_vec();
        let (min0, mean0) = quality(&sys, &tris);
        let n_tris = tris.len();
        improve(&mut sys, &mut tris, &boundary, 6).unwrap();
        let (min1, mean1) = quality(&sys, &tris);
        assert!(min1 >= min0, "worst {min0} -> {min1}");
        assert!(mean1 > mean0, "mean {mean0} -> {mean1}");
        assert_eq!(tris.len(), n_tris, "flips keep the triangle count");
        assert_eq!(&sys.pos[..nf], &fixed_before[..], "boundary bubbles moved");
        for t in &tris {
            let [a, b, c] = t.map(|k| sys.params[k]);
            assert!(
                orient_uv(a, b, c) > 0.0,
                "triangle {t:?} is not counter-clockwise"
            );
        }
        let edges: HashSet<(usize, usize)> = tris
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        for s in &boundary {
            assert!(
                edges.contains(&(s[0].min(s[1]), s[0].max(s[1]))),
                "boundary segment {s:?} lost"
            );
        }
    }
}
