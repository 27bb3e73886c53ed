//! `bm_mesh`: meshing a model and reading the result.

use std::ffi::{c_char, c_int, c_void, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::sync::Arc;

use bubblemesh_core::engine::{Event, MeshError, Options, Report};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::remesh::{self, summary, Matching, PlanError, Region, WarmStart};
use bubblemesh_core::spacing::Constant;
use bubblemesh_core::{mesh_model, Mesh, Model};

use crate::error::{
    abort_with, bm_result, from_unwind, guard, guard_void, in_callback_scope, Error, Result,
};
use crate::geometry::UserPtr;
use crate::model::{bm_model, ModelObj};
use crate::spacing::{bm_spacing, spacing_obj, Ready};
use crate::state::{bm_state, state_obj, StateObj};
use crate::{free_handle, into_handle, need, object, put, utf8, Object};
use bubblemesh_core::remesh::Seed;

/// A finished mesh (opaque): nodes, line segments on edges, triangles on
/// faces, tetrahedra in volumes, each with the model entity it came from.
/// Independent of the model and spacing it was made from (it keeps what
/// `bm_mesh_state` needs of them). Free with `bm_mesh_free`.
#[allow(non_camel_case_types)]
pub struct bm_mesh {
    _private: [u8; 0],
}

/// A model entity: `dim` 0 vertex, 1 edge, 2 face, 3 volume; `id` its
/// 0-based id in the model.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct bm_entity {
    /// 0 vertex, 1 edge, 2 face, 3 volume.
    pub dim: i32,
    /// The 0-based id among the entities of `dim`.
    pub id: u32,
}

/// Progress of a run: `phase` (a short name such as "relax"), the entity
/// being meshed, the step and the step limit. Return 0 to go on, non-zero
/// to stop meshing (`bm_mesh_generate_ex` then returns `BM_ERR_CANCELLED`).
#[allow(non_camel_case_types)]
pub type bm_progress_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        phase: *const c_char,
        dim: c_int,
        id: u32,
        step: usize,
        max_steps: usize,
    ) -> c_int,
>;

/// Meshing options; fill with `bm_options_init`, then change fields.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy)]
pub struct bm_options {
    /// Highest dimension to mesh: 0 vertices, 1 edges, 2 faces, 3 volumes
    /// (tetrahedra), -1 the model's highest (for a STEP file: 2 when it has
    /// solids).
    pub dim: c_int,
    /// Non-zero: stage 1 only (hierarchical placement), fast, lower quality.
    pub fast: c_int,
    /// Step limit of the stage-2 relaxation per face; 0 for the default.
    pub max_steps: usize,
    /// Optional (NULL): called during the relaxation.
    pub progress: bm_progress_fn,
    /// Passed to `progress` as its first argument.
    pub progress_user: *mut c_void,
}

impl bm_options {
    /// The options of the calls without `_ex`: default step limit, no
    /// progress callback.
    fn plain(dim: c_int, fast: c_int) -> Self {
        bm_options {
            dim,
            fast,
            max_steps: 0,
            progress: None,
            progress_user: std::ptr::null_mut(),
        }
    }
}

#[repr(C)]
pub(crate) struct MeshObj {
    magic: u64,
    pub mesh: Mesh,
    report: Report,
    /// What `bm_mesh_state` needs of the model and the spacing.
    pub seed: Seed,
    /// A re-meshing's section of the report (what was matched, kept,
    /// moved, added, removed; the stage-2 steps).
    remesh: Option<serde_json::Value>,
}

impl Object for MeshObj {
    const MAGIC: u64 = 0x626d_5f6d_6573_6821; // "bm_mesh!"
    const KIND: &'static str = "bm_mesh";
}

pub(crate) unsafe fn mesh_obj<'a>(p: *const bm_mesh) -> Result<&'a MeshObj> {
    unsafe { object::<MeshObj>(p as *const c_void, "mesh") }
}

/// Fills `*options` with the defaults: dim -1 (the model's), full quality,
/// default step limit, no progress callback.
#[no_mangle]
pub unsafe extern "C" fn bm_options_init(options: *mut bm_options) -> bm_result {
    guard("bm_options_init", || unsafe {
        put(options, "options", bm_options::plain(-1, 0))
    })
}

/// The code for an engine error: the innermost cause decides.
fn code_of(e: &MeshError) -> bm_result {
    #[allow(unreachable_patterns)]
    match e {
        MeshError::BadSpacing { .. } | MeshError::TooManyBubbles { .. } => {
            bm_result::BM_ERR_SPACING
        }
        MeshError::Invalid(_) | MeshError::Volume(_) | MeshError::Shell(_) => {
            bm_result::BM_ERR_GEOMETRY
        }
        MeshError::Unsupported(_) => bm_result::BM_ERR_UNSUPPORTED,
        MeshError::Connect(_) => bm_result::BM_ERR_MESH,
        MeshError::In { source, .. } | MeshError::RefinementStopped { source, .. } => {
            code_of(source)
        }
        _ => bm_result::BM_ERR_MESH,
    }
}

/// Checks `dim` against the range and the model's dimension (`what`
/// names that dimension in the message).
fn check_dim(dim: c_int, model: &Model, what: &str) -> Result<()> {
    if !(-1..=3).contains(&dim) {
        return Err(Error::range(format!(
            "dim = {dim} must be -1 (the model's), 0, 1, 2 or 3"
        )));
    }
    if dim >= 0 && dim as u8 > model.dim() {
        return Err(Error::range(format!(
            "dim = {dim} but {what} is {} ({} vertices, {} edges, {} \
             faces, {} volumes)",
            model.dim(),
            model.vertices.len(),
            model.edges.len(),
            model.faces.len(),
            model.volumes.len()
        )));
    }
    Ok(())
}

/// The engine options of `opts` (its dimension decided by the caller).
fn engine_options(opts: &bm_options, dim: Option<u8>) -> Options {
    let mut o = Options {
        dim,
        fast: opts.fast != 0,
        ..Default::default()
    };
    if opts.max_steps > 0 {
        o.relax.max_steps = opts.max_steps;
    }
    if let Some(f) = opts.progress {
        let user = UserPtr(opts.progress_user);
        // each stage-2 step is a "relax" progress report (the engine's
        // other events are not part of the C interface)
        o.observer = Some(Arc::new(move |e: &Event<'_>| {
            let &Event::Step {
                entity,
                step,
                max_steps,
                ..
            } = e
            else {
                return;
            };
            let phase = CString::new("relax").unwrap_or_default();
            let rc = unsafe {
                f(
                    user.get(),
                    phase.as_ptr(),
                    entity.dim as c_int,
                    entity.id,
                    step,
                    max_steps,
                )
            };
            if rc != 0 {
                abort_with(Error::new(
                    bm_result::BM_ERR_CANCELLED,
                    format!(
                        "cancelled by the progress callback (it returned {rc}) at step {} of {} \
                         on {}",
                        step, max_steps, entity
                    ),
                ));
            }
        }));
    }
    o
}

/// What a state records about a run besides its bubbles: the spacing and
/// the input, as given.
struct Label {
    spacing: String,
    source: String,
}

/// A re-meshing's inputs: the state it starts from and the region of a
/// local re-meshing (§4.8.1; none: continuous re-meshing, §4.8.2).
struct Warm<'a> {
    state: &'a StateObj,
    region: Option<Region>,
}

/// The code and message of a state that cannot re-mesh a model: one of
/// another model is `BM_ERR_STATE`; a region that selects nothing or names
/// a face the model lacks is the region argument's fault (`BM_ERR_RANGE`).
fn plan_error(e: PlanError, w: &Warm<'_>, prefix: &str) -> Error {
    #[allow(unreachable_patterns)]
    let code = match e {
        PlanError::AnotherModel { .. } => bm_result::BM_ERR_STATE,
        PlanError::EmptyRegion(_)
        | PlanError::NoSuchFace { .. }
        | PlanError::ChangedOutside { .. } => bm_result::BM_ERR_RANGE,
        _ => bm_result::BM_ERR_STATE,
    };
    Error::new(
        code,
        format!(
            "{prefix}cannot re-mesh from the state ({}; made from '{}' with spacing '{}'): {e}",
            w.state.origin, w.state.state.source, w.state.state.spacing
        ),
    )
}

/// The report's `remesh` section, as the command line's: the summary of
/// what was matched, kept, moved, added and removed, and the stage-2 steps
/// of each face.
fn remesh_section(
    w: &Warm<'_>,
    matching: Matching,
    warm: &WarmStart,
    mesh: &Mesh,
    report: &Report,
) -> serde_json::Value {
    let s = summary::section(
        &w.state.state,
        matching,
        warm,
        mesh,
        w.region.as_ref(),
        report.stage2_steps_per_face(),
    );
    serde_json::to_value(s).unwrap_or_default()
}

/// Meshes `model` with the spacing `ready` makes (from the state of `warm`
/// when given): inside the callback scope, with the unwind of a failing
/// callback caught here (so locks held by the caller are released
/// normally). Matching the state to the model and taking the new state's
/// records evaluate the geometry and the spacing too, so they run here. A
/// plugin failure is the cause of any error and fails the run even when
/// meshing succeeded (a minimum can hide the NaN a failed plugin answers).
fn run<'s>(
    model: &Model,
    ready: impl FnOnce() -> Result<Ready<'s>>,
    o: &Options,
    prefix: &str,
    label: &Label,
    warm: Option<&Warm<'_>>,
) -> Result<MeshObj> {
    let r = in_callback_scope(|| {
        catch_unwind(AssertUnwindSafe(|| -> Result<MeshObj> {
            let spacing = ready()?;
            let r = (|| {
                let mut o = o.clone();
                let planned = match warm {
                    Some(w) => {
                        let (start, matching) = remesh::plan(
                            &w.state.state,
                            model,
                            spacing.spacing(),
                            w.region.as_ref(),
                        )
                        .map_err(|e| plan_error(e, w, prefix))?;
                        let start = Arc::new(start);
                        o.warm = Some(start.clone());
                        Some((w, start, matching))
                    }
                    None => None,
                };
                let (mesh, report) = mesh_model(model, spacing.spacing(), &o)
                    .map_err(|e| Error::new(code_of(&e), format!("{prefix}{e}")))?;
                let seed = Seed::new(
                    model,
                    &mesh,
                    spacing.spacing(),
                    &label.spacing,
                    &label.source,
                );
                let remesh = planned.map(|(w, start, matching)| {
                    remesh_section(w, matching, &start, &mesh, &report)
                });
                Ok(MeshObj {
                    magic: MeshObj::MAGIC,
                    mesh,
                    report,
                    seed,
                    remesh,
                })
            })();
            if let Some(f) = spacing.failure() {
                return Err(Error::new(
                    bm_result::BM_ERR_SPACING,
                    format!("{prefix}{f}"),
                ));
            }
            r
        }))
    });
    match r {
        Err(payload) => Err(from_unwind(payload)),
        Ok(r) => r,
    }
}

/// The region argument of a re-meshing: NULL is none.
unsafe fn region_arg(region: *const c_char) -> Result<Option<Region>> {
    if region.is_null() {
        return Ok(None);
    }
    let text = unsafe { utf8(region, "region")? };
    Region::parse(text)
        .map(Some)
        .map_err(|e| Error::range(format!("argument 'region' {e}")))
}

/// Checks the options of a re-meshing: no `fast` (a warm start is a short
/// stage 2, as the command line's `remesh` refuses `--fast`).
fn check_warm_options(opts: &bm_options) -> Result<()> {
    if opts.fast != 0 {
        return Err(Error::new(
            bm_result::BM_ERR_UNSUPPORTED,
            "fast (stage 1 only) is not supported by a re-meshing: a warm start is a short \
             stage 2",
        ));
    }
    Ok(())
}

fn generate(
    model: *const bm_model,
    spacing: *const bm_spacing,
    opts: bm_options,
    warm: Option<(*const bm_state, *const c_char)>,
    out: *mut *mut bm_mesh,
) -> Result<()> {
    let m = unsafe { object::<ModelObj>(model as *const c_void, "model")? };
    let s = unsafe { spacing_obj(spacing)? };
    let warm = match warm {
        Some((state, region)) => Some(Warm {
            state: unsafe { state_obj(state)? },
            region: unsafe { region_arg(region)? },
        }),
        None => None,
    };
    need(out, "out")?;
    if warm.is_some() {
        check_warm_options(&opts)?;
    }
    if !(-1..=3).contains(&opts.dim) {
        return Err(Error::range(format!(
            "dim = {} must be -1 (the model's), 0, 1, 2 or 3",
            opts.dim
        )));
    }
    let model = m.lock()?;
    let _claim = s.claim()?;
    check_dim(opts.dim, &model, "the model's highest dimension")?;
    let o = engine_options(&opts, (opts.dim >= 0).then_some(opts.dim as u8));
    let label = Label {
        spacing: s.describe(),
        source: "bm_model".into(),
    };
    let obj = run(&model, || s.ready(&model), &o, "", &label, warm.as_ref())?;
    unsafe { put(out, "out", into_handle(obj)) }
}

/// Meshes `model` with `spacing` up to dimension `dim` (-1: the model's
/// highest; 3 fills the volumes with tetrahedra), `fast` non-zero for
/// stage 1 only. The new mesh goes to `*out`. Callbacks of the model and
/// the spacing (and spacing plugins) are called from this thread only, one
/// at a time, before this returns.
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_generate(
    model: *const bm_model,
    spacing: *const bm_spacing,
    dim: c_int,
    fast: c_int,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_mesh_generate", || {
        generate(model, spacing, bm_options::plain(dim, fast), None, out)
    })
}

/// `bm_mesh_generate` with options (a step limit, a progress callback that
/// can cancel).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_generate_ex(
    model: *const bm_model,
    spacing: *const bm_spacing,
    options: *const bm_options,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_mesh_generate_ex", || {
        if options.is_null() {
            return Err(Error::null("options"));
        }
        generate(model, spacing, unsafe { *options }, None, out)
    })
}

/// Reads the STEP file at `path` (`bubblemesh-truck`, the reader of the
/// command line): a missing or unreadable file is `BM_ERR_IO`, anything
/// the reader refuses (not STEP, truncated, a syntax error, an entity it
/// cannot convert) `BM_ERR_FORMAT` with its message, which names the file,
/// the entity (`#id TYPE`) and the reason.
fn read_step(path: &str) -> Result<Model> {
    // Read here rather than with `bubblemesh_truck::read_step` (which does
    // the same: read the bytes, then `parse_step` on them as lossy UTF-8)
    // only to tell a file that cannot be read (BM_ERR_IO) from one whose
    // content is refused (BM_ERR_FORMAT) without matching message text.
    let bytes = std::fs::read(path).map_err(|e| {
        Error::new(
            bm_result::BM_ERR_IO,
            format!("{path}: cannot read the STEP file: {e}"),
        )
    })?;
    bubblemesh_truck::parse_step(&String::from_utf8_lossy(&bytes), path)
        .map(|s| s.model)
        .map_err(|e| Error::new(bm_result::BM_ERR_FORMAT, e.to_string()))
}

fn step_file(
    path: *const c_char,
    spacing: *const bm_spacing,
    opts: bm_options,
    warm: Option<(*const bm_state, *const c_char)>,
    out: *mut *mut bm_mesh,
) -> Result<()> {
    let path = unsafe { utf8(path, "path")? };
    let s = if spacing.is_null() {
        None
    } else {
        Some(unsafe { spacing_obj(spacing)? })
    };
    let warm = match warm {
        Some((state, region)) => Some(Warm {
            state: unsafe { state_obj(state)? },
            region: unsafe { region_arg(region)? },
        }),
        None => None,
    };
    need(out, "out")?;
    if warm.is_some() {
        check_warm_options(&opts)?;
    }
    if !(-1..=3).contains(&opts.dim) {
        return Err(Error::range(format!(
            "dim = {} must be -1 (2 for a file with solids, else the file's highest), 0, 1, \
             2 or 3",
            opts.dim
        )));
    }
    let _claim = s.map(|s| s.claim()).transpose()?;
    let model = read_step(path)?;
    check_dim(
        opts.dim,
        &model,
        &format!("the highest dimension of '{path}'"),
    )?;
    // the command line's defaults: a file with solids meshes their
    // boundary surfaces unless dim 3 is asked for
    let dim = if opts.dim >= 0 {
        opts.dim as u8
    } else {
        model.dim().min(2)
    };
    let o = engine_options(&opts, Some(dim));
    let prefix = format!("{path}: ");
    let warm = warm.as_ref();
    let obj = match s {
        Some(s) => {
            let label = Label {
                spacing: s.describe(),
                source: path.to_string(),
            };
            run(&model, || s.ready(&model), &o, &prefix, &label, warm)?
        }
        None => {
            // the command line's default spacing: 1/40 of the bounding-box
            // diagonal
            let diag = model.size();
            if !(diag > 0.0 && diag.is_finite()) {
                return Err(Error::geometry(format!(
                    "{path}: the model is empty or has zero size"
                )));
            }
            let d = diag / 40.0;
            let label = Label {
                spacing: format!("{d}"),
                source: path.to_string(),
            };
            run(
                &model,
                || Ok(Ready::owned(Box::new(Constant(d)))),
                &o,
                &prefix,
                &label,
                warm,
            )?
        }
    };
    unsafe { put(out, "out", into_handle(obj)) }
}

/// Meshes the STEP file at `path` (ISO 10303-21, AP203/AP214/AP242 B-rep,
/// read by the same reader as the command line) with `spacing` up to
/// dimension `dim`, `fast` non-zero for stage 1 only. `spacing` NULL uses
/// the command line's default, 1/40 of the model's bounding-box diagonal.
/// `dim` -1 is the command line's default: the faces (2) for a file with
/// solids, else the file's highest dimension; 3 fills each solid with
/// tetrahedra (entity ids: the file's vertices, edges, faces and solids in
/// the reader's order). Lengths are in the file's length unit.
///
/// A missing or unreadable file gives `BM_ERR_IO`; a file the reader
/// refuses (not STEP, truncated, a syntax error, an entity it cannot
/// convert) `BM_ERR_FORMAT`, with a message naming the file, the entity
/// (`#id TYPE`) and the reason. The file is parsed in memory (a STEP file
/// of N bytes needs a few times N).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_step_file(
    path: *const c_char,
    spacing: *const bm_spacing,
    dim: c_int,
    fast: c_int,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_mesh_step_file", || {
        step_file(path, spacing, bm_options::plain(dim, fast), None, out)
    })
}

/// `bm_mesh_step_file` with options (dimension, step limit, a progress
/// callback that can cancel).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_step_file_ex(
    path: *const c_char,
    spacing: *const bm_spacing,
    options: *const bm_options,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_mesh_step_file_ex", || {
        if options.is_null() {
            return Err(Error::null("options"));
        }
        step_file(path, spacing, unsafe { *options }, None, out)
    })
}

/// Re-meshes `model` (thesis §4.8) with `spacing` up to dimension `dim`
/// (as `bm_mesh_generate`), starting from `state`, the packing of an
/// earlier run (`bm_mesh_state`, `bm_state_load`) on this model before a
/// change (a hole moved, a part made longer, a spacing refined). The new
/// mesh goes to `*out`.
///
/// Each edge, face and volume of `model` that matches the state's entity
/// of the same dimension and id (same name and type of geometry, its
/// length or boundary length within 25 %, its centroid within 25 % of its
/// size) starts from the old bubbles; the others are meshed from scratch.
/// `region` NULL is a continuous re-meshing: the old bubbles the change
/// disturbs (moved geometry, a changed spacing, entities that no longer
/// match), and those within 3 spacings of them, move; the others keep
/// their coordinates bit for bit. `region` "box:x0,y0,z0,x1,y1,z1",
/// "sphere:x,y,z,r" or "faces:3,7" is a local re-meshing: only the old
/// bubbles in the region or within 2 spacings of it (on the listed faces
/// and the edges only they use) move, the others are kept bit for bit.
/// Stage 2 then runs short. `bm_mesh_report_json` tells what was matched,
/// kept, moved, added and removed.
///
/// A state of another model (fewer than half its entities match) gives
/// `BM_ERR_STATE`; a region that does not parse, that selects no bubble,
/// or that names a face the model lacks, `BM_ERR_RANGE`. A re-meshing is
/// not available with `fast` (`bm_remesh_generate_ex`: `BM_ERR_UNSUPPORTED`).
#[no_mangle]
pub unsafe extern "C" fn bm_remesh_generate(
    model: *const bm_model,
    spacing: *const bm_spacing,
    state: *const bm_state,
    dim: c_int,
    region: *const c_char,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_remesh_generate", || {
        generate(
            model,
            spacing,
            bm_options::plain(dim, 0),
            Some((state, region)),
            out,
        )
    })
}

/// `bm_remesh_generate` with options (dimension, step limit, a progress
/// callback that can cancel; `fast` must be 0).
#[no_mangle]
pub unsafe extern "C" fn bm_remesh_generate_ex(
    model: *const bm_model,
    spacing: *const bm_spacing,
    state: *const bm_state,
    options: *const bm_options,
    region: *const c_char,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_remesh_generate_ex", || {
        if options.is_null() {
            return Err(Error::null("options"));
        }
        generate(
            model,
            spacing,
            unsafe { *options },
            Some((state, region)),
            out,
        )
    })
}

/// Re-meshes the STEP file at `path` from `state` (see
/// `bm_remesh_generate`), with the defaults and errors of
/// `bm_mesh_step_file`: `spacing` NULL is 1/40 of the new model's
/// bounding-box diagonal, `dim` -1 the faces of a file with solids. The
/// file's entities are matched by their ids in the reader's order, so the
/// state of an earlier version of the part (re-exported after a change)
/// warm-starts the entities the change left alone.
#[no_mangle]
pub unsafe extern "C" fn bm_remesh_step_file(
    path: *const c_char,
    spacing: *const bm_spacing,
    state: *const bm_state,
    dim: c_int,
    region: *const c_char,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_remesh_step_file", || {
        step_file(
            path,
            spacing,
            bm_options::plain(dim, 0),
            Some((state, region)),
            out,
        )
    })
}

/// `bm_remesh_step_file` with options (dimension, step limit, a progress
/// callback that can cancel; `fast` must be 0).
#[no_mangle]
pub unsafe extern "C" fn bm_remesh_step_file_ex(
    path: *const c_char,
    spacing: *const bm_spacing,
    state: *const bm_state,
    options: *const bm_options,
    region: *const c_char,
    out: *mut *mut bm_mesh,
) -> bm_result {
    guard("bm_remesh_step_file_ex", || {
        if options.is_null() {
            return Err(Error::null("options"));
        }
        step_file(
            path,
            spacing,
            unsafe { *options },
            Some((state, region)),
            out,
        )
    })
}

/// Frees a mesh (NULL: nothing).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_free(mesh: *mut bm_mesh) {
    guard_void("bm_mesh_free", || unsafe {
        free_handle::<MeshObj>(mesh as *mut c_void)
    })
}

/// Copies `items` into `out[0..len]`, which must hold them all (`out` may be
/// NULL only when there is nothing to copy).
unsafe fn copy_out<T>(
    out: *mut T,
    len: usize,
    per: usize,
    count: usize,
    what: &str,
    items: impl Iterator<Item = T>,
) -> Result<()> {
    let need_len = per * count;
    if need_len == 0 {
        return Ok(());
    }
    if out.is_null() {
        return Err(Error::null("out"));
    }
    if len < need_len {
        return Err(Error::range(format!(
            "the buffer holds {len} values but the mesh's {what} need {need_len} \
             ({count} x {per})"
        )));
    }
    let mut k = 0;
    for it in items.take(need_len) {
        unsafe { out.add(k).write(it) };
        k += 1;
    }
    debug_assert_eq!(k, need_len);
    Ok(())
}

fn entity(e: EntityRef) -> bm_entity {
    bm_entity {
        dim: e.dim as i32,
        id: e.id,
    }
}

/// The number of nodes.
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_node_count(
    mesh: *const bm_mesh,
    out_count: *mut usize,
) -> bm_result {
    guard("bm_mesh_node_count", || unsafe {
        let m = mesh_obj(mesh)?;
        put(out_count, "out_count", m.mesh.nodes.len())
    })
}

/// The number of line segments (on model edges).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_line_count(
    mesh: *const bm_mesh,
    out_count: *mut usize,
) -> bm_result {
    guard("bm_mesh_line_count", || unsafe {
        let m = mesh_obj(mesh)?;
        put(out_count, "out_count", m.mesh.lines.len())
    })
}

/// The number of triangles (on model faces).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_triangle_count(
    mesh: *const bm_mesh,
    out_count: *mut usize,
) -> bm_result {
    guard("bm_mesh_triangle_count", || unsafe {
        let m = mesh_obj(mesh)?;
        put(out_count, "out_count", m.mesh.triangles.len())
    })
}

/// The number of tetrahedra (in model volumes; 0 unless meshed with dim 3).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_tetrahedron_count(
    mesh: *const bm_mesh,
    out_count: *mut usize,
) -> bm_result {
    guard("bm_mesh_tetrahedron_count", || unsafe {
        let m = mesh_obj(mesh)?;
        put(out_count, "out_count", m.mesh.tetrahedra.len())
    })
}

/// Copies the node coordinates, x y z per node, into `xyz` (`len` doubles,
/// at least 3 x node count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_nodes(
    mesh: *const bm_mesh,
    xyz: *mut f64,
    len: usize,
) -> bm_result {
    guard("bm_mesh_nodes", || unsafe {
        let m = mesh_obj(mesh)?;
        let n = &m.mesh.nodes;
        copy_out(
            xyz,
            len,
            3,
            n.len(),
            "node coordinates",
            n.iter().flat_map(|n| [n.pos.x, n.pos.y, n.pos.z]),
        )
    })
}

/// Copies each node's parameters on its entity, 2 per node (t and 0 on an
/// edge, u and v on a face, 0 and 0 on a vertex), into `uv` (`len` doubles,
/// at least 2 x node count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_node_params(
    mesh: *const bm_mesh,
    uv: *mut f64,
    len: usize,
) -> bm_result {
    guard("bm_mesh_node_params", || unsafe {
        let m = mesh_obj(mesh)?;
        let n = &m.mesh.nodes;
        copy_out(
            uv,
            len,
            2,
            n.len(),
            "node parameters",
            n.iter().flat_map(|n| n.params),
        )
    })
}

/// Copies the entity each node lies on (a vertex, an edge, a face) into
/// `out` (`len` entries, at least the node count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_node_entities(
    mesh: *const bm_mesh,
    out: *mut bm_entity,
    len: usize,
) -> bm_result {
    guard("bm_mesh_node_entities", || unsafe {
        let m = mesh_obj(mesh)?;
        let n = &m.mesh.nodes;
        copy_out(
            out,
            len,
            1,
            n.len(),
            "node entities",
            n.iter().map(|n| entity(n.entity)),
        )
    })
}

/// Copies the line segments, 2 node indices (0-based) each, into `out`
/// (`len` values, at least 2 x line count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_lines(
    mesh: *const bm_mesh,
    out: *mut u32,
    len: usize,
) -> bm_result {
    guard("bm_mesh_lines", || unsafe {
        let els = &mesh_obj(mesh)?.mesh.lines;
        copy_out(
            out,
            len,
            2,
            els.len(),
            "lines",
            els.iter().flat_map(|e| e.nodes),
        )
    })
}

/// Copies the triangles, 3 node indices (0-based) each, counter-clockwise
/// in their face's (u,v), into `out` (`len` values, at least 3 x
/// triangle count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_triangles(
    mesh: *const bm_mesh,
    out: *mut u32,
    len: usize,
) -> bm_result {
    guard("bm_mesh_triangles", || unsafe {
        let els = &mesh_obj(mesh)?.mesh.triangles;
        copy_out(
            out,
            len,
            3,
            els.len(),
            "triangles",
            els.iter().flat_map(|e| e.nodes),
        )
    })
}

/// Copies the tetrahedra, 4 node indices (0-based) each, into `out`
/// (`len` values, at least 4 x tetrahedron count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_tetrahedra(
    mesh: *const bm_mesh,
    out: *mut u32,
    len: usize,
) -> bm_result {
    guard("bm_mesh_tetrahedra", || unsafe {
        let els = &mesh_obj(mesh)?.mesh.tetrahedra;
        copy_out(
            out,
            len,
            4,
            els.len(),
            "tetrahedra",
            els.iter().flat_map(|e| e.nodes),
        )
    })
}

/// Copies the edge each line segment lies on into `out` (`len` entries,
/// at least the line count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_line_entities(
    mesh: *const bm_mesh,
    out: *mut bm_entity,
    len: usize,
) -> bm_result {
    guard("bm_mesh_line_entities", || unsafe {
        let els = &mesh_obj(mesh)?.mesh.lines;
        copy_out(
            out,
            len,
            1,
            els.len(),
            "lines",
            els.iter().map(|e| entity(e.entity)),
        )
    })
}

/// Copies the face each triangle lies on into `out` (`len` entries, at
/// least the triangle count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_triangle_entities(
    mesh: *const bm_mesh,
    out: *mut bm_entity,
    len: usize,
) -> bm_result {
    guard("bm_mesh_triangle_entities", || unsafe {
        let els = &mesh_obj(mesh)?.mesh.triangles;
        copy_out(
            out,
            len,
            1,
            els.len(),
            "triangles",
            els.iter().map(|e| entity(e.entity)),
        )
    })
}

/// Copies the volume each tetrahedron lies in into `out` (`len` entries,
/// at least the tetrahedron count).
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_tetrahedron_entities(
    mesh: *const bm_mesh,
    out: *mut bm_entity,
    len: usize,
) -> bm_result {
    guard("bm_mesh_tetrahedron_entities", || unsafe {
        let els = &mesh_obj(mesh)?.mesh.tetrahedra;
        copy_out(
            out,
            len,
            1,
            els.len(),
            "tetrahedra",
            els.iter().map(|e| entity(e.entity)),
        )
    })
}

/// Writes the mesh to `path` (UTF-8); the format follows the extension:
/// `.msh` (Gmsh MSH 4.1 with entity tags), `.vtu`, `.stl`, `.obj`, `.mesh`
/// (Medit). The file is written whole or not at all.
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_write(mesh: *const bm_mesh, path: *const c_char) -> bm_result {
    guard("bm_mesh_write", || unsafe {
        let m = mesh_obj(mesh)?;
        let path = utf8(path, "path")?;
        bubblemesh_io::write(&m.mesh, Path::new(path))
            .map_err(|e| Error::new(bm_result::BM_ERR_IO, e.to_string()))
    })
}

/// The run's report as JSON (counts, timings per stage, per-face stage-2
/// statistics and energy history). A re-meshing's report has a `remesh`
/// section too, as the command line's `--report`: `summary` (`matching`:
/// the entities `matched` and `unmatched`, with why, and the old bubbles
/// left free and kept; the new nodes `kept` bit for bit, `moved`, `added`;
/// the old bubbles `removed`; with a box or sphere region,
/// `far_from_region` and `far_kept`), `stage2_steps_per_face`,
/// `stage2_steps_max`, `stage2_steps_total`. With `buf` NULL, stores the length
/// (without the NUL) in `*out_len` and returns `BM_OK`; otherwise `buf`
/// must hold the JSON and its NUL (`len` > length), else `BM_ERR_RANGE`.
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_report_json(
    mesh: *const bm_mesh,
    buf: *mut c_char,
    len: usize,
    out_len: *mut usize,
) -> bm_result {
    guard("bm_mesh_report_json", || unsafe {
        let m = mesh_obj(mesh)?;
        need(out_len, "out_len")?;
        let serialize = |e: serde_json::Error| {
            Error::new(
                bm_result::BM_ERR_PANIC,
                format!("cannot serialize the report: {e}"),
            )
        };
        let mut value = serde_json::to_value(&m.report).map_err(serialize)?;
        if let (Some(section), Some(obj)) = (&m.remesh, value.as_object_mut()) {
            obj.insert("remesh".into(), section.clone());
        }
        let json = serde_json::to_string(&value).map_err(serialize)?;
        if !buf.is_null() {
            if len <= json.len() {
                return Err(Error::range(format!(
                    "the buffer holds {len} bytes but the report needs {} (with its NUL)",
                    json.len() + 1
                )));
            }
            std::ptr::copy_nonoverlapping(json.as_ptr(), buf as *mut u8, json.len());
            *buf.add(json.len()) = 0;
        }
        put(out_len, "out_len", json.len())
    })
}
