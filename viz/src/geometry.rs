//! Per-element measures and the faces a picture draws.
//!
//! The measures are [`bubblemesh_core::measure`]'s: triangle radius ratio
//! q = 2 r_in / r_circ, tetrahedron radius ratio q = 3 r_in / r_circ, both
//! clipped to [0, 1] with 0 when undefined; angles in degrees.

use bubblemesh_core::mesh::Mesh;
use bubblemesh_core::spacing::{Spacing, SpacingQuery};
use bubblemesh_core::{P3, V3};

/// Radius ratio q = 2 r_in / r_circ of a triangle (1: equilateral).
pub fn triangle_q(a: &P3, b: &P3, c: &P3) -> f64 {
    bubblemesh_core::measure::triangle_radius_ratio(a, b, c)
}

/// The three angles of a triangle, degrees (the third as 180° minus the
/// other two, as `quality` does).
pub fn triangle_angles(a: &P3, b: &P3, c: &P3) -> [f64; 3] {
    let ang = |u: &V3, v: &V3| u.cross(v).norm().atan2(u.dot(v)).to_degrees();
    let (ab, bc, ca) = (b - a, c - b, a - c);
    let at_a = ang(&ab, &(-ca));
    let at_b = ang(&bc, &(-ab));
    [at_a, at_b, 180.0 - at_a - at_b]
}

/// Radius ratio q = 3 r_in / r_circ of a tetrahedron (1: regular), of
/// either orientation, clipped to [0, 1] (0 when flat).
pub fn tet_radius_ratio(p: &[P3; 4]) -> f64 {
    use bubblemesh_core::measure::{clip01, tet_radius_ratio};
    clip01(tet_radius_ratio(&p[0], &p[1], &p[2], &p[3]).abs())
}

/// A face a picture draws: three node ids and the element it belongs to.
#[derive(Clone, Copy, Debug)]
pub struct DrawFace {
    /// The face's three corners, as indices into `mesh.nodes`.
    pub nodes: [u32; 3],
    /// Index into `mesh.triangles`, or into `mesh.tetrahedra` when the mesh
    /// is drawn through its tetrahedra.
    pub element: u32,
}

/// The faces that picture a mesh: its triangles if it has any, else the
/// boundary faces of its tetrahedra (faces in exactly one tetrahedron, each
/// with its tetrahedron). Empty for a mesh with neither.
pub fn draw_faces(mesh: &Mesh) -> Vec<DrawFace> {
    if !mesh.triangles.is_empty() {
        return mesh
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| DrawFace {
                nodes: t.nodes,
                element: i as u32,
            })
            .collect();
    }
    boundary_faces(mesh.tetrahedra.iter().map(|t| t.nodes).enumerate())
}

/// Faces that occur in exactly one of the given tetrahedra
/// ([`bubblemesh_core::measure::boundary_faces`]), each with the position
/// of its tetrahedron in the sequence.
pub fn boundary_faces(tets: impl Iterator<Item = (usize, [u32; 4])>) -> Vec<DrawFace> {
    use bubblemesh_core::measure::TET_FACES;
    let nodes_of: Vec<[u32; 4]> = tets.map(|(_, nodes)| nodes).collect();
    bubblemesh_core::measure::boundary_faces(nodes_of.iter().copied())
        .into_iter()
        .map(|(k, f)| DrawFace {
            nodes: TET_FACES[f as usize].map(|i| nodes_of[k as usize][i]),
            element: k,
        })
        .collect()
}

/// Per-element and per-edge measures of a mesh, for histograms.
#[derive(Clone, Debug, Default)]
pub struct Measures {
    /// Radius ratio of every triangle (or tetrahedron, for a volume mesh).
    pub q: Vec<f64>,
    /// Whether `q` is about tetrahedra.
    pub tets: bool,
    /// Every angle of every triangle, degrees.
    pub angles: Vec<f64>,
    /// L / d(midpoint) for every unique edge of the analysed elements (empty
    /// without a spacing).
    pub length_ratio: Vec<f64>,
}

impl Measures {
    /// Measures `mesh`; with a spacing, also the edge-length ratios L/d, with
    /// d queried at the edge midpoint on the entity of an element using the
    /// edge (as `quality::analyse` does).
    pub fn of(mesh: &Mesh, spacing: Option<&dyn Spacing>) -> Measures {
        let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
        let mut m = Measures::default();
        for t in &mesh.triangles {
            let [a, b, c] = t.nodes.map(|i| pos[i as usize]);
            m.angles.extend(triangle_angles(&a, &b, &c));
        }
        let mut edges: Vec<(u32, u32, usize)> = Vec::new();
        if mesh.tetrahedra.is_empty() {
            m.q = mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.nodes.map(|i| pos[i as usize]);
                    triangle_q(&a, &b, &c)
                })
                .collect();
            for (e, t) in mesh.triangles.iter().enumerate() {
                for (i, j) in [(0, 1), (1, 2), (2, 0)] {
                    let (a, b) = (t.nodes[i], t.nodes[j]);
                    edges.push((a.min(b), a.max(b), e));
                }
            }
        } else {
            m.tets = true;
            m.q = mesh
                .tetrahedra
                .iter()
                .map(|t| tet_radius_ratio(&t.nodes.map(|i| pos[i as usize])))
                .collect();
            for (e, t) in mesh.tetrahedra.iter().enumerate() {
                for i in 0..4 {
                    for j in i + 1..4 {
                        let (a, b) = (t.nodes[i], t.nodes[j]);
                        edges.push((a.min(b), a.max(b), e));
                    }
                }
            }
        }
        if let Some(s) = spacing {
            edges.sort_unstable();
            edges.dedup_by(|x, y| x.0 == y.0 && x.1 == y.1);
            m.length_ratio = edges
                .iter()
                .map(|&(a, b, e)| {
                    let entity = if m.tets {
                        mesh.tetrahedra[e].entity
                    } else {
                        mesh.triangles[e].entity
                    };
                    let (pa, pb) = (pos[a as usize], pos[b as usize]);
                    let d = s.spacing(&SpacingQuery {
                        point: nalgebra::center(&pa, &pb),
                        entity,
                        params: [0.0, 0.0],
                    });
                    (pb - pa).norm() / d
                })
                .collect();
        }
        m
    }
}

/// The spacing d at every node of `mesh` (the bubble diameters), queried on
/// the node's entity with its parameters.
pub fn node_spacing(mesh: &Mesh, spacing: &dyn Spacing) -> Vec<f64> {
    mesh.nodes
        .iter()
        .map(|n| {
            spacing.spacing(&SpacingQuery {
                point: n.pos,
                entity: n.entity,
                params: n.params,
            })
        })
        .collect()
}

/// An estimate of the spacing at every node when none is known: the mean
/// length of the mesh edges at the node (0 for a node on no edge).
pub fn node_spacing_from_edges(mesh: &Mesh) -> Vec<f64> {
    let n = mesh.nodes.len();
    let mut sum = vec![0.0; n];
    let mut count = vec![0usize; n];
    let mut add = |a: u32, b: u32| {
        let l = (mesh.nodes[a as usize].pos - mesh.nodes[b as usize].pos).norm();
        for v in [a, b] {
            sum[v as usize] += l;
            count[v as usize] += 1;
        }
    };
    // each interior edge is seen twice; the mean is unaffected
    for t in &mesh.triangles {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            add(t.nodes[i], t.nodes[j]);
        }
    }
    for t in &mesh.tetrahedra {
        for i in 0..4 {
            for j in i + 1..4 {
                add(t.nodes[i], t.nodes[j]);
            }
        }
    }
    for l in &mesh.lines {
        add(l.nodes[0], l.nodes[1]);
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &c)| if c == 0 { 0.0 } else { s / c as f64 })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equilateral_and_regular_shapes_score_one() {
        let a = P3::new(0.0, 0.0, 0.0);
        let b = P3::new(1.0, 0.0, 0.0);
        let c = P3::new(0.5, 3f64.sqrt() / 2.0, 0.0);
        assert!((triangle_q(&a, &b, &c) - 1.0).abs() < 1e-12);
        for x in triangle_angles(&a, &b, &c) {
            assert!((x - 60.0).abs() < 1e-9);
        }
        let s = 1.0 / 2f64.sqrt();
        let t = [
            P3::new(1.0, 0.0, -s),
            P3::new(-1.0, 0.0, -s),
            P3::new(0.0, 1.0, s),
            P3::new(0.0, -1.0, s),
        ];
        assert!((tet_radius_ratio(&t) - 1.0).abs() < 1e-12);
        // degenerate: zero
        assert_eq!(triangle_q(&a, &b, &P3::new(2.0, 0.0, 0.0)), 0.0);
    }
}
