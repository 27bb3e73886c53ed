//! `bm_spacing`: the node spacing d(x), from an expression or a host
//! callback (plugins: not yet).

use std::ffi::{c_char, c_int, c_void};
use std::sync::{Mutex, MutexGuard, TryLockError};

use bubblemesh_core::spacing::{Expr, Spacing, SpacingQuery};

use crate::error::{abort_with, bm_result, callbacks_allowed, guard, guard_void, Error, Result};
use crate::geometry::UserPtr;
use crate::{free_handle, into_handle, need, object, put, utf8, Object};

/// A node-spacing function (opaque). Create with `bm_spacing_from_expr` or
/// `bm_spacing_from_callback`, free with `bm_spacing_free`.
#[allow(non_camel_case_types)]
pub struct bm_spacing {
    _private: [u8; 0],
}

/// The spacing d at one point: write it (finite, > 0, in model units) to
/// `*out`. The point (x, y, z) lies on the entity (`dim`, `id`): 0 vertex, 1
/// edge, 2 face, 3 volume; (u, v) are the entity's parameters there (t and 0
/// on an edge, 0 and 0 on a vertex). Return 0 on success, non-zero to
/// refuse (meshing then stops with `BM_ERR_CALLBACK`).
#[allow(non_camel_case_types)]
pub type bm_spacing_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        x: f64,
        y: f64,
        z: f64,
        dim: c_int,
        id: u32,
        u: f64,
        v: f64,
        out: *mut f64,
    ) -> c_int,
>;

pub(crate) struct CallbackSpacing {
    f: unsafe extern "C" fn(*mut c_void, f64, f64, f64, c_int, u32, f64, f64, *mut f64) -> c_int,
    user: UserPtr,
}

impl Spacing for CallbackSpacing {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        let p = q.point;
        let what = || {
            let kind = ["vertex", "edge", "face", "volume"][q.entity.dim.min(3) as usize];
            format!(
                "the spacing callback (at ({}, {}, {}) on {kind} {}, params ({}, {}))",
                p.x, p.y, p.z, q.entity.id, q.params[0], q.params[1]
            )
        };
        if !callbacks_allowed() {
            abort_with(Error::callback(format!(
                "{} would have been called outside the thread running bm_mesh_generate; \
                 refused (threading contract)",
                what()
            )));
        }
        let mut d = f64::NAN;
        let rc = unsafe {
            (self.f)(
                self.user.0,
                p.x,
                p.y,
                p.z,
                q.entity.dim as c_int,
                q.entity.id,
                q.params[0],
                q.params[1],
                &mut d,
            )
        };
        if rc != 0 {
            abort_with(Error::callback(format!(
                "{} returned {rc} (failure)",
                what()
            )));
        }
        if !(d.is_finite() && d > 0.0) {
            abort_with(Error::callback(format!(
                "{} gave d = {d}; a spacing must be finite and > 0",
                what()
            )));
        }
        d
    }
}

pub(crate) enum Kind {
    Expr(Expr),
    Callback(CallbackSpacing),
}

#[repr(C)]
pub(crate) struct SpacingObj {
    magic: u64,
    kind: Kind,
    /// Held while a callback spacing is used by `bm_mesh_generate`, so that
    /// its callback is never called from two meshing calls at once.
    busy: Mutex<()>,
}

impl Object for SpacingObj {
    const MAGIC: u64 = 0x626d_5f73_7061_6365; // "bm_space"
    const KIND: &'static str = "bm_spacing";
}

impl SpacingObj {
    pub fn spacing(&self) -> &dyn Spacing {
        match &self.kind {
            Kind::Expr(e) => e,
            Kind::Callback(c) => c,
        }
    }

    /// For a callback spacing, the right to call it (`BM_ERR_BUSY` when
    /// another meshing call uses it); nothing to hold for an expression.
    pub fn claim(&self) -> Result<Option<MutexGuard<'_, ()>>> {
        if let Kind::Expr(_) = self.kind {
            return Ok(None);
        }
        match self.busy.try_lock() {
            Ok(g) => Ok(Some(g)),
            Err(TryLockError::Poisoned(p)) => Ok(Some(p.into_inner())),
            Err(TryLockError::WouldBlock) => Err(Error::new(
                bm_result::BM_ERR_BUSY,
                "the callback spacing is in use by another meshing call",
            )),
        }
    }
}

fn new_obj(kind: Kind) -> SpacingObj {
    SpacingObj {
        magic: SpacingObj::MAGIC,
        kind,
        busy: Mutex::new(()),
    }
}

/// A spacing d(x, y, z) given as an expression: numbers (also `1e-3`),
/// `x y z`, `+ - * / ^` (or `**`), parentheses, `sqrt abs min max exp ln log
/// sin cos tan`, `PI`, `E`. A constant is just a number: "0.05".
#[no_mangle]
pub unsafe extern "C" fn bm_spacing_from_expr(
    text: *const c_char,
    out: *mut *mut bm_spacing,
) -> bm_result {
    guard("bm_spacing_from_expr", || unsafe {
        let text = utf8(text, "text")?;
        need(out, "out")?;
        let e =
            Expr::parse(text).map_err(|e| Error::new(bm_result::BM_ERR_SPACING, e.to_string()))?;
        if let Some(c) = e.constant() {
            if !(c.is_finite() && c > 0.0) {
                return Err(Error::new(
                    bm_result::BM_ERR_SPACING,
                    format!("the spacing '{text}' is {c}; a spacing must be finite and > 0"),
                ));
            }
        }
        put(out, "out", into_handle(new_obj(Kind::Expr(e))))
    })
}

/// A spacing answered by a host callback (see `bm_spacing_fn`); `user` is
/// passed back unchanged and must stay valid until the spacing is freed.
#[no_mangle]
pub unsafe extern "C" fn bm_spacing_from_callback(
    callback: bm_spacing_fn,
    user: *mut c_void,
    out: *mut *mut bm_spacing,
) -> bm_result {
    guard("bm_spacing_from_callback", || unsafe {
        let f = callback.ok_or_else(|| Error::null("callback"))?;
        need(out, "out")?;
        put(
            out,
            "out",
            into_handle(new_obj(Kind::Callback(CallbackSpacing {
                f,
                user: UserPtr(user),
            }))),
        )
    })
}

/// A spacing from a plugin library at `path`: not available in this build
/// (plugins are a separate piece of work). Returns `BM_ERR_UNSUPPORTED`.
#[no_mangle]
pub unsafe extern "C" fn bm_spacing_from_plugin(
    path: *const c_char,
    out: *mut *mut bm_spacing,
) -> bm_result {
    guard("bm_spacing_from_plugin", || unsafe {
        let path = utf8(path, "path")?;
        need(out, "out")?;
        Err(Error::new(
            bm_result::BM_ERR_UNSUPPORTED,
            format!(
                "cannot load the spacing plugin '{path}': spacing plugins are not supported by \
                 this build yet; use bm_spacing_from_callback or bm_spacing_from_expr"
            ),
        ))
    })
}

/// Frees a spacing (NULL: nothing).
#[no_mangle]
pub unsafe extern "C" fn bm_spacing_free(spacing: *mut bm_spacing) {
    guard_void("bm_spacing_free", || unsafe {
        free_handle::<SpacingObj>(spacing as *mut c_void)
    })
}

pub(crate) unsafe fn spacing_obj<'a>(p: *const bm_spacing) -> Result<&'a SpacingObj> {
    unsafe { object::<SpacingObj>(p as *const c_void, "spacing") }
}
