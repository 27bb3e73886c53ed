//! A curve on a surface: C(t) = S(P(t)) for a curve P in the surface's
//! (u,v) plane — how a trimming loop given in parameter space becomes a
//! model edge.
//!
//! Derivatives by the chain rule, with P = (u(t), v(t)):
//! C' = S_u u' + S_v v',
//! C'' = S_uu u'² + 2 S_uv u' v' + S_vv v'² + S_u u'' + S_v v''.

use std::sync::Arc;

use bubblemesh_core::geom::{Curve, Surface, P3, V3};

/// The image on `surface` of the parameter-space curve `pcurve` (whose x, y
/// are u, v; its z is ignored).
#[derive(Debug, Clone)]
pub struct CurveOnSurface {
    /// The surface the curve lies on.
    pub surface: Arc<dyn Surface>,
    /// The curve in the surface's (u,v) (x = u, y = v).
    pub pcurve: Arc<dyn Curve>,
}

impl Curve for CurveOnSurface {
    fn interval(&self) -> (f64, f64) {
        self.pcurve.interval()
    }
    fn point(&self, t: f64) -> P3 {
        let q = self.pcurve.point(t);
        self.surface.point(q.x, q.y)
    }
    fn d1(&self, t: f64) -> V3 {
        let q = self.pcurve.point(t);
        let dq = self.pcurve.d1(t);
        let s = self.surface.derivs(q.x, q.y);
        s.su * dq.x + s.sv * dq.y
    }
    fn d2(&self, t: f64) -> V3 {
        let q = self.pcurve.point(t);
        let dq = self.pcurve.d1(t);
        let ddq = self.pcurve.d2(t);
        let s = self.surface.derivs(q.x, q.y);
        s.suu * (dq.x * dq.x)
            + s.suv * (2.0 * dq.x * dq.y)
            + s.svv * (dq.y * dq.y)
            + s.su * ddq.x
            + s.sv * ddq.y
    }
}
