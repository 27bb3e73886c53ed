//! The circular cone.

use std::f64::consts::{FRAC_PI_2, TAU};

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3, V3};

use super::{check_range, finite3, finite_hint, wrap, Frame, SurfaceError, SINGULAR_REL};

/// The circular cone with apex a = `frame.origin()`, axis z and half-angle
/// α (between the axis and a generator):
///
/// S(u,v) = a + v·(sin α cos u·x + sin α sin u·y + cos α·z)
///
/// u ∈ [0, 2π] is the angle in radians, periodic with period 2π (seam
/// towards x); v ∈ [v0, v1] is the distance from the apex along the
/// generator (slant height) in model units, 0 ≤ v0 < v1 ≤ ∞ (default
/// [0, ∞)). Only the nappe opening towards +z is represented. The apex
/// v = 0 is singular (S_u = 0).
///
/// Invariants: 0 < α < π/2, apex finite, frame orthonormal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    frame: Frame,
    half_angle: f64,
    sin: f64,
    cos: f64,
    v_range: [f64; 2],
}

impl Cone {
    /// The cone with apex `apex`, opening along `axis` (any non-zero
    /// length; seam direction as in [`Frame::new`]), half-angle in radians,
    /// v ∈ [0, ∞).
    pub fn new(apex: P3, axis: V3, half_angle: f64) -> Result<Self, SurfaceError> {
        Self::with_frame(Frame::new(apex, axis)?, half_angle, [0.0, f64::INFINITY])
    }

    /// The truncated cone 0 ≤ v0 < v1 < ∞ (slant distances from the apex).
    pub fn bounded(
        apex: P3,
        axis: V3,
        half_angle: f64,
        v0: f64,
        v1: f64,
    ) -> Result<Self, SurfaceError> {
        check_range([v0, v1], false, "cone slant heights must be finite")?;
        Self::with_frame(Frame::new(apex, axis)?, half_angle, [v0, v1])
    }

    /// The cone in `frame` (apex at the origin, axis z, seam x) with slant
    /// range `v_range`, 0 ≤ v0 < v1 (v1 may be infinite).
    pub fn with_frame(
        frame: Frame,
        half_angle: f64,
        v_range: [f64; 2],
    ) -> Result<Self, SurfaceError> {
        finite3(&frame.origin().coords, "cone apex")?;
        if !(half_angle > 0.0 && half_angle < FRAC_PI_2) {
            return Err(SurfaceError::BadHalfAngle(half_angle));
        }
        check_range(v_range, true, "cone slant heights need v0 < v1")?;
        if !(v_range[0] >= 0.0) {
            return Err(SurfaceError::BadRange {
                what: "cone slant heights must be ≥ 0 (distance from the apex)",
                lo: v_range[0],
                hi: v_range[1],
            });
        }
        let (sin, cos) = half_angle.sin_cos();
        Ok(Cone {
            frame,
            half_angle,
            sin,
            cos,
            v_range,
        })
    }

    /// Apex.
    pub fn apex(&self) -> P3 {
        self.frame.origin()
    }
    /// Half-angle α in radians, in (0, π/2).
    pub fn half_angle(&self) -> f64 {
        self.half_angle
    }
    /// The frame (origin = apex, z = axis, x = seam).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Slant range [v0, v1].
    pub fn v_range(&self) -> [f64; 2] {
        self.v_range
    }
}

impl Surface for Cone {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        ([0.0, TAU], self.v_range)
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let (s, c) = u.sin_cos();
        let rho = v * self.sin;
        self.frame.point(rho * c, rho * s, v * self.cos)
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let f = &self.frame;
        let (s, c) = u.sin_cos();
        let (sa, ca) = (self.sin, self.cos);
        SurfaceDerivs {
            p: f.point(v * sa * c, v * sa * s, v * ca),
            su: f.vector(-v * sa * s, v * sa * c, 0.0),
            sv: f.vector(sa * c, sa * s, ca),
            suu: f.vector(-v * sa * c, -v * sa * s, 0.0),
            suv: f.vector(-sa * s, sa * c, 0.0),
            svv: V3::zeros(),
        }
    }
    /// Exact: u = atan2(y, x) in [0, 2π) and v = ρ sin α + z cos α (the
    /// projection on the generator in the half-plane of p, which is always
    /// the nearest one) clamped to [v0, v1], in local coordinates
    /// (ρ = √(x² + y²)). On the axis (ρ ≤ 1e-14·|p − a|) u is the hint's u
    /// (wrapped), or 0.
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let d = self.frame.to_local(p);
        let rho = d.x.hypot(d.y);
        let u = if rho > 1e-14 * d.norm() {
            wrap(d.y.atan2(d.x), 0.0, TAU)
        } else {
            finite_hint(hint).map_or(0.0, |h| wrap(h[0], 0.0, TAU))
        };
        let v = (rho * self.sin + d.z * self.cos).clamp(self.v_range[0], self.v_range[1]);
        Some([u, v])
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [Some(TAU), None]
    }
    /// The apex, when the face reaches it.
    fn singular_points(&self) -> Vec<P3> {
        if self.v_range()[0] <= 0.0 {
            vec![self.apex()]
        } else {
            Vec::new()
        }
    }
    /// True within 1e-10·L of the apex ([`SINGULAR_REL`]), L = v1 for a
    /// bounded cone and 1 model unit for an unbounded one.
    fn is_singular(&self, _u: f64, v: f64) -> bool {
        let l = if self.v_range[1].is_finite() {
            self.v_range[1]
        } else {
            1.0
        };
        v.abs() <= SINGULAR_REL * l
    }
}
