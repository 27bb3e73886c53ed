//! A face's view of its (possibly shared, possibly periodic) surface: the
//! same point map on the parameter box the face actually uses.
//!
//! CAD surfaces are often larger than their faces (an infinite cylinder, a
//! closed B-spline of which a fillet uses a strip) and periodic in
//! directions the face does not wrap around. The engine classifies (u,v)
//! against the face's loops periodically in every direction the surface
//! reports as periodic, and does not support loops on surfaces periodic in
//! both directions; so each face gets a view that keeps a period only where
//! the face's own boundary closes through it (a full cylinder, a torus ring)
//! and otherwise presents the non-periodic box of the face's (u,v) — with u
//! unwrapped across the surface's seam where the face straddles it.

use std::sync::Arc;

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3};

/// The surface `inner` restricted to `domain`, periodic only in the
/// directions where `periods` says so (a subset of the inner surface's
/// periods, with the same values).
///
/// Invariants: where a period is kept, `domain` is the inner domain in that
/// direction; where a period of the inner surface is dropped, `domain` is a
/// finite interval of width at most the period and [`Surface::inverse`]
/// returns parameters shifted by a multiple of the period into (or nearest
/// to) it.
#[derive(Debug, Clone)]
pub struct FaceView {
    inner: Arc<dyn Surface>,
    domain: ([f64; 2], [f64; 2]),
    periods: [Option<f64>; 2],
}

impl FaceView {
    /// The view; see the type's invariants (not checked).
    pub fn new(
        inner: Arc<dyn Surface>,
        domain: ([f64; 2], [f64; 2]),
        periods: [Option<f64>; 2],
    ) -> Self {
        FaceView {
            inner,
            domain,
            periods,
        }
    }

    /// The surface viewed.
    pub fn inner(&self) -> &Arc<dyn Surface> {
        &self.inner
    }
}

impl Surface for FaceView {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        self.domain
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        self.inner.point(u, v)
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        self.inner.derivs(u, v)
    }
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        let inner_periods = self.inner.periods();
        // a hint outside the inner fundamental domain is moved into it
        let (du, dv) = self.inner.domain();
        let ilo = [du[0], dv[0]];
        let hint = hint.map(|mut h| {
            for c in 0..2 {
                if let Some(t) = inner_periods[c] {
                    h[c] = ilo[c] + (h[c] - ilo[c]).rem_euclid(t);
                }
            }
            h
        });
        let mut uv = self.inner.inverse(p, hint)?;
        let d = [self.domain.0, self.domain.1];
        for c in 0..2 {
            if let (Some(t), None) = (inner_periods[c], self.periods[c]) {
                // the image of uv[c] nearest the centre of the face's range
                let mid = 0.5 * (d[c][0] + d[c][1]);
                uv[c] += t * ((mid - uv[c]) / t).round();
            }
        }
        Some(uv)
    }
    fn periods(&self) -> [Option<f64>; 2] {
        self.periods
    }
    fn is_singular(&self, u: f64, v: f64) -> bool {
        self.inner.is_singular(u, v)
    }
    fn singular_points(&self) -> Vec<P3> {
        self.inner.singular_points()
    }
    fn is_planar(&self) -> bool {
        self.inner.is_planar()
    }
}
