//! Re-meshing (thesis §4.8) through the public API: a warm start from a
//! saved state after a small change. Each test asserts the property the
//! feature exists for: nodes kept bit for bit where nothing changed,
//! quality as from scratch, fewer stage-2 steps, clear refusals.

mod common;

use std::collections::HashSet;
use std::sync::Arc;

use bubblemesh_core::remesh::{self, PlanError, Region, State};
use bubblemesh_core::spacing::{Constant, Expr};
use bubblemesh_core::{mesh_model, Mesh, Model, Options, Report, Spacing, P3};

/// The plate 2×1 with holes of radius 0.2 at (`x1`, 0.5) and (1.5, 0.5).
fn plate(x1: f64) -> Model {
    let mut m = Model::default();
    let l = common::polygon_loop(&mut m, &[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]);
    let h1 = common::circle_hole(&mut m, [x1, 0.5], 0.2);
    let h2 = common::circle_hole(&mut m, [1.5, 0.5], 0.2);
    common::face(&mut m, vec![l, h1, h2]);
    m
}

fn bits(p: &P3) -> (u64, u64, u64) {
    (p.x.to_bits(), p.y.to_bits(), p.z.to_bits())
}

fn max_steps(r: &Report) -> usize {
    r.faces
        .iter()
        .filter_map(|f| f.relax.as_ref().map(|x| x.steps))
        .max()
        .unwrap_or(0)
}

fn mean_min(mesh: &Mesh) -> (f64, f64) {
    let q = common::radius_ratios(mesh);
    (
        q.iter().sum::<f64>() / q.len() as f64,
        q.iter().cloned().fold(1.0, f64::min),
    )
}

/// Meshes `model` from `state` (through its file bytes), returning the
/// mesh and report.
fn remesh(
    state: &State,
    model: &Model,
    spacing: &dyn Spacing,
    region: Option<&Region>,
) -> (Mesh, Report) {
    let state = State::from_bytes(&state.to_bytes()).unwrap();
    let (warm, _) = remesh::plan(&state, model, spacing, region).unwrap();
    let opts = Options {
        warm: Some(Arc::new(warm)),
        ..Default::default()
    };
    mesh_model(model, spacing, &opts).unwrap()
}

/// §4.8.2: the first hole moves by 10 % of its radius. The warm mesh is
/// valid (mesh_model checks it), as good as one from scratch, takes fewer
/// stage-2 steps, and far from the hole every node is the old one, bit for
/// bit.
#[test]
fn a_moved_hole_remeshes_warm_and_keeps_the_rest() {
    let d = 0.03;
    let s = Constant(d);
    let old = plate(0.5);
    let (m0, _) = mesh_model(&old, &s, &Options::default()).unwrap();
    let state = remesh::state_of(&old, &m0, &s, "0.03", "plate");
    let new = plate(0.52);
    let (warm, wr) = remesh(&state, &new, &s, None);
    let (scratch, sr) = mesh_model(&new, &s, &Options::default()).unwrap();
    let (wq, sq) = (mean_min(&warm), mean_min(&scratch));
    assert!(wq.0 > sq.0 - 0.005, "q mean {} vs {}", wq.0, sq.0);
    assert!(wq.1 > sq.1 - 0.03, "q min {} vs {}", wq.1, sq.1);
    assert!(
        max_steps(&wr) < max_steps(&sr),
        "warm {} steps, scratch {}",
        max_steps(&wr),
        max_steps(&sr)
    );
    // nodes far from both the old and the new hole are kept exactly
    let now: HashSet<_> = warm.nodes.iter().map(|n| bits(&n.pos)).collect();
    let far: Vec<_> = m0
        .nodes
        .iter()
        .filter(|n| {
            let r = (n.pos - P3::new(0.51, 0.5, 0.0)).norm();
            r > 0.21 + 0.01 + 6.0 * d
        })
        .collect();
    assert!(far.len() > m0.nodes.len() / 2, "{} far nodes", far.len());
    let moved = far.iter().filter(|n| !now.contains(&bits(&n.pos))).count();
    assert_eq!(moved, 0, "{moved} of {} far nodes moved", far.len());
}

/// §4.8.1: with a region, every old node farther than two spacings from
/// it keeps its coordinates bit for bit, and the triangles among nodes
/// farther than four spacings are the old ones.
#[test]
fn a_local_remesh_keeps_nodes_and_elements_outside_the_band() {
    let d = 0.03;
    let s = Constant(d);
    let old = plate(0.5);
    let (m0, _) = mesh_model(&old, &s, &Options::default()).unwrap();
    let state = remesh::state_of(&old, &m0, &s, "0.03", "plate");
    let new = plate(0.52);
    let region = Region::parse("sphere:0.51,0.5,0,0.25").unwrap();
    let (warm, _) = remesh(&state, &new, &s, Some(&region));
    let now: HashSet<_> = warm.nodes.iter().map(|n| bits(&n.pos)).collect();
    let dist = |p: &P3| region.distance(p).unwrap();
    let far: Vec<_> = m0.nodes.iter().filter(|n| dist(&n.pos) > 2.0 * d).collect();
    assert!(far.len() > m0.nodes.len() / 2);
    let moved = far.iter().filter(|n| !now.contains(&bits(&n.pos))).count();
    assert_eq!(
        moved,
        0,
        "{moved} of {} nodes outside the band moved",
        far.len()
    );
    // the elements between them
    let tri_keys = |m: &Mesh, beyond: f64| -> HashSet<Vec<(u64, u64, u64)>> {
        m.triangles
            .iter()
            .filter(|t| {
                t.nodes
                    .iter()
                    .all(|&i| dist(&m.nodes[i as usize].pos) > beyond)
            })
            .map(|t| {
                let mut k: Vec<_> = t
                    .nodes
                    .iter()
                    .map(|&i| bits(&m.nodes[i as usize].pos))
                    .collect();
                k.sort_unstable();
                k
            })
            .collect()
    };
    let before = tri_keys(&m0, 4.0 * d);
    let after = tri_keys(&warm, 4.0 * d);
    assert!(!before.is_empty());
    let lost = before.difference(&after).count();
    assert_eq!(
        lost,
        0,
        "{lost} of {} old triangles outside the band changed",
        before.len()
    );
}

/// The adaptive loop: a spacing refined between the holes warm-starts
/// from the old packing; the new mesh follows the new spacing as well as
/// one from scratch, in fewer steps, and the nodes where the spacing did
/// not change (far from the refined zone) are kept.
#[test]
fn a_refined_spacing_remeshes_warm() {
    let old = plate(0.5);
    let s0 = Constant(0.03);
    let (m0, _) = mesh_model(&old, &s0, &Options::default()).unwrap();
    let state = remesh::state_of(&old, &m0, &s0, "0.03", "plate");
    let s1 = Expr::parse("min(0.03, 0.018 + 0.06*sqrt((x-1)^2 + (y-0.5)^2))").unwrap();
    let (warm, wr) = remesh(&state, &old, &s1, None);
    let (scratch, sr) = mesh_model(&old, &s1, &Options::default()).unwrap();
    let d1 = |p: &P3| s1.eval(p);
    let (w_in, _) = common::spacing_conformance(&warm, d1);
    let (s_in, _) = common::spacing_conformance(&scratch, d1);
    assert!(w_in > s_in - 0.01, "L/d in band {w_in} vs {s_in}");
    assert!(mean_min(&warm).0 > mean_min(&scratch).0 - 0.005);
    assert!(max_steps(&wr) < max_steps(&sr));
    let now: HashSet<_> = warm.nodes.iter().map(|n| bits(&n.pos)).collect();
    let unchanged: Vec<_> = m0
        .nodes
        .iter()
        .filter(|n| (n.pos - P3::new(1.0, 0.5, 0.0)).norm() > 0.2 + 4.0 * 0.03)
        .collect();
    assert!(unchanged.iter().all(|n| now.contains(&bits(&n.pos))));
}

/// A state of another model, a region that selects nothing and a face
/// that does not exist are refused with errors that say so.
#[test]
fn bad_plans_are_refused() {
    let s = Constant(0.1);
    let sq = common::square();
    let (m, _) = mesh_model(&sq, &s, &Options::default()).unwrap();
    let state = remesh::state_of(&sq, &m, &s, "0.1", "square");
    let e = remesh::plan(&state, &plate(0.5), &s, None).unwrap_err();
    assert!(matches!(e, PlanError::AnotherModel { .. }), "{e}");
    assert!(e.to_string().contains("another model"), "{e}");
    let far = Region::parse("box:5,5,5,6,6,6").unwrap();
    let e = remesh::plan(&state, &sq, &s, Some(&far)).unwrap_err();
    assert!(matches!(e, PlanError::EmptyRegion(_)), "{e}");
    assert!(e.to_string().contains("selects nothing"), "{e}");
    let e = remesh::plan(&state, &sq, &s, Some(&Region::Faces(vec![3]))).unwrap_err();
    assert!(e.to_string().contains("face 3"), "{e}");
    // the same model matches every entity
    let (_, matching) = remesh::plan(&state, &sq, &s, None).unwrap();
    assert_eq!(matching.matched.len(), 5);
    assert!(matching.unmatched.is_empty());
}
