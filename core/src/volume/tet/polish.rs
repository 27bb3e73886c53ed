//! Mean-quality smoothing of a volume's free nodes, the last step of the
//! volume connection (not in the thesis).
//!
//! Why: after stage 2, ODT smoothing ([`crate::volume::tet::odt`]) and sliver removal
//! ([`crate::volume::tet::sliver`]) the worst tetrahedra are fixed, but a graded packing
//! still leaves many middling ones: on case I (d = 0.02 + 0.1·x) the mean
//! radius ratio was 0.865, interior tetrahedra 0.876 against 0.909 for the
//! uniform case H. Moving every free node to raise the *sum* of the radius
//! ratios of its star lifts I to 0.887 (with 20 ODT iterations before).
//! Measured on I, one thread: a pattern search over 14 directions (as the
//! sliver pass does for the worst tetrahedron) gave 0.8873 in 3.9 s; a
//! gradient ascent (central differences, backtracking) 0.8856 in
//! 1.4 s for one pass and 0.8872 in 2.9 s for two. More passes gain
//! nothing (four: 0.8878): stars hold tetrahedra no move can fix. So
//! [`polish`] alternates: one pass, then [`FLIP_ROUNDS`] times a sweep of
//! mean-raising flips ([`crate::volume::tet::flip::raise_mean`]) and another pass. On I
//! that gives 0.903 (passes alone 0.8872), on H 0.913 (0.906), on J 0.915
//! (0.909), for one more pass's time. After a BCC start the volume asks
//! for the first pass only (see [`FLIP_ROUNDS`]).
//!
//! Cost (case K, 2.75 M tetrahedra, one thread): only nodes with a star
//! tetrahedron below [`SKIP_Q`] are coloured and searched (about 70k of
//! 443k free nodes), each over its star gathered once ([`Star`]): about
//! 1.1 s.
//!
//! Invariants kept: every tetrahedron of a moved node's star stays
//! positively oriented (exact `orient3d`), so no node leaves its volume and
//! the topology — hence the boundary — is unchanged; the worst
//! [`crate::volume::tet::sliver::objective`] of a star never drops below the smaller of
//! its value before and [`crate::volume::tet::sliver::TARGET_Q`], so the sliver pass's
//! guarantees (radius ratio and dihedral angles) survive.
//!
//! Parallel: nodes are greedily coloured so that no two nodes of one colour
//! share a tetrahedron; the nodes of a colour move at once (rayon), each
//! reading only positions that colour does not change. The result does
//! not depend on the number of threads.

use rayon::prelude::*;

use crate::geom::{P3, V3};

use crate::volume::tet::sliver::{radius_ratio_of, Star, TARGET_Q};

/// Rounds of flips and smoothing after the first pass of [`polish`]. The
/// caller may ask for fewer. After an FCC start a second round added
/// 0.0014 to the mean on case I. After a BCC start, whose interior needs
/// nothing, the volume asks for none: since the sliver pass flips before
/// it smooths ([`crate::volume::tet::sliver::improve`]), one round added 0.0001 to the
/// mean on K (857 flips, about 1 s of its time), 0.0008 on H and 0.0010
/// on J (session 9; minimum and dihedral angles unchanged).
pub const FLIP_ROUNDS: usize = 2;
/// Flips are tried around tetrahedra whose objective is below this (0.8
/// and 1.0 made about 10 % more flips for the same mean on case I, at 4×
/// and 8× the time).
pub const FLIP_BELOW: f64 = 0.7;
/// A node whose star's tetrahedra all have a radius ratio of at least this
/// stays where it is: the inside of a BCC lattice (0.949 each), where the
/// gradient is zero by symmetry (on case K this skips most nodes).
pub const SKIP_Q: f64 = 0.94;
/// Gradient steps per node and pass. Six gave means higher by 0.0003 (H),
/// 0.0005 (J), 0.0001 (I) and under 0.0001 (K) for about 15 % more of the
/// polish's time on K (session 8).
const ASCENT_STEPS: usize = 4;
/// First trial step along the gradient, and the step below which the
/// backtracking gives up, in units of the node's spacing.
const FIRST_STEP: f64 = 0.05;
const LAST_STEP: f64 = 0.01;

/// What [`polish`] did.
#[derive(Clone, Copy, Debug, Default)]
pub struct PolishStats {
    /// Node moves, summed over the passes.
    pub moves: usize,
    /// Flips made by the mean-raising sweeps.
    pub flips: usize,
}

/// The mean-quality step: a smoothing pass, then up to `rounds` (at most
/// [`FLIP_ROUNDS`]) times a sweep of mean-raising flips and another pass
/// (see the module doc). `movable` marks the free nodes, `d` is the spacing
/// per node; the tetrahedra must be positively oriented, and stay so.
pub fn polish(
    pos: &mut [P3],
    movable: &[bool],
    tets: &mut Vec<[u32; 4]>,
    d: &[f64],
    rounds: usize,
) -> PolishStats {
    let mut stats = PolishStats {
        moves: smooth(pos, movable, tets, d, 1),
        flips: 0,
    };
    for _ in 0..rounds.min(FLIP_ROUNDS) {
        let mu =
            tets.iter().map(|t| radius_ratio_of(pos, t)).sum::<f64>() / tets.len().max(1) as f64;
        let flips = crate::volume::tet::flip::raise_mean(pos, tets, mu, FLIP_BELOW);
        stats.flips += flips;
        if flips == 0 {
            break;
        }
        stats.moves += smooth(pos, movable, tets, d, 1);
    }
    stats
}

/// Moves the free nodes (`movable`) of the tetrahedra `tets` to raise the
/// sum of radius ratios of their stars, `passes` times over; `d` is the
/// spacing per node. Returns the number of node moves.
pub fn smooth(
    pos: &mut [P3],
    movable: &[bool],
    tets: &[[u32; 4]],
    d: &[f64],
    passes: usize,
) -> usize {
    let n = pos.len();
    // node -> tetrahedra (CSR)
    let (start, inc) = crate::volume::tet::sliver::node_tets(n, tets);
    let star = |v: usize| &inc[start[v] as usize..start[v + 1] as usize];
    let mut moved = 0;
    for _ in 0..passes {
        // only nodes with a tetrahedron below SKIP_Q in their star are
        // searched (search() would return the others unmoved), so only they
        // are coloured: on case K a sixth of the free nodes
        let mut wanted = vec![false; n];
        for t in tets {
            if radius_ratio_of(pos, t) < SKIP_Q {
                for &v in t {
                    wanted[v as usize] = movable[v as usize];
                }
            }
        }
        let classes = colour(n, &wanted, tets, &star);
        for class in &classes {
            let snapshot: &[P3] = pos;
            let moves: Vec<(usize, P3)> = class
                .par_iter()
                .filter_map(|&v| {
                    let p = search(snapshot, tets, star(v), v, d[v]);
                    (p != snapshot[v]).then_some((v, p))
                })
                .collect();
            moved += moves.len();
            for (v, p) in moves {
                pos[v] = p;
            }
        }
    }
    moved
}

/// Greedy colouring of the free nodes: two nodes of a tetrahedron never
/// share a colour. Returns the nodes of each colour.
fn colour<'a>(
    n: usize,
    movable: &[bool],
    tets: &[[u32; 4]],
    star: &impl Fn(usize) -> &'a [u32],
) -> Vec<Vec<usize>> {
    let mut col = vec![u32::MAX; n];
    let mut classes: Vec<Vec<usize>> = Vec::new();
    let mut used: Vec<u32> = Vec::new();
    for v in (0..n).filter(|&v| movable[v]) {
        used.clear();
        for &t in star(v) {
            for &w in &tets[t as usize] {
                let c = col[w as usize];
                if c != u32::MAX {
                    used.push(c);
                }
            }
        }
        let c = (0u32..).find(|c| !used.contains(c)).unwrap_or(0);
        col[v] = c;
        if classes.len() <= c as usize {
            classes.resize_with(c as usize + 1, Vec::new);
        }
        classes[c as usize].push(v);
    }
    classes
}

/// Gradient ascent for node `v`'s position: the best found, or its own.
fn search(pos: &[P3], tets: &[[u32; 4]], star: &[u32], v: usize, d: f64) -> P3 {
    let star = Star::gather(pos, tets, star, v);
    let mut at = pos[v];
    let (mut best, smallest) = star.sum_min(&at);
    if smallest >= SKIP_Q {
        return at;
    }
    let floor = star.worst(&at).min(TARGET_Q);
    // gradient ascent with backtracking: forward differences of the sum
    // (three star evaluations; central differences took six for the same
    // means on cases H and I, 0.913 and 0.903, and 1.4× the time), then
    // the longest of FIRST_STEP·d, halved down to LAST_STEP·d, that
    // improves it within the constraints
    let h = 0.01 * d;
    for _ in 0..ASCENT_STEPS {
        let g = V3::new(
            star.sum(&(at + V3::x() * h)) - best,
            star.sum(&(at + V3::y() * h)) - best,
            star.sum(&(at + V3::z() * h)) - best,
        );
        let gn = g.norm();
        if !(gn > 0.0) {
            break;
        }
        let dir = g / gn;
        let mut step = FIRST_STEP * d;
        let mut moved = false;
        while step > LAST_STEP * d {
            let cand = at + dir * step;
            let s = star.sum(&cand);
            if s > best + 1e-9 && star.worst(&cand) >= floor && star.positive(&cand) {
                best = s;
                at = cand;
                moved = true;
                break;
            }
            step *= 0.5;
        }
        if !moved {
            break;
        }
    }
    at
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A k×k×k cubic lattice of unit spacing whose inner nodes are jittered
    /// by up to ±jit/2 (deterministic), its Delaunay tetrahedra and which
    /// nodes are free (the inner ones).
    pub(crate) fn jittered_lattice(k: usize, jit: f64) -> (Vec<P3>, Vec<bool>, Vec<[u32; 4]>) {
        let mut pos = Vec::new();
        let mut movable = Vec::new();
        let mut state = 0x1234_5678_u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for i in 0..k {
            for j in 0..k {
                for l in 0..k {
                    let inner = [i, j, l].iter().all(|&c| c > 0 && c < k - 1);
                    let jit = if inner { jit } else { 0.0 };
                    pos.push(P3::new(
                        i as f64 + jit * rnd(),
                        j as f64 + jit * rnd(),
                        l as f64 + jit * rnd(),
                    ));
                    movable.push(inner);
                }
            }
        }
        let coords: Vec<[f64; 3]> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tets = bubblemesh_delaunay::tetrahedralize(&coords).unwrap().tets;
        (pos, movable, tets)
    }

    pub(crate) fn mean_q(pos: &[P3], tets: &[[u32; 4]]) -> f64 {
        tets.iter().map(|t| radius_ratio_of(pos, t)).sum::<f64>() / tets.len() as f64
    }

    pub(crate) fn worst_objective(pos: &[P3], tets: &[[u32; 4]]) -> f64 {
        tets.iter()
            .map(|t| crate::volume::tet::sliver::objective_of(pos, t))
            .fold(f64::INFINITY, f64::min)
    }

    pub(crate) fn assert_positive(pos: &[P3], tets: &[[u32; 4]]) {
        for t in tets {
            let [a, b, c, e] = t.map(|k| crate::volume::connect::c3(&pos[k as usize]));
            assert!(robust::orient3d(a, b, c, e) < 0.0, "tet {t:?} not positive");
        }
    }

    /// The summed (signed) volume of `tets`.
    pub(crate) fn volume(pos: &[P3], tets: &[[u32; 4]]) -> f64 {
        tets.iter()
            .map(|t| {
                let [a, b, c, d] = t.map(|k| pos[k as usize]);
                (b - a).dot(&(c - a).cross(&(d - a))) / 6.0
            })
            .sum()
    }

    /// The faces (sorted corners) held by one tetrahedron, sorted; asserts
    /// that every face is held by one or two (a conforming mesh).
    pub(crate) fn boundary_faces(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
        let mut m = std::collections::HashMap::new();
        for t in tets {
            for f in crate::volume::tet::sliver::FACE3 {
                let mut k = f.map(|i| t[i]);
                k.sort_unstable();
                *m.entry(k).or_insert(0usize) += 1;
            }
        }
        assert!(
            m.values().all(|&c| c == 1 || c == 2),
            "a face held by three tetrahedra"
        );
        let mut b: Vec<[u32; 3]> = m
            .into_iter()
            .filter(|&(_, c)| c == 1)
            .map(|(f, _)| f)
            .collect();
        b.sort_unstable();
        b
    }

    /// A jittered cubic lattice: the pass must raise the mean radius
    /// ratio, move only free nodes, keep every tetrahedron positive and the
    /// worst objective no lower than before (it is below TARGET_Q here).
    #[test]
    fn polish_raises_the_mean_and_keeps_tets_valid() {
        let (mut pos, movable, tets) = jittered_lattice(7, 0.3);
        let d = vec![1.0; pos.len()];
        let (m0, w0) = (mean_q(&pos, &tets), worst_objective(&pos, &tets));
        assert!(w0 < TARGET_Q);
        let before = pos.clone();
        let moved = smooth(&mut pos, &movable, &tets, &d, 1);
        let (m1, w1) = (mean_q(&pos, &tets), worst_objective(&pos, &tets));
        assert!(moved > 0);
        assert!(m1 > m0 + 0.01, "mean {m0} -> {m1}");
        assert!(w1 >= w0, "worst {w0} -> {w1}");
        for (i, (p, b)) in pos.iter().zip(&before).enumerate() {
            assert!(movable[i] || p == b, "fixed node {i} moved");
        }
        assert_positive(&pos, &tets);
    }

    /// The flips are what [`polish`] adds to smoothing: on the same lattice
    /// it must end higher than three smoothing passes (its own count), with
    /// the same guarantees.
    #[test]
    fn polish_with_flips_beats_smoothing_alone() {
        let (pos0, movable, tets0) = jittered_lattice(8, 0.45);
        let d = vec![1.0; pos0.len()];
        let w0 = worst_objective(&pos0, &tets0);
        let (mut pos_s, tets_s) = (pos0.clone(), tets0.clone());
        smooth(&mut pos_s, &movable, &tets_s, &d, 1 + FLIP_ROUNDS);
        let (mut pos_p, mut tets_p) = (pos0.clone(), tets0.clone());
        let stats = polish(&mut pos_p, &movable, &mut tets_p, &d, FLIP_ROUNDS);
        let (ms, mp) = (mean_q(&pos_s, &tets_s), mean_q(&pos_p, &tets_p));
        assert!(stats.flips > 0);
        assert!(mp > ms + 0.05, "smoothing {ms}, polish {mp} ({stats:?})");
        assert!(worst_objective(&pos_p, &tets_p) >= w0.min(TARGET_Q));
        assert_positive(&pos_p, &tets_p);
    }
}
