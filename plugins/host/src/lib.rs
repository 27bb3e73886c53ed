//! # bubblemesh-plugin-host
//!
//! Loads spacing plugins (shared libraries speaking the C ABI of
//! `bubblemesh-plugin-api`) and makes each a [`Spacing`]: [`PluginSpacing`].
//!
//! Loading ([`Plugin::load`]) refuses, with a message naming the file, a
//! missing file, a file the dynamic loader cannot load, a library without
//! the `bubblemesh_plugin_entry` symbol, a table with the wrong magic or ABI
//! version, and a table whose struct sizes differ from the host's (a plugin
//! built against another header). Nothing of a table is read before its
//! frozen header (magic, version, sizes) has been checked.
//!
//! While meshing, [`PluginSpacing`] computes the local geometry of every
//! query from the model (tangent and curvature of curves, normal and
//! principal curvatures of surfaces: [`bubblemesh_core::curvature`]), calls
//! the plugin once per batch, and checks every value (finite, > 0). The
//! [`Spacing`] trait has no error channel, so a failure (the plugin said
//! no, panicked, or returned NaN, zero, a negative or infinite value) is
//! kept ([`PluginSpacing::failure`]) and every later query answers NaN
//! without calling the plugin again; the engine then stops on the NaN, and
//! the caller reports the kept message, which names the plugin, the point
//! and the entity. Callers must check `failure()` after meshing even when
//! meshing succeeded: a `min` with another spacing hides a NaN.
//!
//! Threads: a plugin declaring `BM_PLUGIN_THREAD_SAFE` is called from any
//! number of threads at once; any other is serialised by a lock.

use std::ffi::{c_char, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use bubblemesh_core::curvature::{
    curve_curvature, edge_faces, edge_point_uv, surface_principal, Principal,
};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::spacing::{Spacing, SpacingQuery};
use bubblemesh_core::Model;
pub use bubblemesh_plugin_api as api;
use bubblemesh_plugin_api::{
    BmArg, BmInitInfo, BmPlugin, BmPluginEntryFn, BmQuery, BM_GEOM_SURFACE, BM_GEOM_TANGENT, BM_OK,
    BM_PLUGIN_ABI_VERSION, BM_PLUGIN_ENTRY, BM_PLUGIN_MAGIC, BM_PLUGIN_THREAD_SAFE,
};

mod config;
pub use config::{read_config, specs_from_command_line, PluginSpec};

/// Why a plugin cannot be used. Every variant names the library's path.
#[derive(Debug, thiserror::Error)]
pub enum PluginError {
    #[error("plugin {}: no such file", .path.display())]
    Missing { path: PathBuf },
    #[error("plugin {}: is a directory, not a shared library", .path.display())]
    IsDirectory { path: PathBuf },
    #[error("plugin {}: not a regular file, not a shared library", .path.display())]
    NotAFile { path: PathBuf },
    #[error("plugin {}: cannot load the shared library: {reason}", .path.display())]
    NotLoadable { path: PathBuf, reason: String },
    #[error(
        "plugin {}: not a bubblemesh spacing plugin (it exports no '{BM_PLUGIN_ENTRY}' symbol)",
        .path.display()
    )]
    NotAPlugin { path: PathBuf },
    #[error("plugin {}: not a bubblemesh spacing plugin: {reason}", .path.display())]
    BadTable { path: PathBuf, reason: String },
    #[error(
        "plugin {}: built for plugin ABI version {found}, but this bubblemesh speaks version \
         {BM_PLUGIN_ABI_VERSION}; rebuild the plugin against bubblemesh-plugin-api (or \
         bubblemesh_plugin.h) of this release",
        .path.display()
    )]
    WrongVersion { path: PathBuf, found: u32 },
    #[error(
        "plugin {}: its structs differ from this bubblemesh's ({what}); it was built against \
         another header: rebuild it",
        .path.display()
    )]
    WrongLayout { path: PathBuf, what: String },
    #[error("plugin {} ('{name}'): {message}", .path.display())]
    Init {
        path: PathBuf,
        name: String,
        message: String,
    },
}

/// A loaded plugin library and its checked function table. Stays loaded
/// while any [`Instance`] made from it lives (they hold an `Arc`).
pub struct Plugin {
    path: PathBuf,
    table: BmPlugin,
    name: String,
    description: String,
    // last: unloaded after everything above (the table points into it)
    _lib: libloading::Library,
}

impl std::fmt::Debug for Plugin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Plugin({}, '{}')", self.path.display(), self.name)
    }
}

// SAFETY: the table holds function pointers and pointers to the library's
// static strings, valid while `_lib` is loaded; nothing in it is mutated.
unsafe impl Send for Plugin {}
unsafe impl Sync for Plugin {}

impl Plugin {
    /// Loads the library at `path` and checks its table (see the crate docs).
    pub fn load(path: &Path) -> Result<Arc<Plugin>, PluginError> {
        let path = path.to_path_buf();
        match std::fs::metadata(&path) {
            Err(_) => return Err(PluginError::Missing { path }),
            Ok(m) if m.is_dir() => return Err(PluginError::IsDirectory { path }),
            Ok(m) if !m.is_file() => return Err(PluginError::NotAFile { path }),
            Ok(_) => {}
        }
        // A bare file name would make dlopen search the library path; a
        // plugin is always the file the user named.
        let open = if path.components().count() == 1 {
            Path::new(".").join(&path)
        } else {
            path.clone()
        };
        // SAFETY: loading runs the library's initialisers; that is what
        // loading a plugin means.
        let lib =
            unsafe { libloading::Library::new(&open) }.map_err(|e| PluginError::NotLoadable {
                path: path.clone(),
                reason: e.to_string(),
            })?;
        let bad = |reason: &str| PluginError::BadTable {
            path: path.clone(),
            reason: reason.to_string(),
        };
        let symbol = format!("{BM_PLUGIN_ENTRY}\0");
        // SAFETY: the symbol's type is fixed by the ABI.
        let entry: BmPluginEntryFn = unsafe {
            *lib.get::<BmPluginEntryFn>(symbol.as_bytes())
                .map_err(|_| PluginError::NotAPlugin { path: path.clone() })?
        };
        // SAFETY: the entry takes nothing and returns a pointer.
        let ptr = unsafe { entry() };
        if ptr.is_null() {
            return Err(bad("bubblemesh_plugin_entry returned NULL"));
        }
        // The frozen header: four u32 at the start of every version's table.
        // SAFETY: any table of any version starts with these 16 bytes.
        let header = unsafe { std::ptr::read(ptr as *const [u32; 4]) };
        let [magic, version, table_size, query_size] = header;
        if magic != BM_PLUGIN_MAGIC {
            return Err(bad(&format!(
                "its table starts with 0x{magic:08x}, not the magic 0x{BM_PLUGIN_MAGIC:08x}"
            )));
        }
        if version != BM_PLUGIN_ABI_VERSION {
            return Err(PluginError::WrongVersion {
                path,
                found: version,
            });
        }
        let want = [
            ("table", table_size, std::mem::size_of::<BmPlugin>() as u32),
            ("BmQuery", query_size, std::mem::size_of::<BmQuery>() as u32),
        ];
        for (what, got, host) in want {
            if got != host {
                return Err(PluginError::WrongLayout {
                    path,
                    what: format!("sizeof({what}) is {got} bytes in the plugin, {host} here"),
                });
            }
        }
        // SAFETY: version and size match: the whole table is ours to read.
        let table = unsafe { std::ptr::read(ptr) };
        let info_size = std::mem::size_of::<BmInitInfo>() as u32;
        if table.init_info_size != info_size {
            return Err(PluginError::WrongLayout {
                path,
                what: format!(
                    "sizeof(BmInitInfo) is {} bytes in the plugin, {info_size} here",
                    table.init_info_size
                ),
            });
        }
        if table.init.is_none() || table.spacing.is_none() || table.destroy.is_none() {
            return Err(bad("its table has a NULL init, spacing or destroy"));
        }
        // SAFETY: NUL-terminated strings per the ABI (checked for NULL).
        let text = |p: *const c_char, what: &str| -> Result<String, PluginError> {
            if p.is_null() {
                return Err(bad(&format!("its {what} is NULL")));
            }
            unsafe { CStr::from_ptr(p) }
                .to_str()
                .map(str::to_string)
                .map_err(|_| bad(&format!("its {what} is not UTF-8")))
        };
        let name = text(table.name, "name")?;
        let description = text(table.description, "description")?;
        Ok(Arc::new(Plugin {
            path,
            table,
            name,
            description,
            _lib: lib,
        }))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
    /// The plugin's own short name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The plugin's one-line description (what it computes, its arguments).
    pub fn description(&self) -> &str {
        &self.description
    }
    /// Whether the plugin may be called from several threads at once.
    pub fn thread_safe(&self) -> bool {
        self.table.flags & BM_PLUGIN_THREAD_SAFE != 0
    }
}

const ERR_LEN: usize = 1024;

thread_local! {
    /// The error buffer handed to `spacing`, one per thread.
    static ERR: std::cell::RefCell<[c_char; ERR_LEN]> =
        const { std::cell::RefCell::new([0; ERR_LEN]) };
}

/// A plugin's state made by its `init` with one set of arguments; freed by
/// `destroy` on drop.
pub struct Instance {
    plugin: Arc<Plugin>,
    state: *mut c_void,
    /// Serialises calls of a plugin that is not thread-safe.
    lock: Option<Mutex<()>>,
}

// SAFETY: calls are serialised by `lock` unless the plugin declared its
// state immutable after init (BM_PLUGIN_THREAD_SAFE).
unsafe impl Send for Instance {}
unsafe impl Sync for Instance {}

/// A value a plugin must not return, or its refusal.
#[derive(Debug, Clone, PartialEq)]
pub enum CallError {
    /// The plugin returned non-zero with this message.
    Failed(String),
    /// `out[index]` is not finite and > 0.
    BadValue { index: usize, value: f64 },
}

impl Instance {
    /// Calls the plugin's `init` with `args` (`key`, `value`).
    pub fn new(
        plugin: Arc<Plugin>,
        info: &BmInitInfo,
        args: &[(String, String)],
    ) -> Result<Instance, PluginError> {
        let init_err = |message: String| PluginError::Init {
            path: plugin.path.clone(),
            name: plugin.name.clone(),
            message,
        };
        let mut owned = Vec::with_capacity(args.len());
        for (k, v) in args {
            let k = CString::new(k.as_str())
                .map_err(|_| init_err(format!("argument key '{k}' holds a NUL byte")))?;
            let v = CString::new(v.as_str())
                .map_err(|_| init_err(format!("argument value '{v}' holds a NUL byte")))?;
            owned.push((k, v));
        }
        let c_args: Vec<BmArg> = owned
            .iter()
            .map(|(k, v)| BmArg {
                key: k.as_ptr(),
                value: v.as_ptr(),
            })
            .collect();
        let mut info = *info;
        info.struct_size = std::mem::size_of::<BmInitInfo>() as u32;
        let mut state: *mut c_void = std::ptr::null_mut();
        let mut err = [0 as c_char; ERR_LEN];
        let init = plugin.table.init.expect("checked at load");
        // SAFETY: pointers valid for the call; the ABI's init signature.
        let rc = unsafe {
            init(
                &info,
                c_args.as_ptr(),
                c_args.len(),
                &mut state,
                err.as_mut_ptr(),
                ERR_LEN,
            )
        };
        if rc != BM_OK {
            return Err(init_err(format!(
                "init refused its arguments: {}",
                message(&err, "no message")
            )));
        }
        let lock = (!plugin.thread_safe()).then(|| Mutex::new(()));
        Ok(Instance {
            plugin,
            state,
            lock,
        })
    }

    pub fn plugin(&self) -> &Arc<Plugin> {
        &self.plugin
    }

    /// d at every query, one plugin call; every value checked finite and > 0
    /// (`out` is filled with NaN first, so a value left unwritten is caught).
    pub fn spacing(&self, qs: &[BmQuery], out: &mut [f64]) -> Result<(), CallError> {
        assert_eq!(qs.len(), out.len());
        if qs.is_empty() {
            return Ok(());
        }
        out.fill(f64::NAN);
        ERR.with(|e| self.call_with(qs, out, &mut e.borrow_mut()[..]))
    }

    fn call_with(
        &self,
        qs: &[BmQuery],
        out: &mut [f64],
        err: &mut [c_char],
    ) -> Result<(), CallError> {
        // the plugin writes a message only on failure: clearing the first
        // byte is enough (no 1 KiB memset per call on the hot path)
        err[0] = 0;
        let f = self.plugin.table.spacing.expect("checked at load");
        let _guard = self
            .lock
            .as_ref()
            .map(|m| m.lock().unwrap_or_else(|p| p.into_inner()));
        // SAFETY: the ABI's spacing signature; buffers of length qs.len().
        let rc = unsafe {
            f(
                self.state,
                qs.as_ptr(),
                qs.len(),
                out.as_mut_ptr(),
                err.as_mut_ptr(),
                err.len(),
            )
        };
        if rc != BM_OK {
            return Err(CallError::Failed(message(err, "it gave no message")));
        }
        match out.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            Some(index) => Err(CallError::BadValue {
                index,
                value: out[index],
            }),
            None => Ok(()),
        }
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        if let Some(d) = self.plugin.table.destroy {
            // SAFETY: the state came from this plugin's init; last use.
            unsafe { d(self.state) }
        }
    }
}

fn message(buf: &[c_char], otherwise: &str) -> String {
    // the plugin may have forgotten the NUL: never read past the buffer
    let bytes: Vec<u8> = buf
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    let s = String::from_utf8_lossy(&bytes).trim().to_string();
    if s.is_empty() {
        otherwise.to_string()
    } else {
        s
    }
}

/// The [`BmInitInfo`] of a model.
pub fn init_info(model: &Model) -> BmInitInfo {
    let (lo, hi) = model
        .bbox()
        .map(|(a, b)| ([a.x, a.y, a.z], [b.x, b.y, b.z]))
        .unwrap_or_default();
    BmInitInfo {
        struct_size: std::mem::size_of::<BmInitInfo>() as u32,
        model_dim: model.dim() as u32,
        bbox_min: lo,
        bbox_max: hi,
        model_size: model.size(),
    }
}

/// A plugin as a [`Spacing`] on one model. Cloning shares the instance (and
/// its kept failure).
#[derive(Clone)]
pub struct PluginSpacing {
    inner: Arc<Inner>,
}

struct Inner {
    instance: Instance,
    model: Arc<Model>,
    /// Faces each edge bounds (their surface curvature applies on the edge).
    edge_faces: Vec<Vec<u32>>,
    /// Geometry at each vertex: the largest curvatures of the edges and
    /// faces around it.
    vertex_geom: Vec<BmQuery>,
    failure: OnceLock<String>,
}

impl PluginSpacing {
    /// Loads `spec.path` and initialises it with `spec.args` for `model`.
    pub fn load(spec: &PluginSpec, model: Arc<Model>) -> Result<PluginSpacing, PluginError> {
        let plugin = Plugin::load(&spec.path)?;
        PluginSpacing::new(plugin, &spec.args, model)
    }

    /// Initialises a loaded plugin with `args` for `model`.
    pub fn new(
        plugin: Arc<Plugin>,
        args: &[(String, String)],
        model: Arc<Model>,
    ) -> Result<PluginSpacing, PluginError> {
        let instance = Instance::new(plugin, &init_info(&model), args)?;
        let edge_faces = edge_faces(&model);
        let mut vertex_geom: Vec<BmQuery> = model
            .vertices
            .iter()
            .map(|v| BmQuery {
                point: v.point.coords.into(),
                ..Default::default()
            })
            .collect();
        for (ei, e) in model.edges.iter().enumerate() {
            for (v, t) in [(e.start, e.t0), (e.end, e.t1)] {
                let g = edge_geometry(&model, &edge_faces, ei as u32, t);
                if let Some(slot) = vertex_geom.get_mut(v as usize) {
                    slot.curve_curvature = slot.curve_curvature.max(g.curve_curvature);
                    if g.geom & BM_GEOM_SURFACE != 0
                        && (slot.geom & BM_GEOM_SURFACE == 0 || g.k1.abs() > slot.k1.abs())
                    {
                        copy_surface(slot, &g);
                    }
                }
            }
        }
        Ok(PluginSpacing {
            inner: Arc::new(Inner {
                instance,
                model,
                edge_faces,
                vertex_geom,
                failure: OnceLock::new(),
            }),
        })
    }

    pub fn plugin(&self) -> &Arc<Plugin> {
        self.inner.instance.plugin()
    }

    /// The first failure while meshing (the plugin refused, panicked or
    /// returned a value that is not finite and > 0), with the plugin's path,
    /// the point and the entity.
    pub fn failure(&self) -> Option<&str> {
        self.inner.failure.get().map(String::as_str)
    }

    /// What the plugin is given for `q`: the point, entity and parameters
    /// with the local geometry of the model there.
    pub fn query(&self, q: &SpacingQuery) -> BmQuery {
        let m = &self.inner.model;
        let mut b = match q.entity.dim {
            0 => self
                .inner
                .vertex_geom
                .get(q.entity.id as usize)
                .copied()
                .unwrap_or_default(),
            1 if (q.entity.id as usize) < m.edges.len() => {
                edge_geometry(m, &self.inner.edge_faces, q.entity.id, q.params[0])
            }
            2 => {
                let mut b = BmQuery::default();
                if let Some(f) = m.faces.get(q.entity.id as usize) {
                    if let Some(p) = surface_principal(f.surface.as_ref(), q.params) {
                        set_surface(&mut b, &p);
                    }
                }
                b
            }
            _ => BmQuery::default(),
        };
        b.point = q.point.coords.into();
        b.params = q.params;
        b.dim = q.entity.dim as u32;
        b.id = q.entity.id;
        b
    }

    fn fail(&self, q: &SpacingQuery, what: String) {
        let p = q.point;
        let _ = self.inner.failure.set(format!(
            "plugin {} ('{}'): {what} at ({}, {}, {}) on {}",
            self.plugin().path().display(),
            self.plugin().name(),
            p.x,
            p.y,
            p.z,
            describe(&self.inner.model, q.entity)
        ));
    }

    fn call(&self, qs: &[SpacingQuery], bq: &[BmQuery], out: &mut [f64]) {
        if self.inner.failure.get().is_some() {
            out.fill(f64::NAN);
            return;
        }
        match self.inner.instance.spacing(bq, out) {
            Ok(()) => {}
            Err(CallError::Failed(msg)) => {
                self.fail(
                    &qs[0],
                    format!("failed ({msg}) on a batch of {} points starting", qs.len()),
                );
                out.fill(f64::NAN);
            }
            Err(CallError::BadValue { index, value }) => {
                self.fail(
                    &qs[index],
                    format!("returned the spacing {value} (a spacing must be finite and > 0)"),
                );
                out.fill(f64::NAN);
            }
        }
    }
}

fn describe(model: &Model, e: EntityRef) -> String {
    model.describe(e)
}

fn set_surface(b: &mut BmQuery, p: &Principal) {
    b.geom |= BM_GEOM_SURFACE;
    b.normal = p.normal.into();
    b.k1 = p.k1;
    b.k2 = p.k2;
    b.dir1 = p.dir1.into();
    b.dir2 = p.dir2.into();
}

fn copy_surface(dst: &mut BmQuery, src: &BmQuery) {
    dst.geom |= BM_GEOM_SURFACE;
    dst.normal = src.normal;
    dst.k1 = src.k1;
    dst.k2 = src.k2;
    dst.dir1 = src.dir1;
    dst.dir2 = src.dir2;
}

/// Tangent and curvature of edge `ei` at `t`, and the surface geometry of
/// the most curved face the edge bounds.
fn edge_geometry(model: &Model, edge_faces: &[Vec<u32>], ei: u32, t: f64) -> BmQuery {
    let mut b = BmQuery::default();
    let Some(e) = model.edges.get(ei as usize) else {
        return b;
    };
    let d1 = e.curve.d1(t);
    let n = d1.norm();
    if n > 0.0 {
        b.tangent = (d1 / n).into();
        b.geom |= BM_GEOM_TANGENT;
    }
    b.curve_curvature = curve_curvature(e.curve.as_ref(), t);
    let mut best: Option<Principal> = None;
    for &fi in edge_faces.get(ei as usize).map_or(&[][..], |v| &v[..]) {
        let Some(uv) = edge_point_uv(model, fi, ei, t) else {
            continue;
        };
        if let Some(p) = surface_principal(model.faces[fi as usize].surface.as_ref(), uv) {
            if best.is_none_or(|b| p.k1.abs() > b.k1.abs()) {
                best = Some(p);
            }
        }
    }
    if let Some(p) = best {
        set_surface(&mut b, &p);
    }
    b
}

impl Spacing for PluginSpacing {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        let mut out = [f64::NAN];
        self.call(std::slice::from_ref(q), &[self.query(q)], &mut out);
        out[0]
    }

    /// One plugin call for the whole batch.
    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        let bq: Vec<BmQuery> = qs.iter().map(|q| self.query(q)).collect();
        self.call(qs, &bq, out);
    }
}
