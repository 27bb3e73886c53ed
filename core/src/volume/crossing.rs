//! Where a volume's surface mesh passes through itself: two of its
//! triangles with no corner in common, one's side through the other's
//! inside (exact `orient3d`).
//!
//! No tetrahedralization has such a boundary, whatever its interior
//! nodes, so when the connection misses boundary triangles this says why:
//! two faces' meshes that cross (the chords of two curved faces closer
//! than their sag, cured by a finer mesh) or CAD faces that cross each
//! other (an invalid solid, which no size cures). Asked only then: a
//! volume that connects has no crossing (its positive tetrahedra's
//! boundary is the surface mesh). A surface mesh (`--dim 2`) is asked
//! too, once, for the warning of [`self_crossing`].

use std::collections::{HashMap, HashSet};

use crate::geom::P3;
use crate::measure::orient3d;
use crate::mesh::Mesh;
use crate::model::{EntityRef, Model};
use crate::verify::SelfCrossing;

/// The first pair (in triangle order) of `tris` (corners in `pos`) of
/// which one's side passes through the other's inside, and a point of
/// that crossing; `None` where no two cross. Triangles that share a corner
/// are not compared. Buckets of the triangles' boxes on a grid of the
/// median side: O(n) for a mesh of even size.
pub(crate) fn first_crossing(pos: &[P3], tris: &[[u32; 3]]) -> Option<(usize, usize, P3)> {
    if tris.len() < 2 {
        return None;
    }
    let corners = |t: &[u32; 3]| t.map(|k| pos[k as usize]);
    let mut sides: Vec<f64> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = corners(t);
            (b - a).norm().max((c - b).norm()).max((a - c).norm())
        })
        .collect();
    let mid = sides.len() / 2;
    let h = *sides.select_nth_unstable_by(mid, f64::total_cmp).1;
    if !(h > 0.0 && h.is_finite()) {
        return None;
    }
    let boxes: Vec<([i64; 3], [i64; 3])> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = corners(t);
            let cell =
                |f: fn(f64, f64) -> f64, k: usize| (f(f(a[k], b[k]), c[k]) / h).floor() as i64;
            (
                [0, 1, 2].map(|k| cell(f64::min, k)),
                [0, 1, 2].map(|k| cell(f64::max, k)),
            )
        })
        .collect();
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (i, (lo, hi)) in boxes.iter().enumerate() {
        // a sliver of a box across a huge part is not worth its cells
        if (0..3).map(|k| hi[k] - lo[k] + 1).product::<i64>() > 4096 {
            continue;
        }
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    grid.entry([x, y, z]).or_default().push(i as u32);
                }
            }
        }
    }
    let mut seen: HashSet<(u32, u32)> = HashSet::new();
    let mut found: Option<(usize, usize, P3)> = None;
    for cell in grid.values() {
        for (n, &i) in cell.iter().enumerate() {
            for &j in &cell[n + 1..] {
                let (i, j) = (i.min(j), i.max(j));
                if found.is_some_and(|f| (f.0, f.1) <= (i as usize, j as usize))
                    || !seen.insert((i, j))
                {
                    continue;
                }
                let (ti, tj) = (&tris[i as usize], &tris[j as usize]);
                if ti.iter().any(|k| tj.contains(k)) {
                    continue;
                }
                if let Some(p) =
                    cross(&corners(ti), &corners(tj)).or_else(|| cross(&corners(tj), &corners(ti)))
                {
                    found = Some((i as usize, j as usize, p));
                }
            }
        }
    }
    found
}

/// Where a side of triangle `s` passes through the inside of triangle
/// `t` (strictly: both ends strictly on either side of t's plane, the
/// side strictly inside t's three edges), if one does.
fn cross(s: &[P3; 3], t: &[P3; 3]) -> Option<P3> {
    let [a, b, c] = t;
    (0..3).find_map(|k| {
        let (p, q) = (&s[k], &s[(k + 1) % 3]);
        let (op, oq) = (orient3d(a, b, c, p), orient3d(a, b, c, q));
        if !(op * oq < 0.0) {
            return None;
        }
        let e = [
            orient3d(p, q, a, b),
            orient3d(p, q, b, c),
            orient3d(p, q, c, a),
        ];
        if !(e.iter().all(|&v| v > 0.0) || e.iter().all(|&v| v < 0.0)) {
            return None;
        }
        Some(p + (q - p) * (op / (op - oq)))
    })
}

/// The first volume of `model` whose faces' triangles in `mesh` cross
/// ([`SelfCrossing`], by [`first_crossing`]);
/// `None` when none does. Each volume's faces are compared among
/// themselves only: separate solids that touch or overlap are not a
/// crossing.
pub(crate) fn self_crossing(model: &Model, mesh: &Mesh) -> Option<SelfCrossing> {
    let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
    // each face's triangles, gathered once for every volume it bounds
    let mut of_face: HashMap<u32, Vec<[u32; 3]>> = HashMap::new();
    for t in mesh.triangles.iter().filter(|t| t.entity.dim == 2) {
        of_face.entry(t.entity.id).or_default().push(t.nodes);
    }
    for (vi, v) in model.volumes.iter().enumerate() {
        let (mut tris, mut owner) = (Vec::new(), Vec::new());
        for &f in &v.faces {
            let mine = of_face.get(&f).map_or(&[][..], |t| t.as_slice());
            tris.extend_from_slice(mine);
            owner.resize(owner.len() + mine.len(), f);
        }
        if let Some((i, j, p)) = first_crossing(&pos, &tris) {
            let face = |k: usize| model.describe(EntityRef::new(2, owner[k]));
            return Some(SelfCrossing {
                volume: model.describe(EntityRef::new(3, vi as u32)),
                faces: [face(i), face(j)],
                at: [p.x, p.y, p.z],
            });
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit squares' triangles (each square two triangles), the second
    /// standing on the first's middle when `through`, else above it.
    fn squares(through: bool) -> (Vec<P3>, Vec<[u32; 3]>) {
        let z0 = if through { -0.5 } else { 0.1 };
        let pos = vec![
            P3::new(0.0, 0.0, 0.0),
            P3::new(1.0, 0.0, 0.0),
            P3::new(1.0, 1.0, 0.0),
            P3::new(0.0, 1.0, 0.0),
            P3::new(0.2, 0.5, z0),
            P3::new(0.8, 0.5, z0),
            P3::new(0.8, 0.5, z0 + 1.0),
            P3::new(0.2, 0.5, z0 + 1.0),
        ];
        (pos, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    }

    #[test]
    fn a_triangle_through_another_is_found_where_it_crosses() {
        let (pos, tris) = squares(true);
        let (i, j, p) = first_crossing(&pos, &tris).unwrap();
        assert!(i < 2 && j >= 2, "{i} {j}");
        assert!(p.z.abs() < 1e-12 && (p.y - 0.5).abs() < 1e-12, "{p:?}");
    }

    #[test]
    fn triangles_apart_or_sharing_a_corner_do_not_cross() {
        let (pos, tris) = squares(false);
        assert!(first_crossing(&pos, &tris).is_none());
        // a closed box's triangles touch only along shared sides and corners
        let (pos, tris) = crate::volume::shell::tests::cube();
        assert!(first_crossing(&pos, &tris).is_none());
    }
}
