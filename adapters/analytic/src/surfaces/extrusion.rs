//! The extrusion (general cylinder) of a profile curve.

use std::sync::Arc;

use bubblemesh_core::geom::{Curve, Surface, SurfaceDerivs, P3, V3};

use super::{
    area_singular, area_singular_of, check_range, finite3, newton_inverse, typical_partials, wrap,
    SurfaceError,
};

/// The profile curve C(t), t ∈ [t0, t1], swept along the vector d:
///
/// S(u,v) = C(u) + v·d
///
/// u ∈ [t0, t1] is the profile's own parameter; v ∈ [v0, v1] is the
/// dimensionless sweep fraction ([0, 1] by default, so the surface spans
/// C to C + d; infinite ends allowed). When the profile is closed
/// ([`Curve::is_closed`]) u is periodic with period t1 − t0 and is taken
/// modulo the period before the curve is evaluated.
///
/// Derivatives: S_u = C'(u), S_v = d, S_uu = C''(u), S_uv = S_vv = 0.
/// Points where C' is zero or parallel to d are singular
/// (|S_u × S_v| ≤ [`SINGULAR_REL`](super::SINGULAR_REL) × typical |C'| × |d|).
#[derive(Clone, Debug)]
pub struct Extrusion {
    profile: Arc<dyn Curve>,
    direction: V3,
    v_range: [f64; 2],
    t: [f64; 2],
    closed: bool,
    size: f64,
    scale: [f64; 2],
}

impl Extrusion {
    /// `profile` swept by `direction`, v ∈ [0, 1].
    pub fn new(profile: Arc<dyn Curve>, direction: V3) -> Result<Self, SurfaceError> {
        Self::with_range(profile, direction, [0.0, 1.0])
    }

    /// `profile` swept by v·`direction` for v ∈ `v_range` (v0 < v1,
    /// infinite ends allowed).
    ///
    /// Rejected: a non-finite or zero direction, a profile with a non-finite
    /// interval or points, a profile that is a point or a segment parallel
    /// to the direction.
    pub fn with_range(
        profile: Arc<dyn Curve>,
        direction: V3,
        v_range: [f64; 2],
    ) -> Result<Self, SurfaceError> {
        finite3(&direction, "extrusion direction")?;
        if direction == V3::zeros() {
            return Err(SurfaceError::BadAxis("the extrusion direction is zero"));
        }
        check_range(v_range, true, "extrusion range needs v0 < v1")?;
        let (t0, t1) = profile.interval();
        if !(t0.is_finite() && t1.is_finite() && t0 < t1) {
            return Err(SurfaceError::DegenerateProfile(
                "the profile interval must be finite and non-empty",
            ));
        }
        let (mut lo, mut hi) = (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY));
        let (mut cross, mut tangent) = (0.0f64, 0.0f64);
        for k in 0..=64 {
            let t = t0 + k as f64 / 64.0 * (t1 - t0);
            let (q, d1) = (profile.point(t), profile.d1(t));
            if !q.iter().chain(d1.iter()).all(|x| x.is_finite()) {
                return Err(SurfaceError::DegenerateProfile(
                    "the profile evaluates to non-finite points",
                ));
            }
            lo = lo.inf(&q.coords);
            hi = hi.sup(&q.coords);
            cross = cross.max(d1.cross(&direction).norm());
            tangent = tangent.max(d1.norm());
        }
        if !(cross > 1e-12 * tangent * direction.norm()) {
            return Err(SurfaceError::DegenerateProfile(
                "the profile is a point or runs parallel to the extrusion direction",
            ));
        }
        let sweep = v_range[1] - v_range[0];
        let size = (hi - lo).norm()
            + if sweep.is_finite() {
                sweep * direction.norm()
            } else {
                0.0
            };
        let mut s = Extrusion {
            closed: profile.is_closed(),
            profile,
            direction,
            v_range,
            t: [t0, t1],
            size: size.max(f64::MIN_POSITIVE),
            scale: [1.0, 1.0],
        };
        s.scale = typical_partials(&s);
        Ok(s)
    }

    /// The profile curve (v = 0).
    pub fn profile(&self) -> &Arc<dyn Curve> {
        &self.profile
    }
    /// The sweep vector d.
    pub fn direction(&self) -> V3 {
        self.direction
    }
    /// The v range [v0, v1].
    pub fn v_range(&self) -> [f64; 2] {
        self.v_range
    }
    /// Size used by the inverse's distance check (model units): the
    /// profile's bounding-box diagonal plus the sweep length when finite.
    pub fn size(&self) -> f64 {
        self.size
    }

    fn param(&self, u: f64) -> f64 {
        if self.closed {
            wrap(u, self.t[0], self.t[1] - self.t[0])
        } else {
            u
        }
    }
}

impl Surface for Extrusion {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (self.t, self.v_range)
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        self.profile.point(self.param(u)) + self.direction * v
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let (c, c1, c2) = self.profile.derivs(self.param(u));
        SurfaceDerivs {
            p: c + self.direction * v,
            su: c1,
            sv: self.direction,
            suu: c2,
            suv: V3::zeros(),
            svv: V3::zeros(),
        }
    }
    fn tangents(&self, u: f64, v: f64) -> (P3, V3, V3) {
        let (c, c1) = self.profile.tangent(self.param(u));
        (c + self.direction * v, c1, self.direction)
    }
    /// Newton on the closest-point problem (module documentation). Without
    /// a hint the start is the best of 64 profile samples, each with the v
    /// that is optimal for it ((p − C(u))·d / |d|², clamped).
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        newton_inverse(self, p, hint, self.size, || {
            let dd = self.direction.norm_squared();
            (0..=64)
                .map(|k| {
                    let u = self.t[0] + k as f64 / 64.0 * (self.t[1] - self.t[0]);
                    let v = ((p - self.profile.point(u)).dot(&self.direction) / dd)
                        .clamp(self.v_range[0], self.v_range[1]);
                    [u, v]
                })
                .collect()
        })
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [self.closed.then_some(self.t[1] - self.t[0]), None]
    }
    fn is_singular(&self, u: f64, v: f64) -> bool {
        area_singular(&self.derivs(u, v), self.scale)
    }
    fn is_singular_with(&self, _u: f64, _v: f64, su: &V3, sv: &V3) -> bool {
        area_singular_of(su, sv, self.scale)
    }
}
