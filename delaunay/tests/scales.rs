//! Tiny (1e-6) and huge (1e6) models: exact predicates do not depend on scale.
mod common;
use bubblemesh_delaunay::tetrahedralize;
use common::*;

#[test]
fn power_of_two_scaling_gives_identical_tets() {
    // Scaling by 2^±20 is exact in binary, so every predicate sign is the same
    // and the (unique) triangulation must be identical.
    let base = fcc_lattice(6);
    let t0 = tetrahedralize(&base).unwrap();
    for s in [2f64.powi(-20), 2f64.powi(20)] {
        let pts: Vec<[f64; 3]> = base.iter().map(|p| p.map(|x| x * s)).collect();
        let t = tetrahedralize(&pts).unwrap();
        assert_eq!(t.tets, t0.tets);
        check(&pts, &t, Some(216.0 * s * s * s), Sphere::Global);
    }
}

#[test]
fn micro_scale_model_is_valid() {
    let pts: Vec<[f64; 3]> = cube_points(1000, 8)
        .iter()
        .map(|p| p.map(|x| 1e-6 * x))
        .collect();
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(1e-18), Sphere::Global);
}

#[test]
fn kilometre_scale_model_far_from_the_origin_is_valid() {
    let pts: Vec<[f64; 3]> = cube_points(1000, 9)
        .iter()
        .map(|p| [1e6 * p[0] + 3e6, 1e6 * p[1] - 5e6, 1e6 * p[2]])
        .collect();
    let t = tetrahedralize(&pts).unwrap();
    let c = check(&pts, &t, None, Sphere::Global);
    assert!((c.volume - 1e18).abs() < 1e-9 * 1e18);
}

#[test]
fn lattice_of_1e_minus_6_spacing_at_a_1e6_offset_is_valid() {
    // Coordinates ~1e6 with ~1e-6 spacing: 12 significant digits apart, and
    // the rounded lattice is nearly degenerate everywhere.
    let pts: Vec<[f64; 3]> = cubic_lattice(6)
        .iter()
        .map(|p| p.map(|x| 1e6 + 1e-6 * x))
        .collect();
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, None, Sphere::Global);
}
