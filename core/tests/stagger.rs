//! Edge nodes across a face narrower than the spacing are staggered
//! (`edge::stagger`): the strip's triangles get about atan(2w) instead of
//! atan(w); a slit (the gap between the edges outside the face) is not a
//! strip, and its sides keep their own nodes.

mod common;

use bubblemesh_core::engine::Options;
use bubblemesh_core::spacing::Constant;
use bubblemesh_core::{mesh_model, EntityRef, Mesh};
use common::{face, polygon_loop};

/// The smallest angle of the mesh's triangles, degrees.
fn smallest_angle(mesh: &Mesh) -> f64 {
    let mut least: f64 = 180.0;
    for t in &mesh.triangles {
        let p = t.nodes.map(|v| mesh.nodes[v as usize].pos);
        for k in 0..3 {
            let (u, v) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
            least = least.min(u.cross(&v).norm().atan2(u.dot(&v)).to_degrees());
        }
    }
    least
}

/// The x coordinates of the interior nodes of edge `ei`, sorted.
fn edge_xs(mesh: &Mesh, ei: u32) -> Vec<f64> {
    let mut xs: Vec<f64> = mesh
        .nodes
        .iter()
        .filter(|n| n.entity == EntityRef::new(1, ei))
        .map(|n| n.pos.x)
        .collect();
    xs.sort_by(f64::total_cmp);
    xs
}

/// A strip 10 × 0.3 at spacing 1, its loop run either way round: side by
/// side, the rungs a spacing apart give triangles of 16.7° (atan 0.3);
/// staggered, about 31° (atan 0.6), and no worse than 25° anywhere.
#[test]
fn nodes_across_a_strip_narrower_than_the_spacing_are_staggered() {
    for reversed in [false, true] {
        let mut pts = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 0.3], [0.0, 0.3]];
        if reversed {
            pts.reverse();
        }
        let mut model = bubblemesh_core::model::Model::default();
        let l = polygon_loop(&mut model, &pts);
        face(&mut model, vec![l]);
        let (mesh, _) = mesh_model(&model, &Constant(1.0), &Options::default()).unwrap();
        let least = smallest_angle(&mesh);
        assert!(
            least > 25.0,
            "reversed {reversed}: smallest angle {least:.2}°"
        );
        // the two long sides' (edges 0 and 2) nodes alternate along the strip: exactly one
        // of the later side's between two neighbours of the earlier side's
        let (xa, xb) = (edge_xs(&mesh, 0), edge_xs(&mesh, 2));
        assert!(xa.len() >= 8, "{xa:?}");
        for w in xa.windows(2) {
            let between = xb.iter().filter(|&&x| x > w[0] && x < w[1]).count();
            assert_eq!(between, 1, "reversed {reversed}: {xa:?} {xb:?}");
        }
    }
}

/// A C-shaped face: a slit 0.1 wide and 8 long cut into a 10 × 3
/// rectangle. The slit's two sides are 0.1 apart but the face is not
/// between them, so they keep the nodes each gets on its own (side by
/// side, as the spacing places them on two equal segments).
#[test]
fn the_sides_of_a_slit_keep_their_own_nodes() {
    let mut model = bubblemesh_core::model::Model::default();
    let pts = [
        [0.0, 0.0],
        [10.0, 0.0],
        [10.0, 3.0],
        [0.0, 3.0],
        [0.0, 1.55],
        [8.0, 1.55],
        [8.0, 1.45],
        [0.0, 1.45],
    ];
    let l = polygon_loop(&mut model, &pts);
    face(&mut model, vec![l]);
    let (mesh, _) = mesh_model(&model, &Constant(1.0), &Options::default()).unwrap();
    let (upper, lower) = (edge_xs(&mesh, 4), edge_xs(&mesh, 6));
    assert_eq!(upper.len(), lower.len());
    assert!(upper.len() >= 6);
    for (a, b) in upper.iter().zip(&lower) {
        assert!(
            (a - b).abs() < 1e-9,
            "slit sides' nodes moved: {upper:?} {lower:?}"
        );
    }
}
