//! Random uniform points: a valid Delaunay tetrahedralization of the hull,
//! independent of insertion order.
mod common;
use bubblemesh_delaunay::{tetrahedralize, Delaunay3};
use common::*;

#[test]
fn random_points_in_a_cube_fill_the_cube_with_delaunay_tets() {
    let pts = cube_points(3000, 1);
    let t = tetrahedralize(&pts).unwrap();
    assert!(t.duplicates.is_empty());
    // Roughly 6.5 tets per point in 3D.
    assert!(t.tets.len() > 5 * pts.len() && t.tets.len() < 8 * pts.len());
    check(&pts, &t, Some(1.0), Sphere::Global);
}

#[test]
fn small_random_input_without_corners_triangulates_its_convex_hull() {
    let mut r = Rng(2);
    let pts: Vec<[f64; 3]> = (0..200)
        .map(|_| [r.uniform() - 0.5, 2.0 * r.uniform(), 0.1 * r.uniform()])
        .collect();
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, None, Sphere::Global);
}

#[test]
fn insertion_order_does_not_change_the_result() {
    // The perturbed Delaunay triangulation is unique: inserting the points one
    // by one in input order must give the same tets as the BRIO batch build.
    let pts = cube_points(1500, 3);
    let batch = tetrahedralize(&pts).unwrap();
    let mut d = Delaunay3::new(&pts[..4]).unwrap();
    for (i, &p) in pts.iter().enumerate().skip(4) {
        assert_eq!(d.insert(p, None).unwrap(), i as u32);
    }
    let inc = d.tetrahedralization();
    check(&pts, &inc, Some(1.0), Sphere::Local);
    assert_eq!(canonical(&batch.tets), canonical(&inc.tets));
    assert_eq!(d.num_tets(), inc.tets.len());
}
