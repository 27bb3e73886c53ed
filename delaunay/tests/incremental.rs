//! Steiner-point insertion after a first build (the volume mesher's use).
mod common;
use bubblemesh_delaunay::{tetrahedralize, Delaunay3};
use common::*;

#[test]
fn inserting_points_into_a_bounding_box_build_matches_a_batch_build() {
    let corners = cube_points(0, 0);
    let mut d = Delaunay3::new(&corners).unwrap();
    let mut all = corners.clone();
    let mut r = Rng(21);
    let mut prev = None;
    for _ in 0..800 {
        let p = [r.uniform(), r.uniform(), r.uniform()];
        let id = d.insert(p, prev).unwrap();
        assert_eq!(id as usize, all.len());
        all.push(p);
        prev = Some(id);
    }
    // Points outside the current hull extend it.
    for p in [[1.5, 0.5, 0.5], [-0.5, -0.5, -0.5], [0.5, 0.5, 2.0]] {
        d.insert(p, Some(0)).unwrap();
        all.push(p);
    }
    let t = d.tetrahedralization();
    check(&all, &t, None, Sphere::Global);
    assert_eq!(
        canonical(&t.tets),
        canonical(&tetrahedralize(&all).unwrap().tets)
    );
}
