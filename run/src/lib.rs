//! # bubblemesh-run
//!
//! The steps of a meshing run that the command line (`cli/`) and the
//! Python package (`python/`) share, so that both read a model, build a
//! spacing, choose the engine's options and write a mesh the same way and
//! fail with the same words:
//!
//! - [`read_model`]: a STEP or TOML file into a [`Model`] (with what the
//!   STEP reader found, [`step_summary`]);
//! - [`size_text`], [`build_spacing`]: the spacing of `--size`,
//!   `--curvature`, `--view-spacing` and plugins, combined and clamped;
//! - [`EngineSettings::options`], [`thread_count`], [`check_threads`]: the
//!   engine's options with the command line's defaults;
//! - [`stage_output`]: a mesh file through `bubblemesh-io` or a picture
//!   through `bubblemesh-viz`, staged in an [`OutputSet`] (written whole
//!   or not at all);
//! - the warnings a run prints ([`refined_warnings`], [`touching_warning`],
//!   [`open_shell_warning`], [`self_crossing_warning`],
//!   [`poor_element_warnings`]) and its progress bar ([`progress_bar`]).
//!
//! Every failure is an [`Error`], whose text is the command line's
//! message.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::path::Path;
use std::sync::Arc;

use bubblemesh_core::engine::{Integrator, VolumeLattice};
use bubblemesh_core::quality::{self, QualityReport};
use bubblemesh_core::spacing::Expr;
use bubblemesh_core::{Mesh, Model, Options, Report, Spacing, P3, V3};
use bubblemesh_io::output::OutputSet;
use bubblemesh_plugin_host::{PluginSpacing, PluginSpec};
use bubblemesh_viz::geometry::{node_spacing, node_spacing_from_edges, Measures};
use bubblemesh_viz::{ColorBy, Kind, PictureOptions, ViewerOptions};

mod error;

pub use error::Error;

/// The most threads a run accepts: 4 per core, at least 64, at most 1024
/// (more only cost memory and start-up time; far more make thread
/// creation fail).
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    cores.saturating_mul(4).clamp(64, 1024)
}

/// Parses a thread count (`--threads`).
pub fn parse_threads(s: &str) -> Result<usize, Error> {
    let n: u64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number of threads"))?;
    check_threads(n)
}

/// Checks a thread count: 1 to [`max_threads`].
pub fn check_threads(n: u64) -> Result<usize, Error> {
    let max = max_threads();
    if n == 0 || n > max as u64 {
        return Err(Error::Message(format!(
            "{n} is not in 1..={max} (4 per core, at least 64, at most 1024)"
        )));
    }
    Ok(n as usize)
}

/// The threads of a run: `given`, else one per core.
pub fn thread_count(given: Option<usize>) -> usize {
    given.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(max_threads())
    })
}

/// What the STEP reader found, for the report: per face whose boundary
/// was off its surface, the largest gap (model units) it closed by
/// projection; the degenerate edges read as vertices.
pub fn step_summary(info: &bubblemesh_truck::StepInfo) -> serde_json::Value {
    let gaps: Vec<serde_json::Value> = info
        .face_gap
        .iter()
        .enumerate()
        .filter(|(_, &g)| g > 0.0)
        .map(|(f, &g)| {
            serde_json::json!({
                "face": f,
                "step_id": info.face_ids.get(f),
                "largest_boundary_gap": g,
            })
        })
        .collect();
    serde_json::json!({
        "length_unit": info.length_unit.as_ref().map(|u| serde_json::json!({
            "name": u.name,
            "metres": u.metres,
        })),
        "file_length_unit": info.file_length_unit.as_ref().map(|u| serde_json::json!({
            "name": u.name,
            "metres": u.metres,
        })),
        "face_gaps": gaps,
        "degenerate_edges": info.degenerate_edges,
    })
}

/// A length unit the STEP reader converts to (`--unit`).
pub fn parse_unit(s: &str) -> Result<bubblemesh_truck::LengthUnit, String> {
    bubblemesh_truck::LengthUnit::parse(s)
        .ok_or_else(|| format!("unknown length unit '{s}'; expected mm, cm, m, in or ft"))
}

/// Whether `path` names a STEP file (`.step`, `.stp`, any case).
pub fn is_step(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("step") || e.eq_ignore_ascii_case("stp"))
}

/// Reads the input model, choosing the reader by extension; for STEP files
/// also what the reader found ([`step_summary`]), converted to `unit` when
/// one is given.
pub fn read_model(
    path: &Path,
    unit: Option<&bubblemesh_truck::LengthUnit>,
) -> Result<(Model, Option<serde_json::Value>), Error> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "toml" if unit.is_some() => Err(Error::Message(format!(
            "{}: --unit applies to STEP files; a domain file has no length unit",
            path.display()
        ))),
        "toml" => Ok((bubblemesh_analytic::read_domain(path)?, None)),
        "step" | "stp" => {
            let options = bubblemesh_truck::StepOptions {
                unit: unit.cloned(),
            };
            let s = bubblemesh_truck::read_step_with(path, &options)?;
            let summary = step_summary(&s.info);
            Ok((s.model, Some(summary)))
        }
        _ => Err(Error::Message(format!(
            "{}: unknown input type '.{ext}'; expected a domain file (.toml) or STEP (.step, .stp)",
            path.display()
        ))),
    }
}

/// `x` rounded to `digits` significant digits, printed in full (1e-6 model
/// units stay readable instead of rounding to 0.000000).
pub fn significant(x: f64, digits: usize) -> String {
    let rounded: f64 = format!("{:.*e}", digits.saturating_sub(1), x)
        .parse()
        .unwrap_or(x);
    format!("{rounded}")
}

/// Parses the spacing expression and checks it at sample points of the model.
pub fn parse_spacing(text: &str, model: &Model) -> Result<Expr, Error> {
    let e = Expr::parse(text)?;
    let mut samples: Vec<P3> = model.vertices.iter().map(|v| v.point).collect();
    for edge in &model.edges {
        for k in 0..=8 {
            samples.push(
                edge.curve
                    .point(edge.t0 + (edge.t1 - edge.t0) * k as f64 / 8.0),
            );
        }
    }
    e.check_positive(&samples)?;
    Ok(e)
}

/// The size expression of a run: `size` when given; else nothing when
/// another spacing source is given (`others_given`); else 1/40 of the
/// model's bounding-box diagonal, returned also as the number the caller
/// says it chose. `input` names the model in the error of an empty one.
pub fn size_text(
    size: Option<&str>,
    others_given: bool,
    model: &Model,
    input: &Path,
) -> Result<(String, Option<f64>), Error> {
    Ok(match size {
        Some(s) => (s.to_string(), None),
        None if others_given => (String::new(), None),
        None => {
            let diag = model.size();
            if !(diag > 0.0) {
                return Err(Error::Message(format!(
                    "{}: the model is empty or has zero size",
                    input.display()
                )));
            }
            let d = diag / 40.0;
            (format!("{d}"), Some(d))
        }
    })
}

/// How several spacing sources combine (`--combine`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Combine {
    /// Their minimum (thesis §4.8.1).
    #[default]
    Min,
    /// Their product (thesis Fig. 5.10c).
    Product,
}

/// The spacing sources of a run besides the size expression.
#[derive(Default)]
pub struct SpacingRequest<'a> {
    /// A spacing the caller made itself (the Python package's callable),
    /// with its description; it stands where the size expression would.
    pub custom: Option<(Box<dyn Spacing>, String)>,
    /// `--curvature EPS`.
    pub curvature: Option<f64>,
    /// `--view-spacing X,Y,Z,A`.
    pub view_spacing: Option<&'a str>,
    /// `--combine`.
    pub combine: Combine,
    /// The plugins with their arguments.
    pub plugins: &'a [PluginSpec],
    /// `--d-min`.
    pub d_min: Option<f64>,
    /// `--d-max`.
    pub d_max: Option<f64>,
}

impl SpacingRequest<'_> {
    /// Whether a source other than the size expression is given.
    pub fn others_given(&self) -> bool {
        self.custom.is_some()
            || self.curvature.is_some()
            || self.view_spacing.is_some()
            || !self.plugins.is_empty()
    }
}

/// A run's spacing: the combined spacing, its one-line description and
/// the plugins among its sources (whose failures the caller must check
/// after meshing: [`BuiltSpacing::plugin_failure`]).
pub struct BuiltSpacing {
    /// The spacing the engine is given.
    pub spacing: Box<dyn Spacing>,
    /// "spacing d = …, min with …".
    pub note: String,
    /// The plugins among the sources.
    pub plugins: Vec<PluginSpacing>,
}

impl BuiltSpacing {
    /// The first failure of a plugin (refusal, panic, NaN, d <= 0), with
    /// `input` before it: the cause of any meshing error, and a failure of
    /// the run even when a minimum hid it.
    pub fn plugin_failure(&self, input: &str) -> Option<Error> {
        self.plugins
            .iter()
            .find_map(|p| p.failure())
            .map(|f| Error::Message(format!("{input}: {f}")))
    }
}

/// The spacing a run asks for: the size expression `size_text` (or the
/// caller's own spacing), the curvature and view sources and the plugins,
/// combined by minimum or product and clamped to `d_min`/`d_max`.
pub fn build_spacing(
    r: SpacingRequest<'_>,
    size_text: &str,
    model: &Arc<Model>,
) -> Result<BuiltSpacing, Error> {
    use bubblemesh_core::curvature::{Curvature, View};
    use bubblemesh_core::spacing::{Clamped, MinOf, ProductOf};
    let positive = |v: f64, what: &str| -> Result<f64, Error> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(Error::Message(format!(
                "{what} must be a positive number (got {v})"
            )))
        }
    };
    let d_min = r.d_min.map(|v| positive(v, "--d-min")).transpose()?;
    let d_max = r.d_max.map(|v| positive(v, "--d-max")).transpose()?;
    if let (Some(lo), Some(hi)) = (d_min, d_max) {
        if lo > hi {
            return Err(Error::Message(format!(
                "--d-min {lo} is larger than --d-max {hi}"
            )));
        }
    }
    let mut sources: Vec<Box<dyn Spacing>> = Vec::new();
    let mut words: Vec<String> = Vec::new();
    if let Some((s, text)) = r.custom {
        sources.push(s);
        words.push(format!("d = {text}"));
    } else if !size_text.is_empty() {
        sources.push(Box::new(parse_spacing(size_text, model)?));
        words.push(format!("d = {size_text}"));
    }
    if let Some(eps) = r.curvature {
        let eps = positive(eps, "--curvature")?;
        let lo = d_min.unwrap_or(eps);
        let hi = d_max.unwrap_or(model.size() / 10.0).max(lo);
        sources.push(Box::new(Curvature::new(model.clone(), eps, lo, hi)));
        words.push(format!("curvature eps = {eps} (d in [{lo}, {hi}])"));
    }
    if let Some(v) = r.view_spacing {
        let parts: Vec<f64> = v
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| {
                Error::Message(format!(
                    "--view-spacing '{v}': expected four numbers X,Y,Z,A"
                ))
            })?;
        if parts.len() != 4 || parts.iter().any(|x| !x.is_finite()) {
            return Err(Error::Message(format!(
                "--view-spacing '{v}': expected four numbers X,Y,Z,A"
            )));
        }
        let factor = positive(parts[3], "the --view-spacing factor A")?;
        let lo = d_min.unwrap_or(f64::MIN_POSITIVE);
        let hi = d_max.unwrap_or(f64::INFINITY);
        sources.push(Box::new(View {
            viewpoint: P3::new(parts[0], parts[1], parts[2]),
            factor,
            d_min: lo,
            d_max: hi,
        }));
        words.push(format!(
            "view from ({}, {}, {}) x {factor}",
            parts[0], parts[1], parts[2]
        ));
    }
    let mut plugins = Vec::new();
    for spec in r.plugins {
        let p = PluginSpacing::load(spec, model.clone())?;
        words.push(format!(
            "plugin '{}' ({})",
            p.plugin().name(),
            spec.path.display()
        ));
        plugins.push(p.clone());
        sources.push(Box::new(p));
    }
    let joined = match r.combine {
        Combine::Min => words.join(", min with "),
        Combine::Product => words.join(" times "),
    };
    if sources.is_empty() {
        return Err(Error::Message("no spacing source given".to_string()));
    }
    let combined: Box<dyn Spacing> = if sources.len() == 1 {
        sources.pop().expect("one source")
    } else {
        match r.combine {
            Combine::Min => Box::new(MinOf(sources)),
            Combine::Product => Box::new(ProductOf(sources)),
        }
    };
    let spacing: Box<dyn Spacing> = match (d_min, d_max) {
        (None, None) => combined,
        (lo, hi) => Box::new(Clamped {
            inner: combined,
            min: lo.unwrap_or(0.0),
            max: hi.unwrap_or(f64::INFINITY),
        }),
    };
    Ok(BuiltSpacing {
        spacing,
        note: format!("spacing {joined}"),
        plugins,
    })
}

/// Checks the highest dimension asked for (`--dim`): 1, 2 or 3.
pub fn check_dim(dim: Option<u8>) -> Result<(), Error> {
    match dim {
        Some(d) if d == 0 || d > 3 => Err(Error::Message(format!(
            "--dim {d}: the dimension must be 1, 2 or 3"
        ))),
        _ => Ok(()),
    }
}

/// What a run asks of the engine, with the command line's defaults.
#[derive(Clone, Debug)]
pub struct EngineSettings {
    /// `--dim`.
    pub dim: Option<u8>,
    /// `--fast`.
    pub fast: bool,
    /// `--fcc`.
    pub fcc: bool,
    /// `--integrator` (default Euler).
    pub integrator: Integrator,
    /// `--max-steps` (default 600).
    pub max_steps: usize,
    /// The threads the run has ([`thread_count`]).
    pub threads: usize,
    /// `--circle-points`: at least this many nodes per full turn of a
    /// curved edge (0: the requested spacing as it is).
    pub circle_points: u32,
}

impl Default for EngineSettings {
    fn default() -> Self {
        EngineSettings {
            dim: None,
            fast: false,
            fcc: false,
            integrator: Integrator::Euler,
            max_steps: 600,
            threads: thread_count(None),
            circle_points: bubblemesh_core::DEFAULT_CIRCLE_POINTS,
        }
    }
}

impl EngineSettings {
    /// The engine's options for meshing `model` read from `input`. A STEP
    /// solid meshes its boundary surfaces unless a dimension is given (fast,
    /// and what a surface-mesh user expects); `dim` 3 fills its solids with
    /// tetrahedra. The caller runs the engine on a pool of
    /// [`EngineSettings::threads`] threads.
    pub fn options(&self, input: &Path, model: &Model) -> Options {
        let mut opts = Options {
            dim: self
                .dim
                .or((is_step(input) && model.dim() == 3).then_some(2)),
            fast: self.fast,
            volume_lattice: if self.fcc {
                VolumeLattice::Fcc
            } else {
                VolumeLattice::Auto
            },
            circle_points: self.circle_points,
            ..Default::default()
        };
        opts.relax.integrator = self.integrator;
        opts.relax.max_steps = self.max_steps.max(1);
        opts.relax.parallel = self.threads > 1;
        opts
    }
}

/// Whether OUTPUT is a picture (`Some`) or a mesh file (`None`); an
/// extension that is neither is an error before any work is done.
pub fn output_kind(path: &Path) -> Result<Option<Kind>, Error> {
    if let Some(k) = Kind::from_path(path) {
        return Ok(Some(k));
    }
    bubblemesh_io::Format::from_path(path)
        .map(|_| None)
        .map_err(Error::OutputKind)
}

/// How pictures are drawn (`--color`, `--view`, `--bubbles`, `--width`).
#[derive(Clone, Debug)]
pub struct PictureSettings {
    /// Colour by radius ratio or by source entity.
    pub color: ColorBy,
    /// Direction towards the viewer.
    pub view: Option<V3>,
    /// Draw the bubbles.
    pub bubbles: bool,
    /// Width in pixels (.svg, .png).
    pub width: u32,
}

impl Default for PictureSettings {
    fn default() -> Self {
        PictureSettings {
            color: ColorBy::Quality,
            view: None,
            bubbles: false,
            width: 1000,
        }
    }
}

/// What a picture shows besides the mesh.
pub struct Drawing<'a> {
    /// The title (the input file).
    pub title: &'a str,
    /// The spacing (bubble diameters, L/d).
    pub spacing: Option<&'a dyn Spacing>,
    /// The quality report shown by the viewer.
    pub quality: &'a QualityReport,
    /// Lines of notes (the spacing asked for).
    pub notes: Vec<String>,
}

/// The picture options of `mesh` drawn with `pic`.
pub fn picture_options(
    mesh: &Mesh,
    pic: &PictureSettings,
    spacing: Option<&dyn Spacing>,
    title: &str,
) -> PictureOptions {
    PictureOptions {
        color: pic.color,
        view: pic.view,
        bubbles: pic.bubbles.then(|| match spacing {
            Some(s) => node_spacing(mesh, s),
            None => node_spacing_from_edges(mesh),
        }),
        width: pic.width,
        title: Some(title.to_string()),
        ..Default::default()
    }
}

/// The browser viewer page of `mesh` (the `.html` output).
pub fn viewer_page(mesh: &Mesh, pic: &PictureSettings, d: &Drawing) -> Result<String, Error> {
    let m = Measures::of(mesh, d.spacing);
    let figures = bubblemesh_viz::plots::quality_histograms(&m)
        .into_iter()
        .map(|(stem, svg)| (stem.replace('_', " "), svg))
        .collect();
    Ok(bubblemesh_viz::viewer(
        mesh,
        &ViewerOptions {
            title: d.title.to_string(),
            color: pic.color,
            view: pic.view,
            quality: Some(d.quality),
            figures,
            notes: d.notes.clone(),
        },
    )?)
}

/// Stages the mesh as `path` in `out`: a mesh file through
/// `bubblemesh_io`, or a picture or viewer page through `bubblemesh_viz`.
pub fn stage_output(
    out: &mut OutputSet,
    mesh: &Mesh,
    path: &Path,
    kind: Option<Kind>,
    pic: &PictureSettings,
    d: &Drawing,
) -> Result<(), Error> {
    let Some(kind) = kind else {
        let format = bubblemesh_io::Format::from_path(path)?;
        if matches!(
            format,
            bubblemesh_io::Format::Stl | bubblemesh_io::Format::Obj
        ) && bubblemesh_io::surface_triangles(mesh).is_empty()
        {
            return Err(Error::Message(format!(
                "{}: the mesh has no triangles ({} nodes, {} edge elements): .{} holds \
                 triangles only; use .msh, .vtu or .mesh for edges",
                path.display(),
                mesh.nodes.len(),
                mesh.lines.len(),
                format.extension()
            )));
        }
        return Ok(bubblemesh_io::stage_as(out, mesh, path, format)?);
    };
    let fail = |source| Error::Picture {
        path: path.to_path_buf(),
        source,
    };
    let bytes = match kind {
        Kind::Svg => bubblemesh_viz::svg(mesh, &picture_options(mesh, pic, d.spacing, d.title))
            .map_err(fail)?
            .into_bytes(),
        Kind::Png => bubblemesh_viz::png(mesh, &picture_options(mesh, pic, d.spacing, d.title))
            .map_err(fail)?,
        Kind::Html => match viewer_page(mesh, pic, d) {
            Ok(page) => page.into_bytes(),
            Err(Error::Viz(source)) => return Err(fail(source)),
            Err(e) => return Err(e),
        },
    };
    stage_bytes(out, path, &bytes)
}

/// Stages a file of this run (written at commit).
pub fn stage_bytes(out: &mut OutputSet, path: &Path, bytes: &[u8]) -> Result<(), Error> {
    out.bytes(path, bytes).map_err(Error::Write)
}

/// The note that curved edges were meshed finer than asked to keep
/// `--circle-points` nodes per turn (`bubblemesh_core::circle_points`).
pub fn circle_points_note(model: &Model, report: &Report) -> Option<String> {
    let c = report.circle_points.as_ref()?;
    if let Some(why) = &c.dropped {
        let why: String = why.chars().take(200).collect();
        return Some(format!(
            "note: meshed at the size as given: {} nodes per turn of curved edges gave a face no \
             valid mesh ({why})",
            c.n
        ));
    }
    let finest = c
        .edges
        .iter()
        .min_by(|a, b| (a.d / a.requested).total_cmp(&(b.d / b.requested)));
    let mut parts = Vec::new();
    if let Some(finest) = finest {
        let edge = model.describe(bubblemesh_core::EntityRef::new(1, finest.edge));
        parts.push(format!(
            "{} curved edge(s) meshed finer than the size to keep {} nodes per turn, the finest \
             {edge} (radius {}) at {} instead of {}",
            c.edges.len(),
            c.n,
            significant(finest.radius, 3),
            significant(finest.d, 3),
            significant(finest.requested, 3),
        ));
    }
    if let Some(finest) = c
        .capped_faces
        .iter()
        .min_by(|a, b| (a.d / a.requested).total_cmp(&(b.d / b.requested)))
    {
        let face = model.describe(bubblemesh_core::EntityRef::new(2, finest.edge));
        parts.push(format!(
            "{} curved face(s) (a hole's, a pin's or a pipe's wall) meshed finer than the size to \
             keep {} nodes per turn, the finest {face} (radius {}) at {} instead of {}",
            c.capped_faces.len(),
            c.n,
            significant(finest.radius, 3),
            significant(finest.d, 3),
            significant(finest.requested, 3),
        ));
    }
    if let Some(shortest) = c
        .short_edges
        .iter()
        .min_by(|a, b| a.length.total_cmp(&b.length))
    {
        let edge = model.describe(bubblemesh_core::EntityRef::new(1, shortest.edge));
        parts.push(format!(
            "{} edge(s) shorter than {} times the size, the shortest {edge} ({} long)",
            c.short_edges.len(),
            bubblemesh_core::circle_points::SHORT_EDGE,
            significant(shortest.length, 3),
        ));
    }
    if parts.is_empty() {
        return None;
    }
    let mut line = format!(
        "note: {}; the faces around them grade back to the size (--circle-points 0 keeps the size)",
        parts.join("; ")
    );
    if !c.released.is_empty() {
        line.push_str(&format!(
            "; {} face(s) failed with the finer spacing and were meshed with the size inside",
            c.released.len()
        ));
    }
    Some(line)
}

/// The warnings of faces and places the engine meshed finer than asked
/// (`engine::refine`): the mesh departs from the requested spacing there,
/// so the user is told.
pub fn refined_warnings(model: &Model, report: &Report) -> Vec<String> {
    let mut out: Vec<String> = report
        .refined
        .iter()
        .map(|r| {
            let face = model.describe(bubblemesh_core::EntityRef::new(2, r.face));
            let reason: String = r.reason.chars().take(200).collect();
            format!(
                "warning: {face}: meshed with {} of the requested spacing, which could not give it a valid mesh ({reason})",
                r.spacing_factor
            )
        })
        .collect();
    if let Some(r) = report.refined_places.first() {
        let finest = report
            .refined_places
            .iter()
            .map(|p| p.spacing_factor)
            .fold(1.0, f64::min);
        let reason: String = r.reason.chars().take(200).collect();
        out.push(format!(
            "warning: {} place(s) meshed finer than asked, down to {} of the requested spacing, \
             the first within {:.6} of ({:.6}, {:.6}, {:.6}): the tetrahedralization could not \
             recover the surface mesh there ({reason})",
            report.refined_places.len(),
            significant(finest, 3),
            r.radius,
            r.centre[0],
            r.centre[1],
            r.centre[2]
        ));
    }
    out
}

/// The warning that separate parts of the mesh (solids of an assembly)
/// touch without being joined ([`bubblemesh_core::verify::touching_parts`]):
/// the mesh is valid part by part, but not one connected mesh there.
pub fn touching_warning(report: &Report) -> Option<String> {
    let t = report.touching.as_ref()?;
    let first = t
        .entities
        .first()
        .map(|[a, b]| format!(", first between {a} and {b}"))
        .unwrap_or_default();
    Some(format!(
        "warning: separate parts of the mesh touch at {} pair(s) of coinciding nodes{first} near ({:.6}, {:.6}, {:.6}): \
         each part is meshed on its own, so they are not connected there (a simulation needs contact or tie \
         conditions; a checker that wants one connected mesh counts them as duplicate nodes)",
        t.node_pairs, t.at[0], t.at[1], t.at[2]
    ))
}

/// The warning that a volume's faces do not close it
/// ([`bubblemesh_core::verify::open_shell`]): the surface mesh is written,
/// open where the file's shell is.
pub fn open_shell_warning(report: &Report) -> Option<String> {
    let o = report.open_shell.as_ref()?;
    Some(format!(
        "warning: the faces of {} do not close it: {} edge(s) lie on one of its faces only, the first {} near \
         ({:.6}, {:.6}, {:.6}); the surface mesh is open there as the file's shell is (tetrahedra need a closed one)",
        o.volume, o.edges, o.first, o.at[0], o.at[1], o.at[2]
    ))
}

/// The warning that a volume's surface mesh passes through itself
/// ([`bubblemesh_core::verify::SelfCrossing`]): written as the faces are,
/// but it encloses no solid.
pub fn self_crossing_warning(report: &Report) -> Option<String> {
    let c = report.self_crossing.as_ref()?;
    Some(format!(
        "warning: the surface mesh of {} passes through itself: {} crosses {} at ({:.6}, {:.6}, {:.6}) \
         (where the model's faces themselves cross, the solid is invalid; otherwise a finer size separates them); \
         it is written as the faces are, but encloses no solid",
        c.volume, c.faces[0], c.faces[1], c.at[0], c.at[1], c.at[2]
    ))
}

/// The warnings of faces and volumes with elements of radius ratio below
/// [`quality::POOR_Q`] ([`quality::poor_elements`]).
pub fn poor_element_warnings(low: &[quality::PoorElements]) -> Vec<String> {
    low.iter()
        .map(|p| {
            let kind = if p.dim == 3 { "volume" } else { "face" };
            let name = p
                .name
                .as_ref()
                .map(|n| format!(" '{n}'"))
                .unwrap_or_default();
            format!(
                "warning: {kind} {}{name}: {} element(s) of radius ratio below {} (worst {:.2e} near ({}, {}, {}), \
                 {} thick there); the geometry is thinner there than the spacing resolves",
                p.id,
                p.count,
                quality::POOR_Q,
                p.worst_q,
                significant(p.at[0], 6),
                significant(p.at[1], 6),
                significant(p.at[2], 6),
                significant(p.thickness, 3),
            )
        })
        .collect()
}

/// A progress bar on stderr for interactive runs of non-trivial models:
/// `None` when `quiet`, when stderr is not a terminal or when the model has
/// no face.
pub fn progress_bar(quiet: bool, model: &Model) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() || model.faces.is_empty() {
        return None;
    }
    let b = indicatif::ProgressBar::new(1);
    b.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {msg} [{bar:30}] step {pos}/{len} ({elapsed})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b.enable_steady_tick(std::time::Duration::from_millis(200));
    Some(b)
}

/// Shows a stage-2 step on `bar`.
pub fn show_step(bar: &indicatif::ProgressBar, e: &bubblemesh_core::Event<'_>) {
    if let &bubblemesh_core::Event::Step {
        entity,
        step,
        max_steps,
        ..
    } = e
    {
        bar.set_length(max_steps as u64);
        bar.set_position(step as u64);
        bar.set_message(format!("stage 2 on {entity}"));
    }
}
