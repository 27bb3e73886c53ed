//! Optimal-Delaunay smoothing of a volume's bubbles after stage 2 (not in
//! the thesis; Chen & Holst 2004, Alliez et al. 2005, "Variational
//! tetrahedral meshing").
//!
//! Why: the force balance packs bubbles face-centred cubic (§4.1.3), and
//! the Delaunay tetrahedralization of an FCC packing splits every
//! octahedral hole into four tetrahedra of radius ratio 0.72, so the
//! tetrahedra of a perfect packing average about 0.81. Moving each free
//! node to the volume-weighted mean of the circumcentres of its
//! tetrahedra (the minimiser of the ODT energy for the current
//! connectivity) and re-tetrahedralizing drives the mesh towards the
//! near-regular tetrahedra the ODT energy favours, while the bubbles move
//! by a fraction of their spacing, so the node density — the spacing —
//! is kept. Weights carry the spacing: a tetrahedron counts with
//! |T|/d_T³, the node density of its region.

use super::mesh::TetMesh;
use crate::geom::P3;
use crate::measure::tet_circumcentre;
use bubblemesh_delaunay::Moved;

/// ODT smoothing's tuning.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OdtParams {
    /// Iterations (each needs the Delaunay tetrahedralization of all nodes:
    /// the first is built, the others moved from the last by flips).
    pub iterations: usize,
    /// Largest move of a node per iteration, in units of its spacing.
    pub max_step: f64,
    /// Tetrahedralize only the free nodes and the fixed ones within
    /// [`LOCAL_REACH`] spacings of them (a warm start, where most nodes
    /// are kept): a free node's Delaunay tetrahedra are made of its
    /// neighbours, so its target is the same, at the cost of the region
    /// instead of the volume.
    pub local: bool,
}

/// How far, in spacings of a free node, the fixed nodes that a local
/// smoothing tetrahedralizes with it reach: a free node's Delaunay
/// neighbours lie within about 1.5 spacings of it, and a warm start's free
/// nodes move by a small fraction of a spacing (on case e of
/// `bench/run_remesh.py` 2 and 3 gave the same mean radius ratio, 2 at
/// two thirds of the time).
pub(crate) const LOCAL_REACH: f64 = 2.0;

impl Default for OdtParams {
    fn default() -> Self {
        OdtParams {
            iterations: 20,
            max_step: 0.25,
            local: false,
        }
    }
}

/// What [`odt_smooth`] did.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct OdtStats {
    /// Iterations done (it stops early when no node moves more than
    /// 0.001·d).
    pub iterations: usize,
    /// Iterations whose tetrahedralization was built anew rather than
    /// moved from the last one's (the first, and those where flips could
    /// not reach it).
    pub rebuilt: usize,
}

/// Moves the free nodes (`mesh.movable`) towards the spacing-weighted mean
/// of the circumcentres of their Delaunay tetrahedra, keeping each where
/// `inside` accepts it. `mesh.tets` is not read (each iteration
/// tetrahedralizes the nodes: the first anew, the others by moving the last
/// iteration's) and not changed: the caller connects the smoothed nodes.
///
/// Why `inside` is a closure: the volume's inside test belongs to the
/// volume, which calls this pass, not the other way round.
pub(crate) fn odt_smooth(
    mesh: &mut TetMesh,
    params: &OdtParams,
    inside: impl Fn(&P3) -> bool,
) -> OdtStats {
    smooth(mesh, params, inside, false)
}

/// [`odt_smooth`], with every iteration's tetrahedralization built anew
/// where `rebuild` is set (a test compares the two).
fn smooth(
    mesh: &mut TetMesh,
    params: &OdtParams,
    inside: impl Fn(&P3) -> bool,
    rebuild: bool,
) -> OdtStats {
    let TetMesh {
        pos, movable, d, ..
    } = mesh;
    let n = pos.len();
    // the nodes tetrahedralized each iteration (all, or the free ones and
    // the fixed ones near them)
    let active: Vec<u32> = if params.local {
        let free: Vec<P3> = (0..n).filter(|&i| movable[i]).map(|i| pos[i]).collect();
        let dfree: Vec<f64> = (0..n).filter(|&i| movable[i]).map(|i| d[i]).collect();
        let dmax = dfree.iter().cloned().fold(0.0f64, f64::max);
        let g = crate::bubbles::grid::Grid::new(&free, (LOCAL_REACH * dmax).max(f64::MIN_POSITIVE));
        (0..n as u32)
            .filter(|&i| {
                let i = i as usize;
                let mut near = movable[i];
                if !near {
                    g.query(&pos[i], LOCAL_REACH * dmax, |j| {
                        near |=
                            (free[j as usize] - pos[i]).norm() <= LOCAL_REACH * dfree[j as usize];
                    });
                }
                near
            })
            .collect()
    } else {
        (0..n as u32).collect()
    };
    let mut done = 0;
    let mut rebuilt = 0;
    // The tetrahedralization of the last iteration, moved to the new
    // positions by flips (`Delaunay3::moved`): the same tets as a new build.
    let mut tri: Option<bubblemesh_delaunay::Delaunay3> = None;
    for _ in 0..params.iterations {
        let coords: Vec<[f64; 3]> = active
            .iter()
            .map(|&i| {
                let p = pos[i as usize];
                [p.x, p.y, p.z]
            })
            .collect();
        let next = match tri.take().filter(|_| !rebuild) {
            None => bubblemesh_delaunay::Delaunay3::new(&coords).map(|d| (d, Moved::Rebuilt)),
            Some(d) => d.moved(&coords),
        };
        let Ok((dt, how)) = next else {
            break;
        };
        rebuilt += usize::from(how == Moved::Rebuilt);
        // In one order whatever the tets' storage order (which differs
        // between a new build and a moved one), so that the sums below, and
        // the positions, do not depend on how the tets were reached.
        // (as one 128-bit key each: sorted as numbers, in the order of the
        // sorted vertex quadruples, faster than comparing arrays)
        let mut keys: Vec<u128> = dt
            .tets()
            .map(|mut t| {
                t.sort_unstable();
                t.iter().fold(0u128, |k, &v| (k << 32) | u128::from(v))
            })
            .collect();
        keys.sort_unstable();
        let tets = keys
            .iter()
            .map(|&k| [96, 64, 32, 0].map(|s| (k >> s) as u32));
        tri = Some(dt);
        let mut acc = vec![nalgebra::Vector3::<f64>::zeros(); n];
        let mut wsum = vec![0.0f64; n];
        for t in tets {
            let t = t.map(|k| active[k as usize]);
            let [a, b, c, e] = t.map(|k| pos[k as usize]);
            let Some(cc) = tet_circumcentre(&a, &b, &c, &e) else {
                continue;
            };
            let vol6 = crate::measure::tet_volume6(&a, &b, &c, &e);
            let dt_ = 0.25 * t.iter().map(|&k| d[k as usize]).sum::<f64>();
            let wt = vol6.abs() / (dt_ * dt_ * dt_);
            for &k in &t {
                let k = k as usize;
                if movable[k] {
                    acc[k] += cc.coords * wt;
                    wsum[k] += wt;
                }
            }
        }
        let mut moved = 0.0f64;
        for i in (0..n).filter(|&i| movable[i]) {
            if wsum[i] <= 0.0 {
                continue;
            }
            let target = P3::from(acc[i] / wsum[i]);
            let mut step = target - pos[i];
            let len = step.norm();
            if len > params.max_step * d[i] {
                step *= params.max_step * d[i] / len;
            }
            let cand = pos[i] + step;
            if inside(&cand) {
                pos[i] = cand;
                moved = moved.max(step.norm() / d[i]);
            }
        }
        done += 1;
        if moved < 1e-3 {
            break;
        }
    }
    OdtStats {
        iterations: done,
        rebuilt,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::tet::mesh::testing::{assert_positive, jittered_mesh, mean_q};

    fn delaunay(pos: &[P3]) -> Vec<[u32; 4]> {
        let coords: Vec<[f64; 3]> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        bubblemesh_delaunay::tetrahedralize(&coords).unwrap().tets
    }

    /// On a jittered lattice, ODT moves only free nodes, keeps them inside,
    /// and the re-tetrahedralization is all positive with a mean radius
    /// ratio no lower than before.
    #[test]
    fn odt_keeps_tets_positive_and_raises_the_mean() {
        let mut mesh = jittered_mesh(7, 0.4);
        let (pos0, m0) = (mesh.pos.clone(), mean_q(&mesh.pos, &mesh.tets));
        let inside = |p: &P3| (0..3).all(|k| p[k] > 0.0 && p[k] < 6.0);
        let stats = odt_smooth(&mut mesh, &OdtParams::default(), inside);
        assert!(stats.iterations > 0);
        for (i, (p, p0)) in mesh.pos.iter().zip(&pos0).enumerate() {
            assert!(mesh.movable[i] || p == p0, "fixed node {i} moved");
            assert!(!mesh.movable[i] || inside(p));
        }
        let tets = delaunay(&mesh.pos);
        assert_positive(&mesh.pos, &tets);
        let m1 = mean_q(&mesh.pos, &tets);
        assert!(m1 >= m0, "mean {m0} -> {m1}");
    }

    /// The tetrahedra of an iteration moved from the last one's by flips
    /// are those of a new build but in another storage order; the sums run
    /// in one order, so the nodes end on the same bits either way.
    #[test]
    fn moved_and_rebuilt_tetrahedralizations_smooth_to_the_same_bits() {
        let mut moved = jittered_mesh(9, 0.4);
        let mut rebuilt = moved.clone();
        let inside = |p: &P3| (0..3).all(|k| p[k] > 0.0 && p[k] < 8.0);
        let a = smooth(&mut moved, &OdtParams::default(), inside, false);
        let b = smooth(&mut rebuilt, &OdtParams::default(), inside, true);
        assert_eq!(a.iterations, b.iterations);
        assert_eq!(b.rebuilt, b.iterations);
        assert!(a.rebuilt < a.iterations, "every iteration was rebuilt");
        assert_eq!(moved.pos, rebuilt.pos);
    }

    /// A warm start's local smoothing (`OdtParams::local`: only the free
    /// nodes and the fixed ones within `LOCAL_REACH` spacings are
    /// tetrahedralized) moves the free nodes as the whole-volume smoothing
    /// does, to rounding (the tetrahedra come in another order, so the
    /// sums do): a corner of a jittered lattice free, the rest fixed.
    #[test]
    fn local_odt_moves_the_free_nodes_as_the_whole_one() {
        let base = jittered_mesh(10, 0.4);
        let mut whole = base.clone();
        for (m, p) in whole.movable.iter_mut().zip(&base.pos) {
            *m = *m && p.x < 3.5 && p.y < 3.5 && p.z < 3.5;
        }
        let mut local = whole.clone();
        let inside = |p: &P3| (0..3).all(|k| p[k] > 0.0 && p[k] < 9.0);
        let params = OdtParams {
            iterations: 3,
            ..Default::default()
        };
        odt_smooth(&mut whole, &params, inside);
        odt_smooth(
            &mut local,
            &OdtParams {
                local: true,
                ..params
            },
            inside,
        );
        let free = whole.movable.iter().filter(|&&m| m).count();
        assert!(free >= 27, "{free} free nodes");
        let mut moved = 0;
        for i in 0..base.pos.len() {
            let gap = (whole.pos[i] - local.pos[i]).norm();
            assert!(
                gap <= 1e-12,
                "node {i}: {} against {}",
                whole.pos[i],
                local.pos[i]
            );
            moved += (whole.pos[i] != base.pos[i]) as usize;
        }
        assert!(moved > 0 && moved <= free, "{moved} moved of {free} free");
    }
}
