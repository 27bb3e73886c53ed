//! The carrier of a face's bubbles (thesis §4.5): bubbles move on the
//! face's surface through their (u,v) and stay inside its trimmed region.
//! The parameter step of a displacement is solved with the first
//! fundamental form ([`parameter_step`]; see [`crate::bubbles::constraint`]
//! for why not eq. 4.5.2 as printed); near a singular point of the
//! parametrization the moved point is projected back instead.

use crate::bubbles::constraint::{parameter_step, Carrier, Kept};
use crate::face::region::Region;
use crate::geom::{Surface, P3, V3};
use crate::model::EntityRef;

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
    /// Tells this carrier's entry in [`LAST_TANGENTS`] from another's.
    id: u64,
}

/// The last [`Surface::tangents`] a carrier asked on this thread: (carrier
/// id, (u,v) bits, the answer). A stage-2 step moves a bubble to new (u,v)
/// (its point) and then projects its velocity on the tangent plane there
/// (the partials at the same (u,v)): one evaluation instead of two, which
/// on a NURBS face is most of the step.
type Tangents = (u64, [u64; 2], P3, V3, V3);

thread_local! {
    static LAST_TANGENTS: std::cell::Cell<Option<Tangents>> = const { std::cell::Cell::new(None) };
}

/// Ids for [`OnFace::id`].
static NEXT_CARRIER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

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
            id: NEXT_CARRIER.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
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

impl OnFace<'_> {
    /// [`Surface::tangents`] at `uv`, from [`LAST_TANGENTS`] when it was
    /// the last one asked here (the same numbers).
    fn tangents(&self, uv: [f64; 2]) -> (P3, V3, V3) {
        let key = [uv[0].to_bits(), uv[1].to_bits()];
        if let Some((id, k, p, su, sv)) = LAST_TANGENTS.get() {
            if id == self.id && k == key {
                return (p, su, sv);
            }
        }
        let (p, su, sv) = self.surface.tangents(uv[0], uv[1]);
        LAST_TANGENTS.set(Some((self.id, key, p, su, sv)));
        (p, su, sv)
    }

    /// Whether the parametrization degenerates at `uv` (the adapter says so,
    /// or S_u × S_v is tiny against |S_u|·|S_v| or against the larger of them
    /// squared): there bubbles move by projection.
    fn degenerate(&self, uv: [f64; 2], su: &V3, sv: &V3) -> bool {
        if self.surface.is_singular_with(uv[0], uv[1], su, sv) {
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
    fn tangent_derivs(&self, params: [f64; 2]) -> (V3, V3) {
        let (_, su, sv) = self.tangents(params);
        if !self.degenerate(params, &su, &sv) {
            return (su, sv);
        }
        let (lo, hi) = self.region.bbox();
        let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let q = [
            params[0] + 1e-6 * (mid[0] - params[0]),
            params[1] + 1e-6 * (mid[1] - params[1]),
        ];
        let (_, su, sv) = self.surface.tangents(q[0], q[1]);
        (su, sv)
    }
}

impl Carrier for OnFace<'_> {
    fn entity(&self) -> EntityRef {
        self.entity
    }
    fn advance(&self, pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])> {
        self.advance_kept(pos, params, dx, None)
            .map(|(p, uv, _)| (p, uv))
    }
    /// The partials at the start are those kept from the move that ended
    /// there (the same numbers [`Surface::tangents`] gives at those
    /// parameters), so a move evaluates the surface once, at its end.
    fn advance_kept(
        &self,
        _pos: &P3,
        params: [f64; 2],
        dx: &V3,
        kept: Option<Kept>,
    ) -> Option<(P3, [f64; 2], Option<Kept>)> {
        let uv = if let Some(pl) = &self.plane {
            let step = parameter_step(&pl.su, &pl.sv, dx)?;
            [params[0] + step[0], params[1] + step[1]]
        } else {
            let (su, sv) = match kept {
                Some(k) => k,
                None => {
                    let (_, su, sv) = self.tangents(params);
                    (su, sv)
                }
            };
            if self.degenerate(params, &su, &sv) {
                // near a pole or an apex the first fundamental form is
                // singular: project the moved point back onto the surface
                // instead
                let p = self.tangents(params).0;
                self.surface.inverse(&(p + dx), Some(params))?
            } else {
                let step = parameter_step(&su, &sv, dx)?;
                [params[0] + step[0], params[1] + step[1]]
            }
        };
        let uv = self.region.wrap(uv);
        if !uv[0].is_finite() || !uv[1].is_finite() || !self.contains(uv) {
            return None;
        }
        // the point with its partials: the step's projection on the
        // tangent plane asks them next (see LAST_TANGENTS), and the next
        // move starts from them
        match self.plane {
            Some(_) => Some((self.surface.point(uv[0], uv[1]), uv, None)),
            None => {
                let (p, su, sv) = self.tangents(uv);
                Some((p, uv, Some((su, sv))))
            }
        }
    }
    fn frame(&self, params: [f64; 2]) -> (V3, V3) {
        if let Some(pl) = &self.plane {
            return pl.frame;
        }
        let (su, sv) = self.tangent_derivs(params);
        let (a, b) = if su.norm_squared() >= sv.norm_squared() {
            (su, sv)
        } else {
            (sv, su)
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
    fn tangent_length(&self, params: [f64; 2], duv: [f64; 2]) -> Option<f64> {
        let (su, sv) = match &self.plane {
            Some(pl) => (pl.su, pl.sv),
            None => {
                let (_, su, sv) = self.tangents(params);
                if self.degenerate(params, &su, &sv) {
                    return None;
                }
                (su, sv)
            }
        };
        let l = (su * duv[0] + sv * duv[1]).norm();
        l.is_finite().then_some(l)
    }
    fn normal(&self, params: [f64; 2]) -> V3 {
        let (su, sv) = self.tangent_derivs(params);
        su.cross(&sv).normalize()
    }
    fn planar(&self) -> bool {
        self.surface.is_planar()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bubbles::system::RelaxSettings;
    use crate::bubbles::testing::{self, hex_fill, square_system};
    use crate::geom::Plane;
    use crate::spacing::Constant;

    /// Bubbles moved by the first fundamental form stay on the face and
    /// inside its region, even when every one is kicked toward the outside.
    #[test]
    fn face_bubbles_stay_inside_the_region() {
        let s = Constant(0.05);
        let boundary = square_system(&s).params;
        let plane = Plane::xy();
        let carrier = OnFace::new(
            &plane,
            Region::new(std::slice::from_ref(&boundary)),
            EntityRef::new(2, 0),
        );
        let mut sys = testing::system(carrier, &s, boundary, 2);
        hex_fill(&mut sys, 0.05, 0.05, |_, _| false);
        for i in sys.n_fixed..sys.n() {
            sys.vel[i] = V3::new(sys.pos[i].x - 0.5, sys.pos[i].y - 0.5, 0.0) * 2.0;
        }
        sys.relax(&RelaxSettings::default(), |_, _, _| {}).unwrap();
        for i in sys.n_fixed..sys.n() {
            assert!(sys.carrier.contains(sys.params[i]));
            assert_eq!(sys.pos[i].z, 0.0);
        }
    }

    /// z = (x² + y²)/2 over the unit square, counting its evaluations.
    #[derive(Debug, Default)]
    struct Bowl {
        tangents: std::sync::atomic::AtomicUsize,
    }

    impl crate::geom::Surface for Bowl {
        fn domain(&self) -> ([f64; 2], [f64; 2]) {
            ([0.0, 1.0], [0.0, 1.0])
        }
        fn point(&self, u: f64, v: f64) -> P3 {
            P3::new(u, v, 0.5 * (u * u + v * v))
        }
        fn derivs(&self, u: f64, v: f64) -> crate::geom::SurfaceDerivs {
            crate::geom::SurfaceDerivs {
                p: self.point(u, v),
                su: V3::new(1.0, 0.0, u),
                sv: V3::new(0.0, 1.0, v),
                suu: V3::new(0.0, 0.0, 1.0),
                suv: V3::zeros(),
                svv: V3::new(0.0, 0.0, 1.0),
            }
        }
        fn tangents(&self, u: f64, v: f64) -> (P3, V3, V3) {
            self.tangents
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let d = self.derivs(u, v);
            (d.p, d.su, d.sv)
        }
        fn inverse(&self, p: &P3, _: Option<[f64; 2]>) -> Option<[f64; 2]> {
            Some([p.x, p.y])
        }
    }

    /// Stage 2 on a curved face evaluates the surface once per move: the
    /// partials at a move's start are those its last move ended with
    /// (`Carrier::advance_kept`), the end's serve the velocity's projection
    /// (`LAST_TANGENTS`). The bubbles end where they end when nothing is
    /// kept, bit for bit. Without the kept partials: two per move.
    #[test]
    fn a_curved_face_is_evaluated_once_per_move() {
        let s = Constant(0.05);
        let boundary = square_system(&s).params;
        let run = |keep: bool| {
            let bowl = Bowl::default();
            let carrier = OnFace::new(
                &bowl,
                Region::new(std::slice::from_ref(&boundary)),
                EntityRef::new(2, 0),
            );
            // a carrier that drops what it is handed: every move starts
            // from the surface
            struct Forgetful<'a>(OnFace<'a>);
            impl Carrier for Forgetful<'_> {
                fn entity(&self) -> EntityRef {
                    self.0.entity()
                }
                fn advance(&self, pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])> {
                    self.0.advance(pos, params, dx)
                }
                fn frame(&self, params: [f64; 2]) -> (V3, V3) {
                    self.0.frame(params)
                }
                fn contains(&self, params: [f64; 2]) -> bool {
                    self.0.contains(params)
                }
                fn point(&self, params: [f64; 2]) -> P3 {
                    self.0.point(params)
                }
                fn normal(&self, params: [f64; 2]) -> V3 {
                    self.0.normal(params)
                }
                fn planar(&self) -> bool {
                    false
                }
                fn tangent_length(&self, params: [f64; 2], duv: [f64; 2]) -> Option<f64> {
                    self.0.tangent_length(params, duv)
                }
            }
            // the same packing relaxed on either carrier; the count is of
            // stage 2's evaluations alone
            fn relaxed<C: Carrier>(
                carrier: C,
                boundary: &[[f64; 2]],
                bowl: &Bowl,
            ) -> (Vec<P3>, usize) {
                let s = Constant(0.05);
                let settings = RelaxSettings {
                    max_steps: 100,
                    population_until: 0.0,
                    plateau: f64::NEG_INFINITY,
                    ..Default::default()
                };
                let mut sys = testing::system(carrier, &s, boundary.to_vec(), 2);
                hex_fill(&mut sys, 0.05, 0.05, |_, _| false);
                let before = bowl.tangents.load(std::sync::atomic::Ordering::Relaxed);
                sys.relax(&settings, |_, _, _| {}).unwrap();
                (sys.pos.clone(), before)
            }
            let (pos, before) = if keep {
                relaxed(carrier, &boundary, &bowl)
            } else {
                relaxed(Forgetful(carrier), &boundary, &bowl)
            };
            let evaluations = bowl.tangents.load(std::sync::atomic::Ordering::Relaxed) - before;
            (pos, evaluations)
        };
        let (kept, once) = run(true);
        let (forgotten, twice) = run(false);
        assert_eq!(kept, forgotten);
        assert!(
            (once as f64) < 0.6 * twice as f64,
            "{once} evaluations with the partials kept, {twice} without"
        );
    }
}
