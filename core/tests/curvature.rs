//! Curvature-based spacing keeps the mesh within the tolerance of the true
//! surface (thesis §4.6, eq. 4.6.1), measured by sampling every triangle.

mod common;

use std::sync::Arc;

use bubblemesh_core::curvature::Curvature;
use bubblemesh_core::{mesh_model, Options};

/// Distance from a point to the torus R = 1, r = 0.3 about z.
fn torus_distance(p: &bubblemesh_core::P3) -> f64 {
    let rho = p.x.hypot(p.y) - 1.0;
    (rho.hypot(p.z) - 0.3).abs()
}

#[test]
fn torus_mesh_stays_within_eps() {
    let model = Arc::new(common::closed_surface(Arc::new(common::Torus(1.0, 0.3))));
    let eps = 0.002;
    let s = Curvature::new(model.clone(), eps, 1e-4, 1.0);
    let (mesh, _) = mesh_model(&model, &s, &Options::default()).unwrap();
    let mut worst: f64 = 0.0;
    for t in &mesh.triangles {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos.coords);
        for (a, b) in [
            (1.0 / 3.0, 1.0 / 3.0),
            (0.5, 0.5),
            (0.5, 0.0),
            (0.0, 0.5),
            (0.25, 0.25),
            (0.6, 0.2),
            (0.2, 0.6),
        ] {
            let q = p[0] * (1.0 - a - b) + p[1] * a + p[2] * b;
            worst = worst.max(torus_distance(&bubblemesh_core::P3::from(q)));
        }
    }
    assert!(
        worst <= 1.1 * eps,
        "max distance {worst} > 1.1 eps = {}",
        1.1 * eps
    );
    assert!(
        worst >= 0.5 * eps,
        "max distance {worst}: the mesh is finer than it needs to be"
    );
}
