//! A 10×10×10 cubic lattice: every unit cube has 8 cospherical corners, so
//! every in-sphere tie goes through the symbolic perturbation.
mod common;
use bubblemesh_delaunay::{tetrahedralize, Delaunay3};
use common::*;

#[test]
fn cubic_lattice_gives_a_valid_delaunay_tetrahedralization_of_the_cube() {
    let pts = cubic_lattice(10);
    let t = tetrahedralize(&pts).unwrap();
    assert!(t.duplicates.is_empty());
    let c = check(&pts, &t, Some(729.0), Sphere::Global);
    // Each of the 6 square faces of the hull is 81 squares = 162 triangles.
    assert_eq!(c.hull_faces, 6 * 162);
}

#[test]
fn cubic_lattice_result_is_the_same_in_any_insertion_order() {
    let pts = cubic_lattice(6);
    let batch = tetrahedralize(&pts).unwrap();
    check(&pts, &batch, Some(125.0), Sphere::Global);
    let mut order: Vec<usize> = (0..pts.len()).collect();
    Rng(11).shuffle(&mut order);
    // Start from four non-coplanar lattice points, then the rest shuffled.
    let first = [0usize, 1, 6, 36];
    let mut d = Delaunay3::new(&first.map(|i| pts[i])).unwrap();
    let mut id_of = vec![u32::MAX; pts.len()];
    for (k, &i) in first.iter().enumerate() {
        id_of[i] = k as u32;
    }
    for &i in &order {
        if !first.contains(&i) {
            id_of[i] = d.insert(pts[i], None).unwrap();
        }
    }
    // Map vertex ids back to lattice indices.
    let mut back = vec![0u32; pts.len()];
    for (i, &v) in id_of.iter().enumerate() {
        back[v as usize] = i as u32;
    }
    let inc: Vec<[u32; 4]> = d.tets().map(|t| t.map(|v| back[v as usize])).collect();
    assert_eq!(canonical(&batch.tets), canonical(&inc));
}
