//! A face whose boundary touches itself — a hole tangent to the outer loop,
//! written with a vertex of its own at the touching point, as
//! as_gehause_rohteil.stp has — is refused before any meshing, with the
//! face, the point and both vertices named (refinement cannot separate two
//! nodes at one point; before, the run retried for 12 s and ended on "two
//! mesh nodes coincide").

mod common;

use bubblemesh_core::engine::Options;
use bubblemesh_core::spacing::Constant;
use bubblemesh_core::{mesh_model, model::Model};
use common::{circle_hole, face, polygon_loop};

/// The square [0, 10]² with a vertex at (10, 5) and a circular hole of
/// radius `r` about (10 − r, 5), whose own vertex is at (10, 5) too when
/// the hole touches.
fn square_with_hole(r: f64, centre_x: f64) -> Model {
    let mut model = Model::default();
    let outer = polygon_loop(
        &mut model,
        &[
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 5.0],
            [10.0, 10.0],
            [0.0, 10.0],
        ],
    );
    let hole = circle_hole(&mut model, [centre_x, 5.0], r);
    face(&mut model, vec![outer, hole]);
    model
}

#[test]
fn a_hole_touching_the_outer_loop_is_refused_by_name() {
    let model = square_with_hole(3.0, 7.0);
    let err = mesh_model(&model, &Constant(1.0), &Options::default())
        .expect_err("a pinched face must be refused")
        .to_string();
    assert!(err.contains("face 0"), "{err}");
    assert!(err.contains("touches itself at (10, 5, 0)"), "{err}");
    assert!(
        err.contains("vertex 2") && err.contains("vertex 5"),
        "{err}"
    );
}

/// The same hole a tenth of a spacing away from the outer loop is a
/// valid face, and meshes.
#[test]
fn a_hole_near_the_outer_loop_still_meshes() {
    let model = square_with_hole(3.0, 6.9);
    let (mesh, _) = mesh_model(&model, &Constant(1.0), &Options::default()).unwrap();
    assert!(!mesh.triangles.is_empty());
}
