//! The tetrahedral mesh every pass of [`super`] works on: node positions,
//! which nodes may move, the spacing at each node, and the tetrahedra
//! (positively oriented, indices into the nodes). The node → tetrahedra
//! incidence and the stars are derived on demand ([`super::star::node_tets`],
//! [`super::star::Star`]), since every flip changes them.

use crate::geom::P3;

/// A volume's tetrahedral mesh during improvement. Nodes below the
/// volume's boundary count are the boundary's and never move; `movable`
/// is false for them (and for free nodes the boundary recovery removed).
#[derive(Clone, Debug, Default)]
pub(crate) struct TetMesh {
    /// Node positions.
    pub pos: Vec<P3>,
    /// Whether each node may move.
    pub movable: Vec<bool>,
    /// The spacing d(x) at each node, model units.
    pub d: Vec<f64>,
    /// Tetrahedra, positively oriented.
    pub tets: Vec<[u32; 4]>,
}

impl TetMesh {
    /// Every tetrahedron's [`super::star::objective`], in order.
    pub(crate) fn objectives(&self) -> Vec<f64> {
        self.tets
            .iter()
            .map(|t| super::star::objective_of(&self.pos, t))
            .collect()
    }
}

/// The mean [`radius ratio`](crate::measure::tet_radius_ratio_of) of
/// tetrahedra `tets` (0 for none).
pub(crate) fn mean_radius_ratio(pos: &[P3], tets: &[[u32; 4]]) -> f64 {
    tets.iter()
        .map(|t| crate::measure::tet_radius_ratio_of(pos, t))
        .sum::<f64>()
        / tets.len().max(1) as f64
}

/// Small real meshes and the checks the passes' tests share.
#[cfg(test)]
pub(crate) mod testing {
    use super::TetMesh;
    use crate::geom::P3;

    /// A k×k×k cubic lattice of unit spacing whose inner nodes are jittered
    /// by up to ±jit/2 (deterministic), its Delaunay tetrahedra and which
    /// nodes are free (the inner ones).
    pub(crate) fn jittered_lattice(k: usize, jit: f64) -> (Vec<P3>, Vec<bool>, Vec<[u32; 4]>) {
        let mut pos = Vec::new();
        let mut movable = Vec::new();
        let mut uniform = crate::bubbles::testing::uniform(0x1234_5678);
        let mut rnd = || uniform() - 0.5;
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

    /// [`jittered_lattice`] as a [`TetMesh`] of unit spacing.
    pub(crate) fn jittered_mesh(k: usize, jit: f64) -> TetMesh {
        let (pos, movable, tets) = jittered_lattice(k, jit);
        TetMesh {
            d: vec![1.0; pos.len()],
            pos,
            movable,
            tets,
        }
    }

    pub(crate) fn mean_q(pos: &[P3], tets: &[[u32; 4]]) -> f64 {
        super::mean_radius_ratio(pos, tets)
    }

    pub(crate) fn worst_objective(pos: &[P3], tets: &[[u32; 4]]) -> f64 {
        tets.iter()
            .map(|t| super::super::star::objective_of(pos, t))
            .fold(f64::INFINITY, f64::min)
    }

    pub(crate) fn assert_positive(pos: &[P3], tets: &[[u32; 4]]) {
        for t in tets {
            let [a, b, c, e] = t.map(|k| pos[k as usize]);
            assert!(
                crate::measure::orient3d(&a, &b, &c, &e) < 0.0,
                "tet {t:?} not positive"
            );
        }
    }

    /// The summed (signed) volume of `tets`.
    pub(crate) fn volume(pos: &[P3], tets: &[[u32; 4]]) -> f64 {
        tets.iter()
            .map(|t| {
                let [a, b, c, d] = t.map(|k| pos[k as usize]);
                crate::measure::tet_volume6(&a, &b, &c, &d) / 6.0
            })
            .sum()
    }

    /// The faces (sorted corners) held by one tetrahedron, sorted; asserts
    /// that every face is held by one or two (a conforming mesh).
    pub(crate) fn boundary_faces(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
        let mut m = std::collections::HashMap::new();
        for t in tets {
            for f in crate::measure::TET_FACES {
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
        // the same set as measure's
        let mut via_measure: Vec<[u32; 3]> = crate::measure::boundary_faces(tets.iter().copied())
            .into_iter()
            .map(|(t, k)| {
                let mut f = crate::measure::TET_FACES[k as usize].map(|i| tets[t as usize][i]);
                f.sort_unstable();
                f
            })
            .collect();
        via_measure.sort_unstable();
        assert_eq!(b, via_measure);
        b
    }
}
