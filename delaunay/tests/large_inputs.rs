//! Full validity check of the benchmark-sized inputs (slow: `#[ignore]`d,
//! run with `cargo test --release -p bubblemesh-delaunay --test large_inputs -- --ignored`).
mod common;
use bubblemesh_delaunay::tetrahedralize;
use common::*;

#[test]
#[ignore]
fn two_hundred_thousand_uniform_points_are_locally_delaunay() {
    let pts = cube_points(200_000, 77);
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(1.0), Sphere::Local);
}

#[test]
#[ignore]
fn fcc_lattice_of_a_hundred_thousand_points_is_locally_delaunay() {
    let pts = fcc_lattice(58);
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(58.0f64.powi(3)), Sphere::Local);
}
