//! `bubblemesh._native`: the Rust half of the Python package `bubblemesh`.
//!
//! [`mesh`] runs the same steps as `bubblemesh mesh` (through
//! `bubblemesh-run`: reading the model, building the spacing, the engine's
//! options with the command line's defaults) on a thread of its own while
//! the calling thread, without the GIL, waits for it and looks for Ctrl-C
//! every 50 ms. The GIL is taken back only to call Python: the spacing
//! callable ([`spacing::PySpacing`], in batches), the progress callback,
//! and the signal check. A cancellation (Ctrl-C, a progress callback
//! answering `False` or raising, a spacing callable failing) unwinds the
//! meshing thread with [`Abort`] (`resume_unwind`, so no panic message),
//! which the runner catches; any other panic of the engine becomes a
//! `MeshError`. Nothing panics across the boundary.
//!
//! The pure-Python half (`pysrc/bubblemesh/__init__.py`) turns CadQuery
//! and build123d objects into STEP files and a Python callable into the
//! `size_fn` argument.

#![forbid(unsafe_code)]

mod meshobj;
mod spacing;

use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bubblemesh_core::{mesh_model, Event, MeshError as CoreError};
use bubblemesh_plugin_host::PluginSpec;
use bubblemesh_run::{Combine, EngineSettings, Error as RunError, SpacingRequest};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyKeyboardInterrupt};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

use crate::meshobj::Mesh;
use crate::spacing::PySpacing;

create_exception!(
    bubblemesh,
    MeshError,
    PyException,
    "Meshing failed; the message is the command line's."
);
create_exception!(
    bubblemesh,
    InputError,
    MeshError,
    "The input (file, model, option) could not be read or is invalid."
);
create_exception!(
    bubblemesh,
    SpacingError,
    MeshError,
    "The spacing (size expression, callable, plugin) is invalid or failed."
);
create_exception!(
    bubblemesh,
    Cancelled,
    MeshError,
    "Meshing was cancelled by the progress callback."
);

/// The unwinding payload of a cancelled run: the reason is kept in
/// [`Run::failure`].
pub(crate) struct Abort;

/// What a run shares between the waiting thread, the meshing thread and
/// the callbacks: whether it is cancelled, and the first error that
/// cancelled it.
#[derive(Default)]
pub(crate) struct Run {
    cancelled: AtomicBool,
    failure: Mutex<Option<PyErr>>,
}

impl Run {
    /// Cancels the run because of `err` (the first reason is kept).
    pub(crate) fn cancel(&self, err: PyErr) {
        let mut f = self.failure.lock().unwrap_or_else(|p| p.into_inner());
        if f.is_none() {
            *f = Some(err);
        }
        self.cancelled.store(true, Ordering::SeqCst);
    }

    /// Whether the run is cancelled.
    pub(crate) fn cancelled(&self) -> bool {
        self.cancelled.load(Ordering::SeqCst)
    }

    /// Unwinds the meshing thread when the run is cancelled.
    pub(crate) fn stop_if_cancelled(&self) {
        if self.cancelled() {
            std::panic::resume_unwind(Box::new(Abort));
        }
    }

    /// The error that cancelled the run.
    fn take_failure(&self) -> Option<PyErr> {
        self.failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
    }

    /// The error that cancelled a call after the run (a spacing callable
    /// failing in `Mesh.quality`), and the run no longer cancelled.
    pub(crate) fn take_failure_and_reset(&self) -> Option<PyErr> {
        let f = self.take_failure();
        self.cancelled.store(false, Ordering::SeqCst);
        f
    }
}

/// The Python exception of a run's error, carrying its message.
pub(crate) fn to_py(e: RunError) -> PyErr {
    let msg = e.to_string();
    match e {
        RunError::Expr(_) | RunError::Plugin(_) => SpacingError::new_err(msg),
        RunError::Mesh {
            source: CoreError::BadSpacing { .. },
            ..
        } => SpacingError::new_err(msg),
        RunError::Mesh { .. } | RunError::Threads { .. } => MeshError::new_err(msg),
        RunError::Write(_)
        | RunError::MakeDir(_)
        | RunError::OutputKind(_)
        | RunError::Picture { .. }
        | RunError::Viz(_)
        | RunError::Json(_) => MeshError::new_err(msg),
        RunError::Message(_) | RunError::Domain(_) | RunError::Step(_) | RunError::Io(_) => {
            InputError::new_err(msg)
        }
    }
}

/// The progress callback of a run: a Python callable told of the events,
/// stage-2 steps at most every 0.1 s.
struct Progress {
    callback: Py<PyAny>,
    last_step: Mutex<Option<Instant>>,
}

impl Progress {
    /// Tells the callback of `e` (unless it is a step too soon after the
    /// last one told); `Err` when it answered `False` or raised.
    fn tell(&self, e: &Event<'_>, t0: Instant) -> Result<(), PyErr> {
        if let Event::Step {
            step, max_steps, ..
        } = e
        {
            let mut last = self.last_step.lock().unwrap_or_else(|p| p.into_inner());
            let now = Instant::now();
            let due = last.map_or(true, |t| now - t >= Duration::from_millis(100));
            if !(due || *step == 1 || step == max_steps) {
                return Ok(());
            }
            *last = Some(now);
        }
        Python::with_gil(|py| {
            let info = PyDict::new(py);
            let (event, entity) = match e {
                Event::Stage1 { entity, .. } => ("stage1", *entity),
                Event::Step {
                    entity,
                    step,
                    max_steps,
                    ..
                } => {
                    info.set_item("step", *step)?;
                    info.set_item("max_steps", *max_steps)?;
                    ("step", *entity)
                }
                Event::Pass {
                    entity,
                    name,
                    seconds,
                    ..
                } => {
                    info.set_item("name", *name)?;
                    info.set_item("seconds", *seconds)?;
                    ("pass", *entity)
                }
                Event::Done { entity, .. } => ("done", *entity),
            };
            info.set_item("event", event)?;
            info.set_item("dim", entity.dim)?;
            info.set_item("entity", entity.id)?;
            info.set_item("elapsed", t0.elapsed().as_secs_f64())?;
            let answer = self.callback.call1(py, (info,))?;
            if answer
                .bind(py)
                .downcast::<PyBool>()
                .is_ok_and(|b| !b.is_true())
            {
                return Err(Cancelled::new_err(
                    "meshing cancelled: the progress callback returned False",
                ));
            }
            Ok(())
        })
    }
}

/// Meshes a STEP or TOML file: see `bubblemesh.mesh` (the Python wrapper,
/// which turns CAD objects and callables into these arguments).
#[pyfunction]
#[pyo3(signature = (
    path, size=None, size_fn=None, dim=None, curvature=None, view=None, plugins=Vec::new(),
    fast=false, threads=None, progress=None, show_progress=true, unit=None, d_min=None,
    d_max=None, combine="min", circle_points=bubblemesh_core::DEFAULT_CIRCLE_POINTS, name=None
))]
#[allow(clippy::too_many_arguments)]
fn mesh(
    py: Python<'_>,
    path: PathBuf,
    size: Option<String>,
    size_fn: Option<Py<PyAny>>,
    dim: Option<u8>,
    curvature: Option<f64>,
    view: Option<String>,
    plugins: Vec<(PathBuf, Vec<(String, String)>)>,
    fast: bool,
    threads: Option<u64>,
    progress: Option<Py<PyAny>>,
    show_progress: bool,
    unit: Option<String>,
    d_min: Option<f64>,
    d_max: Option<f64>,
    combine: &str,
    circle_points: u32,
    name: Option<String>,
) -> PyResult<Mesh> {
    let t0 = Instant::now();
    let input_name = name.unwrap_or_else(|| path.display().to_string());
    let threads = match threads {
        Some(n) => Some(bubblemesh_run::check_threads(n).map_err(to_py)?),
        None => None,
    };
    let threads = bubblemesh_run::thread_count(threads);
    let unit = match unit {
        Some(u) => Some(bubblemesh_run::parse_unit(&u).map_err(InputError::new_err)?),
        None => None,
    };
    let combine = match combine {
        "min" => Combine::Min,
        "product" => Combine::Product,
        other => {
            return Err(InputError::new_err(format!(
                "combine '{other}': expected 'min' or 'product'"
            )))
        }
    };
    let specs: Vec<PluginSpec> = plugins
        .into_iter()
        .map(|(path, args)| PluginSpec { path, args })
        .collect();
    let (model, step_info) =
        py.allow_threads(|| bubblemesh_run::read_model(&path, unit.as_ref()).map_err(to_py))?;
    bubblemesh_run::check_dim(dim).map_err(to_py)?;
    let model = Arc::new(model);
    let run = Arc::new(Run::default());
    let custom = match size_fn {
        Some(f) => Some((
            Box::new(PySpacing::new(py, f, &model, run.clone())?)
                as Box<dyn bubblemesh_core::Spacing>,
            "<Python callable>".to_string(),
        )),
        None => None,
    };
    let request = SpacingRequest {
        custom,
        curvature,
        view_spacing: view.as_deref(),
        combine,
        plugins: &specs,
        d_min,
        d_max,
    };
    let (size_text, _) =
        bubblemesh_run::size_text(size.as_deref(), request.others_given(), &model, &path)
            .map_err(to_py)?;
    let built = bubblemesh_run::build_spacing(request, &size_text, &model).map_err(to_py)?;
    if circle_points > bubblemesh_core::MAX_CIRCLE_POINTS {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "circle_points must be 0 to {}, not {circle_points}",
            bubblemesh_core::MAX_CIRCLE_POINTS
        )));
    }
    let settings = EngineSettings {
        dim,
        fast,
        threads,
        circle_points,
        ..Default::default()
    };
    let mut opts = settings.options(&path, &model);
    let bar = if show_progress && progress.is_none() {
        bubblemesh_run::progress_bar(false, &model)
    } else {
        None
    };
    let progress = progress.map(|callback| Progress {
        callback,
        last_step: Mutex::new(None),
    });
    {
        let run = run.clone();
        let bar = bar.clone();
        opts.observer = Some(Arc::new(move |e: &Event<'_>| {
            run.stop_if_cancelled();
            if let Some(b) = &bar {
                bubblemesh_run::show_step(b, e);
            }
            if let Some(p) = &progress {
                if let Err(err) = p.tell(e, t0) {
                    run.cancel(err);
                    run.stop_if_cancelled();
                }
            }
        }));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|source| to_py(RunError::Threads { threads, source }))?;
    let spacing = built.spacing.as_ref();
    let meshed = py.allow_threads(|| {
        std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::channel();
            let (model, opts) = (&model, &opts);
            s.spawn(move || {
                let r = pool.install(|| {
                    std::panic::catch_unwind(AssertUnwindSafe(|| mesh_model(model, spacing, opts)))
                });
                let _ = tx.send(r);
            });
            loop {
                match rx.recv_timeout(Duration::from_millis(50)) {
                    Ok(r) => return r,
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                        if let Err(e) = Python::with_gil(|py| py.check_signals()) {
                            run.cancel(e);
                        }
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                        return Err(Box::new("the meshing thread ended without a result")
                            as Box<dyn std::any::Any + Send>)
                    }
                }
            }
        })
    });
    drop(opts);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if let Some(err) = run.take_failure() {
        return Err(err);
    }
    if let Some(f) = built.plugin_failure(&input_name) {
        return Err(to_py(f));
    }
    let (mesh, report) = match meshed {
        Ok(Ok(m)) => m,
        Ok(Err(source)) => {
            return Err(to_py(RunError::Mesh {
                input: input_name,
                source,
            }))
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            return Err(MeshError::new_err(format!(
                "{input_name}: internal error of the engine (a bug, please report it): {what}"
            )));
        }
    };
    let t_mesh = t0.elapsed().as_secs_f64();
    let mut warnings = bubblemesh_run::refined_warnings(&model, &report);
    warnings.extend(bubblemesh_run::touching_warning(&report));
    warnings.extend(bubblemesh_run::open_shell_warning(&report));
    warnings.extend(bubblemesh_run::self_crossing_warning(&report));
    let low = bubblemesh_core::quality::poor_elements(&mesh, bubblemesh_core::quality::POOR_Q);
    warnings.extend(bubblemesh_run::poor_element_warnings(&low));
    let report_json = serde_json::json!({
        "input": input_name,
        "size": size_text,
        "dim": report.dim,
        "fast": fast,
        "engine": report,
        "step": step_info,
        "poor_elements": low,
        "time_mesh_s": t_mesh,
    });
    if run.cancelled() {
        // Ctrl-C after the engine finished: still a KeyboardInterrupt
        return Err(PyKeyboardInterrupt::new_err("meshing interrupted"));
    }
    Ok(Mesh::new(
        mesh,
        built.spacing,
        run,
        input_name,
        built.note,
        report_json,
        warnings,
    ))
}

/// The native module `bubblemesh._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("MeshError", py.get_type::<MeshError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("SpacingError", py.get_type::<SpacingError>())?;
    m.add("Cancelled", py.get_type::<Cancelled>())?;
    m.add_function(wrap_pyfunction!(mesh, m)?)?;
    m.add_function(wrap_pyfunction!(meshobj::read, m)?)?;
    m.add_class::<Mesh>()?;
    Ok(())
}
