//! Strips: faces narrower than two spacings whose long sides are meshed
//! alike, so that their boundary nodes face each other (the side walls of
//! a plate). One row of triangles joins them as near-right triangles
//! (radius ratio 0.82 at a width of 1.2 spacings); the strips' middle rows
//! (`face::placement::strip_rows`) make two rows of near-isosceles ones.

use bubblemesh_analytic::parse_domain;
use bubblemesh_core::measure::triangle_radius_ratio;
use bubblemesh_core::spacing::Constant;
use bubblemesh_core::verify::verify;
use bubblemesh_core::{mesh_model, Options};

/// The radius ratios of the triangles of `mesh` whose normal is
/// perpendicular to z (the side walls of a plate lying in the xy-plane).
fn side_wall_quality(text: &str, d: f64) -> Vec<f64> {
    let model = parse_domain(text, "strips.toml").expect("domain");
    let opts = Options {
        dim: Some(2),
        ..Default::default()
    };
    let (mesh, _) = mesh_model(&model, &Constant(d), &opts).expect("mesh");
    verify(&model, &mesh, 2).expect("the mesh passes the final check");
    mesh.triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.nodes.map(|n| mesh.nodes[n as usize].pos);
            let n = (b - a).cross(&(c - a)).normalize();
            (n.z.abs() < 1e-6).then(|| triangle_radius_ratio(&a, &b, &c))
        })
        .collect()
}

/// A plate 1.2 spacings thick: its side walls were one row of right
/// triangles (mean and least radius ratio 0.82); with a middle row every
/// triangle is at least 0.88 and the mean over 0.9.
#[test]
fn side_walls_of_a_thin_plate_get_a_middle_row() {
    let plate = r#"
format = "bubblemesh-domain 1"
[[solid]]
name = "plate"
box = { min = [0, 0, 0], max = [10, 6, 1.2] }
"#;
    let q = side_wall_quality(plate, 1.0);
    assert!(!q.is_empty());
    let mean = q.iter().sum::<f64>() / q.len() as f64;
    let least = q.iter().cloned().fold(f64::INFINITY, f64::min);
    // without the middle row: 2 triangles per segment of the 32 around
    assert!(q.len() > 3 * 32, "{} side-wall triangles", q.len());
    assert!(mean > 0.9, "side walls' mean radius ratio {mean:.3}");
    assert!(least > 0.88, "side walls' least radius ratio {least:.3}");
}

/// A wall two spacings wide is not a strip for this rule: stage 2 packs
/// it, and its triangles stay near-equilateral.
#[test]
fn a_wall_two_spacings_wide_is_packed_as_before() {
    let plate = r#"
format = "bubblemesh-domain 1"
[[solid]]
name = "plate"
box = { min = [0, 0, 0], max = [10, 6, 2.0] }
"#;
    let q = side_wall_quality(plate, 1.0);
    let mean = q.iter().sum::<f64>() / q.len() as f64;
    assert!(mean > 0.9, "side walls' mean radius ratio {mean:.3}");
}
