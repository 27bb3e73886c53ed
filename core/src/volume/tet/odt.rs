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

use crate::geom::P3;

use crate::volume::InVolume;

/// ODT iterations.
pub const ITERATIONS: usize = 20;
/// Largest move of a node per iteration, in units of its spacing.
pub const MAX_STEP: f64 = 0.25;

/// Smooths the free nodes `pos[n_fixed..]` (spacing `d`), keeping them
/// inside `carrier`'s volume. Returns the number of iterations done.
pub fn smooth(
    pos: &mut [P3],
    n_fixed: usize,
    d: &[f64],
    carrier: &InVolume<'_>,
    iterations: usize,
) -> usize {
    let n = pos.len();
    let mut done = 0;
    for _ in 0..iterations {
        let coords: Vec<[f64; 3]> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        let Ok(dt) = bubblemesh_delaunay::tetrahedralize(&coords) else {
            break;
        };
        let mut acc = vec![nalgebra::Vector3::<f64>::zeros(); n];
        let mut wsum = vec![0.0f64; n];
        for t in &dt.tets {
            let [a, b, c, e] = t.map(|k| pos[k as usize]);
            let (u, v, w) = (b - a, c - a, e - a);
            let vol6 = u.dot(&v.cross(&w));
            if vol6 == 0.0 {
                continue;
            }
            // circumcentre relative to a
            let num = v.cross(&w) * u.norm_squared()
                + w.cross(&u) * v.norm_squared()
                + u.cross(&v) * w.norm_squared();
            let cc = a.coords + num / (2.0 * vol6);
            let dt_ = 0.25 * t.iter().map(|&k| d[k as usize]).sum::<f64>();
            let wt = vol6.abs() / (dt_ * dt_ * dt_);
            for &k in t {
                let k = k as usize;
                if k >= n_fixed {
                    acc[k] += cc * wt;
                    wsum[k] += wt;
                }
            }
        }
        let mut moved = 0.0f64;
        for i in n_fixed..n {
            if wsum[i] <= 0.0 {
                continue;
            }
            let target = P3::from(acc[i] / wsum[i]);
            let mut step = target - pos[i];
            let len = step.norm();
            if len > MAX_STEP * d[i] {
                step *= MAX_STEP * d[i] / len;
            }
            let cand = pos[i] + step;
            if carrier.contains_point(&cand) {
                pos[i] = cand;
                moved = moved.max(step.norm() / d[i]);
            }
        }
        done += 1;
        if moved < 1e-3 {
            break;
        }
    }
    done
}
