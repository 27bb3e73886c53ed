//! The one definition of each element measure in the workspace: radius
//! ratios, dihedral extremes, circumcentres, the tetrahedron face table,
//! the boundary faces of a set of tetrahedra and the index check a mesh
//! passes before it is written or drawn.
//!
//! Why one module: the meshing passes decide with these numbers and the
//! quality report, the writers and the pictures show them; with copies, a
//! change to one copy made the report disagree with the decisions. Where
//! the copies differed in the order of their floating-point operations,
//! the arithmetic kept is the one the meshing passes decided with, so
//! meshes stay bit-identical.
//!
//! Conventions: points are in model units; angles in degrees; a
//! tetrahedron [a, b, c, d] is *positive* when det(b−a, c−a, d−a) > 0.

use crate::geom::{P3, V3};
use crate::mesh::{Element, Mesh};

/// The faces of a tetrahedron [a, b, c, d]: face k is opposite corner k,
/// ordered so that a positive tetrahedron sees each face's normal (right
/// hand) pointing out. `[t[k], FACES[k]...]` is an even permutation of t.
///
/// The viewer's JavaScript keeps its own copy (`viz/src/html.rs`, `TF`); a
/// test there checks that it equals this one.
pub const TET_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// A triangle's corners in ascending order: the key of a face whichever
/// way round its tetrahedra or triangles name it.
pub(crate) fn sorted3(mut t: [u32; 3]) -> [u32; 3] {
    t.sort_unstable();
    t
}

/// The four corners of a tetrahedron in increasing order (a key that
/// does not depend on their order in the element).
pub(crate) fn sorted4(mut t: [u32; 4]) -> [u32; 4] {
    t.sort_unstable();
    t
}

/// Six times the signed volume of tetrahedron [a, b, c, d]:
/// det(b−a, c−a, d−a), model units cubed; positive for a positive
/// tetrahedron. Floating point: use an exact predicate where the sign
/// decides.
pub fn tet_volume6(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
    (b - a).dot(&(c - a).cross(&(d - a)))
}

/// The exact sign of det(a−d, b−d, c−d) (Shewchuk's adaptive predicate):
/// positive when d lies below the plane of a, b, c (a, b, c counter-clockwise
/// seen from above), so `orient3d(a, b, c, d)` is negative for a positive
/// tetrahedron [a, b, c, d]; zero when the four points are coplanar.
pub fn orient3d(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
    robust::orient3d(c3(a), c3(b), c3(c), c3(d))
}

/// A point as the exact predicates of `robust` take it.
pub(crate) fn c3(p: &P3) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// Area of the triangle a, b, c (model units²), ½ |(b − a) × (c − a)|.
#[inline]
pub fn triangle_area(a: &P3, b: &P3, c: &P3) -> f64 {
    0.5 * (b - a).cross(&(c - a)).norm()
}

/// Radius ratio of a triangle, q = 2·r_in/r_circ
/// = (b+c−a)(c+a−b)(a+b−c)/(abc) for edge lengths a, b, c: 1 for an
/// equilateral triangle, 0 for a degenerate one,
/// clipped to [0, 1] with 0 when undefined (coincident corners).
/// Dimensionless; the same in any plane in 3D.
pub fn triangle_radius_ratio(a: &P3, b: &P3, c: &P3) -> f64 {
    radius_ratio_of_lengths((c - b).norm(), (a - c).norm(), (b - a).norm())
}

/// The mean and the least [`triangle_radius_ratio`] of triangles `tris`
/// (corner indices into `pos`); (0, +∞) for none.
pub fn mean_and_least_radius_ratio(pos: &[P3], tris: &[[usize; 3]]) -> (f64, f64) {
    let (sum, least) = tris
        .iter()
        .map(|t| triangle_radius_ratio(&pos[t[0]], &pos[t[1]], &pos[t[2]]))
        .fold((0.0, f64::INFINITY), |(s, m), q| (s + q, m.min(q)));
    (sum / tris.len().max(1) as f64, least)
}

/// [`triangle_radius_ratio`] from the edge lengths: `la` opposite the
/// first corner, `lb` the second, `lc` the third.
#[inline]
pub fn radius_ratio_of_lengths(la: f64, lb: f64, lc: f64) -> f64 {
    clip01((lb + lc - la) * (lc + la - lb) * (la + lb - lc) / (la * lb * lc))
}

/// The angles (radians) of triangle (a, b, c) at a, b and c: the first two
/// by atan2 of the edges' cross and dot products (exact near 0 and π,
/// where the law of cosines loses digits), the third π minus them. The
/// quality report and the angle lift of the 2D improvement both read them
/// from here.
pub fn triangle_angles(a: &P3, b: &P3, c: &P3) -> [f64; 3] {
    let (ab, bc, ca) = (b - a, c - b, a - c);
    let ang = |u: &V3, v: &V3| u.cross(v).norm().atan2(u.dot(v));
    let at_a = ang(&ab, &(-ca));
    let at_b = ang(&bc, &(-ab));
    [at_a, at_b, std::f64::consts::PI - at_a - at_b]
}

/// The smallest of [`triangle_angles`] (radians).
pub fn triangle_min_angle(a: &P3, b: &P3, c: &P3) -> f64 {
    let [x, y, z] = triangle_angles(a, b, c);
    x.min(y).min(z)
}

/// The smallest angle (radians) of a triangle given by its side lengths
/// `la`, `lb`, `lc` (the one opposite the shortest side, by the law of
/// cosines): [`triangle_min_angle`] for a caller that has the lengths and
/// not the corners (the angle lift's trials, which measure each
/// neighbour's distance once).
pub fn min_angle_of_lengths(la: f64, lb: f64, lc: f64) -> f64 {
    let (a, b, c) = if la <= lb && la <= lc {
        (la, lb, lc)
    } else if lb <= lc {
        (lb, lc, la)
    } else {
        (lc, la, lb)
    };
    ((b * b + c * c - a * a) / (2.0 * b * c))
        .clamp(-1.0, 1.0)
        .acos()
}

/// Signed radius ratio of a tetrahedron, 3·r_in/r_circ: 1 for a regular
/// tetrahedron, 0 for a flat one, in (0, 1] for a positive tetrahedron and
/// its negative for an inverted one. Dimensionless.
///
/// With u, v, w the edges from a and V6 = u·(v×w): r_in = V6/(2A) (A the
/// surface area) and r_circ = |N|/(2·V6) with
/// N = |u|²(v×w) + |v|²(w×u) + |w|²(u×v), so 3·r_in/r_circ = 3·V6²/(A·|N|).
pub fn tet_radius_ratio(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
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

/// [`tet_radius_ratio`] of tetrahedron `t` (indices into `pos`).
pub fn tet_radius_ratio_of(pos: &[P3], t: &[u32; 4]) -> f64 {
    let [a, b, c, d] = t.map(|k| pos[k as usize]);
    tet_radius_ratio(&a, &b, &c, &d)
}

/// The smallest and largest dihedral angle of a tetrahedron, degrees, in
/// [0, 180]: the angle at the edge shared by faces i and j is
/// 180° − ∠(n_i, n_j) with outward face normals (60°–90° for the
/// tetrahedra of a BCC lattice, 70.53° for a regular one). Either
/// orientation gives the same angles. A face of zero area counts with a
/// zero normal (its angles 90°).
pub fn dihedral_extremes(a: &P3, b: &P3, c: &P3, d: &P3) -> (f64, f64) {
    let p = [a, b, c, d];
    // outward face normals; face k is opposite corner k
    let mut n = [V3::zeros(); 4];
    for (k, nk) in n.iter_mut().enumerate() {
        let f = TET_FACES[k].map(|i| p[i]);
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

/// The circumcentre of a tetrahedron (the centre of the sphere through its
/// corners, whose emptiness is the Delaunay criterion of the thesis's 3D
/// connection, §5.1.4), `None` when it is flat:
/// a + N/(2·V6) with N and V6 as in [`tet_radius_ratio`]. Model units.
pub fn tet_circumcentre(a: &P3, b: &P3, c: &P3, d: &P3) -> Option<P3> {
    let (u, v, w) = (b - a, c - a, d - a);
    let vol6 = u.dot(&v.cross(&w));
    if vol6 == 0.0 {
        return None;
    }
    let num = v.cross(&w) * u.norm_squared()
        + w.cross(&u) * v.norm_squared()
        + u.cross(&v) * w.norm_squared();
    Some(P3::from(a.coords + num / (2.0 * vol6)))
}

/// The circumcentre and circumradius of a triangle, in its plane (model
/// units); for a degenerate triangle, the centroid and the distance to the
/// farthest corner.
pub fn triangle_circumball(a: &P3, b: &P3, c: &P3) -> (P3, f64) {
    let (ab, ac) = (b - a, c - a);
    let n = ab.cross(&ac);
    let nn = n.norm_squared();
    if nn == 0.0 {
        let m = P3::from((a.coords + b.coords + c.coords) / 3.0);
        let r = (a - m).norm().max((b - m).norm()).max((c - m).norm());
        return (m, r);
    }
    let off = (n.cross(&ab) * ac.norm_squared() + ac.cross(&n) * ab.norm_squared()) / (2.0 * nn);
    (a + off, off.norm())
}

/// The faces that occur in exactly one of the tetrahedra `tets`, as
/// (index of the tetrahedron in `tets`, k) for face [`TET_FACES`]`[k]`,
/// in the order of their sorted node triples. Faces inside the set occur
/// twice (in a conforming set), so these bound it.
pub fn boundary_faces(tets: impl IntoIterator<Item = [u32; 4]>) -> Vec<(u32, u8)> {
    let mut faces: Vec<([u32; 3], u32, u8)> = Vec::new();
    for (t, nodes) in tets.into_iter().enumerate() {
        for (k, idx) in TET_FACES.iter().enumerate() {
            let mut key = idx.map(|i| nodes[i]);
            key.sort_unstable();
            faces.push((key, t as u32, k as u8));
        }
    }
    faces.sort_unstable();
    faces
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|run| run.len() == 1)
        .map(|run| (run[0].1, run[0].2))
        .collect()
}

/// What is wrong with a mesh's indices and numbers, found by
/// [`check_indices`].
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IndexError {
    /// More nodes than a 32-bit index reaches.
    #[error("{0} nodes exceed the 32-bit index range")]
    TooManyNodes(usize),
    /// A node coordinate is NaN or infinite.
    #[error("node {index} has a non-finite coordinate ({}, {}, {})", pos.x, pos.y, pos.z)]
    NonFinite {
        /// The node.
        index: usize,
        /// Its position.
        pos: P3,
    },
    /// A node, element or entity on an entity of dimension above 3.
    #[error("{what} is on an entity of dimension {dim}")]
    Dimension {
        /// "node 3", "triangle 7", …
        what: String,
        /// The dimension found.
        dim: u8,
    },
    /// An entity of the entity table of dimension above 3.
    #[error("entity {id} has dimension {dim}")]
    EntityDimension {
        /// The entity's id.
        id: u32,
        /// Its dimension.
        dim: u8,
    },
    /// An element names a node that does not exist.
    #[error("{kind} {index} refers to node {node} but there are {nodes} nodes")]
    NodeRange {
        /// "line", "triangle" or "tetrahedron".
        kind: &'static str,
        /// The element.
        index: usize,
        /// The node it names.
        node: u32,
        /// How many nodes there are.
        nodes: usize,
    },
}

/// Checks what every reader of a mesh relies on, in this order: at most
/// 2³² nodes; every node finite and on an entity of dimension ≤ 3; every
/// line, triangle and tetrahedron naming existing nodes and on an entity
/// of dimension ≤ 3; every entity of dimension ≤ 3. The first defect found
/// is returned.
pub fn check_indices(mesh: &Mesh) -> Result<(), IndexError> {
    let n = mesh.nodes.len();
    if n > u32::MAX as usize {
        return Err(IndexError::TooManyNodes(n));
    }
    for (i, node) in mesh.nodes.iter().enumerate() {
        if !node.pos.iter().all(|c| c.is_finite()) {
            return Err(IndexError::NonFinite {
                index: i,
                pos: node.pos,
            });
        }
        if node.entity.dim > 3 {
            return Err(IndexError::Dimension {
                what: format!("node {i}"),
                dim: node.entity.dim,
            });
        }
    }
    fn check<const N: usize>(
        kind: &'static str,
        elems: &[Element<N>],
        n: usize,
    ) -> Result<(), IndexError> {
        for (i, e) in elems.iter().enumerate() {
            if let Some(&v) = e.nodes.iter().find(|&&v| v as usize >= n) {
                return Err(IndexError::NodeRange {
                    kind,
                    index: i,
                    node: v,
                    nodes: n,
                });
            }
            if e.entity.dim > 3 {
                return Err(IndexError::Dimension {
                    what: format!("{kind} {i}"),
                    dim: e.entity.dim,
                });
            }
        }
        Ok(())
    }
    check("line", &mesh.lines, n)?;
    check("triangle", &mesh.triangles, n)?;
    check("tetrahedron", &mesh.tetrahedra, n)?;
    for e in &mesh.entities {
        if e.entity.dim > 3 {
            return Err(IndexError::EntityDimension {
                id: e.entity.id,
                dim: e.entity.dim,
            });
        }
    }
    Ok(())
}

/// The first node with a NaN or infinite coordinate, if any (what a
/// picture refuses; [`check_indices`] checks it too).
pub fn first_non_finite(mesh: &Mesh) -> Option<usize> {
    mesh.nodes
        .iter()
        .position(|p| !p.pos.iter().all(|c| c.is_finite()))
}

/// The first node index of an element (lines, then triangles, then
/// tetrahedra) that names no node, if any.
pub fn first_missing_node(mesh: &Mesh) -> Option<u32> {
    let n = mesh.nodes.len();
    let lines = mesh.lines.iter().flat_map(|e| e.nodes.iter());
    let tris = mesh.triangles.iter().flat_map(|e| e.nodes.iter());
    let tets = mesh.tetrahedra.iter().flat_map(|e| e.nodes.iter());
    lines
        .chain(tris)
        .chain(tets)
        .copied()
        .find(|&v| v as usize >= n)
}

/// Clips to [0, 1], mapping NaN to 0 (numpy: `nan_to_num(clip(x, 0, 1))`).
pub fn clip01(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn regular() -> [P3; 4] {
        [
            P3::new(1.0, 1.0, 1.0),
            P3::new(1.0, -1.0, -1.0),
            P3::new(-1.0, 1.0, -1.0),
            P3::new(-1.0, -1.0, 1.0),
        ]
    }

    fn moved(p: &[P3; 4], s: f64, off: V3) -> [P3; 4] {
        p.map(|x| P3::from(x.coords * s) + off)
    }

    #[test]
    fn regular_tetrahedron_and_equilateral_triangle_score_one() {
        let [a, b, c, d] = regular();
        // [a, b, c, d] as given is negative: its radius ratio is −1
        let q = tet_radius_ratio(&a, &b, &c, &d);
        assert!((q.abs() - 1.0).abs() < 1e-12, "{q}");
        let (lo, hi) = dihedral_extremes(&a, &b, &c, &d);
        let theta = (1.0f64 / 3.0).acos().to_degrees();
        assert!((lo - theta).abs() < 1e-9 && (hi - theta).abs() < 1e-9);
        assert!((triangle_radius_ratio(&a, &b, &c) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_shapes_score_zero() {
        let (a, b, c) = (
            P3::new(0., 0., 0.),
            P3::new(1., 0., 0.),
            P3::new(2., 0., 0.),
        );
        assert_eq!(triangle_radius_ratio(&a, &b, &c), 0.0);
        assert_eq!(triangle_radius_ratio(&a, &a, &c), 0.0);
        let d = P3::new(0.5, 1.0, 0.0);
        assert_eq!(tet_radius_ratio(&a, &b, &d, &P3::new(3.0, 2.0, 0.0)), 0.0);
        assert!(tet_circumcentre(&a, &b, &d, &P3::new(3.0, 2.0, 0.0)).is_none());
    }

    #[test]
    fn orientation_gives_the_sign() {
        let [a, b, c, d] = regular();
        let q = tet_radius_ratio(&a, &b, &c, &d);
        let swapped = tet_radius_ratio(&b, &a, &c, &d);
        assert!((q + swapped).abs() < 1e-12);
        assert!(q * swapped < 0.0);
        assert!(tet_volume6(&a, &b, &c, &d) * tet_volume6(&b, &a, &c, &d) < 0.0);
        assert_eq!(q.signum(), tet_volume6(&a, &b, &c, &d).signum());
        // the angles do not depend on the orientation
        let (lo, hi) = dihedral_extremes(&a, &b, &c, &d);
        let (lo2, hi2) = dihedral_extremes(&b, &a, &c, &d);
        assert!((lo - lo2).abs() < 1e-9 && (hi - hi2).abs() < 1e-9);
    }

    #[test]
    fn measures_do_not_depend_on_scale_or_place() {
        // an irregular tetrahedron, far from the origin and scaled
        let p = [
            P3::new(0.0, 0.0, 0.0),
            P3::new(1.0, 0.1, 0.0),
            P3::new(0.3, 0.9, 0.1),
            P3::new(0.2, 0.3, 0.7),
        ];
        let q0 = tet_radius_ratio(&p[0], &p[1], &p[2], &p[3]);
        let (lo0, hi0) = dihedral_extremes(&p[0], &p[1], &p[2], &p[3]);
        let t0 = triangle_radius_ratio(&p[0], &p[1], &p[2]);
        let c0 = tet_circumcentre(&p[0], &p[1], &p[2], &p[3]).unwrap();
        for (s, off) in [
            (1e-3, V3::zeros()),
            (1e3, V3::zeros()),
            (1.0, V3::repeat(1e6)),
            (0.01, V3::new(1e6, -1e6, 3e5)),
        ] {
            let m = moved(&p, s, off);
            let q = tet_radius_ratio(&m[0], &m[1], &m[2], &m[3]);
            assert!((q - q0).abs() < 1e-6, "{s} {off:?}: {q} vs {q0}");
            let (lo, hi) = dihedral_extremes(&m[0], &m[1], &m[2], &m[3]);
            assert!((lo - lo0).abs() < 1e-4 && (hi - hi0).abs() < 1e-4);
            let t = triangle_radius_ratio(&m[0], &m[1], &m[2]);
            assert!((t - t0).abs() < 1e-6);
            let c = tet_circumcentre(&m[0], &m[1], &m[2], &m[3]).unwrap();
            let want = P3::from(c0.coords * s) + off;
            assert!((c - want).norm() < 1e-6 * (1.0 + off.norm()) * s.max(1.0));
            // the circumcentre is equidistant from the corners
            let r: Vec<f64> = m.iter().map(|x| (x - c).norm()).collect();
            assert!(r
                .iter()
                .all(|x| (x - r[0]).abs() < 1e-6 * r[0] + 1e-9 * off.norm()));
        }
    }

    #[test]
    fn boundary_faces_of_two_tetrahedra() {
        // two tetrahedra sharing the face {1, 2, 3}: six boundary faces
        let tets = [[0, 1, 2, 3], [4, 1, 3, 2]];
        let b = boundary_faces(tets);
        assert_eq!(b.len(), 6);
        assert!(!b.contains(&(0, 0)) && !b.contains(&(1, 0)));
    }

    #[test]
    fn index_check_names_the_defect() {
        use crate::mesh::Node;
        use crate::model::EntityRef;
        let node = |x: f64| Node {
            pos: P3::new(x, 0.0, 0.0),
            entity: EntityRef::new(0, 0),
            params: [0.0; 2],
        };
        let mut m = Mesh {
            nodes: vec![node(0.0), node(1.0)],
            ..Default::default()
        };
        m.lines.push(Element {
            nodes: [0, 2],
            entity: EntityRef::new(1, 0),
        });
        assert_eq!(
            check_indices(&m).unwrap_err().to_string(),
            "line 0 refers to node 2 but there are 2 nodes"
        );
        m.nodes[1].pos.y = f64::NAN;
        assert_eq!(
            check_indices(&m).unwrap_err().to_string(),
            "node 1 has a non-finite coordinate (1, NaN, 0)"
        );
    }
}
