//! Node constraints (thesis §4.5): a [`Carrier`] says how the bubbles of one
//! entity move and stay on it. The face's carrier (on a trimmed surface) is
//! [`crate::face::carrier::OnFace`]; the volume's is in `crate::volume`.
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

use crate::geom::{P3, V3};
use crate::model::EntityRef;

/// What a carrier hands back from a move for the next one from the same
/// parameters ([`Carrier::advance_kept`]): the surface's partials S_u, S_v
/// there.
pub type Kept = (V3, V3);

/// How bubbles of one entity move.
pub trait Carrier: Sync {
    /// The entity the bubbles belong to.
    fn entity(&self) -> EntityRef;
    /// Moves a bubble at `pos` (parameters `params`) by the object-space
    /// displacement `dx`. Returns the new point and parameters, or `None`
    /// when the move would leave the entity (the bubble then stays where it
    /// is).
    fn advance(&self, pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])>;
    /// [`Carrier::advance`], given what the move that brought the bubble
    /// to `params` handed back (`kept`), and handing back what the next
    /// move from the new parameters may use: a curved face's partials
    /// S_u, S_v there, so that stage 2 evaluates the surface once per
    /// bubble and step instead of twice. The result must be that of
    /// `advance` whatever is kept (`kept` is only ever what this carrier
    /// returned for the same `params`). By default nothing is kept.
    fn advance_kept(
        &self,
        pos: &P3,
        params: [f64; 2],
        dx: &V3,
        _kept: Option<Kept>,
    ) -> Option<(P3, [f64; 2], Option<Kept>)> {
        self.advance(pos, params, dx).map(|(p, uv)| (p, uv, None))
    }
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
    /// The model-space length of the parameter step `duv` taken at
    /// `params`, to first order (|S_u·du + S_v·dv|); `None` where the
    /// carrier has no parameters or they degenerate there. Unlike a chord,
    /// it does not shrink when the step wraps around a periodic surface.
    fn tangent_length(&self, _params: [f64; 2], _duv: [f64; 2]) -> Option<f64> {
        None
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
