//! The elliptical arc (and full ellipse) in 3D.

use std::f64::consts::TAU;

use bubblemesh_core::geom::{Curve, P3, V3};

use super::{finite_point, finite_vector, GeometryError};

/// The arc C(θ) = c + a·cos θ·e1 + b·sin θ·e2, θ ∈ [start, end], of the
/// ellipse with centre c, semi-axes a along e1 and b along e2 (the
/// parametrisation of STEP's `ELLIPSE`, ISO 10303-42 §4.4.16).
///
/// θ is the eccentric angle in radians (not the polar angle of the point,
/// nor arc length); the arc runs counter-clockwise seen from the tip of
/// e1 × e2.
///
/// Invariants: `e1`, `e2` orthonormal; a, b finite and > 0;
/// `start < end ≤ start + 2π`; all values finite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EllipseArc {
    center: P3,
    a: f64,
    b: f64,
    e1: V3,
    e2: V3,
    start: f64,
    end: f64,
}

impl EllipseArc {
    /// The arc with centre `center`, semi-axis `a` along `e1` and `b` along
    /// `e2` (any two non-parallel vectors: `e1` is normalised, `e2` made
    /// orthogonal to it and normalised), from eccentric angle `start` to
    /// `end`.
    pub fn new(
        center: P3,
        e1: V3,
        e2: V3,
        a: f64,
        b: f64,
        start: f64,
        end: f64,
    ) -> Result<Self, GeometryError> {
        finite_point(&center, "ellipse centre")?;
        finite_vector(&e1, "ellipse axis e1")?;
        finite_vector(&e2, "ellipse axis e2")?;
        for r in [a, b] {
            if !r.is_finite() {
                return Err(GeometryError::NotFinite("ellipse semi-axis"));
            }
            if !(r > 0.0) {
                return Err(GeometryError::BadRadius(r));
            }
        }
        if !start.is_finite() || !end.is_finite() {
            return Err(GeometryError::NotFinite("ellipse angle"));
        }
        if !(start < end) || end - start > TAU * (1.0 + 1e-12) {
            return Err(GeometryError::BadAngles { start, end });
        }
        let e1 = e1
            .try_normalize(0.0)
            .ok_or(GeometryError::BadPlane("ellipse axis e1 is zero"))?;
        let e2 = (e2 - e1 * e1.dot(&e2))
            .try_normalize(1e-12 * e2.norm())
            .ok_or(GeometryError::BadPlane("ellipse axes are zero or parallel"))?;
        Ok(EllipseArc {
            center,
            a,
            b,
            e1,
            e2,
            start,
            end,
        })
    }

    /// The eccentric angle of the point of the ellipse nearest (in the
    /// ellipse's plane, by the affine map) to `p`: atan2(y/b, x/a) of its
    /// local coordinates, in (−π, π]. Exact for points on the ellipse.
    pub fn angle_of(&self, p: &P3) -> f64 {
        let d = p - self.center;
        (d.dot(&self.e2) / self.b).atan2(d.dot(&self.e1) / self.a)
    }
}

impl Curve for EllipseArc {
    fn interval(&self) -> (f64, f64) {
        (self.start, self.end)
    }
    fn point(&self, t: f64) -> P3 {
        let (s, c) = t.sin_cos();
        self.center + self.e1 * (self.a * c) + self.e2 * (self.b * s)
    }
    fn d1(&self, t: f64) -> V3 {
        let (s, c) = t.sin_cos();
        self.e2 * (self.b * c) - self.e1 * (self.a * s)
    }
    fn d2(&self, t: f64) -> V3 {
        let (s, c) = t.sin_cos();
        -(self.e1 * (self.a * c) + self.e2 * (self.b * s))
    }
    fn is_closed(&self) -> bool {
        self.end - self.start >= TAU * (1.0 - 1e-12)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_match_finite_differences_and_angle_inverts() {
        let e = EllipseArc::new(
            P3::new(1.0, 2.0, 3.0),
            V3::new(1.0, 1.0, 0.0),
            V3::new(0.0, 1.0, 1.0),
            3.0,
            1.5,
            -1.0,
            4.0,
        )
        .unwrap();
        let h = 1e-5;
        for t in [-0.9, 0.0, 1.3, 3.9] {
            let fd1 = (e.point(t + h) - e.point(t - h)) / (2.0 * h);
            let fd2 = (e.d1(t + h) - e.d1(t - h)) / (2.0 * h);
            assert!((fd1 - e.d1(t)).norm() < 1e-8, "C' at {t}");
            assert!((fd2 - e.d2(t)).norm() < 1e-8, "C'' at {t}");
            // angle_of answers in (−π, π]: equal to t up to a whole turn
            let da = (e.angle_of(&e.point(t)) - t).rem_euclid(std::f64::consts::TAU);
            assert!(da.min(std::f64::consts::TAU - da) < 1e-12, "angle at {t}");
        }
        // semi-axes: the points at θ = 0 and π/2 are a and b from the centre
        assert!(((e.point(0.0) - P3::new(1.0, 2.0, 3.0)).norm() - 3.0).abs() < 1e-12);
        assert!(
            ((e.point(std::f64::consts::FRAC_PI_2) - P3::new(1.0, 2.0, 3.0)).norm() - 1.5).abs()
                < 1e-12
        );
    }

    #[test]
    fn rejects_bad_input() {
        let o = P3::origin();
        assert!(EllipseArc::new(o, V3::x(), V3::y(), 0.0, 1.0, 0.0, 1.0).is_err());
        assert!(EllipseArc::new(o, V3::x(), V3::x(), 1.0, 1.0, 0.0, 1.0).is_err());
        assert!(EllipseArc::new(o, V3::x(), V3::y(), 1.0, 1.0, 1.0, 1.0).is_err());
        assert!(EllipseArc::new(o, V3::x(), V3::y(), 1.0, f64::NAN, 0.0, 1.0).is_err());
    }
}
