//! `bm_spacing`: the node spacing d(x), from an expression, a host
//! callback, or spacing plugins (shared libraries loaded by
//! `bubblemesh-plugin-host`, the same loader as the command line's
//! `--plugin`).

use std::ffi::{c_char, c_int, c_void};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};

use bubblemesh_core::spacing::{Expr, MinOf, Spacing, SpacingQuery};
use bubblemesh_core::Model;
use bubblemesh_plugin_host::{Plugin, PluginError, PluginSpacing, PluginSpec};

use crate::error::{abort_with, bm_result, callbacks_allowed, guard, guard_void, Error, Result};
use crate::geometry::UserPtr;
use crate::{free_handle, into_handle, need, object, put, utf8, Object};

/// A node-spacing function (opaque). Create with `bm_spacing_from_expr`,
/// `bm_spacing_from_callback`, `bm_spacing_from_plugin` or
/// `bm_spacing_from_plugin_config`; free with `bm_spacing_free`.
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

/// A plugin library, loaded and checked when the spacing is created, with
/// its arguments. It is initialised (`init` with the model's bounding box
/// and these arguments) at each meshing call, for that call's model.
pub(crate) struct PluginSource {
    plugin: Arc<Plugin>,
    args: Vec<(String, String)>,
}

// a handle holds one spacing for its lifetime: the size of the callback
// variant is paid once per handle
#[allow(clippy::large_enum_variant)]
pub(crate) enum Kind {
    Expr(Expr),
    Callback(CallbackSpacing),
    /// One or more plugins; several combine by their minimum (as the
    /// command line's default `--combine min`, thesis §4.8.1).
    Plugins(Vec<PluginSource>),
}

/// A spacing ready for one meshing call: borrowed from the handle, or
/// built for the call's model (plugins, the STEP default), with the plugin
/// instances whose failures must be checked after meshing.
pub(crate) struct Ready<'a> {
    borrowed: Option<&'a dyn Spacing>,
    owned: Option<Box<dyn Spacing>>,
    plugins: Vec<PluginSpacing>,
}

impl<'a> Ready<'a> {
    /// A spacing owned by the call (the STEP default d).
    pub fn owned(s: Box<dyn Spacing>) -> Ready<'a> {
        Ready {
            borrowed: None,
            owned: Some(s),
            plugins: Vec::new(),
        }
    }

    pub fn spacing(&self) -> &dyn Spacing {
        match (&self.owned, self.borrowed) {
            (Some(o), _) => o.as_ref(),
            (None, Some(b)) => b,
            (None, None) => unreachable!("a Ready spacing holds one spacing"),
        }
    }

    /// The first plugin failure of the run (a refusal, a panic, a value
    /// that is not finite and > 0), naming the plugin, the point and the
    /// entity. The engine stops on the NaN a failed plugin answers, but a
    /// minimum with another plugin can hide it, so this is checked after
    /// every run, successful or not.
    pub fn failure(&self) -> Option<String> {
        self.plugins
            .iter()
            .find_map(|p| p.failure().map(str::to_string))
    }
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
    /// The spacing for one meshing call on `model`. Plugins are initialised
    /// here for this model (their `init` may refuse its arguments:
    /// `BM_ERR_SPACING`); building their vertex geometry evaluates the
    /// model's curves and surfaces, so call this inside the callback scope
    /// and the unwind guard of the meshing call.
    pub fn ready(&self, model: &Model) -> Result<Ready<'_>> {
        let plugins = match &self.kind {
            Kind::Expr(e) => return Ok(borrowed(e)),
            Kind::Callback(c) => return Ok(borrowed(c)),
            Kind::Plugins(p) => p,
        };
        let shared = Arc::new(model.clone());
        let mut list = Vec::with_capacity(plugins.len());
        for src in plugins {
            let p = PluginSpacing::new(src.plugin.clone(), &src.args, shared.clone())
                .map_err(|e| Error::new(bm_result::BM_ERR_SPACING, e.to_string()))?;
            list.push(p);
        }
        let spacing: Box<dyn Spacing> = if list.len() == 1 {
            Box::new(list[0].clone())
        } else {
            Box::new(MinOf(
                list.iter()
                    .map(|p| Box::new(p.clone()) as Box<dyn Spacing>)
                    .collect(),
            ))
        };
        Ok(Ready {
            borrowed: None,
            owned: Some(spacing),
            plugins: list,
        })
    }

    /// The spacing as a state records it (`bm_mesh_state`): an
    /// expression's text, "callback", or the plugins' paths and arguments.
    pub fn describe(&self) -> String {
        match &self.kind {
            Kind::Expr(e) => e.text().to_string(),
            Kind::Callback(_) => "callback".to_string(),
            Kind::Plugins(p) => p
                .iter()
                .map(|src| {
                    let mut t = format!("plugin:{}", src.plugin.path().display());
                    for (k, v) in &src.args {
                        t.push_str(&format!(" {k}={v}"));
                    }
                    t
                })
                .collect::<Vec<_>>()
                .join(", "),
        }
    }

    /// For a callback or plugin spacing, the right to call it
    /// (`BM_ERR_BUSY` when another meshing call uses it); nothing to hold
    /// for an expression.
    pub fn claim(&self) -> Result<Option<MutexGuard<'_, ()>>> {
        let what = match self.kind {
            Kind::Expr(_) => return Ok(None),
            Kind::Callback(_) => "callback",
            Kind::Plugins(_) => "plugin",
        };
        match self.busy.try_lock() {
            Ok(g) => Ok(Some(g)),
            Err(TryLockError::Poisoned(p)) => Ok(Some(p.into_inner())),
            Err(TryLockError::WouldBlock) => Err(Error::new(
                bm_result::BM_ERR_BUSY,
                format!("the {what} spacing is in use by another meshing call"),
            )),
        }
    }
}

fn borrowed(s: &dyn Spacing) -> Ready<'_> {
    Ready {
        borrowed: Some(s),
        owned: None,
        plugins: Vec::new(),
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

/// The code for a plugin that cannot be loaded: a missing file is
/// `BM_ERR_IO`, a file that is not a usable plugin `BM_ERR_FORMAT`, an
/// `init` that refuses `BM_ERR_SPACING`.
fn plugin_error(e: PluginError) -> Error {
    let code = match e {
        PluginError::Missing { .. }
        | PluginError::IsDirectory { .. }
        | PluginError::NotAFile { .. } => bm_result::BM_ERR_IO,
        PluginError::Init { .. } => bm_result::BM_ERR_SPACING,
        _ => bm_result::BM_ERR_FORMAT,
    };
    Error::new(code, e.to_string())
}

fn load_plugins(specs: Vec<PluginSpec>) -> Result<SpacingObj> {
    let mut list = Vec::with_capacity(specs.len());
    for spec in specs {
        list.push(PluginSource {
            plugin: Plugin::load(&spec.path).map_err(plugin_error)?,
            args: spec.args,
        });
    }
    Ok(new_obj(Kind::Plugins(list)))
}

/// A spacing from the plugin library at `path` (a shared library speaking
/// the plugin ABI of `bubblemesh-plugin-api`, see plugins/README.md), with
/// `arg_count` arguments `args[k]`, each "KEY=VALUE" (as the command line's
/// `--plugin-arg`; `args` may be NULL when `arg_count` is 0).
///
/// The library is loaded and checked here: a missing file gives
/// `BM_ERR_IO`, a file that is not a loadable bubblemesh plugin (no entry
/// symbol, wrong ABI version or struct layout) `BM_ERR_FORMAT`, a malformed
/// argument `BM_ERR_RANGE`; each message names the file. The plugin's
/// `init` runs at each meshing call with that call's model (its bounding
/// box) and these arguments: a refusal then fails the meshing call with
/// `BM_ERR_SPACING` and the plugin's message, and so does a plugin that
/// fails or answers a value that is not finite and > 0 while meshing.
/// Plugin spacings are used by one meshing call at a time (`BM_ERR_BUSY`
/// otherwise), from the thread of that call.
#[no_mangle]
pub unsafe extern "C" fn bm_spacing_from_plugin(
    path: *const c_char,
    args: *const *const c_char,
    arg_count: usize,
    out: *mut *mut bm_spacing,
) -> bm_result {
    guard("bm_spacing_from_plugin", || unsafe {
        let path = utf8(path, "path")?;
        need(out, "out")?;
        if arg_count > 0 && args.is_null() {
            return Err(Error::null("args"));
        }
        if arg_count > 1 << 16 {
            return Err(Error::range(format!(
                "arg_count = {arg_count} is unreasonably large"
            )));
        }
        let mut pairs = Vec::with_capacity(arg_count);
        for k in 0..arg_count {
            let a = utf8(*args.add(k), &format!("args[{k}]"))?;
            match a.split_once('=') {
                Some((key, value)) if !key.trim().is_empty() => {
                    pairs.push((key.trim().to_string(), value.to_string()))
                }
                _ => {
                    return Err(Error::range(format!(
                        "args[{k}] = '{a}': expected KEY=VALUE"
                    )))
                }
            }
        }
        let obj = load_plugins(vec![PluginSpec {
            path: PathBuf::from(path),
            args: pairs,
        }])?;
        put(out, "out", into_handle(obj))
    })
}

/// A spacing from a plugin configuration file (TOML, as the command line's
/// `--plugin-config`): `[[plugin]]` tables with `path` (relative to the
/// file) and `args = { key = value, ... }`. Several plugins combine by
/// their minimum. Errors as `bm_spacing_from_plugin`; an unreadable file
/// is `BM_ERR_IO`, a malformed one `BM_ERR_FORMAT`.
#[no_mangle]
pub unsafe extern "C" fn bm_spacing_from_plugin_config(
    path: *const c_char,
    out: *mut *mut bm_spacing,
) -> bm_result {
    guard("bm_spacing_from_plugin_config", || unsafe {
        let path = utf8(path, "path")?;
        need(out, "out")?;
        let file = Path::new(path);
        if let Err(e) = std::fs::metadata(file) {
            return Err(Error::new(
                bm_result::BM_ERR_IO,
                format!("{path}: cannot read the plugin configuration: {e}"),
            ));
        }
        let specs = bubblemesh_plugin_host::read_config(file)
            .map_err(|e| Error::new(bm_result::BM_ERR_FORMAT, e))?;
        put(out, "out", into_handle(load_plugins(specs)?))
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
