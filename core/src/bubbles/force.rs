//! Inter-bubble force (thesis §4.2).
//!
//! The force between bubbles i and j depends on their distance r through the
//! ratio w = r / r0, where r0 = (d_i + d_j)/2 is the stable distance
//! (eq. 3.2.1–3.2.2, 4.2.3). It repels for w < 1, attracts for 1 < w < 1.5,
//! and vanishes beyond the cutoff w = 1.5.
//!
//! ## The cubic law, eq. 4.2.6, corrected
//! The thesis solves f(1) = 0, f(1.5) = 0, f'(0) = 0, f'(1) = −k0/r0
//! (eq. 4.2.4) for f(w) = A w³ + B w² + C w + D and prints
//! `f(w) = k0/r0 (1.25 w³ − 2.375 w² + 1.125 w)`. That polynomial is not the
//! solution (its value at w = 1.5 is 0.5625, and f'(1) is +0.125). Solving the
//! four conditions gives C = 0, A = 1.25, B = −2.375, **D = 1.125**:
//!
//! φ(w) = 1.25 w³ − 2.375 w² + 1.125, φ(1) = φ(1.5) = 0, φ'(0) = 0, φ'(1) = −1.
//!
//! The force magnitude used here is F(r) = k0 · r0 · φ(r/r0), so that
//! dF/dr = −k0 at r = r0 (k0 is the linear spring constant of eq. 3.2.4) and
//! forces scale with bubble size (the dynamics are scale-free).

/// Cutoff of the force as a multiple of the stable distance (eq. 4.2.6).
pub const CUTOFF: f64 = 1.5;

/// φ(w) of the corrected cubic law, zero for w ≥ 1.5. Positive = repulsion.
#[inline]
pub fn phi(w: f64) -> f64 {
    if w >= CUTOFF {
        0.0
    } else {
        (1.25 * w - 2.375) * w * w + 1.125
    }
}

/// φ'(w) = dφ/dw (for the test of the conditions of eq. 4.2.4).
#[cfg(test)]
#[inline]
pub fn dphi(w: f64) -> f64 {
    if w >= CUTOFF {
        0.0
    } else {
        (3.75 * w - 4.75) * w
    }
}

/// Repulsive force magnitude between two bubbles at distance `r` with stable
/// distance `r0` and spring constant `k0` (positive pushes them apart).
#[inline]
pub fn magnitude(r: f64, r0: f64, k0: f64) -> f64 {
    k0 * r0 * phi(r / r0)
}

/// Potential energy of a pair: U(r) = ∫_r^{1.5 r0} F(s) ds = k0 r0² (Φ(1.5) − Φ(w)),
/// with Φ(w) = ∫φ = 0.3125 w⁴ − 0.791 6̅ w³ + 1.125 w. U ≥ 0 is not guaranteed
/// (the attracting tail makes U(1) < 0); only differences matter.
#[inline]
pub fn potential(r: f64, r0: f64, k0: f64) -> f64 {
    let big_phi = |w: f64| ((0.3125 * w - 2.375 / 3.0) * w * w + 1.125) * w;
    let w = (r / r0).min(CUTOFF);
    k0 * r0 * r0 * (big_phi(CUTOFF) - big_phi(w))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeros_at_stable_distance_and_cutoff() {
        assert!(phi(1.0).abs() < 1e-15);
        assert!(phi(1.5).abs() < 1e-15);
        assert_eq!(phi(2.0), 0.0);
    }

    #[test]
    fn slope_is_minus_one_at_stable_distance_and_flat_at_zero() {
        assert!((dphi(1.0) + 1.0).abs() < 1e-15);
        assert!(dphi(0.0).abs() < 1e-15);
        // and by finite differences, so the closed form cannot drift from phi
        let h = 1e-6;
        for w in [0.2, 0.7, 1.0, 1.3] {
            let fd = (phi(w + h) - phi(w - h)) / (2.0 * h);
            assert!((fd - dphi(w)).abs() < 1e-8, "w = {w}");
        }
    }

    #[test]
    fn repels_inside_attracts_outside_saturates_at_zero() {
        for k in 0..100 {
            let w = k as f64 / 100.0;
            assert!(phi(w) > 0.0, "repulsion expected at w = {w}");
        }
        for k in 1..50 {
            let w = 1.0 + k as f64 / 100.0;
            assert!(phi(w) < 0.0, "attraction expected at w = {w}");
        }
        assert_eq!(phi(0.0), 1.125);
    }

    #[test]
    fn magnitude_slope_is_minus_k0() {
        let (r0, k0, h) = (0.3, 2.0, 1e-7);
        let s = (magnitude(r0 + h, r0, k0) - magnitude(r0 - h, r0, k0)) / (2.0 * h);
        assert!((s + k0).abs() < 1e-6, "{s}");
    }

    #[test]
    fn potential_is_the_integral_of_the_force() {
        let (r0, k0, h) = (0.5, 1.0, 1e-6);
        for r in [0.1, 0.4, 0.5, 0.6, 0.7] {
            let du = (potential(r + h, r0, k0) - potential(r - h, r0, k0)) / (2.0 * h);
            assert!((du + magnitude(r, r0, k0)).abs() < 1e-6, "r = {r}");
        }
        assert!(potential(0.75, r0, k0).abs() < 1e-15);
    }
}
