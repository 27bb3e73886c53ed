//! Duplicate points are reported with their index and skipped, never a crash.
mod common;
use bubblemesh_delaunay::{tetrahedralize, Delaunay3, DelaunayError};
use common::*;

#[test]
fn duplicates_are_reported_and_the_rest_is_triangulated() {
    let base = cube_points(500, 5);
    let mut pts = base.clone();
    // Copies of points 0, 7, 7 again and a corner, appended.
    for &i in &[0usize, 7, 7, 503] {
        pts.push(base[i]);
    }
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(1.0), Sphere::Global);
    // Which copy of a pair is kept depends on the insertion order; each group
    // of equal points must keep exactly one.
    let mut dup_groups: Vec<Vec<u32>> = t
        .duplicates
        .iter()
        .map(|&(d, k)| {
            let mut g = vec![d, k];
            g.sort();
            g
        })
        .collect();
    dup_groups.sort();
    assert_eq!(t.duplicates.len(), 4);
    for &(d, k) in &t.duplicates {
        assert_eq!(pts[d as usize], pts[k as usize]);
    }
    // Same tets as without the copies (unique perturbed Delaunay), after
    // mapping kept copies back to the original indices.
    let clean = tetrahedralize(&base).unwrap();
    let orig = |v: u32| {
        let p = pts[v as usize];
        base.iter().position(|&q| q == p).unwrap() as u32
    };
    let mapped: Vec<[u32; 4]> = t.tets.iter().map(|v| v.map(orig)).collect();
    assert_eq!(canonical(&clean.tets), canonical(&mapped));
}

#[test]
fn every_lattice_point_given_twice_keeps_one_of_each() {
    let mut pts = cubic_lattice(5);
    pts.extend(cubic_lattice(5));
    let t = tetrahedralize(&pts).unwrap();
    assert_eq!(t.duplicates.len(), 125);
    check(&pts, &t, Some(64.0), Sphere::Global);
}

#[test]
fn inserting_an_existing_point_is_an_error_and_changes_nothing() {
    let pts = cube_points(100, 6);
    let mut d = Delaunay3::new(&pts).unwrap();
    let before = d.tetrahedralization();
    let err = d.insert(pts[42], Some(3)).unwrap_err();
    assert_eq!(
        err,
        DelaunayError::Duplicate {
            existing: 42,
            point: pts[42]
        }
    );
    assert_eq!(d.num_points(), pts.len());
    assert_eq!(d.tetrahedralization(), before);
    // A new point still gets the next index.
    assert_eq!(
        d.insert([0.5, 0.5, 0.5001], None).unwrap(),
        pts.len() as u32
    );
}
