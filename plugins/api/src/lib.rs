//! # bubblemesh-plugin-api
//!
//! The binary interface between the mesher (the *host*) and a spacing
//! plugin: a shared library that gives the node spacing d(x) (the bubble
//! diameter, thesis §3.2.1 and §4.6) at many points per call. The interface
//! is plain C: `#[repr(C)]` structs and `extern "C"` function pointers, so a
//! plugin may be written in any language (`plugins/c-example/` is in C, with
//! the header `bubblemesh_plugin.h` generated from this file by cbindgen).
//! No Rust trait object, `String` or `Vec` ever crosses the boundary.
//!
//! ## The contract
//!
//! A plugin exports one symbol, [`BM_PLUGIN_ENTRY`] =
//! `bubblemesh_plugin_entry`, a function of type [`BmPluginEntryFn`] that
//! returns a pointer to a static [`BmPlugin`] function table. Its first four
//! `u32` fields (magic, ABI version, table size, query size) are frozen for
//! every ABI version, so the host can refuse a mismatched library before it
//! reads anything else.
//!
//! 1. `init(info, args, n_args, &state, err, err_len)` once per use, with
//!    the model's size ([`BmInitInfo`]) and the user's `key=value` strings
//!    ([`BmArg`]). Returns [`BM_OK`] and an opaque `state`, or non-zero with
//!    a NUL-terminated message in `err` (at most `err_len` bytes, truncated).
//! 2. `spacing(state, queries, n, out, err, err_len)` any number of times:
//!    writes `out[i]` = d at `queries[i]` for `i < n` (model units). Every
//!    value must be finite and > 0; the host checks and refuses NaN, zero,
//!    negative and infinite values, naming the point and the plugin.
//!    Non-zero return: the plugin could not answer; `err` says why.
//! 3. `destroy(state)` once, after the last `spacing` call.
//!
//! **Threads.** If the table's `flags` contain [`BM_PLUGIN_THREAD_SAFE`], the
//! host may call `spacing` on the same state from several threads at once;
//! the plugin promises its state is immutable after `init` (Rust plugins
//! made with [`export_plugin!`] always are: [`SpacingPlugin::spacing`] takes
//! `&self` and the type is `Sync`). Without the flag the host serialises
//! every call to one state with a lock. `init` and `destroy` are never
//! called concurrently with anything on the same state.
//!
//! **Errors and panics.** A function never unwinds out of the library: Rust
//! plugins made with [`export_plugin!`] catch panics with
//! `std::panic::catch_unwind` and return them as errors (so a plugin must
//! not be built with `panic = "abort"`). C plugins must not `longjmp` or
//! throw across the boundary.
//!
//! ## What a plugin sees per point
//!
//! [`BmQuery`]: the point, the model entity (dimension, id) and its
//! parameters, and the local geometry the host computes from the model:
//! on an edge the unit tangent and the curve's curvature; on a face the
//! unit normal and the principal curvatures with their directions. An edge
//! or vertex bubble also sits on the faces around it, so there the surface
//! fields describe the most curved of those faces (largest |κ₁|). `geom`
//! says which fields are valid.
//!
//! ## Writing a plugin in Rust
//!
//! Implement [`SpacingPlugin`] and call [`export_plugin!`] once; build the
//! crate as `crate-type = ["cdylib"]`. See `plugins/template/` and
//! `plugins/README.md`.

use std::ffi::{c_char, c_void};

/// `"BMSP"`: the first field of every [`BmPlugin`] table.
pub const BM_PLUGIN_MAGIC: u32 = 0x424D_5350;
/// The ABI version this crate describes. Bumped on any change to the
/// layout or meaning of the structs below; the host refuses any other.
pub const BM_PLUGIN_ABI_VERSION: u32 = 1;
/// [`BmPlugin::flags`]: `spacing` may be called from several threads at
/// once on the same state.
pub const BM_PLUGIN_THREAD_SAFE: u32 = 1;
/// [`BmQuery::geom`]: `tangent` and `curve_curvature` are valid.
pub const BM_GEOM_TANGENT: u32 = 1;
/// [`BmQuery::geom`]: `normal`, `k1`, `k2`, `dir1`, `dir2` are valid.
pub const BM_GEOM_SURFACE: u32 = 2;
/// Success.
pub const BM_OK: i32 = 0;
/// Failure: the error buffer holds the reason.
pub const BM_ERR: i32 = 1;
/// The name of the symbol every plugin exports (a [`BmPluginEntryFn`]).
pub const BM_PLUGIN_ENTRY: &str = "bubblemesh_plugin_entry";

/// One point where the host asks for the spacing. Lengths in model units,
/// curvatures in 1/model units.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BmQuery {
    /// The point in model space.
    pub point: [f64; 3],
    /// The entity's parameters at the point: `[t, 0]` on an edge, `[u, v]`
    /// on a face, zero on vertices and volumes.
    pub params: [f64; 2],
    /// Dimension of the entity the point lies on: 0 vertex, 1 edge, 2 face,
    /// 3 volume.
    pub dim: u32,
    /// The entity's 0-based id among the model's entities of that dimension.
    pub id: u32,
    /// Which geometry fields are valid: [`BM_GEOM_TANGENT`] |
    /// [`BM_GEOM_SURFACE`].
    pub geom: u32,
    /// Zero (room for the future without changing the layout).
    pub reserved: u32,
    /// Unit tangent of the curve (edges, in the direction of increasing t).
    pub tangent: [f64; 3],
    /// Curvature κ = |C' × C''| / |C'|³ of the curve (edges), ≥ 0; at a
    /// vertex the largest over the edges that end there.
    pub curve_curvature: f64,
    /// Unit normal S_u × S_v / |S_u × S_v| of the surface.
    pub normal: [f64; 3],
    /// Principal curvatures (eigenvalues of the shape operator, sign
    /// relative to `normal`), ordered |k1| ≥ |k2|. Thesis eq. 5.1.2 uses
    /// ρ = 1/|k1|.
    pub k1: f64,
    pub k2: f64,
    /// Unit principal directions of k1 and k2 (tangent to the surface,
    /// `dir2 = normal × dir1`).
    pub dir1: [f64; 3],
    pub dir2: [f64; 3],
}

/// One `key=value` configuration string pair, both NUL-terminated UTF-8.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct BmArg {
    pub key: *const c_char,
    pub value: *const c_char,
}

/// What the host tells `init` about the model being meshed.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BmInitInfo {
    /// `size_of::<BmInitInfo>()` as the host knows it.
    pub struct_size: u32,
    /// The model's dimension (1 curves, 2 faces, 3 volumes).
    pub model_dim: u32,
    /// Axis-aligned bounding box of the model.
    pub bbox_min: [f64; 3],
    pub bbox_max: [f64; 3],
    /// Length of the bounding box's diagonal.
    pub model_size: f64,
}

/// `init`: reads the arguments, makes the plugin's state.
pub type BmInitFn = unsafe extern "C" fn(
    info: *const BmInitInfo,
    args: *const BmArg,
    n_args: usize,
    state: *mut *mut c_void,
    err: *mut c_char,
    err_len: usize,
) -> i32;

/// `spacing`: d at `n` points, written to `out[0..n]`.
pub type BmSpacingFn = unsafe extern "C" fn(
    state: *mut c_void,
    queries: *const BmQuery,
    n: usize,
    out: *mut f64,
    err: *mut c_char,
    err_len: usize,
) -> i32;

/// `destroy`: frees the state made by `init`.
pub type BmDestroyFn = unsafe extern "C" fn(state: *mut c_void);

/// The function table a plugin exports (through [`BmPluginEntryFn`]).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct BmPlugin {
    /// [`BM_PLUGIN_MAGIC`].
    pub magic: u32,
    /// [`BM_PLUGIN_ABI_VERSION`] of the header the plugin was built against.
    pub abi_version: u32,
    /// `sizeof(BmPlugin)` as the plugin was compiled.
    pub table_size: u32,
    /// `sizeof(BmQuery)` as the plugin was compiled.
    pub query_size: u32,
    /// [`BM_PLUGIN_THREAD_SAFE`] or 0.
    pub flags: u32,
    /// `sizeof(BmInitInfo)` as the plugin was compiled.
    pub init_info_size: u32,
    /// Short name (NUL-terminated UTF-8), e.g. "curvature".
    pub name: *const c_char,
    /// One line saying what the plugin does and its arguments.
    pub description: *const c_char,
    /// A [`BmInitFn`] (spelled out: cbindgen needs the type inline).
    pub init: Option<
        unsafe extern "C" fn(
            info: *const BmInitInfo,
            args: *const BmArg,
            n_args: usize,
            state: *mut *mut c_void,
            err: *mut c_char,
            err_len: usize,
        ) -> i32,
    >,
    /// A [`BmSpacingFn`].
    pub spacing: Option<
        unsafe extern "C" fn(
            state: *mut c_void,
            queries: *const BmQuery,
            n: usize,
            out: *mut f64,
            err: *mut c_char,
            err_len: usize,
        ) -> i32,
    >,
    /// A [`BmDestroyFn`].
    pub destroy: Option<unsafe extern "C" fn(state: *mut c_void)>,
}

/// The type of the exported symbol `bubblemesh_plugin_entry`: returns the
/// plugin's static table (never NULL for a valid plugin).
pub type BmPluginEntryFn = unsafe extern "C" fn() -> *const BmPlugin;

/// A [`BmPlugin`] that may live in a `static` (its pointers are to static
/// strings and functions).
#[repr(transparent)]
pub struct StaticPlugin(pub BmPlugin);
// SAFETY: the table is immutable and points only at 'static data.
unsafe impl Sync for StaticPlugin {}

// ---------------------------------------------------------------------------
// Writing plugins in Rust

/// The model facts given to [`SpacingPlugin::init`].
pub type InitInfo = BmInitInfo;

/// The `key=value` arguments given to a plugin, in order.
#[derive(Clone, Debug, Default)]
pub struct Args {
    pairs: Vec<(String, String)>,
}

impl Args {
    /// Arguments from pairs (for tests and hosts written in Rust).
    pub fn new(pairs: Vec<(String, String)>) -> Self {
        Args { pairs }
    }

    /// All pairs, in the order given.
    pub fn pairs(&self) -> &[(String, String)] {
        &self.pairs
    }

    /// Errs on a key not in `known` or given twice, naming the known keys.
    pub fn check_known(&self, known: &[&str]) -> Result<(), String> {
        for (i, (k, _)) in self.pairs.iter().enumerate() {
            if !known.contains(&k.as_str()) {
                return Err(format!(
                    "unknown argument '{k}' (known: {})",
                    known.join(", ")
                ));
            }
            if self.pairs[..i].iter().any(|(k2, _)| k2 == k) {
                return Err(format!("argument '{k}' is given twice"));
            }
        }
        Ok(())
    }

    /// The value of `key`, if given.
    pub fn str(&self, key: &str) -> Option<&str> {
        self.pairs
            .iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// `key` as a finite number, if given.
    pub fn f64(&self, key: &str) -> Result<Option<f64>, String> {
        match self.str(key) {
            None => Ok(None),
            Some(v) => match v.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(Some(x)),
                _ => Err(format!("argument {key}={v}: expected a finite number")),
            },
        }
    }

    /// `key` as a number > 0, if given.
    pub fn positive(&self, key: &str) -> Result<Option<f64>, String> {
        match self.f64(key)? {
            Some(x) if x <= 0.0 => Err(format!("argument {key}={x}: must be > 0")),
            x => Ok(x),
        }
    }

    /// `key` as three numbers "x,y,z", if given.
    pub fn vec3(&self, key: &str) -> Result<Option<[f64; 3]>, String> {
        let Some(v) = self.str(key) else {
            return Ok(None);
        };
        let parts: Vec<f64> = v
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("argument {key}={v}: expected three numbers x,y,z"))?;
        match parts[..] {
            [x, y, z] if parts.iter().all(|c| c.is_finite()) => Ok(Some([x, y, z])),
            _ => Err(format!("argument {key}={v}: expected three numbers x,y,z")),
        }
    }
}

/// A spacing plugin written in Rust. The type is the plugin's state: made
/// once by `init`, then only read (`&self`) — so the table made by
/// [`export_plugin!`] declares [`BM_PLUGIN_THREAD_SAFE`].
pub trait SpacingPlugin: Send + Sync + Sized + 'static {
    /// Reads the arguments; an `Err` is shown to the user with the plugin's
    /// path.
    fn init(info: &InitInfo, args: &Args) -> Result<Self, String>;
    /// Writes d at `queries[i]` into `out[i]` (same lengths). An `Err`
    /// stops meshing with the message.
    fn spacing(&self, queries: &[BmQuery], out: &mut [f64]) -> Result<(), String>;
}

/// Exports a [`SpacingPlugin`] type as a plugin: defines the
/// `bubblemesh_plugin_entry` symbol and the C functions of its table, each
/// of which catches panics.
///
/// ```ignore
/// bubblemesh_plugin_api::export_plugin!(MyPlugin, "my-plugin", "d = ...; args: a, b");
/// ```
#[macro_export]
macro_rules! export_plugin {
    ($ty:ty, $name:literal, $description:literal) => {
        /// The plugin's entry point (bubblemesh plugin ABI).
        #[no_mangle]
        pub extern "C" fn bubblemesh_plugin_entry() -> *const $crate::BmPlugin {
            unsafe extern "C" fn init(
                info: *const $crate::BmInitInfo,
                args: *const $crate::BmArg,
                n_args: usize,
                state: *mut *mut ::std::ffi::c_void,
                err: *mut ::std::ffi::c_char,
                err_len: usize,
            ) -> i32 {
                $crate::rt::init::<$ty>(info, args, n_args, state, err, err_len)
            }
            unsafe extern "C" fn spacing(
                state: *mut ::std::ffi::c_void,
                queries: *const $crate::BmQuery,
                n: usize,
                out: *mut f64,
                err: *mut ::std::ffi::c_char,
                err_len: usize,
            ) -> i32 {
                $crate::rt::spacing::<$ty>(state, queries, n, out, err, err_len)
            }
            unsafe extern "C" fn destroy(state: *mut ::std::ffi::c_void) {
                $crate::rt::destroy::<$ty>(state)
            }
            static TABLE: $crate::StaticPlugin = $crate::StaticPlugin($crate::BmPlugin {
                magic: $crate::BM_PLUGIN_MAGIC,
                abi_version: $crate::BM_PLUGIN_ABI_VERSION,
                table_size: ::std::mem::size_of::<$crate::BmPlugin>() as u32,
                query_size: ::std::mem::size_of::<$crate::BmQuery>() as u32,
                flags: $crate::BM_PLUGIN_THREAD_SAFE,
                init_info_size: ::std::mem::size_of::<$crate::BmInitInfo>() as u32,
                name: concat!($name, "\0").as_ptr() as *const ::std::ffi::c_char,
                description: concat!($description, "\0").as_ptr() as *const ::std::ffi::c_char,
                init: Some(init),
                spacing: Some(spacing),
                destroy: Some(destroy),
            });
            &TABLE.0
        }
    };
}

/// The bodies of the functions [`export_plugin!`] defines. Public only for
/// the macro.
#[doc(hidden)]
pub mod rt {
    use super::*;
    use std::ffi::CStr;
    use std::panic::{catch_unwind, AssertUnwindSafe};

    /// Copies `msg` into the host's buffer, truncated on a UTF-8 boundary,
    /// NUL-terminated.
    pub unsafe fn write_err(err: *mut c_char, err_len: usize, msg: &str) {
        if err.is_null() || err_len == 0 {
            return;
        }
        let mut n = msg.len().min(err_len - 1);
        while !msg.is_char_boundary(n) {
            n -= 1;
        }
        std::ptr::copy_nonoverlapping(msg.as_ptr(), err as *mut u8, n);
        *err.add(n) = 0;
    }

    fn panic_text(p: Box<dyn std::any::Any + Send>) -> String {
        if let Some(s) = p.downcast_ref::<&str>() {
            s.to_string()
        } else if let Some(s) = p.downcast_ref::<String>() {
            s.clone()
        } else {
            "(no message)".to_string()
        }
    }

    unsafe fn c_str(p: *const c_char, what: &str) -> Result<String, String> {
        if p.is_null() {
            return Err(format!("{what} is NULL"));
        }
        CStr::from_ptr(p)
            .to_str()
            .map(str::to_string)
            .map_err(|_| format!("{what} is not UTF-8"))
    }

    pub unsafe fn init<T: SpacingPlugin>(
        info: *const BmInitInfo,
        args: *const BmArg,
        n_args: usize,
        state: *mut *mut c_void,
        err: *mut c_char,
        err_len: usize,
    ) -> i32 {
        let r = catch_unwind(AssertUnwindSafe(|| -> Result<T, String> {
            if state.is_null() || info.is_null() || (args.is_null() && n_args > 0) {
                return Err("init called with a NULL pointer".into());
            }
            let mut info_copy = BmInitInfo::default();
            let n = ((*info).struct_size as usize).min(std::mem::size_of::<BmInitInfo>());
            std::ptr::copy_nonoverlapping(
                info as *const u8,
                &mut info_copy as *mut BmInitInfo as *mut u8,
                n,
            );
            let mut pairs = Vec::with_capacity(n_args);
            for i in 0..n_args {
                let a = *args.add(i);
                pairs.push((c_str(a.key, "a key")?, c_str(a.value, "a value")?));
            }
            T::init(&info_copy, &Args::new(pairs))
        }));
        match r {
            Ok(Ok(t)) => {
                *state = Box::into_raw(Box::new(t)) as *mut c_void;
                BM_OK
            }
            Ok(Err(msg)) => {
                write_err(err, err_len, &msg);
                BM_ERR
            }
            Err(p) => {
                write_err(
                    err,
                    err_len,
                    &format!("panicked in init: {}", panic_text(p)),
                );
                BM_ERR
            }
        }
    }

    pub unsafe fn spacing<T: SpacingPlugin>(
        state: *mut c_void,
        queries: *const BmQuery,
        n: usize,
        out: *mut f64,
        err: *mut c_char,
        err_len: usize,
    ) -> i32 {
        if n == 0 {
            return BM_OK;
        }
        if state.is_null() || queries.is_null() || out.is_null() {
            write_err(err, err_len, "spacing called with a NULL pointer");
            return BM_ERR;
        }
        let me = &*(state as *const T);
        let qs = std::slice::from_raw_parts(queries, n);
        let out = std::slice::from_raw_parts_mut(out, n);
        match catch_unwind(AssertUnwindSafe(|| me.spacing(qs, out))) {
            Ok(Ok(())) => BM_OK,
            Ok(Err(msg)) => {
                write_err(err, err_len, &msg);
                BM_ERR
            }
            Err(p) => {
                write_err(err, err_len, &format!("panicked: {}", panic_text(p)));
                BM_ERR
            }
        }
    }

    pub unsafe fn destroy<T: SpacingPlugin>(state: *mut c_void) {
        if !state.is_null() {
            // a panic in Drop must not unwind into the host
            let _ = catch_unwind(AssertUnwindSafe(|| drop(Box::from_raw(state as *mut T))));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_the_documented_one() {
        // every field is 8 or 4 bytes, no padding: the C header says the same
        assert_eq!(std::mem::size_of::<BmQuery>(), 176);
        assert_eq!(std::mem::offset_of!(BmQuery, tangent), 56);
        assert_eq!(std::mem::offset_of!(BmQuery, dir2), 152);
        assert_eq!(std::mem::size_of::<BmInitInfo>(), 64);
    }

    #[test]
    fn args_check_unknown_and_duplicates() {
        let a = Args::new(vec![("eps".into(), "0.1".into()), ("x".into(), "1".into())]);
        let e = a.check_known(&["eps"]).unwrap_err();
        assert!(e.contains("'x'") && e.contains("eps"), "{e}");
        let a = Args::new(vec![
            ("eps".into(), "0.1".into()),
            ("eps".into(), "1".into()),
        ]);
        assert!(a.check_known(&["eps"]).unwrap_err().contains("twice"));
        let a = Args::new(vec![
            ("v".into(), "1, 2,3".into()),
            ("n".into(), "-1".into()),
        ]);
        assert_eq!(a.vec3("v").unwrap(), Some([1.0, 2.0, 3.0]));
        assert!(a.positive("n").unwrap_err().contains("> 0"));
        assert!(Args::new(vec![("v".into(), "1,2".into())])
            .vec3("v")
            .is_err());
    }

    #[test]
    fn error_text_is_truncated_on_a_char_boundary() {
        let mut buf = [1 as c_char; 5];
        unsafe { rt::write_err(buf.as_mut_ptr(), buf.len(), "aéé") };
        let s = unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) };
        assert_eq!(s.to_str().unwrap(), "aé");
    }
}
