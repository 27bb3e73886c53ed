//! Exact predicates in this crate's orientation convention, and the symbolic
//! perturbation that breaks `insphere == 0` ties.
//!
//! Convention: a tetrahedron `(a, b, c, d)` is *positive* when
//! `orient(a, b, c, d) > 0`, i.e. its signed volume
//! `(b - a) · ((c - a) × (d - a)) / 6` is positive (right-handed). This is the
//! negative of Shewchuk's `orient3d` sign (the `robust` crate), which is
//! positive when `d` lies *below* the counter-clockwise triangle `abc`.
//!
//! Perturbation (Edelsbrunner & Mücke's simulation of simplicity applied to the
//! lifting map, as in Devillers & Teillaud, "Perturbations for Delaunay and
//! weighted Delaunay 3D triangulations", CGTA 44 (2011)): point `p` is lifted to
//! `|p|² + ε^(r(p))` where `r` ranks the points in lexicographic (x, y, z)
//! order, the lexicographically largest point getting the dominant
//! perturbation. The perturbed lifted points are in general position, so the
//! perturbed Delaunay triangulation is unique (independent of insertion order)
//! and Bowyer–Watson cavities computed with the perturbed test are exactly the
//! conflict regions of a (regular) triangulation: star-shaped from the new
//! point. Only the lifting is perturbed, never the coordinates, so orientation
//! tests stay exact and every output tetrahedron has non-zero volume.

use robust::{insphere, orient3d, Coord3D};

#[inline(always)]
fn c(p: &[f64; 3]) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// Exact sign of six times the signed volume of `(a, b, c, d)`: `> 0` iff
/// right-handed, `0` iff coplanar. (The magnitude is only approximate.)
#[inline(always)]
pub fn orient(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3]) -> f64 {
    -orient3d(c(a), c(b), c(cc), c(d))
}

/// Exact in-sphere sign for a *positive* tetrahedron `(a, b, c, d)`: `> 0` iff
/// `e` is strictly inside its circumsphere, `0` iff on it. For a negative
/// tetrahedron the sign is reversed.
#[inline(always)]
pub fn insph(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3], e: &[f64; 3]) -> f64 {
    -insphere(c(a), c(b), c(cc), c(d), c(e))
}

/// Lexicographic (x, y, z) order: the perturbation rank.
#[inline]
pub fn lex_greater(a: &[f64; 3], b: &[f64; 3]) -> bool {
    (a[0], a[1], a[2]) > (b[0], b[1], b[2])
}

/// Perturbed answer to "is `p` inside the circumsphere of `tet`" when the exact
/// in-sphere determinant is zero. `tet` holds four vertex ids whose points
/// (`pts[id]`) have orientation sign `tet_sign` (±1), and `p` is a fifth,
/// distinct point (id `pid`). With the lifting of the module doc the perturbed
/// determinant's leading term belongs to the highest-ranked of the five points
/// with a non-zero cofactor: if that is `p`, `p` is lifted above the sphere
/// (outside); if it is a vertex `v`, `p` is inside iff the tetrahedron with `v`
/// replaced by `p` has the same orientation as `tet`.
///
/// The same rule serves the coplanar hull case (`tet` = a hull triangle plus a
/// point off its plane, `p` in that plane): it is then the perturbed 2D
/// in-circle test in the plane, consistent with the 3D one.
/// Two steps always decide for distinct points (a third would need `p` on two
/// lines through a vertex and on a sphere or circle through it, i.e. `p` equal
/// to that vertex).
pub fn perturbed_inside(pts: &[[f64; 3]], tet: [u32; 4], tet_sign: f64, pid: u32) -> bool {
    let mut ids = [tet[0], tet[1], tet[2], tet[3], pid];
    // Sort by decreasing rank (insertion sort on 5 ids).
    for i in 1..5 {
        let mut j = i;
        while j > 0 && lex_greater(&pts[ids[j] as usize], &pts[ids[j - 1] as usize]) {
            ids.swap(j, j - 1);
            j -= 1;
        }
    }
    for &top in &ids {
        if top == pid {
            return false;
        }
        let Some(k) = tet.iter().position(|&v| v == top) else {
            continue;
        };
        let mut w = tet.map(|v| pts[v as usize]);
        w[k] = pts[pid as usize];
        let o = orient(&w[0], &w[1], &w[2], &w[3]);
        if o != 0.0 {
            return (o > 0.0) == (tet_sign > 0.0);
        }
    }
    debug_assert!(false, "perturbation undecided: duplicate points?");
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn right_handed_unit_tet_is_positive_and_contains_its_centroid() {
        let a = [0.0, 0.0, 0.0];
        let b = [1.0, 0.0, 0.0];
        let c = [0.0, 1.0, 0.0];
        let d = [0.0, 0.0, 1.0];
        assert!(orient(&a, &b, &c, &d) > 0.0);
        assert!(orient(&b, &a, &c, &d) < 0.0);
        assert!(insph(&a, &b, &c, &d, &[0.25, 0.25, 0.25]) > 0.0);
        assert!(insph(&a, &b, &c, &d, &[2.0, 2.0, 2.0]) < 0.0);
        assert_eq!(insph(&a, &b, &c, &d, &[1.0, 1.0, 0.0]), 0.0);
    }

    #[test]
    fn perturbation_agrees_on_both_sides_of_a_shared_face() {
        // Five cospherical cube corners; tets 0123 and 4123 share face 123.
        // "Is 4 in sphere(0123)" and "is 0 in sphere(4123)" are the same
        // determinant with two rows swapped: the perturbed answers must agree
        // (both outside: the two-tet configuration is the perturbed Delaunay one).
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ];
        let s = orient(&pts[0], &pts[1], &pts[2], &pts[3]);
        assert_eq!(insph(&pts[0], &pts[1], &pts[2], &pts[3], &pts[4]), 0.0);
        let in1 = perturbed_inside(&pts, [0, 1, 2, 3], s, 4);
        let s2 = orient(&pts[4], &pts[1], &pts[2], &pts[3]);
        let in2 = perturbed_inside(&pts, [4, 1, 2, 3], s2, 0);
        assert_eq!(in1, in2);
        // 4 is the lexicographically largest point: lifted outward.
        assert!(!in1);
    }
}
