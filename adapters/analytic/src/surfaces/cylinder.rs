//! The circular cylinder.

use std::f64::consts::TAU;

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3, V3};

use super::{check_radius, check_range, finite3, finite_hint, wrap, Frame, SurfaceError};

/// The circular cylinder of radius r around the axis through o =
/// `frame.origin()` along z:
///
/// S(u,v) = o + r·(cos u·x + sin u·y) + v·z
///
/// u ∈ [0, 2π] is the angle in radians, periodic with period 2π (seam
/// towards x); v ∈ [v0, v1] is the height along the axis in model units,
/// v0 < v1, either end possibly infinite (the default is the whole line).
/// No singular points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    frame: Frame,
    radius: f64,
    v_range: [f64; 2],
}

impl Cylinder {
    /// The infinite cylinder (v ∈ (−∞, ∞)) with axis through `origin` along
    /// `axis` (any non-zero length; the seam direction follows
    /// [`Frame::new`]).
    pub fn new(origin: P3, axis: V3, radius: f64) -> Result<Self, SurfaceError> {
        Self::with_frame(
            Frame::new(origin, axis)?,
            radius,
            [f64::NEG_INFINITY, f64::INFINITY],
        )
    }

    /// The cylinder between heights v0 < v1 (finite) along the axis.
    pub fn bounded(
        origin: P3,
        axis: V3,
        radius: f64,
        v0: f64,
        v1: f64,
    ) -> Result<Self, SurfaceError> {
        check_range(
            [v0, v1],
            false,
            "cylinder heights must be finite with v0 < v1",
        )?;
        Self::with_frame(Frame::new(origin, axis)?, radius, [v0, v1])
    }

    /// The cylinder in `frame` (axis z, seam x) with height range `v_range`
    /// (v0 < v1, infinite ends allowed).
    pub fn with_frame(frame: Frame, radius: f64, v_range: [f64; 2]) -> Result<Self, SurfaceError> {
        finite3(&frame.origin().coords, "cylinder origin")?;
        check_radius(radius)?;
        check_range(v_range, true, "cylinder heights need v0 < v1")?;
        Ok(Cylinder {
            frame,
            radius,
            v_range,
        })
    }

    /// Radius (model units), > 0.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// The frame (origin on the axis at v = 0, z = axis, x = seam).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Height range [v0, v1].
    pub fn v_range(&self) -> [f64; 2] {
        self.v_range
    }
}

impl Surface for Cylinder {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        ([0.0, TAU], self.v_range)
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let (s, c) = u.sin_cos();
        self.frame.point(self.radius * c, self.radius * s, v)
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let r = self.radius;
        let f = &self.frame;
        let (s, c) = u.sin_cos();
        SurfaceDerivs {
            p: f.point(r * c, r * s, v),
            su: f.vector(-r * s, r * c, 0.0),
            sv: f.z(),
            suu: f.vector(-r * c, -r * s, 0.0),
            suv: f.vector(0.0, 0.0, 0.0),
            svv: f.vector(0.0, 0.0, 0.0),
        }
    }
    /// Exact: u = atan2(y, x) in [0, 2π), v = z clamped to [v0, v1] (local
    /// coordinates). On the axis (√(x² + y²) ≤ 1e-14·r) u is the hint's u
    /// (wrapped), or 0.
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let d = self.frame.to_local(p);
        let u = if d.x.hypot(d.y) > 1e-14 * self.radius {
            wrap(d.y.atan2(d.x), 0.0, TAU)
        } else {
            finite_hint(hint).map_or(0.0, |h| wrap(h[0], 0.0, TAU))
        };
        Some([u, d.z.clamp(self.v_range[0], self.v_range[1])])
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [Some(TAU), None]
    }
}
