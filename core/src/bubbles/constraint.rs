//! Node constraints (thesis §4.5): bubbles on a face stay on its surface and
//! inside its trimmed region.
//!
//! The thesis (eq. 4.5.2) maps an object-space displacement Δx to parameter
//! space by projecting it on each tangent separately, Δu = Δx·S_u/|S_u|²,
//! Δv = Δx·S_v/|S_v|², which is exact only when S_u ⟂ S_v. Here the tangent
//! displacement is solved for exactly with the first fundamental form:
//!
//! [E F; F G] [Δu; Δv] = [Δx·S_u; Δx·S_v], E = S_u·S_u, F = S_u·S_v, G = S_v·S_v,
//!
//! and the new point is S(u + Δu, v + Δv), so the bubble is on the surface
//! by construction.

use crate::geom::{Surface, P3, V3};
use crate::model::EntityRef;

use crate::face::region::Region;

/// How bubbles of one entity move.
pub trait Carrier: Sync {
    /// The entity the bubbles belong to.
    fn entity(&self) -> EntityRef;
    /// Moves a bubble at `pos` (parameters `params`) by the object-space
    /// displacement `dx`. Returns the new point and parameters, or `None`
    /// when the move would leave the entity (the bubble then stays where it
    /// is).
    fn advance(&self, pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])>;
    /// Two orthonormal tangent directions at `params` (for angular gaps).
    fn frame(&self, params: [f64; 2]) -> (V3, V3);
    /// The dimension of the entity the bubbles move in (2 surface, 3
    /// volume).
    fn dim(&self) -> u8 {
        2
    }
    /// The part of a velocity the bubble can follow: its projection on the
    /// tangent plane at `params` (everything, in a volume).
    fn project(&self, params: [f64; 2], v: &V3) -> V3 {
        let (t1, t2) = self.frame(params);
        t1 * v.dot(&t1) + t2 * v.dot(&t2)
    }
    /// Whether `params` is inside the entity.
    fn contains(&self, params: [f64; 2]) -> bool;
    /// The point at `params`.
    fn point(&self, params: [f64; 2]) -> P3;
    /// The unit normal S_u × S_v at `params` (its limit at a singular point).
    fn normal(&self, params: [f64; 2]) -> V3;
    /// Whether the entity is flat, so (u,v) orientation equals model-space
    /// orientation.
    fn planar(&self) -> bool;
}

/// Bubbles on a trimmed surface. Build it with [`OnFace::new`].
pub struct OnFace<'a> {
    pub surface: &'a dyn Surface,
    pub region: Region,
    pub entity: EntityRef,
    /// On a plane ([`Surface::is_planar`]: an affine parametrization),
    /// S_u and S_v and the tangent frame, which are the same everywhere.
    /// Why: for the six faces of case K, evaluating them per bubble and
    /// step through the trait object cost more than the forces.
    plane: Option<PlaneFrame>,
}

#[derive(Clone, Copy)]
struct PlaneFrame {
    su: V3,
    sv: V3,
    frame: (V3, V3),
}

impl<'a> OnFace<'a> {
    pub fn new(surface: &'a dyn Surface, region: Region, entity: EntityRef) -> Self {
        let mut f = OnFace {
            surface,
            region,
            entity,
            plane: None,
        };
        if surface.is_planar() {
            let (lo, hi) = f.region.bbox();
            let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
            let dv = surface.derivs(mid[0], mid[1]);
            if !f.degenerate(mid, &dv.su, &dv.sv) {
                f.plane = Some(PlaneFrame {
                    su: dv.su,
                    sv: dv.sv,
                    frame: f.frame(mid),
                });
            }
        }
        f
    }
}

/// Solves the first-fundamental-form system for the parameter step of a
/// tangent displacement `dx` (see the module docs). `None` at a degenerate
/// point (S_u × S_v = 0).
pub fn parameter_step(su: &V3, sv: &V3, dx: &V3) -> Option<[f64; 2]> {
    let (e, f, g) = (su.dot(su), su.dot(sv), sv.dot(sv));
    let det = e * g - f * f;
    if !(det > 1e-300) {
        return None;
    }
    let (a, b) = (dx.dot(su), dx.dot(sv));
    Some([(g * a - f * b) / det, (e * b - f * a) / det])
}

impl OnFace<'_> {
    /// Whether the parametrization degenerates at `uv` (the adapter says so,
    /// or S_u × S_v is tiny against |S_u|·|S_v| or against the larger of them
    /// squared): there bubbles move by projection.
    fn degenerate(&self, uv: [f64; 2], su: &V3, sv: &V3) -> bool {
        if self.surface.is_singular(uv[0], uv[1]) {
            return true;
        }
        let cross = su.cross(sv).norm();
        let scale = su.norm_squared().max(sv.norm_squared());
        !(cross > 1e-3 * scale)
    }
}

impl OnFace<'_> {
    /// Derivatives for the tangent plane at `params`; at a singular point
    /// those of a point a hair toward the middle of the domain (the tangent
    /// plane is the limit there).
    fn tangent_derivs(&self, params: [f64; 2]) -> crate::geom::SurfaceDerivs {
        let dv = self.surface.derivs(params[0], params[1]);
        if !self.degenerate(params, &dv.su, &dv.sv) {
            return dv;
        }
        let (lo, hi) = self.region.bbox();
        let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let q = [
            params[0] + 1e-6 * (mid[0] - params[0]),
            params[1] + 1e-6 * (mid[1] - params[1]),
        ];
        self.surface.derivs(q[0], q[1])
    }
}

impl Carrier for OnFace<'_> {
    fn entity(&self) -> EntityRef {
        self.entity
    }
    fn advance(&self, _pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])> {
        let uv = if let Some(pl) = &self.plane {
            let step = parameter_step(&pl.su, &pl.sv, dx)?;
            [params[0] + step[0], params[1] + step[1]]
        } else {
            let dv = self.surface.derivs(params[0], params[1]);
            if self.degenerate(params, &dv.su, &dv.sv) {
                // near a pole or an apex the first fundamental form is
                // singular: project the moved point back onto the surface
                // instead
                self.surface.inverse(&(dv.p + dx), Some(params))?
            } else {
                let step = parameter_step(&dv.su, &dv.sv, dx)?;
                [params[0] + step[0], params[1] + step[1]]
            }
        };
        let uv = self.region.wrap(uv);
        if !(uv[0].is_finite() && uv[1].is_finite()) || !self.contains(uv) {
            return None;
        }
        Some((self.surface.point(uv[0], uv[1]), uv))
    }
    fn frame(&self, params: [f64; 2]) -> (V3, V3) {
        if let Some(pl) = &self.plane {
            return pl.frame;
        }
        let dv = self.tangent_derivs(params);
        let (a, b) = if dv.su.norm_squared() >= dv.sv.norm_squared() {
            (dv.su, dv.sv)
        } else {
            (dv.sv, dv.su)
        };
        let t1 = a.normalize();
        let mut t2 = b - t1 * t1.dot(&b);
        if t2.norm_squared() <= 0.0 {
            t2 = t1.cross(&V3::z()).cross(&t1);
        }
        (t1, t2.normalize())
    }
    fn contains(&self, params: [f64; 2]) -> bool {
        match self.surface.trim(params[0], params[1]) {
            Some(inside) => inside && self.region.contains(params[0], params[1]),
            None => self.region.contains(params[0], params[1]),
        }
    }
    fn point(&self, params: [f64; 2]) -> P3 {
        self.surface.point(params[0], params[1])
    }
    fn normal(&self, params: [f64; 2]) -> V3 {
        let dv = self.tangent_derivs(params);
        dv.su.cross(&dv.sv).normalize()
    }
    fn planar(&self) -> bool {
        self.surface.is_planar()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_fundamental_form_step_is_exact_on_a_skewed_plane() {
        // S(u,v) = u·(1,0,0) + v·(1,1,0): S_u and S_v are not orthogonal, so
        // the thesis's separate projections (eq. 4.5.2) would be wrong.
        let su = V3::new(1.0, 0.0, 0.0);
        let sv = V3::new(1.0, 1.0, 0.0);
        let dx = V3::new(0.3, 0.2, 0.0);
        let s = parameter_step(&su, &sv, &dx).unwrap();
        let back = su * s[0] + sv * s[1];
        assert!((back - dx).norm() < 1e-14);
        // eq. 4.5.2 as printed misses:
        let naive = su * (dx.dot(&su) / su.dot(&su)) + sv * (dx.dot(&sv) / sv.dot(&sv));
        assert!((naive - dx).norm() > 0.1);
    }

    #[test]
    fn normal_component_is_dropped() {
        let su = V3::new(2.0, 0.0, 0.0);
        let sv = V3::new(0.0, 0.5, 0.0);
        let s = parameter_step(&su, &sv, &V3::new(0.2, 0.1, 5.0)).unwrap();
        assert!((s[0] - 0.1).abs() < 1e-15 && (s[1] - 0.2).abs() < 1e-15);
    }
}
