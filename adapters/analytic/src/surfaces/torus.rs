//! The ring torus.

use std::f64::consts::TAU;

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3, V3};

use super::{finite3, finite_hint, wrap, Frame, SurfaceError};
use crate::curves::GeometryError;

/// The ring torus with centre c = `frame.origin()`, axis z, major radius R
/// (centre to the tube's core circle) and minor radius r (of the tube):
///
/// S(u,v) = c + ((R + r cos v) cos u)·x + ((R + r cos v) sin u)·y + (r sin v)·z
///
/// u ∈ [0, 2π] (angle around the axis) and v ∈ [0, 2π] (angle around the
/// tube, v = 0 on the outer equator, v = π/2 on top) are both periodic with
/// period 2π, in radians. With R > r > 0 there are no singular points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Torus {
    frame: Frame,
    major: f64,
    minor: f64,
}

impl Torus {
    /// The torus centred at `center` around `axis` (any non-zero length;
    /// seam direction as in [`Frame::new`]).
    pub fn new(center: P3, axis: V3, major: f64, minor: f64) -> Result<Self, SurfaceError> {
        Self::with_frame(Frame::new(center, axis)?, major, minor)
    }

    /// The torus in `frame` (centre at the origin, axis z, seam x).
    pub fn with_frame(frame: Frame, major: f64, minor: f64) -> Result<Self, SurfaceError> {
        finite3(&frame.origin().coords, "torus centre")?;
        if !major.is_finite() || !minor.is_finite() {
            return Err(GeometryError::NotFinite("torus radius").into());
        }
        if !(minor > 0.0 && major > minor) {
            return Err(SurfaceError::BadTorus { major, minor });
        }
        Ok(Torus {
            frame,
            major,
            minor,
        })
    }

    /// Centre.
    pub fn center(&self) -> P3 {
        self.frame.origin()
    }
    /// Major radius R (model units).
    pub fn major_radius(&self) -> f64 {
        self.major
    }
    /// Minor radius r (model units), 0 < r < R.
    pub fn minor_radius(&self) -> f64 {
        self.minor
    }
    /// The frame (origin = centre, z = axis, x = seam).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
}

impl Surface for Torus {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        ([0.0, TAU], [0.0, TAU])
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let ((su, cu), (sv, cv)) = (u.sin_cos(), v.sin_cos());
        let rho = self.major + self.minor * cv;
        self.frame.point(rho * cu, rho * su, self.minor * sv)
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let f = &self.frame;
        let r = self.minor;
        let ((su, cu), (sv, cv)) = (u.sin_cos(), v.sin_cos());
        let rho = self.major + r * cv;
        SurfaceDerivs {
            p: f.point(rho * cu, rho * su, r * sv),
            su: f.vector(-rho * su, rho * cu, 0.0),
            sv: f.vector(-r * sv * cu, -r * sv * su, r * cv),
            suu: f.vector(-rho * cu, -rho * su, 0.0),
            suv: f.vector(r * sv * su, -r * sv * cu, 0.0),
            svv: f.vector(-r * cv * cu, -r * cv * su, -r * sv),
        }
    }
    /// Exact: u = atan2(y, x), v = atan2(z, ρ − R), both in [0, 2π), in
    /// local coordinates (ρ = √(x² + y²)). On the axis (ρ ≤ 1e-14·R) u is
    /// the hint's u, or 0; on the core circle (|(ρ − R, z)| ≤ 1e-14·R) v is
    /// the hint's v, or 0.
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let hint = finite_hint(hint);
        let d = self.frame.to_local(p);
        let rho = d.x.hypot(d.y);
        let eps = 1e-14 * self.major;
        let u = if rho > eps {
            wrap(d.y.atan2(d.x), 0.0, TAU)
        } else {
            hint.map_or(0.0, |h| wrap(h[0], 0.0, TAU))
        };
        let v = if (rho - self.major).hypot(d.z) > eps {
            wrap(d.z.atan2(rho - self.major), 0.0, TAU)
        } else {
            hint.map_or(0.0, |h| wrap(h[1], 0.0, TAU))
        };
        Some([u, v])
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [Some(TAU), Some(TAU)]
    }
}
