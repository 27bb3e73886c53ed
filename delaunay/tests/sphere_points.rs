//! Points on one sphere plus its centre: all sphere points are cospherical,
//! so every tet must use the centre; cocircular hull faces exercise the
//! coplanar in-circle tie-break on the hull.
mod common;
use bubblemesh_delaunay::tetrahedralize;
use common::*;

/// All integer points with x² + y² + z² = r2.
fn integer_sphere(r2: i64) -> Vec<[f64; 3]> {
    let r = (r2 as f64).sqrt() as i64 + 1;
    let mut pts = Vec::new();
    for x in -r..=r {
        for y in -r..=r {
            for z in -r..=r {
                if x * x + y * y + z * z == r2 {
                    pts.push([x as f64, y as f64, z as f64]);
                }
            }
        }
    }
    pts
}

#[test]
fn exactly_cospherical_points_plus_centre_form_a_cone_from_the_centre() {
    // 2·3·5·7·... : r2 = 425 has a couple of hundred representations.
    let mut pts = integer_sphere(425);
    assert!(pts.len() >= 150, "{}", pts.len());
    pts.push([0.0, 0.0, 0.0]);
    let centre = (pts.len() - 1) as u32;
    let t = tetrahedralize(&pts).unwrap();
    let c = check(&pts, &t, None, Sphere::Global);
    // Every circumsphere of four sphere points is the sphere itself, which has
    // the centre strictly inside: so every tet has the centre as a vertex.
    assert!(t.tets.iter().all(|v| v.contains(&centre)));
    assert_eq!(c.hull_faces, t.tets.len());
}

#[test]
fn exactly_cospherical_points_alone_are_triangulated_by_the_perturbation() {
    // No centre: every in-sphere test between these points is a tie, so the
    // whole triangulation comes from the symbolic perturbation.
    let pts = integer_sphere(425);
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, None, Sphere::Global);
    // And it is the same for a shuffled input (unique perturbed triangulation).
    let mut order: Vec<usize> = (0..pts.len()).collect();
    Rng(5).shuffle(&mut order);
    let shuffled: Vec<[f64; 3]> = order.iter().map(|&i| pts[i]).collect();
    let t2 = tetrahedralize(&shuffled).unwrap();
    let back: Vec<[u32; 4]> = t2
        .tets
        .iter()
        .map(|v| v.map(|x| order[x as usize] as u32))
        .collect();
    assert_eq!(canonical(&t.tets), canonical(&back));
}

#[test]
fn the_eight_corners_of_a_cube() {
    let pts = cubic_lattice(2);
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, Some(1.0), Sphere::Global);
    // A cube splits into 5 or 6 tets.
    assert!(t.tets.len() == 5 || t.tets.len() == 6, "{}", t.tets.len());
}

#[test]
fn two_hundred_float_points_on_a_sphere_plus_centre() {
    // Fibonacci sphere: nearly (not exactly) cospherical in floating point.
    let n = 200;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut pts: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            [r * a.cos(), r * a.sin(), z]
        })
        .collect();
    pts.push([0.0, 0.0, 0.0]);
    let t = tetrahedralize(&pts).unwrap();
    check(&pts, &t, None, Sphere::Global);
}
