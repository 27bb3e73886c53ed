//! Large coplanar subsets: hull faces with many cocircular points (2D tie-break
//! on the hull), two parallel planes, a pyramid over a grid.
mod common;
use bubblemesh_delaunay::{tetrahedralize, Delaunay3};
use common::*;

#[test]
fn pyramid_over_a_square_grid_uses_the_apex_in_every_tet() {
    // 10×10 grid in z = 0 (cocircular squares on the hull base) and one apex
    // above: every tet is the apex joined to a base triangle.
    let mut pts = Vec::new();
    for i in 0..10 {
        for j in 0..10 {
            pts.push([i as f64, j as f64, 0.0]);
        }
    }
    pts.push([4.5, 4.5, 3.0]);
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(81.0 * 3.0 / 3.0), Sphere::Global);
    assert_eq!(t.tets.len(), 2 * 81);
    assert!(t.tets.iter().all(|v| v.contains(&100)));
}

#[test]
fn two_parallel_square_grids_form_a_slab() {
    let mut pts = Vec::new();
    for z in [0.0, 1.0] {
        for i in 0..8 {
            for j in 0..8 {
                pts.push([i as f64, j as f64, z]);
            }
        }
    }
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(49.0), Sphere::Global);
}

#[test]
fn points_only_on_the_surface_of_a_cube() {
    let pts: Vec<[f64; 3]> = cubic_lattice(7)
        .into_iter()
        .filter(|p| p.iter().any(|&x| x == 0.0 || x == 6.0))
        .collect();
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(216.0), Sphere::Global);
}

#[test]
fn has_face_finds_exactly_the_tet_faces() {
    let pts = cubic_lattice(4);
    let d = Delaunay3::new(&pts).unwrap();
    let t = d.tetrahedralization();
    let mut faces = std::collections::HashSet::new();
    for v in &t.tets {
        for i in 0..4 {
            let mut f = [v[(i + 1) % 4], v[(i + 2) % 4], v[(i + 3) % 4]];
            assert!(d.has_face(f));
            f.sort();
            faces.insert(f);
        }
    }
    // Every other triangle of the first 20 points is not a face.
    for a in 0..20u32 {
        for b in a + 1..20 {
            for c in b + 1..20 {
                assert_eq!(
                    d.has_face([c, a, b]),
                    faces.contains(&[a, b, c]),
                    "{a} {b} {c}"
                );
            }
        }
    }
    assert!(!d.has_face([0, 1, 1]));
    assert!(!d.has_face([0, 1, 1000]));
}
