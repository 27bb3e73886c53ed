//! Moving points of a triangulation (`Delaunay3::moved`): the tets must be
//! exactly those of a new build of the moved points, whether flips or a
//! rebuild got there, and small moves must be done by flips.
mod common;
use bubblemesh_delaunay::{tetrahedralize, Delaunay3, Moved};
use common::*;

/// Moves `d`'s points to `pts`, checks the result against a batch build and
/// every invariant, and returns how it was reached.
fn move_and_check(d: Delaunay3, pts: &[[f64; 3]]) -> (Delaunay3, Moved) {
    let (d, how) = d.moved(pts).unwrap();
    let t = d.tetrahedralization();
    check(pts, &t, None, Sphere::Local);
    assert_eq!(
        canonical(&t.tets),
        canonical(&tetrahedralize(pts).unwrap().tets),
        "moved ({how:?}) differs from a new build"
    );
    assert_eq!(d.num_tets(), t.tets.len());
    (d, how)
}

/// Moves every point for which `free` holds by up to `amp` in each
/// coordinate.
fn jitter(pts: &mut [[f64; 3]], r: &mut Rng, amp: f64, free: impl Fn(&[f64; 3]) -> bool) {
    for p in pts.iter_mut().filter(|p| free(p)) {
        for x in p.iter_mut() {
            *x += amp * (2.0 * r.uniform() - 1.0);
        }
    }
}

fn interior(p: &[f64; 3], lo: f64, hi: f64) -> bool {
    p.iter().all(|&x| x > lo && x < hi)
}

#[test]
fn small_moves_of_random_points_are_flipped_to_the_new_builds_tets() {
    let mut pts = cube_points(3000, 5);
    let mut d = Delaunay3::new(&pts).unwrap();
    let mut r = Rng(8);
    let mut flipped = 0;
    // Spacing of 3000 points in the unit cube: about 0.07.
    for round in 0..6 {
        let amp = [0.0005, 0.002, 0.005, 0.01, 0.002, 0.0005][round];
        jitter(&mut pts, &mut r, amp, |p| interior(p, 0.0, 1.0));
        let (next, how) = move_and_check(d, &pts);
        d = next;
        if let Moved::Kept { flips, .. } = how {
            assert!(flips > 0, "round {round}: points moved but nothing flipped");
            flipped += 1;
        }
    }
    assert_eq!(flipped, 6, "small moves must not need a new build");
}

#[test]
fn lattice_points_jittered_and_put_back_reach_the_perturbed_triangulation() {
    // An FCC lattice is full of cospherical sets (the symbolic perturbation
    // decides them); jittering the interior breaks them, putting the points
    // back restores them, and both ways must give the unique triangulation.
    let exact = fcc_lattice(8);
    let mut d = Delaunay3::new(&exact).unwrap();
    let mut r = Rng(3);
    let mut pts = exact.clone();
    let mut flipped = 0;
    for round in 0..4 {
        jitter(&mut pts, &mut r, 0.02, |p| interior(p, 0.0, 8.0));
        let (next, how) = move_and_check(d, &pts);
        d = next;
        flipped += matches!(how, Moved::Kept { .. }) as usize;
        // Back onto the lattice, faces whose apexes' segment meets an edge
        // exactly may be left to a new build: correct either way.
        d = move_and_check(d, &exact).0;
        pts = exact.clone();
        let _ = round;
    }
    assert_eq!(flipped, 4, "jittering a lattice needs no new build");
}

#[test]
fn points_on_planes_stay_and_interior_points_move() {
    // The volume mesher's case: boundary nodes on the faces of a box (many
    // coplanar and cocircular sets) stay, interior nodes move.
    let mut pts = cubic_lattice(7);
    let mut r = Rng(11);
    jitter(&mut pts, &mut r, 0.3, |p| interior(p, 0.0, 6.0));
    let mut d = Delaunay3::new(&pts).unwrap();
    for _ in 0..5 {
        jitter(&mut pts, &mut r, 0.05, |p| interior(p, 0.0, 6.0));
        d = move_and_check(d, &pts).0;
    }
}

#[test]
fn moves_that_invert_tets_reinsert_and_a_moved_hull_vertex_builds_anew() {
    let mut pts = cube_points(500, 9);
    let d = Delaunay3::new(&pts).unwrap();
    // Far moves (a third of the spacing and more): tets would turn inside
    // out, their vertices are taken out and inserted again.
    let mut r = Rng(2);
    for p in pts.iter_mut().filter(|p| interior(p, 0.0, 1.0)) {
        for x in p.iter_mut() {
            *x = (*x + 0.3 * (2.0 * r.uniform() - 1.0)).clamp(0.01, 0.99);
        }
    }
    let (d, how) = move_and_check(d, &pts);
    assert!(
        matches!(how, Moved::Kept { reinserted, .. } if reinserted > 0),
        "{how:?}"
    );
    // A corner of the hull moves outward.
    let corner = pts.iter().position(|p| *p == [1.0, 1.0, 1.0]).unwrap();
    pts[corner] = [1.1, 1.0, 1.0];
    let (d, how) = move_and_check(d, &pts);
    assert_eq!(how, Moved::Rebuilt);
    // Nothing moved: nothing to do.
    let (_, how) = move_and_check(d, &pts);
    assert_eq!(
        how,
        Moved::Kept {
            flips: 0,
            reinserted: 0
        }
    );
}

#[test]
fn moving_to_a_non_finite_or_a_wrong_count_is_an_error_or_a_new_build() {
    let pts = cube_points(100, 1);
    let d = Delaunay3::new(&pts).unwrap();
    let mut bad = pts.clone();
    bad[3][1] = f64::NAN;
    assert!(d.clone().moved(&bad).is_err());
    let fewer = &pts[..50];
    let (d2, how) = d.moved(fewer).unwrap();
    assert_eq!(how, Moved::Rebuilt);
    assert_eq!(d2.num_points(), 50);
}
