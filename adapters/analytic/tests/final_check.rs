//! The engine's last check (`bubblemesh_core::verify`): each test meshes a
//! real model, breaks the mesh in one way, and expects the check to name
//! the defect. A valid mesh passes.

use bubblemesh_analytic::parse_domain;
use bubblemesh_core::spacing::Constant;
use bubblemesh_core::verify::verify;
use bubblemesh_core::{mesh_model, Mesh, Model, Options};

const SQUARE: &str = r#"
format = "bubblemesh-domain 1"
[[face]]
outer = { polygon = [[0, 0], [1, 0], [1, 1], [0, 1]] }
"#;

const CUBE: &str = r#"
format = "bubblemesh-domain 1"
[[solid]]
name = "cube"
box = { min = [0, 0, 0], max = [1, 1, 1] }
"#;

fn meshed(text: &str, d: f64, dim: u8) -> (Model, Mesh) {
    let model = parse_domain(text, "test.toml").expect("domain");
    let opts = Options {
        dim: Some(dim),
        ..Default::default()
    };
    let (mesh, _) = mesh_model(&model, &Constant(d), &opts).expect("mesh");
    (model, mesh)
}

fn fails_with(model: &Model, mesh: &Mesh, dim: u8, words: &str) {
    match verify(model, mesh, dim) {
        Ok(()) => panic!("the broken mesh passed the check (expected: {words})"),
        Err(e) => assert!(
            e.to_string().contains(words),
            "expected a message with {words:?}, got: {e}"
        ),
    }
}

/// An interior triangle of the square (all three nodes inside the face).
fn interior_triangle(mesh: &Mesh) -> usize {
    mesh.triangles
        .iter()
        .position(|t| {
            t.nodes
                .iter()
                .all(|&n| mesh.nodes[n as usize].entity.dim == 2)
        })
        .expect("an interior triangle")
}

#[test]
fn valid_meshes_pass_the_final_check() {
    let (m, mesh) = meshed(SQUARE, 0.1, 2);
    verify(&m, &mesh, 2).unwrap();
    let (m, mesh) = meshed(CUBE, 0.25, 3);
    verify(&m, &mesh, 3).unwrap();
}

#[test]
fn a_missing_triangle_is_a_gap() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = interior_triangle(&mesh);
    mesh.triangles.remove(t);
    fails_with(&m, &mesh, 2, "has a gap");
}

#[test]
fn a_missing_boundary_triangle_leaves_a_segment_uncovered() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = mesh
        .triangles
        .iter()
        .position(|t| {
            t.nodes
                .iter()
                .filter(|&&n| mesh.nodes[n as usize].entity.dim < 2)
                .count()
                == 2
        })
        .expect("a triangle on the boundary");
    mesh.triangles.remove(t);
    // the boundary segment lies in no triangle (counted against the edge's
    // face uses) or an inner edge of the removed triangle in one only
    let e = verify(&m, &mesh, 2).expect_err("a hole passed");
    let s = e.to_string();
    assert!(s.contains("has a gap") || s.contains("lies in"), "{s}");
}

#[test]
fn a_reversed_triangle_is_inconsistently_oriented() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = interior_triangle(&mesh);
    mesh.triangles[t].nodes.swap(1, 2);
    fails_with(&m, &mesh, 2, "not consistently oriented");
}

#[test]
fn a_duplicated_triangle_makes_a_non_manifold_edge() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = interior_triangle(&mesh);
    let copy = mesh.triangles[t];
    mesh.triangles.push(copy);
    fails_with(&m, &mesh, 2, "lies in 3 triangles");
}

#[test]
fn a_zero_area_triangle_is_refused() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = interior_triangle(&mesh);
    // move one node onto the midpoint of the opposite side
    let [a, b, c] = mesh.triangles[t].nodes;
    let (pb, pc) = (mesh.nodes[b as usize].pos, mesh.nodes[c as usize].pos);
    mesh.nodes[a as usize].pos = bubblemesh_core::P3::from((pb.coords + pc.coords) * 0.5);
    fails_with(&m, &mesh, 2, "zero area");
}

#[test]
fn coinciding_nodes_are_refused() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = interior_triangle(&mesh);
    let [a, b, _] = mesh.triangles[t].nodes;
    mesh.nodes[a as usize].pos = mesh.nodes[b as usize].pos;
    fails_with(&m, &mesh, 2, "coincide");
}

#[test]
fn a_face_without_triangles_is_refused() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    mesh.triangles.clear();
    fails_with(&m, &mesh, 2, "has no triangles");
}

#[test]
fn an_inverted_tetrahedron_is_refused() {
    let (m, mut mesh) = meshed(CUBE, 0.25, 3);
    mesh.tetrahedra[0].nodes.swap(0, 1);
    fails_with(&m, &mesh, 3, "inverted or flat");
}

#[test]
fn a_missing_tetrahedron_opens_the_volume() {
    let (m, mut mesh) = meshed(CUBE, 0.25, 3);
    // a tetrahedron with no face on the boundary: its removal leaves
    // tetrahedron faces on none of the volume's faces
    let on_boundary: std::collections::HashSet<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| {
            let mut k = t.nodes;
            k.sort_unstable();
            k
        })
        .collect();
    let inner = mesh
        .tetrahedra
        .iter()
        .position(|t| {
            let n = t.nodes;
            [
                [n[1], n[2], n[3]],
                [n[0], n[2], n[3]],
                [n[0], n[1], n[3]],
                [n[0], n[1], n[2]],
            ]
            .iter()
            .all(|f| {
                let mut k = *f;
                k.sort_unstable();
                !on_boundary.contains(&k)
            })
        })
        .expect("an inner tetrahedron");
    mesh.tetrahedra.remove(inner);
    fails_with(&m, &mesh, 3, "boundary face that is on none of its faces");
}

#[test]
fn a_volume_without_tetrahedra_is_refused() {
    let (m, mut mesh) = meshed(CUBE, 0.25, 3);
    mesh.tetrahedra.clear();
    fails_with(&m, &mesh, 3, "has no tetrahedra");
}

/// Two faces with a gap each: the error names the first and lists the
/// second in `also`, so that the engine refines both in one round instead
/// of one face per round (as_0053_grabcad_part19.stp took twelve rounds).
#[test]
fn every_refinable_face_defect_is_named_in_one_error() {
    const TWO_SQUARES: &str = r#"
format = "bubblemesh-domain 1"
[[face]]
outer = { polygon = [[0, 0], [1, 0], [1, 1], [0, 1]] }
[[face]]
outer = { polygon = [[2, 0], [3, 0], [3, 1], [2, 1]] }
"#;
    let (m, mut mesh) = meshed(TWO_SQUARES, 0.1, 2);
    for face in [0, 1] {
        let t = mesh
            .triangles
            .iter()
            .position(|t| {
                t.entity.id == face
                    && t.nodes
                        .iter()
                        .all(|&n| mesh.nodes[n as usize].entity.dim == 2)
            })
            .expect("an interior triangle");
        mesh.triangles.remove(t);
    }
    let e = verify(&m, &mesh, 2).expect_err("two gaps");
    assert!(e.to_string().contains("has a gap"), "{e}");
    assert!(e.refinable);
    let mut faces: Vec<u32> = std::iter::once(e.entity)
        .chain(e.also.iter().copied())
        .filter(|x| x.dim == 2)
        .map(|x| x.id)
        .collect();
    faces.sort_unstable();
    faces.dedup();
    assert_eq!(faces, vec![0, 1], "{e:?}");
}

/// A vertex the face contains (a `VERTEX_LOOP`'s, a pole's) must be a
/// corner of the face's triangles: a face meshed as the wrong side of its
/// loops, or capped flat across its pole, leaves it out (the independent
/// checker then finds an unreferenced node).
#[test]
fn an_embedded_vertex_left_out_of_its_face_is_refused() {
    let (mut m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = interior_triangle(&mesh);
    let [a, b, c] = mesh.triangles[t].nodes.map(|n| mesh.nodes[n as usize].pos);
    let centre = bubblemesh_core::P3::from((a.coords + b.coords + c.coords) / 3.0);
    m.vertices.push(bubblemesh_core::model::Vertex {
        point: centre,
        name: Some("inside".into()),
    });
    let v = (m.vertices.len() - 1) as u32;
    m.faces[0].embedded_vertices.push(v);
    mesh.nodes.push(bubblemesh_core::mesh::Node {
        pos: centre,
        entity: bubblemesh_core::model::EntityRef::new(0, v),
        params: [0.0, 0.0],
    });
    fails_with(&m, &mesh, 2, "is no corner of any triangle of face 0");
}

/// A node of a face's own that no triangle of the face uses.
#[test]
fn a_face_node_in_no_triangle_is_refused() {
    let (m, mut mesh) = meshed(SQUARE, 0.1, 2);
    let t = interior_triangle(&mesh);
    let [a, b, c] = mesh.triangles[t].nodes.map(|n| mesh.nodes[n as usize].pos);
    mesh.nodes.push(bubblemesh_core::mesh::Node {
        pos: bubblemesh_core::P3::from((a.coords + b.coords + c.coords) / 3.0),
        entity: bubblemesh_core::model::EntityRef::new(2, 0),
        params: [0.0, 0.0],
    });
    fails_with(&m, &mesh, 2, "is no corner of any of its triangles");
}

/// A node of a volume's own that no tetrahedron uses.
#[test]
fn a_volume_node_in_no_tetrahedron_is_refused() {
    let (m, mut mesh) = meshed(CUBE, 0.25, 3);
    mesh.nodes.push(bubblemesh_core::mesh::Node {
        pos: bubblemesh_core::P3::new(0.5, 0.5, 0.5001),
        entity: bubblemesh_core::model::EntityRef::new(3, 0),
        params: [0.0, 0.0],
    });
    fails_with(&m, &mesh, 3, "is no corner of any of its tetrahedra");
}

/// Adds a model vertex at `p` on no edge and in no face (a free vertex of
/// the file), with its node, as the engine makes one per vertex.
fn add_free_vertex(m: &mut Model, mesh: &mut Mesh, p: bubblemesh_core::P3) {
    m.vertices.push(bubblemesh_core::model::Vertex {
        point: p,
        name: Some("free".into()),
    });
    mesh.nodes.push(bubblemesh_core::mesh::Node {
        pos: p,
        entity: bubblemesh_core::model::EntityRef::new(0, (m.vertices.len() - 1) as u32),
        params: [0.0, 0.0],
    });
}

/// The node of a model vertex on no edge and in no face is in no element:
/// the independent checker calls it unreferenced, so the check refuses the
/// mesh, a surface mesh or a solid one.
#[test]
fn a_node_in_no_element_is_refused() {
    let (mut m, mut mesh) = meshed(SQUARE, 0.1, 2);
    add_free_vertex(&mut m, &mut mesh, bubblemesh_core::P3::new(3.0, 3.0, 0.0));
    fails_with(&m, &mesh, 2, "is in no element");
    let (mut m, mut mesh) = meshed(CUBE, 0.25, 3);
    add_free_vertex(&mut m, &mut mesh, bubblemesh_core::P3::new(3.0, 3.0, 3.0));
    fails_with(&m, &mesh, 3, "is in no element");
}
