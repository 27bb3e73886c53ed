//! The sphere.

use std::f64::consts::{FRAC_PI_2, TAU};

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3};

use super::{check_radius, finite3, finite_hint, wrap, Frame, SurfaceError, SINGULAR_REL};

/// The sphere of centre c = `frame.origin()` and radius r:
///
/// S(u,v) = c + r·(cos v cos u·x + cos v sin u·y + sin v·z)
///
/// in the frame (x, y, z). u ∈ [0, 2π] is the longitude in radians,
/// periodic with period 2π (the seam u = 0 is the half meridian towards x);
/// v ∈ [−π/2, π/2] is the latitude in radians. The poles v = ±π/2 (the
/// points c ± r·z) are singular: S_u = 0 there.
///
/// Invariants: r finite and > 0, centre finite, frame orthonormal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    frame: Frame,
    radius: f64,
}

impl Sphere {
    /// The sphere with poles along the world ±z axis and seam towards +x.
    pub fn new(center: P3, radius: f64) -> Result<Self, SurfaceError> {
        Self::with_frame(Frame::axis_aligned(center), radius)
    }

    /// The sphere centred at `frame.origin()`, poles along ±`frame.z()`,
    /// seam towards `frame.x()`.
    pub fn with_frame(frame: Frame, radius: f64) -> Result<Self, SurfaceError> {
        finite3(&frame.origin().coords, "sphere centre")?;
        check_radius(radius)?;
        Ok(Sphere { frame, radius })
    }

    /// Centre.
    pub fn center(&self) -> P3 {
        self.frame.origin()
    }
    /// Radius (model units), > 0.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// The frame (origin = centre, z = polar axis, x = seam direction).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
}

impl Surface for Sphere {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        ([0.0, TAU], [-FRAC_PI_2, FRAC_PI_2])
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let ((su, cu), (sv, cv)) = (u.sin_cos(), v.sin_cos());
        self.frame.point(
            self.radius * cv * cu,
            self.radius * cv * su,
            self.radius * sv,
        )
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let r = self.radius;
        let f = &self.frame;
        let ((su, cu), (sv, cv)) = (u.sin_cos(), v.sin_cos());
        SurfaceDerivs {
            p: f.point(r * cv * cu, r * cv * su, r * sv),
            su: f.vector(-r * cv * su, r * cv * cu, 0.0),
            sv: f.vector(-r * sv * cu, -r * sv * su, r * cv),
            suu: f.vector(-r * cv * cu, -r * cv * su, 0.0),
            suv: f.vector(r * sv * su, -r * sv * cu, 0.0),
            svv: f.vector(-r * cv * cu, -r * cv * su, -r * sv),
        }
    }
    /// Exact: u = atan2(y, x) taken into [0, 2π), v = atan2(z, √(x² + y²))
    /// in local coordinates. On the polar axis (√(x² + y²) ≤ 1e-14·|p − c|)
    /// v = ±π/2 exactly and u is the hint's u (wrapped), or 0; at the
    /// centre itself (every point is nearest) the hint, wrapped and clamped,
    /// or (0, 0).
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let hint = finite_hint(hint);
        let d = self.frame.to_local(p);
        let rho = d.x.hypot(d.y);
        let n = d.norm();
        let (u, v) = if rho > 1e-14 * n {
            (wrap(d.y.atan2(d.x), 0.0, TAU), d.z.atan2(rho))
        } else if n > 0.0 {
            // On the polar axis: the pole itself, at the hint's longitude.
            let u = hint.map_or(0.0, |h| wrap(h[0], 0.0, TAU));
            (u, FRAC_PI_2.copysign(d.z))
        } else {
            let h = hint.unwrap_or([0.0, 0.0]);
            (wrap(h[0], 0.0, TAU), h[1].clamp(-FRAC_PI_2, FRAC_PI_2))
        };
        Some([u, v])
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [Some(TAU), None]
    }
    /// The two poles.
    fn singular_points(&self) -> Vec<P3> {
        vec![
            self.frame.point(0.0, 0.0, self.radius),
            self.frame.point(0.0, 0.0, -self.radius),
        ]
    }
    /// True within 1e-10 rad of a pole (|cos v| ≤ [`SINGULAR_REL`]).
    fn is_singular(&self, _u: f64, v: f64) -> bool {
        v.cos().abs() <= SINGULAR_REL
    }
}
