//! Face-centred cubic lattice: octahedral holes (6 cospherical points) and
//! coplanar hull faces.
mod common;
use bubblemesh_delaunay::tetrahedralize;
use common::*;

#[test]
fn fcc_lattice_gives_a_valid_delaunay_tetrahedralization_of_the_cube() {
    let pts = fcc_lattice(10);
    let t = tetrahedralize(&pts).unwrap();
    assert!(t.duplicates.is_empty());
    check(&pts, &t, Some(1000.0), Sphere::Global);
}

#[test]
fn shifted_and_scaled_fcc_lattice_is_valid() {
    // Half-integer spacing around an offset: exact in binary, still degenerate.
    let pts: Vec<[f64; 3]> = fcc_lattice(8)
        .iter()
        .map(|p| [p[0] * 0.5 + 100.0, p[1] * 0.5 - 7.0, p[2] * 0.5])
        .collect();
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(64.0), Sphere::Global);
}
