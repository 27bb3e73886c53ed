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
//!
//! A view may also *turn* the parameter plane by half a turn, (u,v) ↦
//! (−u, −v). The engine classifies a point of a face that wraps around its
//! surface in u by the parity of the boundary loops met along +v, so it
//! reads the face as ending below its highest wrapping loop; a face that
//! runs from its loop up to a pole at the top of its v range (a spherical
//! cap around the north pole) is presented turned, with the pole at the
//! bottom. The half turn keeps the orientation: S_u′ × S_v′ = S_u × S_v.

use std::sync::Arc;

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3, V3};

/// The surface `inner` restricted to `domain`, periodic only in the
/// directions where `periods` says so (a subset of the inner surface's
/// periods, with the same values).
///
/// Invariants: where a period is kept, `domain` is the inner domain in that
/// direction; where a period of the inner surface is dropped, `domain` is a
/// finite interval of width at most the period and [`Surface::inverse`]
/// returns parameters shifted by a multiple of the period into (or nearest
/// to) it.
///
/// With `turned`, the view's parameters are (u′, v′) = (−u, −v) of the
/// inner surface's (u, v); `domain` is always given in the inner
/// surface's parameters.
#[derive(Debug, Clone)]
pub struct FaceView {
    inner: Arc<dyn Surface>,
    /// In the inner surface's parameters.
    domain: ([f64; 2], [f64; 2]),
    periods: [Option<f64>; 2],
    turned: bool,
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
            turned: false,
        }
    }

    /// The same view with its parameter plane turned by half a turn (type
    /// documentation).
    pub fn turned(mut self) -> Self {
        self.turned = !self.turned;
        self
    }

    /// Inner parameters of view parameters (and back: the map is an
    /// involution).
    fn map(&self, u: f64, v: f64) -> (f64, f64) {
        if self.turned {
            (-u, -v)
        } else {
            (u, v)
        }
    }

    /// The surface viewed.
    pub fn inner(&self) -> &Arc<dyn Surface> {
        &self.inner
    }
}

impl Surface for FaceView {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        let (u, v) = self.domain;
        if self.turned {
            ([-u[1], -u[0]], [-v[1], -v[0]])
        } else {
            (u, v)
        }
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let (u, v) = self.map(u, v);
        self.inner.point(u, v)
    }
    /// With the half turn the first partials change sign and the second
    /// ones do not.
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let (a, b) = self.map(u, v);
        let mut d = self.inner.derivs(a, b);
        if self.turned {
            d.su = -d.su;
            d.sv = -d.sv;
        }
        d
    }
    fn tangents(&self, u: f64, v: f64) -> (P3, V3, V3) {
        let (a, b) = self.map(u, v);
        let (p, su, sv) = self.inner.tangents(a, b);
        if self.turned {
            (p, -su, -sv)
        } else {
            (p, su, sv)
        }
    }
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        let hint = hint.map(|h| {
            let (a, b) = self.map(h[0], h[1]);
            [a, b]
        });
        let uv = self.inner_inverse(p, hint)?;
        let (a, b) = self.map(uv[0], uv[1]);
        Some([a, b])
    }
    fn periods(&self) -> [Option<f64>; 2] {
        self.periods
    }
    fn is_singular(&self, u: f64, v: f64) -> bool {
        let (u, v) = self.map(u, v);
        self.inner.is_singular(u, v)
    }
    /// The half turn only flips the partials' signs, not their cross
    /// product's length.
    fn is_singular_with(&self, u: f64, v: f64, su: &V3, sv: &V3) -> bool {
        let (u, v) = self.map(u, v);
        self.inner.is_singular_with(u, v, su, sv)
    }
    fn singular_points(&self) -> Vec<P3> {
        self.inner.singular_points()
    }
    fn is_planar(&self) -> bool {
        self.inner.is_planar()
    }
}

impl FaceView {
    /// [`Surface::inverse`] in the inner surface's parameters.
    fn inner_inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
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
}
