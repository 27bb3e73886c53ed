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

/// A plate 10 × 6 × `thickness` meshed as surfaces at spacing 1: the
/// radius ratios of its side walls' triangles (normal perpendicular to z),
/// and how many strip middle-row bubbles the faces kept.
fn side_walls(thickness: f64) -> (Vec<f64>, usize) {
    let text = format!(
        "format = \"bubblemesh-domain 1\"\n[[solid]]\nname = \"plate\"\n\
         box = {{ min = [0, 0, 0], max = [10, 6, {thickness}] }}\n"
    );
    let model = parse_domain(&text, "strips.toml").expect("domain");
    let opts = Options {
        dim: Some(2),
        ..Default::default()
    };
    let (mesh, report) = mesh_model(&model, &Constant(1.0), &opts).expect("mesh");
    verify(&model, &mesh, 2).expect("the mesh passes the final check");
    let q = mesh
        .triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.nodes.map(|n| mesh.nodes[n as usize].pos);
            let n = (b - a).cross(&(c - a)).normalize();
            (n.z.abs() < 1e-6).then(|| triangle_radius_ratio(&a, &b, &c))
        })
        .collect();
    let rows = report.faces.iter().map(|f| f.strip_row_bubbles).sum();
    (q, rows)
}

fn mean(q: &[f64]) -> f64 {
    q.iter().sum::<f64>() / q.len() as f64
}

/// A plate 1.2 spacings thick: its side walls were one row of right
/// triangles (mean and least radius ratio 0.82); with a middle row every
/// triangle is at least 0.88 and the mean over 0.9.
#[test]
fn side_walls_of_a_thin_plate_get_a_middle_row() {
    let (q, rows) = side_walls(1.2);
    let least = q.iter().cloned().fold(f64::INFINITY, f64::min);
    // without the middle row: 2 triangles per segment of the 32 around
    assert!(q.len() > 3 * 32, "{} side-wall triangles", q.len());
    assert!(rows >= 32, "{rows} middle-row bubbles");
    assert!(
        mean(&q) > 0.9,
        "side walls' mean radius ratio {:.3}",
        mean(&q)
    );
    assert!(least > 0.88, "side walls' least radius ratio {least:.3}");
}

/// A wall two spacings wide is packed by stage 2 (no middle row is
/// added), and its triangles stay near-equilateral.
#[test]
fn a_wall_two_spacings_wide_is_packed_as_before() {
    let (q, rows) = side_walls(2.0);
    assert_eq!(rows, 0);
    assert!(
        mean(&q) > 0.9,
        "side walls' mean radius ratio {:.3}",
        mean(&q)
    );
}
