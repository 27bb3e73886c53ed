//! Mean-quality smoothing of a volume's free nodes, the last step of the
//! volume connection (not in the thesis).
//!
//! Why: after stage 2, ODT smoothing ([`super::odt`]) and sliver removal
//! ([`super::sliver`]) the worst tetrahedra are fixed, but a graded packing
//! still leaves many middling ones: on case I (d = 0.02 + 0.1·x) the mean
//! radius ratio was 0.865, interior tetrahedra 0.876 against 0.909 for the
//! uniform case H. Moving every free node to raise the *sum* of the radius
//! ratios of its star lifts I to 0.887 (with 20 ODT iterations before).
//! Measured on I, one thread: a pattern search over 14 directions (as the
//! sliver pass does for the worst tetrahedron) gave 0.8873 in 3.9 s; a
//! gradient ascent (central differences, backtracking) 0.8856 in
//! 1.4 s for one pass and 0.8872 in 2.9 s for two. More passes gain
//! nothing (four: 0.8878): stars hold tetrahedra no move can fix. So
//! [`polish`] alternates: one pass, then [`PolishParams::flip_rounds`] times a sweep of
//! mean-raising flips ([`super::flip::raise_mean`]) and another pass. On I
//! that gives 0.903 (passes alone 0.8872), on H 0.913 (0.906), on J 0.915
//! (0.909), for one more pass's time. After a BCC start the volume asks
//! for the first pass only (see [`PolishParams::flip_rounds`]).
//!
//! Cost (case K, 2.75 M tetrahedra, one thread): only nodes with a star
//! tetrahedron below [`PolishParams::skip_q`] are coloured and searched (about 70k of
//! 443k free nodes), each over its star gathered once ([`Star`]): about
//! 1.1 s.
//!
//! Invariants kept: every tetrahedron of a moved node's star stays
//! positively oriented (exact `orient3d`), so no node leaves its volume and
//! the topology — hence the boundary — is unchanged; the worst
//! [`super::star::objective`] of a star never drops below the smaller of
//! its value before and [`super::star::TARGET_Q`], so the sliver pass's
//! guarantees (radius ratio and dihedral angles) survive.
//!
//! Parallel: nodes are greedily coloured so that no two nodes of one colour
//! share a tetrahedron; the nodes of a colour move at once (rayon), each
//! reading only positions that colour does not change. The result does
//! not depend on the number of threads.

use rayon::prelude::*;

use super::mesh::TetMesh;
use super::star::{node_tets, Star, TARGET_Q};
use crate::geom::{P3, V3};
use crate::measure::tet_radius_ratio_of;

/// The polish's tuning.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PolishParams {
    /// Rounds of flips and smoothing after the first pass of [`polish`].
    /// After an FCC start a second round added 0.0014 to the mean on case
    /// I. After a BCC start, whose interior needs nothing, the volume asks
    /// for none: since the sliver pass flips before it smooths
    /// ([`super::sliver::remove_slivers`]), one round added 0.0001 to the
    /// mean on K (857 flips, about 1 s of its time), 0.0008 on H and 0.0010
    /// on J (minimum and dihedral angles unchanged).
    pub flip_rounds: usize,
    /// Flips are tried around tetrahedra whose objective is below this (0.8
    /// and 1.0 made about 10 % more flips for the same mean on case I, at 4×
    /// and 8× the time).
    pub flip_below: f64,
    /// A node whose star's tetrahedra all have a radius ratio of at least
    /// this stays where it is: the inside of a BCC lattice (0.949 each),
    /// where the gradient is zero by symmetry (on case K this skips most
    /// nodes).
    pub skip_q: f64,
    /// Gradient steps per node and pass. Six gave means higher by 0.0003
    /// (H), 0.0005 (J), 0.0001 (I) and under 0.0001 (K) for about 15 % more
    /// of the polish's time on K.
    pub ascent_steps: usize,
    /// First trial step along the gradient, in units of the node's spacing.
    pub first_step: f64,
    /// The step below which the backtracking gives up, in units of the
    /// node's spacing.
    pub last_step: f64,
}

impl Default for PolishParams {
    fn default() -> Self {
        PolishParams {
            flip_rounds: 2,
            flip_below: 0.7,
            skip_q: 0.94,
            ascent_steps: 4,
            first_step: 0.05,
            last_step: 0.01,
        }
    }
}

/// What [`polish`] did.
#[derive(Clone, Copy, Debug, Default)]
pub struct PolishStats {
    /// Node moves, summed over the passes.
    pub moves: usize,
    /// Flips made by the mean-raising sweeps.
    pub flips: usize,
}

/// The mean-quality step: a pass of [`raise_mean_by_moves`], then up to
/// `params.flip_rounds` times a sweep of mean-raising flips and another
/// pass (see the module doc). The tetrahedra must be positively oriented,
/// and stay so; only `mesh.movable` nodes move.
pub(crate) fn polish(mesh: &mut TetMesh, params: &PolishParams) -> PolishStats {
    let mut stats = PolishStats {
        moves: raise_mean_by_moves(mesh, params, 1),
        flips: 0,
    };
    for _ in 0..params.flip_rounds {
        let (pos, tets) = (&mesh.pos, &mesh.tets);
        let mu = super::mesh::mean_radius_ratio(pos, tets);
        let flips = super::flip::raise_mean(mesh, mu, params.flip_below);
        stats.flips += flips;
        if flips == 0 {
            break;
        }
        stats.moves += raise_mean_by_moves(mesh, params, 1);
    }
    stats
}

/// Moves the free nodes (`mesh.movable`) to raise the sum of radius ratios
/// of their stars, `passes` times over, without lowering any star's worst
/// objective below min(its value, [`TARGET_Q`]). Returns the number of
/// node moves.
pub(crate) fn raise_mean_by_moves(
    mesh: &mut TetMesh,
    params: &PolishParams,
    passes: usize,
) -> usize {
    let TetMesh {
        pos,
        movable,
        d,
        tets,
    } = mesh;
    let (movable, d, tets): (&[bool], &[f64], &[[u32; 4]]) = (movable, d, tets);
    let n = pos.len();
    // node -> tetrahedra (CSR)
    let (start, inc) = node_tets(n, tets);
    let star = |v: usize| &inc[start[v] as usize..start[v + 1] as usize];
    let mut moved = 0;
    for _ in 0..passes {
        // only nodes with a tetrahedron below SKIP_Q in their star are
        // searched (search() would return the others unmoved), so only they
        // are coloured: on case K a sixth of the free nodes
        let mut wanted = vec![false; n];
        for t in tets {
            if tet_radius_ratio_of(pos, t) < params.skip_q {
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
                    let p = search(snapshot, tets, star(v), v, d[v], params);
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
fn search(
    pos: &[P3],
    tets: &[[u32; 4]],
    star: &[u32],
    v: usize,
    d: f64,
    params: &PolishParams,
) -> P3 {
    let star = Star::gather(pos, tets, star, v);
    let mut at = pos[v];
    let (mut best, smallest) = star.sum_min(&at);
    if smallest >= params.skip_q {
        return at;
    }
    let floor = star.worst(&at).min(TARGET_Q);
    // gradient ascent with backtracking: forward differences of the sum
    // (three star evaluations; central differences took six for the same
    // means on cases H and I, 0.913 and 0.903, and 1.4× the time), then
    // the longest of first_step·d, halved down to last_step·d, that
    // improves it within the constraints
    let h = 0.01 * d;
    for _ in 0..params.ascent_steps {
        let g = V3::new(
            star.sum(&(at + V3::x() * h)) - best,
            star.sum(&(at + V3::y() * h)) - best,
            star.sum(&(at + V3::z() * h)) - best,
        );
        let gn = g.norm();
        if gn.is_nan() || gn <= 0.0 {
            break;
        }
        let dir = g / gn;
        let mut step = params.first_step * d;
        let mut moved = false;
        while step > params.last_step * d {
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
mod tests {
    use super::*;
    use crate::volume::tet::mesh::testing::{
        assert_positive, jittered_mesh, mean_q, worst_objective,
    };

    /// A jittered cubic lattice: the moves must raise the mean radius
    /// ratio, move only free nodes, keep every tetrahedron positive and the
    /// worst objective no lower than before (it is below TARGET_Q here).
    #[test]
    fn polish_raises_the_mean_and_keeps_tets_valid() {
        let mut mesh = jittered_mesh(7, 0.3);
        let (m0, w0) = (
            mean_q(&mesh.pos, &mesh.tets),
            worst_objective(&mesh.pos, &mesh.tets),
        );
        assert!(w0 < TARGET_Q);
        let before = mesh.pos.clone();
        let moved = raise_mean_by_moves(&mut mesh, &PolishParams::default(), 1);
        let (m1, w1) = (
            mean_q(&mesh.pos, &mesh.tets),
            worst_objective(&mesh.pos, &mesh.tets),
        );
        assert!(moved > 0);
        assert!(m1 > m0 + 0.01, "mean {m0} -> {m1}");
        assert!(w1 >= w0, "worst {w0} -> {w1}");
        for (i, (p, b)) in mesh.pos.iter().zip(&before).enumerate() {
            assert!(mesh.movable[i] || p == b, "fixed node {i} moved");
        }
        assert_positive(&mesh.pos, &mesh.tets);
    }

    /// The flips are what [`polish`] adds to smoothing: on the same lattice
    /// it must end higher than three smoothing passes (its own count), with
    /// the same guarantees.
    #[test]
    fn polish_with_flips_beats_smoothing_alone() {
        let params = PolishParams::default();
        let mesh0 = jittered_mesh(8, 0.45);
        let w0 = worst_objective(&mesh0.pos, &mesh0.tets);
        let mut smoothed = mesh0.clone();
        raise_mean_by_moves(&mut smoothed, &params, 1 + params.flip_rounds);
        let mut polished = mesh0.clone();
        let stats = polish(&mut polished, &params);
        let ms = mean_q(&smoothed.pos, &smoothed.tets);
        let mp = mean_q(&polished.pos, &polished.tets);
        assert!(stats.flips > 0);
        assert!(mp > ms + 0.05, "smoothing {ms}, polish {mp} ({stats:?})");
        assert!(worst_objective(&polished.pos, &polished.tets) >= w0.min(TARGET_Q));
        assert_positive(&polished.pos, &polished.tets);
    }
}
