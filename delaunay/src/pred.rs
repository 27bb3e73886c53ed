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

/// Shewchuk's machine epsilon (half an ulp of 1).
const EPS: f64 = f64::EPSILON / 2.0;
/// Shewchuk's error-bound coefficients of the floating-point stage.
const O3D_A: f64 = (7.0 + 56.0 * EPS) * EPS;
const ISP_A: f64 = (16.0 + 224.0 * EPS) * EPS;
/// Margin on the static bounds for the rounding of `m^k` itself.
const MARGIN: f64 = 1.0 + 1e-9;
/// Outside this range of coordinate differences the static bounds could
/// underflow or overflow: always take the `robust` path.
const M_MIN: f64 = 1e-50;
const M_MAX: f64 = 1e50;

// Why a filter of our own in front of `robust`: `robust` computes the exact
// "permanent" error bound on every call, as many flops as the determinant.
// Bounding that permanent by a power of the largest coordinate difference m
// (each entry is at most m in magnitude) costs a few `max`es, and is a valid
// *larger* bound, so whenever our test passes `robust`'s first stage would
// pass too and return the same determinant sign. Otherwise we call `robust`,
// which is exact.

/// `max` that compiles to one instruction (inputs are never NaN here; a NaN
/// would only make the filter fail and fall back to `robust`).
#[inline(always)]
fn fmax(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// Exact sign of six times the signed volume of `(a, b, c, d)`: `> 0` iff
/// right-handed, `0` iff coplanar. (The magnitude is only approximate.)
#[inline(always)]
pub fn orient(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3]) -> f64 {
    let (adx, ady, adz) = (a[0] - d[0], a[1] - d[1], a[2] - d[2]);
    let (bdx, bdy, bdz) = (b[0] - d[0], b[1] - d[1], b[2] - d[2]);
    let (cdx, cdy, cdz) = (cc[0] - d[0], cc[1] - d[1], cc[2] - d[2]);
    // Shewchuk's orient3d expansion (same evaluation order as his stage A).
    let det = adz * (bdx * cdy - cdx * bdy)
        + bdz * (cdx * ady - adx * cdy)
        + cdz * (adx * bdy - bdx * ady);
    let m = fmax(
        fmax(fmax(adx.abs(), ady.abs()), fmax(adz.abs(), bdx.abs())),
        fmax(
            fmax(bdy.abs(), bdz.abs()),
            fmax(cdx.abs(), fmax(cdy.abs(), cdz.abs())),
        ),
    );
    // Permanent = sum of 3 terms |z|(|xy| + |xy|) <= 6 m^3.
    let bound = O3D_A * 6.0 * m * m * m * MARGIN;
    if det.abs() > bound && m > M_MIN && m < M_MAX {
        return -det;
    }
    let mut q = [[0i64; 3]; 4];
    if grid_diffs(&[a, b, cc], d, 40, &mut q) {
        let w = |k: usize| q[k].map(i128::from);
        let (a, b, c) = (w(0), w(1), w(2));
        let det = a[2] * (b[0] * c[1] - c[0] * b[1])
            + b[2] * (c[0] * a[1] - a[0] * c[1])
            + c[2] * (a[0] * b[1] - b[0] * a[1]);
        return -(det.signum() as f64);
    }
    -orient3d(c(a), c(b), c(cc), c(d))
}

/// Exact in-sphere sign for a *positive* tetrahedron `(a, b, c, d)`: `> 0` iff
/// `e` is strictly inside its circumsphere, `0` iff on it. For a negative
/// tetrahedron the sign is reversed.
#[inline(always)]
pub fn insph(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3], e: &[f64; 3]) -> f64 {
    let (aex, aey, aez) = (a[0] - e[0], a[1] - e[1], a[2] - e[2]);
    let (bex, bey, bez) = (b[0] - e[0], b[1] - e[1], b[2] - e[2]);
    let (cex, cey, cez) = (cc[0] - e[0], cc[1] - e[1], cc[2] - e[2]);
    let (dex, dey, dez) = (d[0] - e[0], d[1] - e[1], d[2] - e[2]);
    // Shewchuk's insphere expansion (same evaluation order as his stage A).
    let ab = aex * bey - bex * aey;
    let bc = bex * cey - cex * bey;
    let cd = cex * dey - dex * cey;
    let da = dex * aey - aex * dey;
    let ac = aex * cey - cex * aey;
    let bd = bex * dey - dex * bey;
    let abc = aez * bc - bez * ac + cez * ab;
    let bcd = bez * cd - cez * bd + dez * bc;
    let cda = cez * da + dez * ac + aez * cd;
    let dab = dez * ab + aez * bd + bez * da;
    let alift = aex * aex + aey * aey + aez * aez;
    let blift = bex * bex + bey * bey + bez * bez;
    let clift = cex * cex + cey * cey + cez * cez;
    let dlift = dex * dex + dey * dey + dez * dez;
    let det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
    let m = fmax(
        fmax(
            fmax(aex.abs(), fmax(aey.abs(), aez.abs())),
            fmax(bex.abs(), fmax(bey.abs(), bez.abs())),
        ),
        fmax(
            fmax(cex.abs(), fmax(cey.abs(), cez.abs())),
            fmax(dex.abs(), fmax(dey.abs(), dez.abs())),
        ),
    );
    // Permanent = sum of 4 terms lift·(3 terms |z|(|xy| + |xy|)) <= 4·3m²·6m³.
    let m2 = m * m;
    let bound = ISP_A * 72.0 * m2 * m2 * m * MARGIN;
    if det.abs() > bound && m > M_MIN && m < M_MAX {
        return -det;
    }
    let mut q = [[0i64; 3]; 4];
    if grid_diffs(&[a, b, cc, d], e, 23, &mut q) {
        let w = |k: usize| q[k].map(i128::from);
        let (a, b, c, d) = (w(0), w(1), w(2), w(3));
        let ab = a[0] * b[1] - b[0] * a[1];
        let bc = b[0] * c[1] - c[0] * b[1];
        let cd = c[0] * d[1] - d[0] * c[1];
        let da = d[0] * a[1] - a[0] * d[1];
        let ac = a[0] * c[1] - c[0] * a[1];
        let bd = b[0] * d[1] - d[0] * b[1];
        let abc = a[2] * bc - b[2] * ac + c[2] * ab;
        let bcd = b[2] * cd - c[2] * bd + d[2] * bc;
        let cda = c[2] * da + d[2] * ac + a[2] * cd;
        let dab = d[2] * ab + a[2] * bd + b[2] * da;
        let lift = |x: [i128; 3]| x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        let det = (lift(d) * abc - lift(c) * dab) + (lift(b) * cda - lift(a) * bcd);
        return -(det.signum() as f64);
    }
    -insphere(c(a), c(b), c(cc), c(d), c(e))
}

/// Exact integer differences `others[k] - base`, divided by their common
/// power of two, if every coordinate is on the dyadic grid of spacing
/// `ulp(largest coordinate)` and the reduced differences are below
/// `2^bits` in magnitude. Then a determinant of degree `deg` in them with
/// `deg * bits + 7 < 127` is exact in `i128` and has the sign of the real one
/// (the differences are the real ones times a positive power of two).
///
/// Why: lattice inputs (cubic, FCC, grids) make most predicates exactly zero;
/// `robust` proves a zero only in its last, expansion-arithmetic stage, which
/// zero-fills ~20 KB of stack per call. Small integers do it in ~60 flops.
#[inline(never)]
fn grid_diffs(others: &[&[f64; 3]], base: &[f64; 3], bits: u32, out: &mut [[i64; 3]; 4]) -> bool {
    let mut mx = base[0].abs().max(base[1].abs()).max(base[2].abs());
    for o in others {
        mx = mx.max(o[0].abs()).max(o[1].abs()).max(o[2].abs());
    }
    if !(f64::MIN_POSITIVE..1e300).contains(&mx) {
        return false;
    }
    // mx = f · 2^e, f in [1, 2): scale all coordinates by 2^(52 - e) so that
    // they are below 2^53; they must then be integers.
    let e = ((mx.to_bits() >> 52) & 0x7ff) as i64 - 1023;
    let s = 52 - e;
    if !(-1000..=1000).contains(&s) {
        return false;
    }
    let scale = |x: f64| -> Option<i64> {
        // Multiply by 2^s in two exact steps (each factor a normal power of two).
        let h = s / 2;
        let y = x
            * f64::from_bits(((1023 + h) as u64) << 52)
            * f64::from_bits(((1023 + s - h) as u64) << 52);
        // |y| < 2^53 here, so the i64 round trip is exact iff y is an integer
        // (and avoids a libm `trunc` call on targets without SSE4.1).
        let i = y as i64;
        (i as f64 == y).then_some(i)
    };
    let mut bi = [0i64; 3];
    for k in 0..3 {
        match scale(base[k]) {
            Some(v) => bi[k] = v,
            None => return false,
        }
    }
    let mut tz = 64;
    for (o, row) in others.iter().zip(out.iter_mut()) {
        for k in 0..3 {
            match scale(o[k]) {
                Some(v) => {
                    row[k] = v - bi[k];
                    if row[k] != 0 {
                        tz = tz.min(row[k].trailing_zeros());
                    }
                }
                None => return false,
            }
        }
    }
    let lim = 1i64 << bits;
    for row in out.iter_mut().take(others.len()) {
        for x in row.iter_mut() {
            if tz < 64 {
                *x >>= tz;
            }
            if x.abs() >= lim {
                return false;
            }
        }
    }
    true
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
    fn filtered_predicates_have_the_signs_of_robust() {
        // Random, lattice (many exact zeros) and nearly degenerate inputs.
        let mut s = 99u64;
        let mut u = || (crate::sort::splitmix(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
        for k in 0..200_000 {
            let mut p: [[f64; 3]; 5] = [[0.0; 3]; 5];
            for q in &mut p {
                *q = match k % 6 {
                    0 => [u(), u(), u()],
                    1 => [
                        (u() * 4.0).floor(),
                        (u() * 4.0).floor(),
                        (u() * 4.0).floor(),
                    ],
                    2 => [1e6 + u() * 1e-9, 1e6 + u() * 1e-9, u() * 1e-9],
                    3 => [u() * 1e-30, u() * 1e-30, u() * 1e-30],
                    _ => [(u() * 3.0).floor() * 1e-3, (u() * 3.0).floor(), 2.0],
                };
            }
            if k % 8 == 3 {
                // Exactly coplanar: p3 = p0 + (p1 - p0) on the same line.
                p[3] = [
                    2.0 * p[1][0] - p[0][0],
                    2.0 * p[1][1] - p[0][1],
                    2.0 * p[1][2] - p[0][2],
                ];
            }
            let [a, b, cc, d, e] = p;
            let o = orient(&a, &b, &cc, &d);
            let r = -orient3d(c(&a), c(&b), c(&cc), c(&d));
            assert_eq!(
                o.signum() * (o != 0.0) as i32 as f64,
                r.signum() * (r != 0.0) as i32 as f64
            );
            let i = insph(&a, &b, &cc, &d, &e);
            let r = -insphere(c(&a), c(&b), c(&cc), c(&d), c(&e));
            assert_eq!(
                i.signum() * (i != 0.0) as i32 as f64,
                r.signum() * (r != 0.0) as i32 as f64
            );
        }
    }

    #[test]
    fn grid_path_takes_lattices_and_leaves_random_coordinates_to_robust() {
        let mut q = [[0i64; 3]; 4];
        let l = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 2.0],
        ];
        assert!(grid_diffs(&[&l[0], &l[1], &l[2]], &l[3], 23, &mut q));
        assert_eq!(q[0], [0, 0, -1]);
        let off = [
            [1e6, 0.0, 0.0],
            [1e6 + 1.0, 0.5, 0.0],
            [1e6, 0.0, 1.0],
            [1e6, 1.0, 0.0],
        ];
        assert!(grid_diffs(
            &[&off[0], &off[1], &off[2]],
            &off[3],
            23,
            &mut q
        ));
        assert_eq!(q[1], [2, -1, 0]);
        let r = [
            [0.1, 0.2, 0.3],
            [0.4, 0.5, 0.6],
            [0.7, 0.8, 0.9],
            [0.0, 0.0, 0.0],
        ];
        assert!(!grid_diffs(&[&r[0], &r[1], &r[2]], &r[3], 23, &mut q));
    }

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
