//! The straight segment.

use bubblemesh_core::geom::{Curve, P3, V3};

use super::{finite_point, GeometryError};

/// The segment C(t) = p0 + t·(p1 − p0), t ∈ [0, 1].
///
/// The parameter is proportional to arc length; C' = p1 − p0 and C'' = 0.
/// Invariant: both end points are finite (a zero-length segment is allowed
/// here; the domain reader rejects it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    p0: P3,
    p1: P3,
}

impl Line {
    /// The segment from `p0` (t = 0) to `p1` (t = 1).
    pub fn new(p0: P3, p1: P3) -> Result<Self, GeometryError> {
        finite_point(&p0, "line start point")?;
        finite_point(&p1, "line end point")?;
        Ok(Line { p0, p1 })
    }

    /// Start point, C(0).
    pub fn p0(&self) -> P3 {
        self.p0
    }

    /// End point, C(1).
    pub fn p1(&self) -> P3 {
        self.p1
    }
}

impl Curve for Line {
    fn interval(&self) -> (f64, f64) {
        (0.0, 1.0)
    }
    fn point(&self, t: f64) -> P3 {
        self.p0 + (self.p1 - self.p0) * t
    }
    fn d1(&self, _t: f64) -> V3 {
        self.p1 - self.p0
    }
    fn d2(&self, _t: f64) -> V3 {
        V3::zeros()
    }
    fn is_closed(&self) -> bool {
        false
    }
    fn approx_length(&self) -> f64 {
        (self.p1 - self.p0).norm()
    }
}
