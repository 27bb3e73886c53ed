//! B-reps built with truck-modeling's builder mesh into closed surfaces
//! enclosing their exact volume (less the chord error, a fraction of a
//! percent at these sizes).

use std::collections::HashMap;

use bubblemesh_core::spacing::Constant;
use bubblemesh_core::{mesh_model, Mesh, Options};
use bubblemesh_truck::from_truck_solid;
use truck_modeling::*;

/// (closed: every edge shared by two triangles, signed enclosed volume,
/// number of faces with triangles).
fn closed_volume_faces(mesh: &Mesh) -> (bool, f64, usize) {
    let mut count: HashMap<(u32, u32), i32> = HashMap::new();
    let mut vol = 0.0;
    let mut faces = std::collections::HashSet::new();
    for t in &mesh.triangles {
        let [a, b, c] = t.nodes;
        for (u, v) in [(a, b), (b, c), (c, a)] {
            *count.entry((u.min(v), u.max(v))).or_default() += 1;
        }
        let p = |i: u32| mesh.nodes[i as usize].pos.coords;
        vol += p(a).dot(&p(b).cross(&p(c))) / 6.0;
        faces.insert(t.entity);
    }
    (count.values().all(|&c| c == 2), vol, faces.len())
}

fn mesh_solid(solid: &Solid, size: f64, exact: f64) {
    let model = from_truck_solid(solid).unwrap();
    let n_faces = solid.face_iter().count();
    assert_eq!(model.faces.len(), n_faces);
    let opts = Options {
        dim: Some(2),
        ..Default::default()
    };
    let (mesh, _) = mesh_model(&model, &Constant(size), &opts).unwrap();
    let (closed, vol, with_tris) = closed_volume_faces(&mesh);
    eprintln!(
        "{} triangles, volume {vol:.5} vs exact {exact:.5} ({:+.3} %)",
        mesh.triangles.len(),
        100.0 * (vol / exact - 1.0)
    );
    assert!(closed, "not closed");
    assert_eq!(with_tris, n_faces, "a face has no triangles");
    assert!(
        vol > 0.0 && (vol / exact - 1.0).abs() < 0.01,
        "volume {vol} vs exact {exact}"
    );
}

/// A 4 × 4 × 2 box with a through hole of radius 1: planes, a hole made of
/// NURBS circle arcs swept into rational B-spline faces.
#[test]
fn box_with_cylindrical_hole_meshes_closed_with_its_volume() {
    let v = |x: f64, y: f64| builder::vertex(Point3::new(x, y, 0.0));
    let (a, b, c, d) = (v(0.0, 0.0), v(4.0, 0.0), v(4.0, 4.0), v(0.0, 4.0));
    let outer: Wire = vec![
        builder::line(&a, &b),
        builder::line(&b, &c),
        builder::line(&c, &d),
        builder::line(&d, &a),
    ]
    .into();
    let p = builder::vertex(Point3::new(3.0, 2.0, 0.0));
    let circle: Wire = builder::rsweep(&p, Point3::new(2.0, 2.0, 0.0), Vector3::unit_z(), Rad(7.0));
    let face = builder::try_attach_plane(&[outer, circle.inverse()]).unwrap();
    let solid: Solid = builder::tsweep(&face, Vector3::new(0.0, 0.0, 2.0));
    mesh_solid(&solid, 0.25, 32.0 - 2.0 * std::f64::consts::PI);
}

/// A rectangle x ∈ [1, 2], z ∈ [0, 1] revolved about z: a ring of volume
/// 3π bounded by truck's revolved surfaces (cylinders and flat annuli as
/// revolutions of lines).
#[test]
fn revolved_ring_meshes_closed_with_its_volume() {
    let v = |x: f64, z: f64| builder::vertex(Point3::new(x, 0.0, z));
    let (a, b, c, d) = (v(1.0, 0.0), v(2.0, 0.0), v(2.0, 1.0), v(1.0, 1.0));
    let wire: Wire = vec![
        builder::line(&a, &b),
        builder::line(&b, &c),
        builder::line(&c, &d),
        builder::line(&d, &a),
    ]
    .into();
    let face = builder::try_attach_plane(&[wire]).unwrap();
    let solid: Solid = builder::rsweep(&face, Point3::origin(), Vector3::unit_z(), Rad(7.0));
    mesh_solid(&solid, 0.15, 3.0 * std::f64::consts::PI);
}
