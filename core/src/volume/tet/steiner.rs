//! Steiner points for slivers whose corners are all fixed: new free nodes
//! inside the volume that let the next tetrahedralization split them (not
//! in the thesis).

use super::mesh::TetMesh;
use crate::geom::{P3, V3};

/// Rounds of [`steiner_points`] and re-connection after the sliver pass,
/// at most (see [`STEINER_FEW`] for when fewer).
pub(crate) const STEINER_ROUNDS: usize = 6;
/// A round after the second is run only while fewer poor tetrahedra
/// (radius ratio below [`POOR_Q`](crate::quality::POOR_Q)) are left among
/// fixed nodes than after every earlier round, or the round asks for at
/// most half the points of the one before, or for at most this many.
///
/// Why: on some parts the slivers among fixed nodes stop converging after
/// a round or two, each round then asking for as many points as the last
/// (as_0082 at diag/20: 7,338, then 987, 757, 758, 770, 759 points, the
/// count of tetrahedra below the target and the worst one unchanged), and
/// every round costs a whole re-connection and sliver pass. A handful of
/// points is the last few slivers being split, which is where the worst
/// dihedral angle is made (as_0080: 8 and 6 points raise it from 13° to
/// 21°), so those rounds go on; so do the first two (b3d_bottle at
/// diag/20, ~200 points a round: stopping after one left its mean at
/// 0.422, under Gmsh's 0.431) and every round while a poor tetrahedron is
/// left (with only flat ones, below FLAT_Q, counted, b3d_bottle at size 1
/// kept ten below 0.01, the worst 7.9e-6, where six rounds leave none).
/// Measured on the 27 realstep files meshed into tetrahedra at diag/20
/// (one thread): 43.5 → 36.7 s in all, as_0082 9.5 → 6.3 s, as_0048 2.1
/// → 1.5 s; mean radius ratio up on 7 files and down on 3 (at most 0.009:
/// as_0083 0.816 → 0.807, Gmsh 0.570), the smallest dihedral angle lower
/// on 4 (as_0082 0.85° → 0.33°, where Gmsh has no mesh; as_house_walls
/// 5.1° → 4.4°, Gmsh 3.3°; the others by under 0.1°) and higher on 1
/// (as_0084 5.6° → 8.5°); the files at or above Gmsh's mean and smallest
/// angle the same. With no floor (32 → 0) the smallest angles of as_0080,
/// as_0079, as_0085 fell by 3–8°.
pub(crate) const STEINER_FEW: usize = 32;

///
/// Poor tetrahedra must get fewer (flat ones, below [`FLAT_Q`], keep the
/// rounds going: one left refuses the volume, and the refinement round
/// that follows costs more than the Steiner rounds; as_40mm_capot at
/// diag/20 stopped with one and took 5.7 s instead of 4.3 s): where they
/// come back round after round
/// (a wall thinner than the Steiner points' offset, the same boundary
/// nodes making the same slivers), more rounds only cost time —
/// pyocc_Ventilator at diag/20 left 34, 19, 10, 11, 18 and 14 poor ones
/// before its six rounds, the same tetrahedra among them again and again.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SteinerRounds {
    /// The points the last round asked for.
    asked: usize,
    /// The fewest poor tetrahedra among fixed nodes before any round yet.
    least_poor: usize,
}

impl Default for SteinerRounds {
    fn default() -> Self {
        SteinerRounds {
            asked: usize::MAX,
            least_poor: usize::MAX,
        }
    }
}

impl SteinerRounds {
    /// Whether Steiner round `round` (from 0) is run, given the slivers
    /// among fixed nodes it is for (`work`) and the points it asks for
    /// (see [`STEINER_FEW`]); a round that runs is recorded.
    pub(crate) fn worth_a_round(
        &mut self,
        round: usize,
        pos: &[P3],
        work: &[[u32; 4]],
        wanted: usize,
    ) -> bool {
        let q: Vec<f64> = work
            .iter()
            .map(|t| crate::measure::tet_radius_ratio_of(pos, t))
            .collect();
        let poor = q.iter().filter(|&&q| q < crate::quality::POOR_Q).count();
        // a flat one left refuses the volume: a refinement round, dearer
        // than any Steiner round
        let flat = q.iter().any(|&q| q < FLAT_Q);
        let go = wanted > 0
            && (round < 2
                || 2 * wanted <= self.asked
                || wanted <= STEINER_FEW
                || flat
                || (poor > 0 && poor < self.least_poor));
        self.least_poor = self.least_poor.min(poor);
        if go {
            self.asked = wanted;
        }
        go
    }
}
/// A tetrahedron with a radius ratio below this is flat: it gets Steiner
/// points, and the volume is refused rather than meshed with one.
pub(crate) const FLAT_Q: f64 = 1e-6;

/// New free points for `slivers` (the caller passes those whose corners are
/// all fixed: flat in the raw tetrahedralization, or still below
/// [`TARGET_Q`](super::star::TARGET_Q) after the sliver pass): for each, the two points 0.29·d off its
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
/// split; the caller re-connects ([`with_points`]) and runs the sliver pass again, which can move
/// the new points.
pub(crate) fn steiner_points(
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
        let Some((n, nn)) = mean_plane_normal(&p) else {
            continue;
        };
        for s in [1.0, -1.0] {
            let q = c + n * (s * 0.29 * dc / nn);
            if inside(&q) {
                cand.push((q, dc));
            }
        }
    }
    let Some(h) = cand.iter().map(|c| 0.25 * c.1).max_by(f64::total_cmp) else {
        return Vec::new();
    };
    // a hash grid of cell h (the largest exclusion radius, so that a point
    // looks at the 27 cells around its own): a point is dropped when a
    // chosen one lies within a quarter of its own spacing. (Cells of the
    // smallest radius made a point of spacing d look at (2k+1)³ cells, k
    // its spacing over the smallest: where refined places had spacings a
    // hundredth of d, that was most of as_0083's tetrahedra.)
    if !(h > 0.0 && h.is_finite()) {
        return Vec::new();
    }
    let key = |p: &P3| [0, 1, 2].map(|i| (p[i] / h).floor() as i64);
    let mut cells: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
    let mut out: Vec<(P3, f64)> = Vec::new();
    for (c, dc) in cand {
        // r ≤ h: the chosen points within r are in the 27 cells around
        let r = 0.25 * dc;
        let k = key(&c);
        let mut near = false;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
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

/// A normal of a tetrahedron's mean plane and its length: the largest
/// cross product of two opposite edges (for a flat quadrilateral, its
/// diagonals'); `None` when every pair is parallel. A point `t` off the
/// plane is `c + n * (t / len)` (not normalised first: that rounds
/// differently, and the Steiner points' places decide the meshes bit for
/// bit).
pub(crate) fn mean_plane_normal(p: &[P3; 4]) -> Option<(V3, f64)> {
    let n = [(0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2)]
        .iter()
        .map(|&(a, b, e, f)| (p[b] - p[a]).cross(&(p[f] - p[e])))
        .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))?;
    let nn = n.norm();
    (!nn.is_nan() && nn > 0.0).then_some((n, nn))
}

/// The nodes of `mesh` to re-connect after Steiner points: the first
/// `n_keep` (the boundary's, which keep their indices: the boundary
/// triangles refer to them; then a warm start's kept bubbles, which stay
/// where they were), the movable ones, then `extra` (position and
/// spacing). The free nodes the boundary recovery removed are dropped.
/// Returns positions and spacings.
pub(crate) fn with_points(
    mesh: &TetMesh,
    n_keep: usize,
    extra: Vec<(P3, f64)>,
) -> (Vec<P3>, Vec<f64>) {
    let (pos, d) = (&mesh.pos, &mesh.d);
    let mut pos2: Vec<P3> = Vec::with_capacity(pos.len() + extra.len());
    let mut d2: Vec<f64> = Vec::with_capacity(pos.len() + extra.len());
    for i in 0..pos.len() {
        if i < n_keep || mesh.movable[i] {
            pos2.push(pos[i]);
            d2.push(d[i]);
        }
    }
    for (p, dp) in extra {
        pos2.push(p);
        d2.push(dp);
    }
    (pos2, d2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::tet_radius_ratio_of;
    use crate::volume::tet::mesh::testing::assert_positive;

    /// The rounds' stop (as_0082's counts: 7,338 and 987 points run, 757
    /// does not): the first two rounds always run; a later one that asks
    /// for about as many points as the last stops, unless it asks for a
    /// handful, or fewer poor tetrahedra are left than before every earlier
    /// round, or a flat one is; nothing asked, nothing run.
    #[test]
    fn steiner_rounds_stop_where_they_stop_converging() {
        let pos = [
            P3::new(0.0, 0.0, 0.0),
            P3::new(1.0, 0.0, 0.0),
            P3::new(0.0, 1.0, 0.0),
            P3::new(0.0, 0.0, 1.0),
            P3::new(1.0, 1.0, 1e-9),
            P3::new(0.2, 0.2, 0.01),
            P3::new(0.3, 0.1, 0.012),
        ];
        let fair = [[0, 1, 2, 3]];
        let poor = [[0, 1, 2, 5]];
        let two_poor = [[0, 1, 2, 5], [0, 1, 2, 6]];
        let flat = [[0, 1, 2, 4]];
        // as_0082's point counts: 7338, 987, 757, ...
        let mut r = SteinerRounds::default();
        assert!(r.worth_a_round(0, &pos, &fair, 7338));
        assert!(r.worth_a_round(1, &pos, &fair, 987));
        assert!(
            !r.worth_a_round(2, &pos, &fair, 757),
            "the third stops: it asks for about as many as the second"
        );
        let after = |asked: usize| {
            let mut r = SteinerRounds::default();
            assert!(r.worth_a_round(0, &pos, &two_poor, 7338));
            assert!(r.worth_a_round(1, &pos, &two_poor, asked));
            r
        };
        assert!(!after(757).worth_a_round(3, &pos, &fair, 758), "stagnating");
        assert!(after(757).worth_a_round(3, &pos, &fair, 300), "halved");
        assert!(
            after(40).worth_a_round(3, &pos, &fair, STEINER_FEW),
            "a handful"
        );
        assert!(!after(40).worth_a_round(3, &pos, &fair, STEINER_FEW + 1));
        // poor ones: fewer than before every earlier round go on, as many
        // as before one of them do not (they came back)
        assert!(after(757).worth_a_round(3, &pos, &poor, 758), "1 poor < 2");
        let mut r = after(757);
        assert!(!r.worth_a_round(3, &pos, &two_poor, 758), "2 poor again");
        let mut r2 = SteinerRounds::default();
        assert!(r2.worth_a_round(0, &pos, &poor, 7338));
        assert!(r2.worth_a_round(1, &pos, &fair, 987));
        assert!(
            !r2.worth_a_round(2, &pos, &poor, 900),
            "the poor one is back: not fewer than before round 0"
        );
        assert!(
            r2.worth_a_round(2, &pos, &flat, 900),
            "a flat one is back: it would refuse the volume"
        );
        assert!(!r.worth_a_round(0, &pos, &fair, 0), "no points, no round");
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
        assert!(tet_radius_ratio_of(&pos, &t).abs() < FLAT_Q);
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

    /// Insertion keeps the mesh valid: a flat rectangle between two
    /// tetrahedra, its Steiner points added and everything re-tetrahedralized,
    /// leaves every tetrahedron positive and none flat.
    #[test]
    fn inserted_points_give_positive_tetrahedra() {
        let mesh = TetMesh {
            pos: vec![
                P3::new(0.0, 0.0, 0.0),
                P3::new(1.0, 1e-17, 0.0),
                P3::new(1.0, 0.0, 1.0),
                P3::new(0.0, 1e-17, 1.0),
                P3::new(0.5, 0.8, 0.5),
                P3::new(0.5, -0.8, 0.5),
            ],
            movable: vec![false; 6],
            d: vec![1.0; 6],
            tets: vec![[0, 1, 2, 3]],
        };
        let extra = steiner_points(&mesh.pos, &mesh.tets, &mesh.d, |_| true);
        assert_eq!(extra.len(), 2);
        let (pos, d) = with_points(&mesh, 6, extra);
        assert_eq!((pos.len(), d.len()), (8, 8));
        assert_eq!(&pos[..6], &mesh.pos[..]);
        let coords: Vec<[f64; 3]> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tets = bubblemesh_delaunay::tetrahedralize(&coords).unwrap().tets;
        assert!(!tets.is_empty());
        assert_positive(&pos, &tets);
        assert!(tets.iter().all(|t| tet_radius_ratio_of(&pos, t) > FLAT_Q));
    }
}
