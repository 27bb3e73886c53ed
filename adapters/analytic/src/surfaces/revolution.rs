//! The surface of revolution of a profile curve.

use std::f64::consts::TAU;
use std::sync::Arc;

use bubblemesh_core::geom::{Curve, Surface, SurfaceDerivs, P3, V3};

use super::{
    area_singular, area_singular_of, finite3, newton_inverse, typical_partials, wrap, SurfaceError,
};

/// The profile curve C(t), t ∈ [t0, t1], rotated about the axis through o
/// with unit direction a:
///
/// S(u,v) = o + R_u(C(v) − o),  R_u(q) = (q·a)a + cos u·(q − (q·a)a) + sin u·(a × q)
///
/// (Rodrigues' rotation by the angle u about a, counter-clockwise seen from
/// the tip of a). u ∈ [0, 2π] is the rotation angle in radians, periodic
/// with period 2π, and S(0, v) = C(v) is the profile itself (the seam);
/// v ∈ [t0, t1] is the profile's own parameter. When the profile is closed
/// ([`Curve::is_closed`]) v is periodic too, with period t1 − t0, and is
/// taken modulo the period before the curve is evaluated.
///
/// The profile normally lies in a plane containing the axis on one side of
/// it, but any curve is accepted (the formula is a rigid rotation). Points
/// where the profile meets the axis (the poles of a sphere of revolution)
/// are singular; [`Surface::is_singular`] uses the generic test
/// |S_u × S_v| ≤ [`SINGULAR_REL`](super::SINGULAR_REL) × typical |S_u| × typical |S_v|.
///
/// Derivatives: S_u = R'_u(q), S_v = R_u(C'), S_uu = R''_u(q),
/// S_uv = R'_u(C'), S_vv = R_u(C''), with q = C(v) − o, exact given the
/// curve's exact C' and C''.
#[derive(Clone, Debug)]
pub struct Revolution {
    profile: Arc<dyn Curve>,
    origin: P3,
    axis: V3,
    t: [f64; 2],
    closed: bool,
    size: f64,
    scale: [f64; 2],
}

impl Revolution {
    /// The surface swept by `profile` turning about the axis through
    /// `axis_origin` along `axis_direction` (any non-zero length).
    ///
    /// Rejected: non-finite or zero axis, a profile with a non-finite
    /// interval or points, a profile lying on the axis.
    pub fn new(
        profile: Arc<dyn Curve>,
        axis_origin: P3,
        axis_direction: V3,
    ) -> Result<Self, SurfaceError> {
        finite3(&axis_origin.coords, "axis origin")?;
        finite3(&axis_direction, "axis direction")?;
        let axis = axis_direction
            .try_normalize(0.0)
            .ok_or(SurfaceError::BadAxis(
                "the axis direction is the zero vector",
            ))?;
        let (t0, t1) = profile.interval();
        if !(t0.is_finite() && t1.is_finite() && t0 < t1) {
            return Err(SurfaceError::DegenerateProfile(
                "the profile interval must be finite and non-empty",
            ));
        }
        let (mut rmax, mut zmin, mut zmax) = (0.0f64, f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..=64 {
            let q = profile.point(t0 + k as f64 / 64.0 * (t1 - t0)) - axis_origin;
            if !q.iter().all(|x| x.is_finite()) {
                return Err(SurfaceError::DegenerateProfile(
                    "the profile evaluates to non-finite points",
                ));
            }
            let z = q.dot(&axis);
            rmax = rmax.max((q - axis * z).norm());
            zmin = zmin.min(z);
            zmax = zmax.max(z);
        }
        let size = (2.0 * rmax).hypot(zmax - zmin);
        if !(rmax > 1e-12 * size) {
            return Err(SurfaceError::DegenerateProfile(
                "the profile lies on the axis",
            ));
        }
        let mut s = Revolution {
            closed: profile.is_closed(),
            profile,
            origin: axis_origin,
            axis,
            t: [t0, t1],
            size,
            scale: [1.0, 1.0],
        };
        s.scale = typical_partials(&s);
        Ok(s)
    }

    /// The profile curve (u = 0).
    pub fn profile(&self) -> &Arc<dyn Curve> {
        &self.profile
    }
    /// A point of the axis.
    pub fn axis_origin(&self) -> P3 {
        self.origin
    }
    /// Unit axis direction.
    pub fn axis_direction(&self) -> V3 {
        self.axis
    }
    /// Bounding-box diagonal of the surface (model units): the size used by
    /// the inverse's distance check.
    pub fn size(&self) -> f64 {
        self.size
    }

    fn param(&self, v: f64) -> f64 {
        if self.closed {
            wrap(v, self.t[0], self.t[1] - self.t[0])
        } else {
            v
        }
    }

    /// (R_u x, R'_u x, R''_u x).
    fn rot(&self, x: V3, s: f64, c: f64) -> [V3; 3] {
        let along = self.axis * self.axis.dot(&x);
        let w = x - along;
        let j = self.axis.cross(&x);
        [along + w * c + j * s, j * c - w * s, -(w * c + j * s)]
    }
}

impl Surface for Revolution {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        ([0.0, TAU], self.t)
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let (s, c) = u.sin_cos();
        let q = self.profile.point(self.param(v)) - self.origin;
        self.origin + self.rot(q, s, c)[0]
    }
    /// From the profile's [`Curve::tangent`] (no second derivatives).
    fn tangents(&self, u: f64, v: f64) -> (P3, V3, V3) {
        let (c0, c1) = self.profile.tangent(self.param(v));
        let (s, c) = u.sin_cos();
        let q = self.rot(c0 - self.origin, s, c);
        (self.origin + q[0], q[1], self.rot(c1, s, c)[0])
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let (c0, c1, c2) = self.profile.derivs(self.param(v));
        let (s, c) = u.sin_cos();
        let q = self.rot(c0 - self.origin, s, c);
        let q1 = self.rot(c1, s, c);
        let q2 = self.rot(c2, s, c);
        SurfaceDerivs {
            p: self.origin + q[0],
            su: q[1],
            sv: q1[0],
            suu: q[2],
            suv: q1[1],
            svv: q2[0],
        }
    }
    /// Newton on the closest-point problem (module documentation). Without
    /// a hint the start is the best of 64 profile samples, each turned by
    /// the angle that brings it into the half-plane of p (exact in u).
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        newton_inverse(self, p, hint, self.size, || {
            let dp = p - self.origin;
            let wp = dp - self.axis * self.axis.dot(&dp);
            (0..64)
                .map(|k| {
                    let v = self.t[0] + (k as f64 + 0.5) / 64.0 * (self.t[1] - self.t[0]);
                    let q = self.profile.point(v) - self.origin;
                    let wq = q - self.axis * self.axis.dot(&q);
                    let u = self.axis.dot(&wq.cross(&wp)).atan2(wq.dot(&wp));
                    [if u.is_finite() { u } else { 0.0 }, v]
                })
                .collect()
        })
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [Some(TAU), self.closed.then_some(self.t[1] - self.t[0])]
    }
    fn is_singular(&self, u: f64, v: f64) -> bool {
        area_singular(&self.derivs(u, v), self.scale)
    }
    fn is_singular_with(&self, _u: f64, _v: f64, su: &V3, sv: &V3) -> bool {
        area_singular_of(su, sv, self.scale)
    }
}
