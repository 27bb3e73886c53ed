//! Sliver removal after the volume connection (not in the thesis; its
//! §5.1.4 tetrahedra come straight from Delaunay).
//!
//! A Delaunay tetrahedralization of well-packed bubbles still holds
//! *slivers*: four nearly cospherical, nearly coplanar points make a flat
//! tetrahedron with a good circumsphere but a tiny volume. They are removed
//! here by flips that raise the worst tetrahedron they touch
//! ([`crate::volume::tet::flip::raise_worst`]), then by moving the free corners of
//! what the flips leave: a pattern search over small moves
//! (at most [`MAX_MOVE`]·d in total) that raises the worst radius ratio of
//! the node's star, accepted only when every tetrahedron of the star stays
//! positively oriented (exact `orient3d`). Neither touches a boundary
//! triangle, so the boundary stays exactly the faces' meshes, and no node
//! leaves its volume (a node inside a valid star cannot cross the star's
//! outer faces).

use crate::geom::{P3, V3};

/// Tetrahedra whose [`objective`] is below this are worked on (about
/// radius ratio 0.55, dihedral angles within [27°, 138°]).
pub const TARGET_Q: f64 = 0.55;
/// Rounds of the pattern search.
pub const ROUNDS: usize = 4;
/// Rounds of flips and pattern search in [`improve`].
pub const ROUNDS_FLIP_SMOOTH: usize = 3;
/// Largest move of a node per smoothing pass, in units of its spacing.
pub const MAX_MOVE: f64 = 0.35;

/// Rounds of [`steiner_points`] and re-connection after [`improve`].
pub const STEINER_ROUNDS: usize = 6;
/// A tetrahedron with a radius ratio below this is flat: the volume is
/// refused rather than meshed with it.
pub const FLAT_Q: f64 = 1e-6;

/// What sliver removal did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SliverStats {
    /// Tetrahedra below [`TARGET_Q`] before and after, and the worst
    /// [`objective`].
    pub bad_before: usize,
    pub bad_after: usize,
    pub min_q_before: f64,
    pub min_q_after: f64,
    pub moves: usize,
    /// Edge removals and 2-3 flips.
    pub flips: usize,
}

/// Radius ratio 3·r_in/r_circ of the tetrahedron (1 for a regular one),
/// negative when it is inverted, 0 when flat.
pub fn radius_ratio(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
    let (u, v, w) = (b - a, c - a, d - a);
    let vol6 = u.dot(&v.cross(&w));
    if vol6 == 0.0 {
        return 0.0;
    }
    let n = v.cross(&w) * u.norm_squared()
        + w.cross(&u) * v.norm_squared()
        + u.cross(&v) * w.norm_squared();
    let area = 0.5
        * (u.cross(&v).norm()
            + v.cross(&w).norm()
            + w.cross(&u).norm()
            + (c - b).cross(&(d - b)).norm());
    // r_in = 3V/A = vol6/(2A), R = |n|/(2·vol6)  ⇒  3 r_in/R = 3·vol6²/(A·|n|)
    let q = 3.0 * vol6 * vol6 / (area * n.norm());
    if vol6 > 0.0 {
        q
    } else {
        -q
    }
}

/// The quality the improvement maximises: the radius ratio, capped by the
/// extreme dihedral angles (scaled so that 25° and 140° score about 0.51,
/// a regular tetrahedron 1): min(ρ, 1.45·θ_min/70.53°, 1.45·(180° − θ_max)/109.47°).
/// Negative for an inverted tetrahedron.
///
/// This is the hot function of the sliver pass and the polish (60 % of
/// case K's time in a profile), so it shares the face normals between the
/// radius ratio and the dihedral angles, and skips the two `acos` when
/// neither angle term can be the minimum: for θ_min ≥ 49.5° and
/// θ_max ≤ 103.3° both terms exceed 1.016 > ρ (ρ ≤ 1). Equals
/// `radius_ratio(..).min(angle terms from dihedral_extremes(..))` to
/// rounding.
pub fn objective(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
    let (u, v, w) = (b - a, c - a, d - a);
    // inward area normals (×2) of the faces opposite b, c, d, a for a
    // positive tetrahedron
    let mb = v.cross(&w);
    let mc = w.cross(&u);
    let md = u.cross(&v);
    let vol6 = u.dot(&mb);
    if vol6 == 0.0 {
        return 0.0;
    }
    let ma = (d - b).cross(&(c - b));
    let l = [ma.norm(), mb.norm(), mc.norm(), md.norm()];
    let n = mb * u.norm_squared() + mc * v.norm_squared() + md * w.norm_squared();
    let area = 0.5 * (l[0] + l[1] + l[2] + l[3]);
    let rr = 3.0 * vol6 * vol6 / (area * n.norm());
    if vol6 < 0.0 {
        return -rr;
    }
    // θ_ij = 180° − angle(m_i, m_j), the same for inward as for outward
    // normals; the extremes come from the extreme cosines
    let m = [ma, mb, mc, md];
    let (mut cmin, mut cmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..4 {
        for j in i + 1..4 {
            let c = m[i].dot(&m[j]) / (l[i] * l[j]).max(f64::MIN_POSITIVE);
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
    }
    let mut q = rr;
    // θ_min = 180° − acos(cmin) ≥ 49.5° ⇔ cmin ≥ cos(130.5°) ≈ −0.6494
    if cmin < -0.65 {
        let lo = 180.0 - cmin.clamp(-1.0, 1.0).acos().to_degrees();
        q = q.min(1.45 * lo / 70.528_779);
    }
    // θ_max = 180° − acos(cmax) ≤ 103.3° ⇔ cmax ≤ cos(76.7°) ≈ 0.2300
    if cmax > 0.23 {
        let hi = 180.0 - cmax.clamp(-1.0, 1.0).acos().to_degrees();
        q = q.min(1.45 * (180.0 - hi) / 109.471_221);
    }
    q
}

/// The smallest and largest dihedral angle in degrees.
pub fn dihedral_extremes(a: &P3, b: &P3, c: &P3, d: &P3) -> (f64, f64) {
    let p = [a, b, c, d];
    // outward face normals; face k is opposite corner k
    let mut n = [V3::zeros(); 4];
    for (k, nk) in n.iter_mut().enumerate() {
        let f = FACE3[k].map(|i| p[i]);
        let nn = (f[1] - f[0]).cross(&(f[2] - f[0]));
        let s = if nn.dot(&(p[k] - f[0])) > 0.0 {
            -1.0
        } else {
            1.0
        };
        *nk = nn * (s / nn.norm().max(f64::MIN_POSITIVE));
    }
    // dihedral angle θ_ij = 180° − acos(n_i·n_j): the extremes come from
    // the extreme dot products, so two acos instead of six
    let (mut cmin, mut cmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..4 {
        for j in i + 1..4 {
            let c = n[i].dot(&n[j]);
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
    }
    let lo = 180.0 - cmin.clamp(-1.0, 1.0).acos().to_degrees();
    let hi = 180.0 - cmax.clamp(-1.0, 1.0).acos().to_degrees();
    (lo, hi)
}

/// The faces of a tetrahedron [a, b, c, d], face k opposite corner k,
/// ordered so that a positive tetrahedron sees each one's normal pointing
/// out.
pub(crate) const FACE3: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

fn tet_q(pos: &[P3], t: &[u32; 4]) -> f64 {
    let [a, b, c, d] = t.map(|k| pos[k as usize]);
    objective(&a, &b, &c, &d)
}

/// [`objective`] of tetrahedron `t`.
pub fn objective_of(pos: &[P3], t: &[u32; 4]) -> f64 {
    tet_q(pos, t)
}

/// [`radius_ratio`] of tetrahedron `t`.
pub fn radius_ratio_of(pos: &[P3], t: &[u32; 4]) -> f64 {
    let [a, b, c, d] = t.map(|k| pos[k as usize]);
    radius_ratio(&a, &b, &c, &d)
}

/// New free points for `slivers` (the caller passes those whose corners are
/// all fixed: flat in the raw tetrahedralization, or still below
/// [`TARGET_Q`] after [`improve`]): for each, the two points 0.29·d off its
/// centroid along the normal of its mean plane (d: the mean spacing of its
/// corners), those that `inside` accepts, skipping one within a quarter
/// spacing of a point already chosen.
///
/// Why: a sliver whose four corners are all boundary nodes cannot be
/// smoothed away. It happens in a wall about one spacing thick, where no
/// free bubble fits and the two sides' surface meshes face each other;
/// where their lattices are translates of each other (two planar faces
/// meshed alike), the nodes form triangular prisms across the wall whose
/// side rectangles are cocircular and, to rounding, coplanar. Delaunay
/// then splits each rectangle by whichever diagonal the rounding favours;
/// a prism whose three diagonals turn cyclically is Schönhardt's
/// polyhedron, which has no tetrahedralization, and a tetrahedron of volume
/// ~1e-17·L³ on a rectangle glues the two sides together (seen on
/// fixtures/step/b3d_bottle.step at size 1: 77 of them, no flip removes
/// them). A point inside the prism on either side of the rectangle (its
/// centre is a/(2√3) ≈ 0.29·a off a side of length a) lets the prism be
/// split; the caller re-connects and runs [`improve`] again, which can move
/// the new points.
pub fn steiner_points(
    pos: &[P3],
    slivers: &[[u32; 4]],
    d: &[f64],
    inside: impl Fn(&P3) -> bool,
) -> Vec<(P3, f64)> {
    let mut cand: Vec<(P3, f64)> = Vec::new();
    for t in slivers {
        let p = t.map(|k| pos[k as usize]);
        let c = P3::from((p[0].coords + p[1].coords + p[2].coords + p[3].coords) / 4.0);
        let dc = t.iter().map(|&k| d[k as usize]).sum::<f64>() / 4.0;
        // the normal of the mean plane: the largest cross product of two
        // opposite edges (for a flat quadrilateral, its diagonals')
        let n = [(0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2)]
            .iter()
            .map(|&(a, b, e, f)| (p[b] - p[a]).cross(&(p[f] - p[e])))
            .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))
            .unwrap_or_else(V3::zeros);
        let nn = n.norm();
        if !(nn > 0.0) {
            continue;
        }
        for s in [1.0, -1.0] {
            let q = c + n * (s * 0.29 * dc / nn);
            if inside(&q) {
                cand.push((q, dc));
            }
        }
    }
    let Some(h) = cand.iter().map(|c| 0.25 * c.1).min_by(f64::total_cmp) else {
        return Vec::new();
    };
    // a hash grid of cell h (the smallest exclusion radius): a point is
    // dropped when a chosen one lies within a quarter of its own spacing
    let key = |p: &P3| [0, 1, 2].map(|i| (p[i] / h).floor() as i64);
    let mut cells: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
    let mut out: Vec<(P3, f64)> = Vec::new();
    for (c, dc) in cand {
        let r = 0.25 * dc;
        let reach = (r / h).ceil() as i64;
        let k = key(&c);
        let mut near = false;
        'search: for dx in -reach..=reach {
            for dy in -reach..=reach {
                for dz in -reach..=reach {
                    if let Some(v) = cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        if v.iter().any(|&j| (out[j].0 - c).norm() < r) {
                            near = true;
                            break 'search;
                        }
                    }
                }
            }
        }
        if !near {
            cells.entry(k).or_default().push(out.len());
            out.push((c, dc));
        }
    }
    out
}

/// The tetrahedra around each of `n` nodes, as a compressed table: those
/// of node v are `inc[start[v]..start[v + 1]]`, in increasing order.
pub(crate) fn node_tets(n: usize, tets: &[[u32; 4]]) -> (Vec<u32>, Vec<u32>) {
    crate::incidence::node_elements(n, tets, |v| v as usize)
}

/// Node `v`'s star gathered for a search that moves v alone (the sliver
/// pass's and the polish's): per tetrahedron the three other corners
/// (a, b, c), ordered so that [v, a, b, c] is positive, and twice the area
/// of the face (a, b, c), which does not move with v.
///
/// Why by hand: evaluating the star from the mesh's index arrays (which
/// corner is v, four loads per tetrahedron) took a third of the polish's
/// time on case K.
pub(crate) struct Star {
    faces: Vec<([P3; 3], f64)>,
}

impl Star {
    /// The star of node `v`: the tetrahedra `star` (indices into `tets`),
    /// in that order.
    pub(crate) fn gather(pos: &[P3], tets: &[[u32; 4]], star: &[u32], v: usize) -> Star {
        let faces = star
            .iter()
            .map(|&t| {
                let t = tets[t as usize];
                let k = t.iter().position(|&x| x as usize == v).unwrap_or(0);
                // [t_k, face opposite k] is an even permutation of t
                let f = FACE3[k].map(|i| pos[t[i] as usize]);
                let a2 = (f[1] - f[0]).cross(&(f[2] - f[0])).norm();
                (f, a2)
            })
            .collect();
        Star { faces }
    }

    /// Σ radius ratio with v at `x` ([`radius_ratio`] with the fixed face's area reused), and the smallest.
    pub(crate) fn sum_min(&self, x: &P3) -> (f64, f64) {
        let (mut s, mut m) = (0.0, f64::INFINITY);
        for (f, a2) in &self.faces {
            let (u, v, w) = (f[0] - x, f[1] - x, f[2] - x);
            let (vw, wu, uv) = (v.cross(&w), w.cross(&u), u.cross(&v));
            let vol6 = u.dot(&vw);
            let q = if vol6 == 0.0 {
                0.0
            } else {
                let n = vw * u.norm_squared() + wu * v.norm_squared() + uv * w.norm_squared();
                let area = 0.5 * (uv.norm() + vw.norm() + wu.norm() + a2);
                let q = 3.0 * vol6 * vol6 / (area * n.norm());
                if vol6 > 0.0 {
                    q
                } else {
                    -q
                }
            };
            s += q;
            m = m.min(q);
        }
        (s, m)
    }

    pub(crate) fn sum(&self, x: &P3) -> f64 {
        self.sum_min(x).0
    }

    /// The smallest [`objective`] with v at `x`.
    pub(crate) fn worst(&self, x: &P3) -> f64 {
        self.worst_above(x, f64::NEG_INFINITY)
            .unwrap_or(f64::NEG_INFINITY)
    }

    /// The smallest [`objective`] with v at `x`, or `None` as soon as one
    /// tetrahedron (in the star's order) is no better than `best`.
    pub(crate) fn worst_above(&self, x: &P3, best: f64) -> Option<f64> {
        let mut m = f64::INFINITY;
        for (f, _) in &self.faces {
            let q = objective(x, &f[0], &f[1], &f[2]);
            if q <= best {
                return None;
            }
            m = m.min(q);
        }
        Some(m)
    }

    /// Whether every tetrahedron is positive with v at `x` (exact).
    pub(crate) fn positive(&self, x: &P3) -> bool {
        let x = crate::volume::connect::c3(x);
        self.faces.iter().all(|(f, _)| {
            let [a, b, c] = f.map(|p| crate::volume::connect::c3(&p));
            robust::orient3d(x, a, b, c) < 0.0
        })
    }
}

/// Moves free nodes (`movable`) to raise the radius ratio of the tetrahedra
/// below [`TARGET_Q`]. `d` is the spacing per node. Tetrahedra must be
/// positively oriented and stay so.
pub fn improve(
    pos: &mut [P3],
    movable: &mut [bool],
    tets: &mut Vec<[u32; 4]>,
    d: &[f64],
) -> SliverStats {
    let qs: Vec<f64> = tets.iter().map(|t| tet_q(pos, t)).collect();
    improve_with(pos, movable, tets, d, qs)
}

/// [`improve`] given every tetrahedron's [`objective`] (`qs[i]` of
/// `tets[i]`), for a caller that has just computed them.
pub fn improve_with(
    pos: &mut [P3],
    movable: &mut [bool],
    tets: &mut Vec<[u32; 4]>,
    d: &[f64],
    // every tetrahedron's objective, kept current through the passes and
    // flips (one evaluation of the mesh instead of one per pass and sweep)
    mut qs: Vec<f64>,
) -> SliverStats {
    debug_assert_eq!(qs.len(), tets.len());
    let mut stats = SliverStats {
        bad_before: qs.iter().filter(|&&q| q < TARGET_Q).count(),
        min_q_before: qs.iter().cloned().fold(1.0, f64::min),
        ..Default::default()
    };
    // flips first, then the node search on what they leave: a flip round
    // costs a table of the mesh, a node search some fifty star evaluations
    // per node. Measured on case K (BCC, one thread): the flips take 25,296
    // bad tetrahedra to 3,707 in 1.0 s and the pass takes 2.6 s instead of
    // 3.0 s (smoothing first: 1.8 s for the first search alone), with
    // min radius ratio 0.550 instead of 0.533 and no tetrahedron left
    // below the target (10 before); cases H, I, J: the same worst
    // tetrahedra or better, means within 0.0004.
    stats.bad_after = stats.bad_before;
    stats.min_q_after = stats.min_q_before;
    for _ in 0..ROUNDS_FLIP_SMOOTH {
        if stats.bad_after == 0 {
            break;
        }
        stats.flips += crate::volume::tet::flip::raise_worst(pos, tets, &mut qs);
        let s = smooth(pos, movable, tets, d, &mut qs);
        stats.moves += s.moves;
        stats.bad_after = s.bad_after;
        stats.min_q_after = s.min_q_after;
    }
    stats
}

/// [`improve`] where few tetrahedra are below [`TARGET_Q`]: the same
/// passes on the part of the mesh around them only. The part is the stars
/// of the bad tetrahedra's nodes and of their neighbours; only those nodes
/// (whose whole star is in the part) may move, and a flip needs a closed
/// edge ring or a face with two tetrahedra in the part, which are then the
/// mesh's own, so the rest of the mesh is untouched and stays conforming.
/// Returns `None` when no tetrahedron is below [`TARGET_Q`], else what
/// [`improve`] did and the tetrahedra still below [`TARGET_Q`] (all of
/// them: the others are untouched and were not).
///
/// Why: after the polish, case K keeps about ten such tetrahedra among
/// 2.75 M, and [`improve`] on the whole mesh (objectives, node tables and
/// flip tables of every tetrahedron) took about a second for them.
pub fn improve_near_bad(
    pos: &mut [P3],
    movable: &[bool],
    tets: &mut Vec<[u32; 4]>,
    d: &[f64],
) -> Option<(SliverStats, Vec<[u32; 4]>)> {
    let bad: Vec<usize> = (0..tets.len())
        .filter(|&t| tet_q(pos, &tets[t]) < TARGET_Q)
        .collect();
    if bad.is_empty() {
        return None;
    }
    let n = pos.len();
    let (start, inc) = node_tets(n, tets);
    let star = |v: usize| &inc[start[v] as usize..start[v + 1] as usize];
    // the nodes of the bad tetrahedra, then their neighbours
    let mut inner = vec![false; n];
    let mut ring: Vec<usize> = Vec::new();
    for &t in &bad {
        for &v in &tets[t] {
            if !std::mem::replace(&mut inner[v as usize], true) {
                ring.push(v as usize);
            }
        }
    }
    for k in 0..ring.len() {
        for &t in star(ring[k]) {
            for &w in &tets[t as usize] {
                if !std::mem::replace(&mut inner[w as usize], true) {
                    ring.push(w as usize);
                }
            }
        }
    }
    // their stars, renumbered locally
    let mut in_part = vec![false; tets.len()];
    let mut local = vec![u32::MAX; n];
    let mut global: Vec<usize> = Vec::new();
    let mut part: Vec<[u32; 4]> = Vec::new();
    for &v in &ring {
        for &t in star(v) {
            if std::mem::replace(&mut in_part[t as usize], true) {
                continue;
            }
            part.push(tets[t as usize].map(|w| {
                let w = w as usize;
                if local[w] == u32::MAX {
                    local[w] = global.len() as u32;
                    global.push(w);
                }
                local[w]
            }));
        }
    }
    let mut lpos: Vec<P3> = global.iter().map(|&g| pos[g]).collect();
    let mut lmov: Vec<bool> = global.iter().map(|&g| movable[g] && inner[g]).collect();
    let ld: Vec<f64> = global.iter().map(|&g| d[g]).collect();
    let stats = improve(&mut lpos, &mut lmov, &mut part, &ld);
    for (l, &g) in global.iter().enumerate() {
        pos[g] = lpos[l];
    }
    let mut k = 0;
    tets.retain(|_| {
        k += 1;
        !in_part[k - 1]
    });
    let still_bad = part
        .iter()
        .filter(|t| tet_q(&lpos, t) < TARGET_Q)
        .map(|t| t.map(|l| global[l as usize] as u32))
        .collect();
    tets.extend(part.iter().map(|t| t.map(|l| global[l as usize] as u32)));
    Some((stats, still_bad))
}

/// The smoothing pass of [`improve`]. `qs[i]` is the objective of
/// `tets[i]`, on entry and on return.
fn smooth(
    pos: &mut [P3],
    movable: &[bool],
    tets: &[[u32; 4]],
    d: &[f64],
    qs: &mut [f64],
) -> SliverStats {
    let n = pos.len();
    let (start, inc) = node_tets(n, tets);
    let star = |v: usize| &inc[start[v] as usize..start[v + 1] as usize];
    // the objectives are kept current as nodes move (topology is fixed
    // within a pass): the rounds read their work from them instead of
    // re-evaluating 2.7 M tetrahedra each (case K)
    let mut stats = SliverStats {
        bad_before: qs.iter().filter(|&&q| q < TARGET_Q).count(),
        min_q_before: qs.iter().cloned().fold(1.0, f64::min),
        ..Default::default()
    };
    let origin: Vec<P3> = pos.to_vec();
    // the 6 axis and 8 diagonal directions
    let dirs: Vec<V3> = {
        let mut v = Vec::new();
        for x in -1..=1 {
            for y in -1..=1 {
                for z in -1..=1 {
                    let k = (x != 0) as u8 + (y != 0) as u8 + (z != 0) as u8;
                    if k == 1 || k == 3 {
                        v.push(V3::new(x as f64, y as f64, z as f64).normalize());
                    }
                }
            }
        }
        v
    };
    // a node whose star the search could not improve is not searched again
    // in this pass
    let mut stuck = vec![false; n];
    let mut order: Vec<u32> = Vec::new();
    for _round in 0..ROUNDS {
        // nodes of bad tets, worst first
        let mut work: Vec<(f64, usize)> = Vec::new();
        let mut seen = vec![false; n];
        for (t, &q) in tets.iter().zip(qs.iter()) {
            if q < TARGET_Q {
                for &v in t {
                    let v = v as usize;
                    if movable[v] && !seen[v] && !stuck[v] {
                        seen[v] = true;
                        work.push((q, v));
                    }
                }
            }
        }
        if work.is_empty() {
            break;
        }
        work.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut moved_any = false;
        for &(_, v) in &work {
            // the star worst first: a trial move is refused as soon as one
            // tetrahedron is no better than the best so far, which the
            // worst ones decide most often (the same moves as evaluating
            // the whole star, at a fraction of the objectives)
            order.clear();
            order.extend_from_slice(star(v));
            order.sort_by(|&s, &t| qs[s as usize].total_cmp(&qs[t as usize]));
            let mut best = qs[order[0] as usize];
            // the star gathered once for the whole search (its other
            // corners do not move meanwhile; see Star)
            let sg = Star::gather(pos, tets, &order, v);
            let p0 = pos[v];
            let mut x = p0;
            let mut step = 0.1 * d[v];
            while step > 0.01 * d[v] {
                let mut improved = false;
                for dir in &dirs {
                    let cand = x + dir * step;
                    if (cand - origin[v]).norm() > MAX_MOVE * d[v] {
                        continue;
                    }
                    if let Some(w) = sg
                        .worst_above(&cand, best + 1e-9)
                        .filter(|_| sg.positive(&cand))
                    {
                        best = w;
                        improved = true;
                        x = cand;
                    }
                }
                if !improved {
                    step *= 0.5;
                }
            }
            pos[v] = x;
            if pos[v] == p0 {
                stuck[v] = true;
            } else {
                for &t in star(v) {
                    qs[t as usize] = tet_q(pos, &tets[t as usize]);
                }
                stats.moves += 1;
                moved_any = true;
            }
        }
        if !moved_any {
            break;
        }
    }
    stats.bad_after = qs.iter().filter(|&&q| q < TARGET_Q).count();
    stats.min_q_after = qs.iter().cloned().fold(1.0, f64::min);
    stats
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fused [`objective`] against its definition from
    /// [`radius_ratio`] and [`dihedral_extremes`], on random tetrahedra of
    /// every shape (regular-ish to slivers, caps, needles and inverted).
    #[test]
    fn objective_matches_its_definition() {
        let mut rnd = crate::volume::jitter_source(0x9e37_79b9_7f4a_7c15);
        let mut skipped = 0;
        for k in 0..20000 {
            let scale = [1.0, 0.3, 0.02][k % 3];
            let p: Vec<P3> = (0..4)
                .map(|i| {
                    let base = [
                        [0., 0., 0.],
                        [1., 0., 0.],
                        [0.5, 0.87, 0.],
                        [0.5, 0.29, 0.82],
                    ][i];
                    P3::new(
                        base[0] + scale * rnd(),
                        base[1] + scale * rnd(),
                        base[2] * [1.0, 0.5, 0.05][k % 3] + scale * rnd(),
                    )
                })
                .collect();
            let rr = radius_ratio(&p[0], &p[1], &p[2], &p[3]);
            let want = if rr <= 0.0 {
                rr
            } else {
                let (lo, hi) = dihedral_extremes(&p[0], &p[1], &p[2], &p[3]);
                if lo >= 49.5 && hi <= 103.3 {
                    skipped += 1;
                }
                rr.min(1.45 * lo / 70.528_779)
                    .min(1.45 * (180.0 - hi) / 109.471_221)
            };
            let got = objective(&p[0], &p[1], &p[2], &p[3]);
            assert!((got - want).abs() < 1e-9, "{p:?}: {got} vs {want}");
        }
        // the shortcut was taken on some
        assert!(skipped > 100, "{skipped}");
    }

    #[test]
    fn radius_ratio_of_regular_and_sliver() {
        let a = P3::new(1.0, 1.0, 1.0);
        let b = P3::new(1.0, -1.0, -1.0);
        let c = P3::new(-1.0, 1.0, -1.0);
        let d = P3::new(-1.0, -1.0, 1.0);
        assert!((radius_ratio(&a, &b, &c, &d).abs() - 1.0).abs() < 1e-12);
        // a sliver: a square's corners lifted alternately by 0.01
        let s = [
            P3::new(0.0, 0.0, 0.0),
            P3::new(1.0, 0.0, 0.01),
            P3::new(1.0, 1.0, 0.0),
            P3::new(0.0, 1.0, 0.01),
        ];
        assert!(radius_ratio(&s[0], &s[1], &s[2], &s[3]).abs() < 0.05);
    }

    /// A rectangle across a wall, coplanar to rounding (the b3d_bottle
    /// case): one Steiner point on each side of it, 0.29·d off its centre,
    /// both dropped where `inside` refuses them, and a second sliver at the
    /// same place adds nothing.
    #[test]
    fn steiner_points_straddle_a_flat_rectangle() {
        let pos = vec![
            P3::new(0.0, 0.0, 0.0),
            P3::new(1.0, 1e-17, 0.0),
            P3::new(1.0, 0.0, 1.0),
            P3::new(0.0, 1e-17, 1.0),
        ];
        let d = vec![1.0; 4];
        let t = [0, 1, 2, 3];
        assert!(radius_ratio_of(&pos, &t).abs() < FLAT_Q);
        let pts = steiner_points(&pos, &[t, [1, 2, 3, 0]], &d, |_| true);
        assert_eq!(pts.len(), 2, "{pts:?}");
        for (p, dp) in &pts {
            assert_eq!(*dp, 1.0);
            assert!((p.x - 0.5).abs() < 1e-12 && (p.z - 0.5).abs() < 1e-12);
            assert!((p.y.abs() - 0.29).abs() < 1e-12, "{p:?}");
        }
        assert!(pts[0].0.y * pts[1].0.y < 0.0);
        let one_side = steiner_points(&pos, &[t], &d, |p| p.y > 0.0);
        assert_eq!(one_side.len(), 1);
        assert!(one_side[0].0.y > 0.0);
    }

    /// [`improve_near_bad`] works on the neighbourhood of the bad
    /// tetrahedra only: nodes more than one edge away from a bad
    /// tetrahedron's corners keep their place, tetrahedra without a node in
    /// that neighbourhood are kept as they are, and inside it the result
    /// has [`improve`]'s guarantees: every tetrahedron positive, the same
    /// volume and boundary faces, a higher worst objective.
    #[test]
    fn improve_near_bad_stays_near_the_bad_tetrahedra() {
        use crate::volume::tet::polish::tests::{
            assert_positive, boundary_faces, volume, worst_objective,
        };
        // a BCC lattice (cube corners and centres, Delaunay tetrahedra all
        // of radius ratio 0.95) with one node pushed towards a neighbour
        let k = 7;
        let mut rnd = crate::volume::jitter_source(7);
        let mut pos = Vec::new();
        let mut movable = Vec::new();
        for i in 0..k {
            for j in 0..k {
                for l in 0..k {
                    let inner = i > 0 && j > 0 && l > 0 && i < k - 1 && j < k - 1 && l < k - 1;
                    let e = if inner { 1e-4 } else { 0.0 };
                    pos.push(P3::new(
                        i as f64 + e * rnd(),
                        j as f64 + e * rnd(),
                        l as f64 + e * rnd(),
                    ));
                    movable.push(inner);
                    if i < k - 1 && j < k - 1 && l < k - 1 {
                        pos.push(P3::new(i as f64 + 0.5, j as f64 + 0.5, l as f64 + 0.5));
                        movable.push(true);
                    }
                }
            }
        }
        let centre = pos
            .iter()
            .position(|p| (p - P3::new(3.5, 3.5, 3.5)).norm() < 1e-9)
            .unwrap();
        pos[centre] += V3::new(0.28, 0.22, 0.1);
        let coords: Vec<[f64; 3]> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tets0 = bubblemesh_delaunay::tetrahedralize(&coords).unwrap().tets;
        let pos0 = pos.clone();
        let w0 = worst_objective(&pos, &tets0);
        assert!(w0 < TARGET_Q);
        // the neighbourhood, found independently
        let mut near = vec![false; pos.len()];
        for t in tets0.iter().filter(|t| objective_of(&pos, t) < TARGET_Q) {
            for &v in t {
                near[v as usize] = true;
            }
        }
        let core = near.clone();
        for t in &tets0 {
            if t.iter().any(|&v| core[v as usize]) {
                for &v in t {
                    near[v as usize] = true;
                }
            }
        }
        assert!(
            near.iter().any(|&x| !x),
            "the test needs nodes away from the bad tetrahedra"
        );
        let mut tets = tets0.clone();
        let d = vec![1.0; pos.len()];
        let (stats, still_bad) =
            improve_near_bad(&mut pos, &movable, &mut tets, &d).expect("bad tetrahedra");
        let bad_now: Vec<&[u32; 4]> = tets
            .iter()
            .filter(|t| objective_of(&pos, t) < TARGET_Q)
            .collect();
        assert_eq!(bad_now.len(), still_bad.len());
        assert!(bad_now.iter().all(|t| still_bad.contains(t)));
        assert!(stats.bad_after < stats.bad_before);
        assert!(worst_objective(&pos, &tets) > w0);
        assert_positive(&pos, &tets);
        for (v, (p, p0)) in pos.iter().zip(&pos0).enumerate() {
            assert!(
                near[v] || p == p0,
                "node {v} moved away from the bad tetrahedra"
            );
            assert!(movable[v] || p == p0, "fixed node {v} moved");
        }
        let sorted = |t: &[u32; 4]| {
            let mut t = *t;
            t.sort_unstable();
            t
        };
        let now: std::collections::HashSet<[u32; 4]> = tets.iter().map(sorted).collect();
        for t in tets0
            .iter()
            .filter(|t| t.iter().all(|&v| !near[v as usize]))
        {
            assert!(
                now.contains(&sorted(t)),
                "a tetrahedron away from the bad ones changed"
            );
        }
        assert!((volume(&pos, &tets) - volume(&pos0, &tets0)).abs() < 1e-9);
        assert_eq!(boundary_faces(&tets0), boundary_faces(&tets));
        // nothing left to do on a mesh without bad tetrahedra
        let (mut p2, mut t2) = (pos0.clone(), tets0.clone());
        t2.retain(|t| objective_of(&p2, t) >= TARGET_Q);
        assert!(improve_near_bad(&mut p2, &movable, &mut t2, &d).is_none());
    }
}
