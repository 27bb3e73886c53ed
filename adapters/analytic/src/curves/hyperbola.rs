//! The hyperbolic arc in 3D.

use bubblemesh_core::geom::{Curve, P3, V3};

use super::{finite_point, finite_vector, GeometryError};

/// The arc C(t) = c + a·cosh t·e1 + b·sinh t·e2, t ∈ [start, end], of the
/// branch of the hyperbola with centre c, semi-axis a along e1 (towards the
/// branch's vertex) and semi-imaginary axis b along e2 — the
/// parametrisation of STEP's `HYPERBOLA` (ISO 10303-42 §4.4.17). t is
/// dimensionless (not arc length).
///
/// Invariants: `e1`, `e2` orthonormal; a, b finite and > 0; start < end,
/// both finite with |t| ≤ 50 (cosh overflows far beyond any real part).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HyperbolaArc {
    center: P3,
    a: f64,
    b: f64,
    e1: V3,
    e2: V3,
    start: f64,
    end: f64,
}

impl HyperbolaArc {
    /// The arc with centre `center`, semi-axis `a` along `e1`, `b` along
    /// `e2` (made orthonormal as in [`super::EllipseArc::new`]).
    pub fn new(
        center: P3,
        e1: V3,
        e2: V3,
        a: f64,
        b: f64,
        start: f64,
        end: f64,
    ) -> Result<Self, GeometryError> {
        finite_point(&center, "hyperbola centre")?;
        finite_vector(&e1, "hyperbola axis e1")?;
        finite_vector(&e2, "hyperbola axis e2")?;
        for r in [a, b] {
            if !r.is_finite() {
                return Err(GeometryError::NotFinite("hyperbola semi-axis"));
            }
            if !(r > 0.0) {
                return Err(GeometryError::BadRadius(r));
            }
        }
        if !(start.is_finite()
            && end.is_finite()
            && start < end
            && start.abs().max(end.abs()) <= 50.0)
        {
            return Err(GeometryError::BadAngles { start, end });
        }
        let e1 = e1
            .try_normalize(0.0)
            .ok_or(GeometryError::BadPlane("hyperbola axis e1 is zero"))?;
        let e2 = (e2 - e1 * e1.dot(&e2))
            .try_normalize(1e-12 * e2.norm())
            .ok_or(GeometryError::BadPlane(
                "hyperbola axes are zero or parallel",
            ))?;
        Ok(HyperbolaArc {
            center,
            a,
            b,
            e1,
            e2,
            start,
            end,
        })
    }

    /// The parameter of a point on the branch: asinh(y/b) of its local
    /// coordinates (exact on the curve).
    pub fn parameter_of(&self, p: &P3) -> f64 {
        ((p - self.center).dot(&self.e2) / self.b).asinh()
    }
}

impl Curve for HyperbolaArc {
    fn interval(&self) -> (f64, f64) {
        (self.start, self.end)
    }
    fn point(&self, t: f64) -> P3 {
        self.center + self.e1 * (self.a * t.cosh()) + self.e2 * (self.b * t.sinh())
    }
    fn d1(&self, t: f64) -> V3 {
        self.e1 * (self.a * t.sinh()) + self.e2 * (self.b * t.cosh())
    }
    fn d2(&self, t: f64) -> V3 {
        self.e1 * (self.a * t.cosh()) + self.e2 * (self.b * t.sinh())
    }
    fn is_closed(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_and_parameter_inverse() {
        let h = HyperbolaArc::new(
            P3::new(1.0, 0.0, 2.0),
            V3::z(),
            V3::x(),
            2.0,
            0.5,
            -1.5,
            2.0,
        )
        .unwrap();
        let e = 1e-5;
        for t in [-1.2, 0.0, 0.7, 1.9] {
            let fd1 = (h.point(t + e) - h.point(t - e)) / (2.0 * e);
            let fd2 = (h.d1(t + e) - h.d1(t - e)) / (2.0 * e);
            assert!((fd1 - h.d1(t)).norm() < 1e-8);
            assert!((fd2 - h.d2(t)).norm() < 1e-8);
            assert!((h.parameter_of(&h.point(t)) - t).abs() < 1e-12);
        }
        assert!(HyperbolaArc::new(P3::origin(), V3::x(), V3::y(), 1.0, 1.0, 0.0, 60.0).is_err());
    }
}
