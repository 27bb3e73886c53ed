//! Bad input gives a clear error, never a panic.
use bubblemesh_delaunay::{tetrahedralize, Delaunay3, DelaunayError};

#[test]
fn fewer_than_four_points_is_an_error() {
    let e = tetrahedralize(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap_err();
    assert_eq!(e, DelaunayError::TooFewPoints(3));
    assert!(e.to_string().contains("at least 4"));
}

#[test]
fn coplanar_points_are_an_error() {
    // An exactly coplanar tilted grid z = x + 2y.
    let mut pts = Vec::new();
    for i in 0..10 {
        for j in 0..10 {
            pts.push([i as f64, j as f64, (i + 2 * j) as f64]);
        }
    }
    assert_eq!(
        tetrahedralize(&pts).unwrap_err(),
        DelaunayError::Coplanar(100)
    );
    let collinear: Vec<[f64; 3]> = (0..10)
        .map(|i| [i as f64, 2.0 * i as f64, -(i as f64)])
        .collect();
    assert_eq!(
        tetrahedralize(&collinear).unwrap_err(),
        DelaunayError::Coplanar(10)
    );
    assert_eq!(
        tetrahedralize(&[[1.0; 3]; 5]).unwrap_err(),
        DelaunayError::Coplanar(5)
    );
    assert!(DelaunayError::Coplanar(5).to_string().contains("coplanar"));
}

#[test]
fn non_finite_coordinate_is_reported_with_its_index() {
    let mut pts = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    pts.push([f64::NAN, 0.0, 0.0]);
    match tetrahedralize(&pts).unwrap_err() {
        DelaunayError::NonFinite { index, .. } => assert_eq!(index, 4),
        e => panic!("{e}"),
    }
    let mut d = Delaunay3::new(&pts[..4]).unwrap();
    let e = d.insert([0.1, f64::INFINITY, 0.1], None).unwrap_err();
    assert!(
        matches!(e, DelaunayError::NonFinite { index: 4, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("point 4"));
}
