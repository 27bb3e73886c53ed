//! Seeds from a hexagonal lattice conformal to the spacing, for graded planar
//! faces (a second start for stage 2 and the connection).
//!
//! **Why.** A spacing d(x) is the metric |dx|²/d², whose Gaussian curvature
//! is d²·Δ log d. A triangular lattice drawn in that metric needs five- and
//! seven-valent nodes only where the curvature is: ∫Δ log d dA / (π/3) of
//! them in net. Bubble packing anneals instead into many five/seven *pairs*
//! (dislocations), and every triangle touching one loses about 0.03 of
//! radius ratio: on meshkit's graded cases B and C that caps the mean near
//! 0.985 whatever smoothing follows (`bench/bound_2d.py`). This module
//! builds the lattice the metric asks for, with few isolated defects
//! (research and measurements: `bench/research/defects_2d`).
//!
//! **How** (a linearised curvature prescription, Ben-Chen, Gotsman & Bunin
//! 2008, on a background mesh):
//! 1. the face's bubble mesh refined 1-to-4 is the background; L is its
//!    cotan Laplacian and u = −log d at its nodes;
//! 2. φ = u + h with L φ = κ − K_E at the unknown nodes, where K_E is the
//!    Euclidean curvature (π − angle sum on the boundary, 0 inside); the
//!    metric e^{2φ}|dx|² is then flat except at cones κ = ±π/3. The outer
//!    loop is Dirichlet (h = 0, so the spacing on it is exact); hole loops
//!    are Neumann with zero target turning, so a hole becomes a straight
//!    line of the layout and lattice rows can run along it;
//! 3. cones are added greedily at the node of largest |h| among nodes more
//!    than `cone_exclusion` spacings from every cone, with
//!    κ = −sign(h)·π/3, until that |h| < `cone_tol` (L is factored once,
//!    by sparse Cholesky, and solved once per cone);
//! 4. the triangles are laid out in the plane breadth-first with the lengths
//!    ℓ_ij·e^{(φ_i+φ_j)/2} (in units of the spacing); turning by ±60° around
//!    a cone, which a hexagonal lattice does not see;
//! 5. one unit hexagonal lattice per hole, laid out from that hole, turned so
//!    that the hole lies on a lattice row through its nodes and scaled so
//!    that its length is its node count (the annulus then closes on a
//!    lattice vector); each triangle takes the lattice of the hole nearest in
//!    triangle hops (one lattice when the face has no hole);
//! 6. the lattice points inside each laid-out triangle, mapped back by
//!    barycentric coordinates, are the seeds, less those within
//!    `boundary_gap`·d of a boundary or constraint segment and those within
//!    `seed_gap`·d of an earlier seed or a fixed node;
//! 7. holes are Neumann only when the metric makes them nearly closed
//!    geodesics (`hole_tol`); a hole in a nearly uniform spacing is
//!    Dirichlet like the outer loop.
//!
//! The caller (`face::conformal_restart`) takes the seeds as a new stage 1:
//! stage 2, connection, improvement and more rounds of the mean lift, and
//! keeps the result only if its mean radius ratio is higher and its spacing
//! no worse than the packed mesh's. Measured with `bench/run_2d.py`: case B
//! 0.9852 / 0.900 → 0.9930 / 0.887 (mean / min radius ratio), case C
//! 0.9823 / 0.818 → 0.9928 / 0.894, 100 % of edges in [1/√2, √2]; the
//! flattening and second stage 2 cost about as much as the packing (case B,
//! one thread: 0.40 of 0.62 s, the solves 0.04 s of it). Larger faces
//! cost more: see [`LatticeParams::max_background_nodes`].
//!
//! Units: (u,v) of a planar face whose parametrization is an isometry, so a
//! spacing is a (u,v) length. Invariants: the input triangles are
//! counter-clockwise and form a conforming mesh of the face; fixed nodes
//! come first.

use std::collections::{HashMap, VecDeque};

use faer::col::ColRef;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use faer::Side;
use nalgebra::Complex;

type C64 = Complex<f64>;

/// The lattice's tuning, each value with how it was measured.
#[derive(Clone, Copy, Debug)]
pub struct LatticeParams {
    /// Cone placement stops when |h| (log of the lattice's spacing over d)
    /// is below this everywhere outside the cones' neighbourhoods
    /// (buildCones.py: 0.1 placed 74 cones on case B and lost 0.02 of mean;
    /// 0.3 too few).
    pub cone_tol: f64,
    /// Radius, in spacings, of a cone's neighbourhood where |h| is not
    /// looked at (the log singularity of a cone is the lattice's business).
    pub cone_exclusion: f64,
    /// Cones of a sign beyond what the curvature of that sign asks for.
    pub cone_slack: usize,
    /// At most this many cones (a face that needs more has a spacing
    /// varying on the scale of the spacing itself, where a lattice is no
    /// better).
    pub max_cones: usize,
    /// A hole stays Neumann (straight in the layout) while the first-order
    /// |h| on it, before any cone, is at most this (case C's holes: 0.42;
    /// the same plate with d = 0.02 + 0.01 x: 1.43 and 1.54).
    pub hole_tol: f64,
    /// Seeds closer than this many spacings to the boundary are dropped:
    /// the boundary nodes stand there.
    pub boundary_gap: f64,
    /// Seeds closer than this many spacings to a kept seed are dropped.
    pub seed_gap: f64,
    /// Background meshes larger than this are not flattened, and the face
    /// keeps its packed mesh. The bound is memory: the Cholesky factor of
    /// L grows faster than the mesh (case B at a quarter of its spacing,
    /// 99k unknowns: peak 189 MB against 109 MB without the lattice; at an
    /// eighth, 400k unknowns: 788 MB against 70 MB, and the second stage 2
    /// tripled the time). The solves themselves are no longer the cost
    /// (at a quarter: the flattening and second stage 2 12.6 s against
    /// 5.8 s of packing).
    pub max_background_nodes: usize,
}

impl LatticeParams {
    /// The measured values (see each field).
    pub const DEFAULT: LatticeParams = LatticeParams {
        cone_tol: 0.2,
        cone_exclusion: 3.0,
        cone_slack: 2,
        max_cones: 400,
        hole_tol: 0.8,
        boundary_gap: 0.4,
        seed_gap: 0.6,
        max_background_nodes: 120_000,
    };
}

impl Default for LatticeParams {
    fn default() -> Self {
        LatticeParams::DEFAULT
    }
}

/// The lattice's settings.
const PRM: LatticeParams = LatticeParams::DEFAULT;
/// Newton steps on the curvature at most (it converges quadratically).
const NEWTON_STEPS: usize = 8;
/// Lattice points this far outside a laid-out triangle (in barycentric
/// coordinates) still count for it: across the edges where the breadth-first
/// layouts meet, neighbours' images overlap or leave slivers, and a point in
/// a sliver would be lost (the duplicates are dropped by `seed_gap`).
const OVERLAP: f64 = 0.05;

/// A face's bubble mesh and spacing.
pub struct Background<'a> {
    /// (u,v) of the nodes, fixed ones first.
    pub uv: &'a [[f64; 2]],
    /// Counter-clockwise triangles.
    pub tris: &'a [[usize; 3]],
    /// Number of fixed nodes (boundary and embedded).
    pub n_fixed: usize,
    /// Node loops of the holes (not the outer loop).
    pub holes: &'a [Vec<usize>],
    /// Constraint segments (boundary and embedded edges) seeds keep clear of.
    pub segments: &'a [[usize; 2]],
}

/// What [`lattice_seeds`] found.
#[derive(Clone, Debug)]
pub struct Lattice {
    /// Seeds in (u,v), with their spacing.
    pub seeds: Vec<([f64; 2], f64)>,
    /// Cones placed (positive, negative).
    pub cones: (usize, usize),
}

/// Seeds of the lattice conformal to the spacing `d` (a (u,v) length) over
/// the background mesh; `None` when the face cannot be flattened (no outer
/// loop to hold the scale, too large, or a solve that does not converge).
pub fn lattice_seeds(bg: &Background<'_>, d: &mut dyn FnMut([f64; 2]) -> f64) -> Option<Lattice> {
    // the refined mesh has about four times the nodes: check before building it
    if 4 * bg.uv.len() > PRM.max_background_nodes || bg.tris.is_empty() {
        return None;
    }
    let mut mesh = refine(bg);
    let n = mesh.uv.len();
    let dn: Vec<f64> = mesh.uv.iter().map(|&p| d(p)).collect();
    if dn.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
        return None;
    }
    let u: Vec<f64> = dn.iter().map(|&x| -x.ln()).collect();

    let euclid = Metric::new(&mesh, &vec![0.0; n]);
    let mut first = first_order(&mut mesh, &euclid, &u, bg.holes.len())?;
    let (kappa, cones) = place_cones(&mesh, &mut first, &dn)?;
    // the Euclidean factor is not needed again: freed before Newton's
    let FirstOrder {
        unk,
        unk_nodes,
        h,
        laplacian,
        ..
    } = first;
    drop(laplacian);
    let mut phi = u.clone();
    for (m, &i) in unk_nodes.iter().enumerate() {
        phi[i] += h[m];
    }
    // the cones found to first order, the metric is made flat exactly
    if !newton(&mesh, &unk, &unk_nodes, &kappa, &mut phi) {
        return None;
    }
    let f = lay_out(&mesh, bg, &u, &phi)?;
    let raw = lattice_points(&mesh, &f);
    let seeds = clear_seeds(bg, d, &dn, raw);
    Some(Lattice { seeds, cones })
}

/// The first-order solution before any cone: the unknowns (interior nodes
/// and Neumann hole nodes), L restricted to them, the right-hand side and h.
struct FirstOrder {
    /// Index of each background node among the unknowns (`usize::MAX`:
    /// Dirichlet).
    unk: Vec<usize>,
    unk_nodes: Vec<usize>,
    /// The Euclidean L restricted to the unknowns, factored.
    laplacian: Spd,
    /// −(L u)_U − K_E.
    rhs0: Vec<f64>,
    /// h at the unknowns; after [`place_cones`], with the cones.
    h: Vec<f64>,
}

/// Step 2 and 7 of the module docs: h with no cone, a hole made Dirichlet
/// (in `mesh.hole_of`) when it is not nearly a closed geodesic.
fn first_order(
    mesh: &mut Refined,
    euclid: &Metric,
    u: &[f64],
    nholes: usize,
) -> Option<FirstOrder> {
    let n = mesh.uv.len();
    // A hole is Neumann (straight in the layout, lattice rows along it) when
    // the metric makes it close to a closed geodesic: the spacing growing
    // like the distance from the hole's centre (case C), where the first-
    // order solution keeps |h| ≤ `hole_tol` on it. Around any other hole
    // (a hole in a nearly uniform spacing) straightening it would distort
    // the scale by e^|h|, far out of band, so it is Dirichlet like the
    // outer loop.
    loop {
        // unknowns: interior nodes and Neumann hole nodes; the rest is Dirichlet
        let mut unk = vec![usize::MAX; n];
        let mut unk_nodes = Vec::new();
        for (i, x) in unk.iter_mut().enumerate() {
            if !mesh.boundary[i] || mesh.hole_of[i] != usize::MAX {
                *x = unk_nodes.len();
                unk_nodes.push(i);
            }
        }
        if unk_nodes.len() == n || unk_nodes.is_empty() {
            return None; // no Dirichlet node: the scale would be free
        }
        // L restricted to the unknowns, and rhs0 = −(L u)_U − K_E
        let laplacian = euclid.reduced(&unk, &unk_nodes, None)?;
        let rhs0: Vec<f64> = unk_nodes
            .iter()
            .map(|&i| {
                let lu = euclid.diag[i] * u[i]
                    - euclid.off[i].iter().map(|&(j, w)| w * u[j]).sum::<f64>();
                -lu - euclid.curvature[i]
            })
            .collect();
        let h = laplacian.solve(&rhs0)?;
        let mut worst = vec![0.0f64; nholes];
        for (m, &i) in unk_nodes.iter().enumerate() {
            if mesh.hole_of[i] != usize::MAX {
                worst[mesh.hole_of[i]] = worst[mesh.hole_of[i]].max(h[m].abs());
            }
        }
        let dirichlet: Vec<usize> = (0..nholes).filter(|&k| worst[k] > PRM.hole_tol).collect();
        if dirichlet.is_empty() {
            return Some(FirstOrder {
                unk,
                unk_nodes,
                laplacian,
                rhs0,
                h,
            });
        }
        for x in mesh.hole_of.iter_mut() {
            if *x != usize::MAX && dirichlet.contains(x) {
                *x = usize::MAX;
            }
        }
    }
}

/// Step 3 of the module docs: cones placed greedily at the largest |h|,
/// re-solving for h (in `first.h`) after each. Returns κ at the unknowns
/// and the cones placed (positive, negative).
fn place_cones(
    mesh: &Refined,
    first: &mut FirstOrder,
    dn: &[f64],
) -> Option<(Vec<f64>, (usize, usize))> {
    let FirstOrder {
        unk_nodes,
        laplacian,
        rhs0,
        h,
        ..
    } = first;
    let nu = unk_nodes.len();
    let mut kappa = vec![0.0; nu];
    let mut b = rhs0.clone();
    // cones go more than `cone_exclusion` spacings from every cone (a cone's
    // own log singularity is the lattice's business) and not on holes
    let mut far: Vec<bool> = unk_nodes
        .iter()
        .map(|&i| mesh.hole_of[i] == usize::MAX)
        .collect();
    // at most as many cones of a sign as the curvature of that sign asks
    // for (κ ≈ L u + K_E to first order), and a few: near a cone the
    // conformal factor grows like (1/6)·log(1/r), so on a fine background
    // |h| passes `cone_tol` some spacings from any cone, and more cones would
    // only chase that in ± pairs, the dislocations this module avoids
    // (case B at a quarter of its spacing: 400 cones without the budget,
    // 10 + 2 with it)
    let (mut budget_pos, mut budget_neg) = {
        let (mut p, mut q) = (0.0, 0.0);
        for (m, &i) in unk_nodes.iter().enumerate() {
            if mesh.hole_of[i] == usize::MAX {
                let k = -rhs0[m]; // rhs0 = −(L u) − K_E
                if k > 0.0 {
                    p += k
                } else {
                    q -= k
                }
            }
        }
        let third = std::f64::consts::FRAC_PI_3;
        (
            (p / third).ceil() as usize + PRM.cone_slack,
            (q / third).ceil() as usize + PRM.cone_slack,
        )
    };
    let mut cones = (0usize, 0usize);
    let (mut pos_ok, mut neg_ok) = (true, true);
    loop {
        let k = (0..nu)
            .filter(|&k| far[k] && if h[k] < 0.0 { pos_ok } else { neg_ok })
            .max_by(|&a, &c| h[a].abs().total_cmp(&h[c].abs()));
        let Some(k) = k else { break };
        if h[k].abs() < PRM.cone_tol || cones.0 + cones.1 >= PRM.max_cones {
            break;
        }
        let s = -h[k].signum();
        let budget = if s > 0.0 {
            &mut budget_pos
        } else {
            &mut budget_neg
        };
        if *budget == 0 {
            if s > 0.0 {
                pos_ok = false
            } else {
                neg_ok = false
            }
            continue;
        }
        *budget -= 1;
        let pk = mesh.uv[unk_nodes[k]];
        for (m, &i) in unk_nodes.iter().enumerate() {
            let r = PRM.cone_exclusion * dn[i].max(dn[unk_nodes[k]]);
            let q = mesh.uv[i];
            if (q[0] - pk[0]).powi(2) + (q[1] - pk[1]).powi(2) <= r * r {
                far[m] = false;
            }
        }
        kappa[k] += s * std::f64::consts::FRAC_PI_3;
        if s > 0.0 {
            cones.0 += 1
        } else {
            cones.1 += 1
        }
        for m in 0..nu {
            b[m] = rhs0[m] + kappa[m];
        }
        *h = laplacian.solve(&b)?;
    }
    Some((kappa, cones))
}

/// Steps 4 and 5 of the module docs: each triangle laid out in the plane
/// with the metric e^{2φ}|dx|², one layout per region (the Neumann hole
/// nearest in triangle hops, or one region when there is none), each
/// aligned to its hole. `None` when a Neumann hole has no region.
fn lay_out(mesh: &Refined, bg: &Background<'_>, u: &[f64], phi: &[f64]) -> Option<Vec<[C64; 3]>> {
    let nholes = bg.holes.len();
    // regions: each triangle belongs to the Neumann hole nearest in
    // triangle hops (one region when there is none)
    let ntri = mesh.tris.len();
    let neumann: Vec<bool> = (0..nholes).map(|k| mesh.hole_of.contains(&k)).collect();
    let mut region = vec![usize::MAX; ntri];
    let mut queue = VecDeque::new();
    let mut roots = vec![usize::MAX; nholes.max(1)];
    for (t, tri) in mesh.tris.iter().enumerate() {
        for k in 0..3 {
            let (i, j) = (tri[k], tri[(k + 1) % 3]);
            let hi = mesh.hole_of[i];
            if hi != usize::MAX
                && hi == mesh.hole_of[j]
                && mesh.adj[t][k] == usize::MAX
                && region[t] == usize::MAX
            {
                region[t] = hi;
                queue.push_back(t);
                if roots[hi] == usize::MAX {
                    roots[hi] = t;
                }
            }
        }
    }
    if !neumann.contains(&true) {
        // one lattice, rooted where the spacing is largest
        let t = (0..ntri)
            .min_by(|&a, &c| {
                let sa: f64 = mesh.tris[a].iter().map(|&i| u[i]).sum();
                let sc: f64 = mesh.tris[c].iter().map(|&i| u[i]).sum();
                sa.total_cmp(&sc)
            })
            .unwrap();
        region[t] = 0;
        roots[0] = t;
        queue.push_back(t);
    }
    while let Some(t) = queue.pop_front() {
        for k in 0..3 {
            let o = mesh.adj[t][k];
            if o != usize::MAX && region[o] == usize::MAX {
                region[o] = region[t];
                queue.push_back(o);
            }
        }
    }
    if !neumann.contains(&true) {
        roots.truncate(1);
    } else if (0..nholes).any(|k| neumann[k] && roots[k] == usize::MAX) {
        return None;
    }

    // layouts, one per region, aligned to its hole
    let mut f = vec![[C64::new(0.0, 0.0); 3]; ntri];
    let len = |i: usize, j: usize| -> f64 {
        let (a, b) = (mesh.uv[i], mesh.uv[j]);
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt() * (0.5 * (phi[i] + phi[j])).exp()
    };
    for (r, &root) in roots.iter().enumerate() {
        if root == usize::MAX {
            continue; // a Dirichlet hole: no region of its own
        }
        layout(mesh, root, |t| region[t] == r, &len, &mut f);
        if neumann.get(r) == Some(&true) {
            align_to_hole(mesh, r, bg.holes[r].len(), &region, &mut f);
        }
    }
    Some(f)
}

/// Step 6 of the module docs: the points of the unit hexagonal lattice in
/// every laid-out triangle `f[t]`, mapped back to (u,v) by barycentric
/// coordinates.
fn lattice_points(mesh: &Refined, f: &[[C64; 3]]) -> Vec<[f64; 2]> {
    let sin60 = 3f64.sqrt() / 2.0;
    let w = C64::new(0.5, sin60);
    let mut raw: Vec<[f64; 2]> = Vec::new();
    for (t, tri) in mesh.tris.iter().enumerate() {
        let g = f[t];
        let ab = |z: C64| {
            let bb = z.im / sin60;
            (z.re - 0.5 * bb, bb)
        };
        let c: Vec<(f64, f64)> = g.iter().map(|&z| ab(z)).collect();
        let (amin, amax) = c.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |m, x| {
            (m.0.min(x.0), m.1.max(x.0))
        });
        let (bmin, bmax) = c.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |m, x| {
            (m.0.min(x.1), m.1.max(x.1))
        });
        if !(amax - amin < 64.0 && bmax - bmin < 64.0) {
            continue; // a degenerate layout (should not happen): skip it
        }
        let e1 = g[1] - g[0];
        let e2 = g[2] - g[0];
        let det = e1.re * e2.im - e1.im * e2.re;
        if det.abs() < 1e-12 {
            continue;
        }
        for a in amin.floor() as i64..=amax.ceil() as i64 {
            for bb in bmin.floor() as i64..=bmax.ceil() as i64 {
                let q = C64::new(a as f64, 0.0) + w * bb as f64 - g[0];
                let l1 = (q.re * e2.im - q.im * e2.re) / det;
                let l2 = (e1.re * q.im - e1.im * q.re) / det;
                if l1 >= -OVERLAP && l2 >= -OVERLAP && l1 + l2 <= 1.0 + OVERLAP {
                    let (p0, p1, p2) = (mesh.uv[tri[0]], mesh.uv[tri[1]], mesh.uv[tri[2]]);
                    raw.push([
                        p0[0] + l1 * (p1[0] - p0[0]) + l2 * (p2[0] - p0[0]),
                        p0[1] + l1 * (p1[1] - p0[1]) + l2 * (p2[1] - p0[1]),
                    ]);
                }
            }
        }
    }
    raw
}

/// The lattice points, in order, that keep clear of the segments
/// (`boundary_gap`), the fixed nodes and each other (`seed_gap`), with
/// their spacing.
fn clear_seeds(
    bg: &Background<'_>,
    d: &mut dyn FnMut([f64; 2]) -> f64,
    dn: &[f64],
    raw: Vec<[f64; 2]>,
) -> Vec<([f64; 2], f64)> {
    let dmin = dn.iter().cloned().fold(f64::INFINITY, f64::min);
    let seg_grid = SegmentGrid::new(bg.uv, bg.segments);
    let mut pts = PointGrid::new(PRM.seed_gap * dmin);
    let fixed_d: Vec<f64> = (0..bg.n_fixed).map(|i| d(bg.uv[i])).collect();
    for i in 0..bg.n_fixed {
        pts.insert(bg.uv[i]);
    }
    let mut seeds = Vec::new();
    for p in raw {
        let dp = d(p);
        if !(dp.is_finite() && dp > 0.0) {
            continue;
        }
        if seg_grid.near(bg.uv, p, PRM.boundary_gap * dp) {
            continue;
        }
        let mut crowded = false;
        pts.query(p, PRM.seed_gap * dp, |k| {
            // a fixed node counts with the smaller of the two spacings
            let r = if k < bg.n_fixed {
                PRM.seed_gap * dp.min(fixed_d[k])
            } else {
                PRM.seed_gap * dp
            };
            let q = pts.at(k);
            if (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) < r * r {
                crowded = true;
            }
        });
        if !crowded {
            pts.insert(p);
            seeds.push((p, dp));
        }
    }
    seeds
}

/// The background: the bubble mesh refined 1-to-4, with triangle adjacency,
/// boundary flags and hole membership.
struct Refined {
    uv: Vec<[f64; 2]>,
    tris: Vec<[usize; 3]>,
    /// `adj[t][k]`: the triangle across edge (k, k+1) of `t`, or `usize::MAX`.
    adj: Vec<[usize; 3]>,
    boundary: Vec<bool>,
    /// Index of the hole loop a boundary node lies on, or `usize::MAX`.
    hole_of: Vec<usize>,
    /// Nodes of the bubble mesh (the first ones; the others are midpoints).
    n_orig: usize,
}

fn key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

fn refine(bg: &Background<'_>) -> Refined {
    let mut uv = bg.uv.to_vec();
    let mut mid: HashMap<(usize, usize), usize> = HashMap::with_capacity(bg.tris.len() * 2);
    let mut tris = Vec::with_capacity(bg.tris.len() * 4);
    for t in bg.tris {
        let mut m = [0usize; 3];
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            m[k] = *mid.entry(key(a, b)).or_insert_with(|| {
                uv.push([
                    0.5 * (bg.uv[a][0] + bg.uv[b][0]),
                    0.5 * (bg.uv[a][1] + bg.uv[b][1]),
                ]);
                uv.len() - 1
            });
        }
        let [a, b, c] = *t;
        tris.push([a, m[0], m[2]]);
        tris.push([m[0], b, m[1]]);
        tris.push([m[2], m[1], c]);
        tris.push([m[0], m[1], m[2]]);
    }
    let n = uv.len();
    let mut half: HashMap<(usize, usize), (usize, usize)> = HashMap::with_capacity(tris.len() * 2);
    let mut adj = vec![[usize::MAX; 3]; tris.len()];
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let kk = key(tri[k], tri[(k + 1) % 3]);
            if let Some((o, ok)) = half.remove(&kk) {
                adj[t][k] = o;
                adj[o][ok] = t;
            } else {
                half.insert(kk, (t, k));
            }
        }
    }
    let mut boundary = vec![false; n];
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            if adj[t][k] == usize::MAX {
                boundary[tri[k]] = true;
                boundary[tri[(k + 1) % 3]] = true;
            }
        }
    }
    let mut hole_of = vec![usize::MAX; n];
    for (h, lp) in bg.holes.iter().enumerate() {
        for (k, &a) in lp.iter().enumerate() {
            let b = lp[(k + 1) % lp.len()];
            hole_of[a] = h;
            if let Some(&m) = mid.get(&key(a, b)) {
                hole_of[m] = h;
            }
        }
    }
    Refined {
        uv,
        tris,
        adj,
        boundary,
        hole_of,
        n_orig: bg.uv.len(),
    }
}

/// The cotan Laplacian of the metric e^{2φ}|dx|² on the background (edge
/// lengths ℓ_ij·e^{(φ_i+φ_j)/2}, angles by the law of cosines), positive
/// semi-definite: (L x)_i = Σ_j w_ij (x_i − x_j), w_ij = (cot α + cot β)/2;
/// and its curvature at the nodes: 2π (inside) or π (boundary) minus the
/// angle sum there. With φ = 0 these are the Euclidean L and K_E.
struct Metric {
    diag: Vec<f64>,
    off: Vec<Vec<(usize, f64)>>,
    curvature: Vec<f64>,
}

impl Metric {
    fn new(m: &Refined, phi: &[f64]) -> Metric {
        let n = m.uv.len();
        let len = |i: usize, j: usize| {
            let (a, b) = (m.uv[i], m.uv[j]);
            (a[0] - b[0]).hypot(a[1] - b[1]) * (0.5 * (phi[i] + phi[j])).exp()
        };
        // half-weights per (edge, triangle), merged in edge order: a hash
        // map's order would make the sums, and so the mesh, vary run to run
        let mut w: Vec<((usize, usize), f64)> = Vec::with_capacity(m.tris.len() * 3);
        let mut angle_sum = vec![0.0; n];
        for tri in &m.tris {
            let l = [
                len(tri[1], tri[2]),
                len(tri[2], tri[0]),
                len(tri[0], tri[1]),
            ];
            for k in 0..3 {
                // the angle at corner k, opposite l[k]
                let (x, y, z) = (l[k], l[(k + 1) % 3], l[(k + 2) % 3]);
                let c = ((y * y + z * z - x * x) / (2.0 * y * z)).clamp(-1.0, 1.0);
                let a = c.acos();
                angle_sum[tri[k]] += a;
                let cot = 1.0 / a.clamp(1e-6, std::f64::consts::PI - 1e-6).tan();
                w.push((key(tri[(k + 1) % 3], tri[(k + 2) % 3]), 0.5 * cot));
            }
        }
        w.sort_by_key(|e| e.0);
        let mut diag = vec![0.0; n];
        let mut off = vec![Vec::new(); n];
        let mut k = 0;
        while k < w.len() {
            let (i, j) = w[k].0;
            let mut wij = 0.0;
            while k < w.len() && w[k].0 == (i, j) {
                wij += w[k].1;
                k += 1;
            }
            diag[i] += wij;
            diag[j] += wij;
            off[i].push((j, wij));
            off[j].push((i, wij));
        }
        let curvature = angle_sum
            .iter()
            .zip(&m.boundary)
            .map(|(&s, &b)| {
                if b {
                    std::f64::consts::PI - s
                } else {
                    std::f64::consts::TAU - s
                }
            })
            .collect();
        Metric {
            diag,
            off,
            curvature,
        }
    }

    /// L restricted to the unknowns, factored; `symbolic` is the
    /// factorization's structure when an earlier matrix had the same
    /// unknowns. `None` if L is not positive definite there.
    fn reduced(
        &self,
        unk: &[usize],
        unk_nodes: &[usize],
        symbolic: Option<&SymbolicLlt<usize>>,
    ) -> Option<Spd> {
        let mut entries = Vec::with_capacity(unk_nodes.len() * 7);
        for (r, &i) in unk_nodes.iter().enumerate() {
            entries.push(Triplet::new(r, r, self.diag[i]));
            for &(j, w) in &self.off[i] {
                if unk[j] != usize::MAX {
                    entries.push(Triplet::new(r, unk[j], -w));
                }
            }
        }
        let n = unk_nodes.len();
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &entries).ok()?;
        let symbolic = match symbolic {
            Some(s) => s.clone(),
            None => SymbolicLlt::try_new(a.symbolic(), Side::Lower).ok()?,
        };
        let llt = Llt::try_new_with_symbolic(symbolic.clone(), a.as_ref(), Side::Lower).ok()?;
        Some(Spd { llt, symbolic })
    }
}

/// A sparse symmetric positive definite matrix, factored once and solved
/// for many right-hand sides (faer's sparse Cholesky with its fill-reducing
/// ordering: on a background of 90,000 unknowns a factorization takes about
/// 0.1 s and a solve 0.01 s, where a Jacobi-preconditioned conjugate
/// gradient took seconds per solve and grew like n^1.5).
struct Spd {
    llt: Llt<usize, f64>,
    /// The structure of `llt` (shared, not copied, by matrices with the
    /// same unknowns).
    symbolic: SymbolicLlt<usize>,
}

impl Spd {
    /// The solution x of A x = b; `None` if it is not finite.
    fn solve(&self, b: &[f64]) -> Option<Vec<f64>> {
        let x = self.llt.solve(ColRef::from_slice(b));
        let x: Vec<f64> = x.iter().copied().collect();
        x.iter().all(|v| v.is_finite()).then_some(x)
    }

    fn symbolic(&self) -> &SymbolicLlt<usize> {
        &self.symbolic
    }
}

/// Newton steps on the discrete conformal curvature (Springborn, Schröder &
/// Pinkall 2008): φ += L_φ⁻¹(κ − Ω(φ)) at the unknowns, L_φ and Ω(φ) the
/// cotan Laplacian and curvature of the metric e^{2φ}|dx|², until
/// max |κ − Ω| < 1e-7 (three or four steps from the linear solution). To
/// first order the layout's angle sums are off by about 0.1 rad next to a
/// hole, which bends the hole's lattice row and leaves a seam where its
/// ring closes (case C: a lost node on the first ring; research:
/// buildCones.py, mean 0.9909 → 0.9920). False if a solve fails.
fn newton(m: &Refined, unk: &[usize], unk_nodes: &[usize], kappa: &[f64], phi: &mut [f64]) -> bool {
    // every step's L has the same unknowns, so the same structure
    let mut symbolic: Option<SymbolicLlt<usize>> = None;
    for _ in 0..NEWTON_STEPS {
        let g = Metric::new(m, phi);
        let res: Vec<f64> = unk_nodes
            .iter()
            .zip(kappa)
            .map(|(&i, &k)| k - g.curvature[i])
            .collect();
        if res.iter().all(|r| r.abs() < 1e-7) {
            return true;
        }
        if unk_nodes.iter().any(|&i| !(g.diag[i] > 0.0)) {
            return false;
        }
        let Some(l) = g.reduced(unk, unk_nodes, symbolic.as_ref()) else {
            return false;
        };
        let Some(delta) = l.solve(&res) else {
            return false;
        };
        for (&i, dl) in unk_nodes.iter().zip(&delta) {
            phi[i] += dl;
        }
        symbolic = Some(l.symbolic().clone());
    }
    true
}

/// Position of c with |c − a| = la, |c − b| = lb, left of a → b.
fn third(fa: C64, fb: C64, la: f64, lb: f64) -> C64 {
    let e = fb - fa;
    let lab = e.norm();
    let x = (la * la - lb * lb + lab * lab) / (2.0 * lab);
    let y = (la * la - x * x).max(1e-18).sqrt();
    fa + e / lab * C64::new(x, y)
}

/// Unfolds the triangles of a region breadth-first from `root` with the
/// edge lengths `len`, writing their corners' layout positions into `f`.
fn layout(
    m: &Refined,
    root: usize,
    inside: impl Fn(usize) -> bool,
    len: &dyn Fn(usize, usize) -> f64,
    f: &mut [[C64; 3]],
) {
    let [a, b, c] = m.tris[root];
    let fa = C64::new(0.0, 0.0);
    let fb = C64::new(len(a, b), 0.0);
    f[root] = [fa, fb, third(fa, fb, len(a, c), len(b, c))];
    let mut done = vec![false; m.tris.len()];
    done[root] = true;
    let mut queue = VecDeque::from([root]);
    while let Some(t) = queue.pop_front() {
        for k in 0..3 {
            let o = m.adj[t][k];
            if o == usize::MAX || done[o] || !inside(o) {
                continue;
            }
            let (i, j) = (m.tris[t][k], m.tris[t][(k + 1) % 3]);
            let km = (0..3).find(|&q| m.tris[o][q] == j).unwrap();
            let opp = m.tris[o][(km + 2) % 3];
            let (fj, fi) = (f[t][(k + 1) % 3], f[t][k]);
            f[o][km] = fj;
            f[o][(km + 1) % 3] = fi;
            f[o][(km + 2) % 3] = third(fj, fi, len(j, opp), len(i, opp));
            done[o] = true;
            queue.push_back(o);
        }
    }
}

/// Turns, scales and shifts region `h`'s layout so that hole `h` lies on the
/// lattice row through the origin, its `nodes` nodes on lattice columns.
fn align_to_hole(m: &Refined, h: usize, nodes: usize, region: &[usize], f: &mut [[C64; 3]]) {
    let mut edges: Vec<(C64, C64)> = Vec::new();
    for (t, tri) in m.tris.iter().enumerate() {
        if region[t] != h {
            continue;
        }
        for k in 0..3 {
            if m.adj[t][k] == usize::MAX
                && m.hole_of[tri[k]] == h
                && m.hole_of[tri[(k + 1) % 3]] == h
            {
                edges.push((f[t][k], f[t][(k + 1) % 3]));
            }
        }
    }
    if edges.is_empty() {
        return;
    }
    let unit = |e: C64| e / e.norm().max(1e-300);
    let acc6: C64 = edges.iter().map(|&(a, b)| unit(b - a).powi(6)).sum();
    let mut rot = C64::from_polar(1.0, -acc6.arg() / 6.0);
    // the hole now runs along one of the three lattice directions: turn it to the real axis
    let acc2: C64 = edges
        .iter()
        .map(|&(a, b)| (unit(b - a) * rot).powi(2))
        .sum();
    let k = (acc2.arg() / 2.0 / std::f64::consts::FRAC_PI_3).round();
    rot *= C64::from_polar(1.0, -k * std::f64::consts::FRAC_PI_3);
    let length: f64 = edges.iter().map(|&(a, b)| (b - a).norm()).sum();
    let s = rot * (nodes as f64 / length.max(1e-300));
    let row = 3f64.sqrt() / 2.0;
    let tau = std::f64::consts::TAU;
    let pts: Vec<C64> = edges.iter().map(|&(a, _)| a * s).collect();
    let yph: C64 = pts
        .iter()
        .map(|p| C64::from_polar(1.0, tau * p.im / row))
        .sum();
    let yoff = yph.arg() / tau * row;
    let xph: C64 = pts.iter().map(|p| C64::from_polar(1.0, tau * p.re)).sum();
    let xoff = xph.arg() / tau;
    let shift = C64::new(xoff, yoff);
    for (t, ft) in f.iter_mut().enumerate() {
        if region[t] == h {
            for z in ft.iter_mut() {
                *z = *z * s - shift;
            }
        }
    }
    // The hole's nodes were spaced by the edge mesher along the hole, not
    // along the layout, where the scale e^φ varies a little: left alone, the
    // lattice columns drift out of step with them and a five/seven pair
    // forms where the drift reaches half a column. So the columns are moved
    // along the rows (x ↦ g(x), piecewise linear and periodic with the
    // hole's length) to put the hole's nodes on integers.
    let mut xs: Vec<f64> = Vec::new();
    let mut seen = vec![false; m.uv.len()];
    for (t, tri) in m.tris.iter().enumerate() {
        if region[t] != h {
            continue;
        }
        for k in 0..3 {
            let i = tri[k];
            if i < m.n_orig && m.hole_of[i] == h && !seen[i] {
                seen[i] = true;
                xs.push(f[t][k].re);
            }
        }
    }
    if xs.len() != nodes {
        return; // a node seen twice or not at all: leave the columns as they are
    }
    xs.sort_by(f64::total_cmp);
    let period = nodes as f64;
    let x0 = xs[0];
    if xs[nodes - 1] - x0 >= period {
        return;
    }
    let t0 = x0.round();
    let g = |x: f64| -> f64 {
        // periodic: bring x into [x0, x0 + period)
        let wraps = ((x - x0) / period).floor();
        let y = x - wraps * period;
        let k = xs.partition_point(|&v| v <= y); // xs[k-1] <= y < xs[k]
        let (xa, ta, xb, tb) = if k == 0 {
            (
                xs[nodes - 1] - period,
                t0 + period - 1.0 - period,
                xs[0],
                t0,
            )
        } else if k == nodes {
            (
                xs[nodes - 1],
                t0 + period - 1.0,
                xs[0] + period,
                t0 + period,
            )
        } else {
            (xs[k - 1], t0 + (k - 1) as f64, xs[k], t0 + k as f64)
        };
        let r = if xb > xa { (y - xa) / (xb - xa) } else { 0.0 };
        ta + r * (tb - ta) + wraps * period
    };
    for (t, ft) in f.iter_mut().enumerate() {
        if region[t] == h {
            for z in ft.iter_mut() {
                *z = C64::new(g(z.re), z.im);
            }
        }
    }
}

/// Boundary and constraint segments bucketed by a uniform grid, for "is
/// this point within r of a segment".
struct SegmentGrid {
    cell: f64,
    buckets: HashMap<(i64, i64), Vec<usize>>,
    segs: Vec<[usize; 2]>,
}

impl SegmentGrid {
    fn new(uv: &[[f64; 2]], segs: &[[usize; 2]]) -> SegmentGrid {
        let cell = segs
            .iter()
            .map(|s| {
                let (a, b) = (uv[s[0]], uv[s[1]]);
                (a[0] - b[0]).hypot(a[1] - b[1])
            })
            .fold(0.0f64, f64::max)
            .max(1e-12);
        let mut buckets: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (k, s) in segs.iter().enumerate() {
            let (a, b) = (uv[s[0]], uv[s[1]]);
            let c = (
                (0.5 * (a[0] + b[0]) / cell).floor() as i64,
                (0.5 * (a[1] + b[1]) / cell).floor() as i64,
            );
            buckets.entry(c).or_default().push(k);
        }
        SegmentGrid {
            cell,
            buckets,
            segs: segs.to_vec(),
        }
    }

    fn near(&self, uv: &[[f64; 2]], p: [f64; 2], r: f64) -> bool {
        // a segment within r has its midpoint within r + cell/2
        let reach = ((r + 0.5 * self.cell) / self.cell).ceil() as i64 + 1;
        let (ci, cj) = (
            (p[0] / self.cell).floor() as i64,
            (p[1] / self.cell).floor() as i64,
        );
        for di in -reach..=reach {
            for dj in -reach..=reach {
                if let Some(b) = self.buckets.get(&(ci + di, cj + dj)) {
                    for &k in b {
                        let (a, c) = (uv[self.segs[k][0]], uv[self.segs[k][1]]);
                        if point_segment_dist2(p, a, c) < r * r {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

fn point_segment_dist2(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let q = crate::geom::closest_on_segment(p, a, b);
    (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)
}

/// Points in a uniform hash grid that grows as points are inserted.
struct PointGrid {
    cell: f64,
    buckets: HashMap<(i64, i64), Vec<usize>>,
    pts: Vec<[f64; 2]>,
}

impl PointGrid {
    fn new(cell: f64) -> PointGrid {
        PointGrid {
            cell: cell.max(1e-12),
            buckets: HashMap::new(),
            pts: Vec::new(),
        }
    }
    fn cell_of(&self, p: [f64; 2]) -> (i64, i64) {
        (
            (p[0] / self.cell).floor() as i64,
            (p[1] / self.cell).floor() as i64,
        )
    }
    fn insert(&mut self, p: [f64; 2]) {
        let c = self.cell_of(p);
        self.buckets.entry(c).or_default().push(self.pts.len());
        self.pts.push(p);
    }
    fn at(&self, k: usize) -> [f64; 2] {
        self.pts[k]
    }
    fn query(&self, p: [f64; 2], r: f64, mut f: impl FnMut(usize)) {
        let reach = (r / self.cell).ceil() as i64;
        let (ci, cj) = self.cell_of(p);
        for di in -reach..=reach {
            for dj in -reach..=reach {
                if let Some(b) = self.buckets.get(&(ci + di, cj + dj)) {
                    for &k in b {
                        f(k);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (u,v), triangles, fixed nodes, segments.
    type SquareBackground = (Vec<[f64; 2]>, Vec<[usize; 3]>, usize, Vec<[usize; 2]>);

    /// The unit square as an m×m grid of right triangles; fixed nodes (the
    /// boundary, counter-clockwise) first, and the boundary segments.
    fn square_background(m: usize) -> SquareBackground {
        let h = 1.0 / m as f64;
        let on_boundary = |i: usize, j: usize| i == 0 || j == 0 || i == m || j == m;
        let mut ring: Vec<(usize, usize)> = Vec::new();
        ring.extend((0..m).map(|i| (i, 0)));
        ring.extend((0..m).map(|j| (m, j)));
        ring.extend((1..=m).rev().map(|i| (i, m)));
        ring.extend((1..=m).rev().map(|j| (0, j)));
        let mut index = vec![usize::MAX; (m + 1) * (m + 1)];
        let mut uv = Vec::new();
        for &(i, j) in &ring {
            index[i * (m + 1) + j] = uv.len();
            uv.push([i as f64 * h, j as f64 * h]);
        }
        let n_fixed = uv.len();
        for i in 0..=m {
            for j in 0..=m {
                if !on_boundary(i, j) {
                    index[i * (m + 1) + j] = uv.len();
                    uv.push([i as f64 * h, j as f64 * h]);
                }
            }
        }
        let at = |i: usize, j: usize| index[i * (m + 1) + j];
        let mut tris = Vec::new();
        for i in 0..m {
            for j in 0..m {
                tris.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                tris.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        let segs = (0..n_fixed).map(|k| [k, (k + 1) % n_fixed]).collect();
        (uv, tris, n_fixed, segs)
    }

    /// Calls `f` with the m×m square background.
    fn with_square<R>(m: usize, f: impl FnOnce(&Background<'_>) -> R) -> R {
        let (uv, tris, n_fixed, segs) = square_background(m);
        f(&Background {
            uv: &uv,
            tris: &tris,
            n_fixed,
            holes: &[],
            segments: &segs,
        })
    }

    fn seeds_for(d: impl Fn([f64; 2]) -> f64) -> Lattice {
        let mut d = d;
        with_square(40, |bg| lattice_seeds(bg, &mut d)).expect("the square flattens")
    }

    /// log d linear in x is harmonic: the metric is flat, so no cone is
    /// placed and the seeds are one exact lattice in it: every seed away
    /// from the boundary has six neighbours at one spacing (d at the edge's
    /// midpoint; within 2 %).
    #[test]
    fn flat_metric_needs_no_cones_and_gives_an_exact_lattice() {
        let d = |p: [f64; 2]| 0.05 * p[0].exp();
        let lat = seeds_for(d);
        assert_eq!(lat.cones, (0, 0));
        let pts: Vec<[f64; 2]> = lat.seeds.iter().map(|s| s.0).collect();
        let mut checked = 0;
        for (k, &(p, dp)) in lat.seeds.iter().enumerate() {
            let margin = p[0].min(p[1]).min(1.0 - p[0]).min(1.0 - p[1]);
            if margin < 2.5 * dp {
                continue;
            }
            let mut near: Vec<f64> = pts
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .map(|(_, q)| {
                    let mid = [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])];
                    (q[0] - p[0]).hypot(q[1] - p[1]) / d(mid)
                })
                .filter(|&r| r < 1.4)
                .collect();
            near.sort_by(f64::total_cmp);
            assert_eq!(near.len(), 6, "seed {p:?}: neighbours at {near:?}");
            assert!(
                near.iter().all(|r| (r - 1.0).abs() < 0.02),
                "seed {p:?}: neighbours at {near:?} spacings"
            );
            checked += 1;
        }
        assert!(checked > 40, "only {checked} seeds checked");
    }

    /// Case B's spacing is a round sphere seen stereographically (positive
    /// curvature): the cones are mostly positive (five-valent), and few.
    #[test]
    fn sphere_metric_gets_few_positive_cones() {
        let lat = seeds_for(|p| 0.01 + 0.2 * ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2)));
        let (pos, neg) = lat.cones;
        assert!(pos >= neg + 5 && pos + neg <= 20, "cones {:?}", lat.cones);
    }

    /// The interior nodes as the unknowns (the boundary Dirichlet): each
    /// node's index among them (`usize::MAX`: Dirichlet), and the nodes.
    fn interior_unknowns(m: &Refined) -> (Vec<usize>, Vec<usize>) {
        let mut unk = vec![usize::MAX; m.uv.len()];
        let mut unk_nodes = Vec::new();
        for (i, x) in unk.iter_mut().enumerate() {
            if !m.boundary[i] {
                *x = unk_nodes.len();
                unk_nodes.push(i);
            }
        }
        (unk, unk_nodes)
    }

    /// u = −log d at the nodes, d = 0.01 + 0.2 r² (case B).
    fn case_b_u(m: &Refined) -> Vec<f64> {
        m.uv.iter()
            .map(|p| -(0.01 + 0.2 * ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2))).ln())
            .collect()
    }

    /// The factored Laplacian solves L x = b to round-off: the residual,
    /// computed from the metric's own weights, is below 1e-10 of |b| on a
    /// background of 40,000 unknowns (a conjugate gradient stopped at 1e-5
    /// there), and one structure serves a second matrix with the same
    /// unknowns (Newton's steps).
    #[test]
    fn the_factored_laplacian_solves_to_round_off() {
        let m = with_square(100, refine);
        let n = m.uv.len();
        let (unk, unk_nodes) = interior_unknowns(&m);
        assert!(unk_nodes.len() > 39_000, "{} unknowns", unk_nodes.len());
        let residual = |g: &Metric, x: &[f64], b: &[f64]| -> f64 {
            let mut worst = 0.0f64;
            for (r, &i) in unk_nodes.iter().enumerate() {
                let mut lx = g.diag[i] * x[r];
                for &(j, w) in &g.off[i] {
                    if unk[j] != usize::MAX {
                        lx -= w * x[unk[j]];
                    }
                }
                worst = worst.max((lx - b[r]).abs());
            }
            worst / b.iter().map(|v| v * v).sum::<f64>().sqrt()
        };
        let b: Vec<f64> = (0..unk_nodes.len())
            .map(|k| ((k * 7919) % 13) as f64 - 6.0)
            .collect();
        // the Euclidean metric, then another (d graded as case B) with the
        // first one's structure
        let mut symbolic = None;
        for phi in [vec![0.0; n], case_b_u(&m)] {
            let g = Metric::new(&m, &phi);
            let l = g
                .reduced(&unk, &unk_nodes, symbolic.as_ref())
                .expect("positive definite");
            let x = l.solve(&b).expect("finite");
            let r = residual(&g, &x, &b);
            assert!(r < 1e-10, "relative residual {r}");
            symbolic = Some(l.symbolic().clone());
        }
    }

    /// Newton makes the metric flat to the tolerance: the angle sums of the
    /// layout are 2π − κ inside.
    #[test]
    fn newton_closes_the_angle_sums() {
        let m = with_square(16, refine);
        let (unk, unk_nodes) = interior_unknowns(&m);
        // u = −log d with d = 0.01 + 0.2 r², and one positive cone in the middle
        let mut phi = case_b_u(&m);
        let mut kappa = vec![0.0; unk_nodes.len()];
        let mid = (0..unk_nodes.len())
            .min_by(|&a, &b| {
                let r = |k: usize| {
                    let p = m.uv[unk_nodes[k]];
                    (p[0] - 0.5).hypot(p[1] - 0.5)
                };
                r(a).total_cmp(&r(b))
            })
            .unwrap();
        kappa[mid] = std::f64::consts::FRAC_PI_3;
        assert!(newton(&m, &unk, &unk_nodes, &kappa, &mut phi));
        let g = Metric::new(&m, &phi);
        for (k, &i) in unk_nodes.iter().enumerate() {
            assert!(
                (g.curvature[i] - kappa[k]).abs() < 1e-6,
                "node {i}: {}",
                g.curvature[i]
            );
        }
    }
}
