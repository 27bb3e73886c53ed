//! Adapters that implement the core geometry traits by calling the host's
//! callbacks.
//!
//! The traits return plain values, so a callback that fails (returns
//! non-zero) or answers with a non-finite number cannot be reported through
//! them. The adapter then stops the engine at once by unwinding with an
//! [`Abort`](crate::error::Abort) that carries the error code and a message
//! naming the callback, the entity and the parameters; the entry point's
//! guard turns it into `BM_ERR_CALLBACK`. So the engine never computes with a
//! made-up value and cannot loop on one.

use std::ffi::{c_int, c_void};

use bubblemesh_core::geom::{Curve, Surface, SurfaceDerivs, VolumeGeometry, P3, V3};

use crate::error::{abort_with, callbacks_allowed, Error, Result};

/// C(t) and its derivatives. `order` is 0 for C(t), 1 for C'(t), 2 for
/// C''(t); write the 3 components to `out`. Return 0 on success, non-zero
/// to refuse (meshing then stops with `BM_ERR_CALLBACK`).
#[allow(non_camel_case_types)]
pub type bm_curve_eval_fn =
    Option<unsafe extern "C" fn(user: *mut c_void, t: f64, order: c_int, out: *mut f64) -> c_int>;

/// The callbacks of one curve. The library copies the struct; `user` is
/// passed back unchanged and must stay valid until the model is freed.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy)]
pub struct bm_curve_callbacks {
    /// Required.
    pub eval: bm_curve_eval_fn,
}

/// S(u,v) and its partial derivatives, written to `out` as 3-vectors in the
/// order S, Su, Sv, Suu, Suv, Svv. `order` 0 asks for S only (`out[0..3]`),
/// 1 for S, Su, Sv (`out[0..9]`), 2 for all six (`out[0..18]`); entries
/// beyond the order asked may be left alone. Return 0 on success, non-zero
/// to refuse.
#[allow(non_camel_case_types)]
pub type bm_surface_eval_fn = Option<
    unsafe extern "C" fn(user: *mut c_void, u: f64, v: f64, order: c_int, out: *mut f64) -> c_int,
>;

/// Whether (u,v) is inside the trimmed face: write non-zero to `*inside`
/// for inside, 0 for outside. Return 0 on success, non-zero to refuse.
#[allow(non_camel_case_types)]
pub type bm_surface_trim_fn =
    Option<unsafe extern "C" fn(user: *mut c_void, u: f64, v: f64, inside: *mut c_int) -> c_int>;

/// The (u,v) of the surface point nearest to `xyz[0..3]`, written to
/// `uv_out[0..2]`; `hint_uv` is NULL or a nearby (u,v) to search from.
/// Return 0 on success, non-zero to refuse.
#[allow(non_camel_case_types)]
pub type bm_surface_inverse_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        xyz: *const f64,
        hint_uv: *const f64,
        uv_out: *mut f64,
    ) -> c_int,
>;

/// The callbacks of one surface. Only `eval` is required. Without
/// `inverse` the library inverts the map itself (a grid search, then
/// Newton's method on the distance), which needs only `eval`.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy)]
pub struct bm_surface_callbacks {
    /// Required.
    pub eval: bm_surface_eval_fn,
    /// Optional (NULL): in/out of the trimmed region in (u,v), in addition
    /// to the face's loops.
    pub trim: bm_surface_trim_fn,
    /// Optional (NULL): inverse mapping from model space to (u,v).
    pub inverse: bm_surface_inverse_fn,
}

/// Whether `xyz[0..3]` is inside the volume: write non-zero to `*inside`
/// for inside, 0 for outside. Return 0 on success, non-zero to refuse.
#[allow(non_camel_case_types)]
pub type bm_volume_contains_fn =
    Option<unsafe extern "C" fn(user: *mut c_void, xyz: *const f64, inside: *mut c_int) -> c_int>;

/// The callbacks of one volume. `contains` is optional (NULL: the engine
/// decides in/out from the watertight boundary).
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy)]
pub struct bm_volume_callbacks {
    /// Whether a point is inside the volume.
    pub contains: bm_volume_contains_fn,
}

/// The host's user pointer. The threading contract (see the crate docs)
/// makes sharing it sound: the library calls a model's callbacks only from
/// the thread inside `bm_mesh_generate` (or the `bm_model_add_*` call that
/// validates them), one call at a time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct UserPtr(pub *mut c_void);
unsafe impl Send for UserPtr {}
unsafe impl Sync for UserPtr {}

impl UserPtr {
    /// The pointer (a method, so closures capture the whole `UserPtr`).
    pub fn get(self) -> *mut c_void {
        self.0
    }
}

fn check_scope(what: impl FnOnce() -> String) -> Result<()> {
    if callbacks_allowed() {
        Ok(())
    } else {
        Err(Error::callback(format!(
            "{} would have been called outside the thread running bm_mesh_generate; \
             refused (threading contract)",
            what()
        )))
    }
}

fn all_finite(x: &[f64]) -> bool {
    x.iter().all(|v| v.is_finite())
}

const ORDER_NAMES: [&str; 3] = ["C(t)", "C'(t)", "C''(t)"];

/// A curve answered by a host callback.
pub(crate) struct CallbackCurve {
    pub eval: unsafe extern "C" fn(*mut c_void, f64, c_int, *mut f64) -> c_int,
    pub user: UserPtr,
    pub t0: f64,
    pub t1: f64,
    /// The edge id, for messages.
    pub edge: u32,
}

impl std::fmt::Debug for CallbackCurve {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "CallbackCurve(edge {}, [{}, {}])",
            self.edge, self.t0, self.t1
        )
    }
}

impl CallbackCurve {
    /// One evaluation, with every failure turned into an [`Error`].
    pub fn try_eval(&self, t: f64, order: c_int) -> Result<V3> {
        let what = || {
            format!(
                "the curve callback 'eval' of edge {} (t = {t}, order {order}: {})",
                self.edge, ORDER_NAMES[order as usize]
            )
        };
        check_scope(what)?;
        let mut out = [f64::NAN; 3];
        let rc = unsafe { (self.eval)(self.user.0, t, order, out.as_mut_ptr()) };
        if rc != 0 {
            return Err(Error::callback(format!(
                "{} returned {rc} (failure)",
                what()
            )));
        }
        if !all_finite(&out) {
            return Err(Error::callback(format!(
                "{} gave a non-finite value ({}, {}, {})",
                what(),
                out[0],
                out[1],
                out[2]
            )));
        }
        Ok(V3::new(out[0], out[1], out[2]))
    }

    fn eval_or_abort(&self, t: f64, order: c_int) -> V3 {
        self.try_eval(t, order).unwrap_or_else(|e| abort_with(e))
    }
}

impl Curve for CallbackCurve {
    fn interval(&self) -> (f64, f64) {
        (self.t0, self.t1)
    }
    fn point(&self, t: f64) -> P3 {
        P3::from(self.eval_or_abort(t, 0))
    }
    fn d1(&self, t: f64) -> V3 {
        self.eval_or_abort(t, 1)
    }
    fn d2(&self, t: f64) -> V3 {
        self.eval_or_abort(t, 2)
    }
}

/// The straight segment between two vertices (`bm_model_add_line`).
pub(crate) use bubblemesh_core::geom::Segment;

/// A surface answered by host callbacks.
pub(crate) struct CallbackSurface {
    pub eval: unsafe extern "C" fn(*mut c_void, f64, f64, c_int, *mut f64) -> c_int,
    pub trim: bm_surface_trim_fn,
    pub inverse: bm_surface_inverse_fn,
    pub user: UserPtr,
    /// `[u0, u1]`, `[v0, v1]`.
    pub u: [f64; 2],
    pub v: [f64; 2],
    pub periods: [Option<f64>; 2],
    pub singular: Vec<P3>,
    /// Model-space size of the surface (for tolerances).
    pub scale: f64,
    /// The face id, for messages.
    pub face: u32,
}

impl std::fmt::Debug for CallbackSurface {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "CallbackSurface(face {}, u {:?}, v {:?}, periods {:?})",
            self.face, self.u, self.v, self.periods
        )
    }
}

impl CallbackSurface {
    /// One evaluation of `order` (0, 1, 2), with every failure turned into
    /// an [`Error`]. Returns the 18 numbers, the ones beyond the order NaN.
    pub fn try_eval(&self, u: f64, v: f64, order: c_int) -> Result<[f64; 18]> {
        let what = || {
            format!(
                "the surface callback 'eval' of face {} (u = {u}, v = {v}, order {order})",
                self.face
            )
        };
        check_scope(what)?;
        let mut out = [f64::NAN; 18];
        let rc = unsafe { (self.eval)(self.user.0, u, v, order, out.as_mut_ptr()) };
        if rc != 0 {
            return Err(Error::callback(format!(
                "{} returned {rc} (failure)",
                what()
            )));
        }
        let n = [3, 9, 18][order as usize];
        if let Some(k) = out[..n].iter().position(|x| !x.is_finite()) {
            let names = ["S", "Su", "Sv", "Suu", "Suv", "Svv"];
            return Err(Error::callback(format!(
                "{} gave a non-finite value: {}[{}] = {}",
                what(),
                names[k / 3],
                k % 3,
                out[k]
            )));
        }
        Ok(out)
    }

    fn eval_or_abort(&self, u: f64, v: f64, order: c_int) -> [f64; 18] {
        self.try_eval(u, v, order).unwrap_or_else(|e| abort_with(e))
    }

    pub fn try_inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Result<[f64; 2]> {
        match self.inverse {
            Some(f) => {
                let what = || {
                    format!(
                        "the surface callback 'inverse' of face {} (point ({}, {}, {}))",
                        self.face, p.x, p.y, p.z
                    )
                };
                check_scope(what)?;
                let xyz = [p.x, p.y, p.z];
                let mut uv = [f64::NAN; 2];
                let h = hint.unwrap_or([f64::NAN; 2]);
                let hp = if hint.is_some() {
                    h.as_ptr()
                } else {
                    std::ptr::null()
                };
                let rc = unsafe { f(self.user.0, xyz.as_ptr(), hp, uv.as_mut_ptr()) };
                if rc != 0 {
                    return Err(Error::callback(format!(
                        "{} returned {rc} (failure)",
                        what()
                    )));
                }
                if !all_finite(&uv) {
                    return Err(Error::callback(format!(
                        "{} gave a non-finite (u,v) = ({}, {})",
                        what(),
                        uv[0],
                        uv[1]
                    )));
                }
                Ok(uv)
            }
            None => self.newton_inverse(p, hint),
        }
    }

    /// Inverse mapping from `eval` alone: the nearest of a grid of samples
    /// (or the hint), then Newton's method on |S(u,v) − p|², clamped to the
    /// domain in open directions and wrapped in periodic ones.
    fn newton_inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Result<[f64; 2]> {
        let dist = |uv: [f64; 2]| -> Result<f64> {
            let s = self.try_eval(uv[0], uv[1], 0)?;
            Ok((P3::new(s[0], s[1], s[2]) - p).norm())
        };
        let mut starts = Vec::new();
        if let Some(h) = hint {
            starts.push(h);
        }
        // grid start (also when a hint is given but Newton from it does not
        // reach the surface point)
        let grid = || -> Result<[f64; 2]> {
            const N: usize = 12;
            let mut best = (
                [0.5 * (self.u[0] + self.u[1]), 0.5 * (self.v[0] + self.v[1])],
                f64::INFINITY,
            );
            for i in 0..=N {
                for j in 0..=N {
                    let uv = [
                        self.u[0] + (self.u[1] - self.u[0]) * i as f64 / N as f64,
                        self.v[0] + (self.v[1] - self.v[0]) * j as f64 / N as f64,
                    ];
                    let d = dist(uv)?;
                    if d < best.1 {
                        best = (uv, d);
                    }
                }
            }
            Ok(best.0)
        };
        let tol = 1e-10 * self.scale.max(f64::MIN_POSITIVE);
        let mut best = ([f64::NAN; 2], f64::INFINITY);
        for attempt in 0..2 {
            let start = if attempt == 0 && !starts.is_empty() {
                starts[0]
            } else {
                grid()?
            };
            let (uv, d) = self.newton_from(p, start)?;
            if d < best.1 {
                best = (uv, d);
            }
            if best.1 <= 1e-7 * self.scale.max(tol) {
                break;
            }
        }
        Ok(best.0)
    }

    fn newton_from(&self, p: &P3, start: [f64; 2]) -> Result<([f64; 2], f64)> {
        let mut uv = self.fold(start);
        let mut d_best = f64::INFINITY;
        let mut uv_best = uv;
        for _ in 0..40 {
            let s = self.try_eval(uv[0], uv[1], 2)?;
            let v3 = |k: usize| V3::new(s[3 * k], s[3 * k + 1], s[3 * k + 2]);
            let r = P3::from(v3(0)) - p;
            let (su, sv, suu, suv, svv) = (v3(1), v3(2), v3(3), v3(4), v3(5));
            let d = r.norm();
            if d < d_best {
                d_best = d;
                uv_best = uv;
            }
            let g = [r.dot(&su), r.dot(&sv)];
            // full Newton on f = |r|²/2, Gauss–Newton when not positive definite
            let mut h = [
                su.dot(&su) + r.dot(&suu),
                su.dot(&sv) + r.dot(&suv),
                sv.dot(&sv) + r.dot(&svv),
            ];
            let mut det = h[0] * h[2] - h[1] * h[1];
            if !(det > 0.0 && h[0] > 0.0) {
                h = [su.dot(&su), su.dot(&sv), sv.dot(&sv)];
                det = h[0] * h[2] - h[1] * h[1];
            }
            if !(det > 1e-300) {
                break;
            }
            let step = [
                -(h[2] * g[0] - h[1] * g[1]) / det,
                -(h[0] * g[1] - h[1] * g[0]) / det,
            ];
            // no step larger than a quarter of the domain
            let lim = [
                0.25 * (self.u[1] - self.u[0]),
                0.25 * (self.v[1] - self.v[0]),
            ];
            let scale = (step[0].abs() / lim[0])
                .max(step[1].abs() / lim[1])
                .max(1.0);
            let next = self.fold([uv[0] + step[0] / scale, uv[1] + step[1] / scale]);
            let moved = ((next[0] - uv[0]).abs(), (next[1] - uv[1]).abs());
            uv = next;
            if moved.0 <= 1e-14 * (1.0 + uv[0].abs()) && moved.1 <= 1e-14 * (1.0 + uv[1].abs()) {
                break;
            }
        }
        let s = self.try_eval(uv[0], uv[1], 0)?;
        let d = (P3::new(s[0], s[1], s[2]) - p).norm();
        if d < d_best {
            d_best = d;
            uv_best = uv;
        }
        Ok((uv_best, d_best))
    }

    /// Clamps open directions to the domain, wraps periodic ones into
    /// `[start, start + period)`.
    fn fold(&self, uv: [f64; 2]) -> [f64; 2] {
        let mut out = uv;
        for (c, lim) in [self.u, self.v].iter().enumerate() {
            out[c] = match self.periods[c] {
                Some(p) => lim[0] + (uv[c] - lim[0]).rem_euclid(p),
                None => uv[c].clamp(lim[0], lim[1]),
            };
        }
        out
    }
}

impl Surface for CallbackSurface {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (self.u, self.v)
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let s = self.eval_or_abort(u, v, 0);
        P3::new(s[0], s[1], s[2])
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let s = self.eval_or_abort(u, v, 2);
        let v3 = |k: usize| V3::new(s[3 * k], s[3 * k + 1], s[3 * k + 2]);
        SurfaceDerivs {
            p: P3::from(v3(0)),
            su: v3(1),
            sv: v3(2),
            suu: v3(3),
            suv: v3(4),
            svv: v3(5),
        }
    }
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        Some(self.try_inverse(p, hint).unwrap_or_else(|e| abort_with(e)))
    }
    fn periods(&self) -> [Option<f64>; 2] {
        self.periods
    }
    fn is_singular(&self, u: f64, v: f64) -> bool {
        if self.singular.is_empty() {
            return false;
        }
        let p = self.point(u, v);
        let tol = 1e-9 * self.scale;
        self.singular.iter().any(|q| (p - q).norm() <= tol)
    }
    fn singular_points(&self) -> Vec<P3> {
        self.singular.clone()
    }
    fn trim(&self, u: f64, v: f64) -> Option<bool> {
        let f = self.trim?;
        let what = || {
            format!(
                "the surface callback 'trim' of face {} (u = {u}, v = {v})",
                self.face
            )
        };
        if let Err(e) = check_scope(what) {
            abort_with(e);
        }
        let mut inside: c_int = 1;
        let rc = unsafe { f(self.user.0, u, v, &mut inside) };
        if rc != 0 {
            abort_with(Error::callback(format!(
                "{} returned {rc} (failure)",
                what()
            )));
        }
        Some(inside != 0)
    }
}

/// A volume's optional in/out answered by a host callback.
pub(crate) struct CallbackVolume {
    pub contains: unsafe extern "C" fn(*mut c_void, *const f64, *mut c_int) -> c_int,
    pub user: UserPtr,
    pub volume: u32,
}

impl std::fmt::Debug for CallbackVolume {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CallbackVolume({})", self.volume)
    }
}

impl VolumeGeometry for CallbackVolume {
    fn contains(&self, p: &P3) -> Option<bool> {
        let what = || {
            format!(
                "the volume callback 'contains' of volume {} (point ({}, {}, {}))",
                self.volume, p.x, p.y, p.z
            )
        };
        if let Err(e) = check_scope(what) {
            abort_with(e);
        }
        let xyz = [p.x, p.y, p.z];
        let mut inside: c_int = 0;
        let rc = unsafe { (self.contains)(self.user.0, xyz.as_ptr(), &mut inside) };
        if rc != 0 {
            abort_with(Error::callback(format!(
                "{} returned {rc} (failure)",
                what()
            )));
        }
        Some(inside != 0)
    }
}
