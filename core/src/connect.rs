//! Connection of bubble centres into elements (thesis §2.1.1, §3.2.3).
//!
//! Faces: a constrained Delaunay triangulation in the face's (u,v)
//! parameters with `spade` (exact orientation and in-circle predicates via
//! `robust`), constrained by the boundary and embedded edges; triangles
//! outside the face are removed by a topological flood from the oriented
//! boundary segments.
//!
//! Invariants of [`triangulate`]'s result: every input point is a vertex of
//! some triangle or lies outside the kept region; every constraint segment is
//! an edge of the triangulation; triangles are counter-clockwise in (u,v).

use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

/// Why a triangulation could not be built.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    #[error("two mesh nodes coincide at (u,v) = ({0}, {1})")]
    Duplicate(f64, f64),
    #[error(
        "constraint segments cross near (u,v) = ({0}, {1}) (boundary or embedded edges intersect)"
    )]
    Crossing(f64, f64),
    #[error("a coordinate is not finite or too large for the triangulation: {0}")]
    Insertion(String),
}

/// Constrained Delaunay triangulation of `uv` with the constraint segments
/// `segments` (indices into `uv`).
///
/// `boundary` lists the directed boundary segments with the region on their
/// left (they must also be in `segments`). Triangles are classified
/// *topologically*: a triangle holding a boundary segment in its
/// counter-clockwise order is inside, one holding it reversed is outside,
/// and the classification floods across every edge that is not a boundary
/// segment. No geometric in/out test is involved, so slivers between nearly
/// collinear boundary nodes are classified exactly. `keep` decides only for
/// a part that touches no boundary segment (which a valid face does not
/// have). Returns counter-clockwise triangles of indices into `uv`.
pub fn triangulate(
    uv: &[[f64; 2]],
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
    keep: impl Fn([f64; 2]) -> bool,
) -> Result<Vec<[usize; 3]>, ConnectError> {
    let pts: Vec<Point2<f64>> = uv.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let mut conflict = None;
    let cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::try_bulk_load_cdt(
        pts,
        segments.to_vec(),
        |e| {
            conflict.get_or_insert(e);
        },
    )
    .map_err(|e| ConnectError::Insertion(format!("{e:?}")))?;
    if cdt.num_vertices() != uv.len() {
        // find one duplicate to name it
        let mut sorted: Vec<usize> = (0..uv.len()).collect();
        sorted.sort_by(|&a, &b| {
            uv[a][0]
                .total_cmp(&uv[b][0])
                .then(uv[a][1].total_cmp(&uv[b][1]))
        });
        let dup = sorted
            .windows(2)
            .find(|w| uv[w[0]] == uv[w[1]])
            .map(|w| uv[w[0]])
            .unwrap_or([f64::NAN, f64::NAN]);
        return Err(ConnectError::Duplicate(dup[0], dup[1]));
    }
    if let Some([a, _]) = conflict {
        return Err(ConnectError::Crossing(uv[a][0], uv[a][1]));
    }
    let bset: std::collections::HashSet<(usize, usize)> =
        boundary.iter().map(|s| (s[0], s[1])).collect();
    // most edges touch no boundary vertex: test a flag before hashing
    let mut on_b = vec![false; uv.len()];
    for s in boundary {
        on_b[s[0]] = true;
        on_b[s[1]] = true;
    }
    let is_seg = |a: usize, b: usize| on_b[a] && on_b[b] && bset.contains(&(a, b));
    let nf = cdt.num_all_faces();
    // per spade face index: vertices, neighbours across each edge, label
    let mut verts = vec![[usize::MAX; 3]; nf];
    let mut nbr = vec![[usize::MAX; 3]; nf];
    let mut label = vec![0i8; nf]; // 1 inside, -1 outside, 0 unknown
    let mut stack = Vec::new();
    for f in cdt.inner_faces() {
        let fi = f.fix().index();
        for (k, e) in f.adjacent_edges().iter().enumerate() {
            let (a, b) = (e.from().fix().index(), e.to().fix().index());
            verts[fi][k] = a;
            nbr[fi][k] = e
                .rev()
                .face()
                .as_inner()
                .map(|g| g.fix().index())
                .unwrap_or(usize::MAX);
            if is_seg(a, b) {
                label[fi] = 1;
            } else if label[fi] == 0 && is_seg(b, a) {
                label[fi] = -1;
            }
        }
        if label[fi] != 0 {
            stack.push(fi);
        }
    }
    while let Some(fi) = stack.pop() {
        for k in 0..3 {
            let g = nbr[fi][k];
            if g == usize::MAX || label[g] != 0 {
                continue;
            }
            let (a, b) = (verts[fi][k], verts[fi][(k + 1) % 3]);
            if is_seg(a, b) || is_seg(b, a) {
                continue;
            }
            label[g] = label[fi];
            stack.push(g);
        }
    }
    let mut tris = Vec::with_capacity(2 * uv.len());
    for f in cdt.inner_faces() {
        let fi = f.fix().index();
        let idx = verts[fi];
        let inside = match label[fi] {
            1 => true,
            -1 => false,
            _ => keep([
                (uv[idx[0]][0] + uv[idx[1]][0] + uv[idx[2]][0]) / 3.0,
                (uv[idx[0]][1] + uv[idx[1]][1] + uv[idx[2]][1]) / 3.0,
            ]),
        };
        if inside {
            tris.push(idx);
        }
    }
    Ok(tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Co-circular points (a regular octagon plus centre) are the classic
    /// degenerate in-circle case; the result must still be a valid
    /// triangulation covering the octagon.
    #[test]
    fn cocircular_points_triangulate() {
        let mut uv: Vec<[f64; 2]> = (0..8)
            .map(|k| {
                let a = k as f64 * std::f64::consts::FRAC_PI_4;
                [a.cos(), a.sin()]
            })
            .collect();
        uv.push([0.0, 0.0]);
        let t = triangulate(&uv, &[], &[], |_| true).unwrap();
        assert_eq!(t.len(), 8);
        let area: f64 = t
            .iter()
            .map(|t| {
                let (a, b, c) = (uv[t[0]], uv[t[1]], uv[t[2]]);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
            })
            .sum();
        assert!((area - 2.0 * 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn constraint_edge_is_kept_against_delaunay() {
        // the Delaunay edge would be 2-3; the constraint forces 0-1
        let uv = [[0.0, 0.0], [3.0, 0.0], [1.5, 0.2], [1.5, -0.2]];
        let t = triangulate(&uv, &[[0, 1]], &[], |_| true).unwrap();
        let has = t.iter().any(|t| {
            (0..3).any(|k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                (a, b) == (0, 1) || (a, b) == (1, 0)
            })
        });
        assert!(has);
    }

    #[test]
    fn duplicate_point_is_an_error() {
        let uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]];
        assert!(matches!(
            triangulate(&uv, &[], &[], |_| true),
            Err(ConnectError::Duplicate(..))
        ));
    }

    #[test]
    fn crossing_constraints_are_an_error() {
        let uv = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(matches!(
            triangulate(&uv, &[[0, 1], [2, 3]], &[], |_| true),
            Err(ConnectError::Crossing(..))
        ));
    }
}

#[cfg(test)]
mod classification {
    use super::*;

    /// A boundary node pushed a hair inward makes a sliver outside the
    /// region; the topological classification drops it where a centroid
    /// test in floating point may not.
    #[test]
    fn sliver_outside_a_nearly_straight_side_is_dropped() {
        let uv = [
            [0.0, 0.0],
            [0.5, 1e-17],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.5, 0.5],
        ];
        let b = [[0, 1], [1, 2], [2, 3], [3, 4], [4, 0]];
        let t = triangulate(&uv, &b, &b, |_| true).unwrap();
        let area: f64 = t
            .iter()
            .map(|t| {
                let (a, b, c) = (uv[t[0]], uv[t[1]], uv[t[2]]);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
            })
            .sum();
        assert!((area - 1.0).abs() < 1e-12, "area {area}");
        for tri in &t {
            let (a, b, c) = (uv[tri[0]], uv[tri[1]], uv[tri[2]]);
            let ar = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]));
            assert!(ar > 1e-6, "sliver kept: {tri:?}");
        }
    }

    #[test]
    fn hole_is_removed() {
        let uv = [
            [0.0, 0.0],
            [3.0, 0.0],
            [3.0, 3.0],
            [0.0, 3.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [2.0, 2.0],
            [2.0, 1.0], // hole, clockwise
        ];
        let b = [
            [0, 1],
            [1, 2],
            [2, 3],
            [3, 0],
            [4, 5],
            [5, 6],
            [6, 7],
            [7, 4],
        ];
        let t = triangulate(&uv, &b, &b, |_| true).unwrap();
        let area: f64 = t
            .iter()
            .map(|t| {
                let (a, b, c) = (uv[t[0]], uv[t[1]], uv[t[2]]);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
            })
            .sum();
        assert!((area - 8.0).abs() < 1e-12, "area {area}");
    }
}
