//! `bubblemesh`: the command line.
//!
//! ```text
//! bubblemesh mesh INPUT -o OUTPUT [--size EXPR] [--dim N] [--fast] [--report FILE.json]
//!                 [--plugin LIB [--plugin-arg KEY=VALUE]...]... [--plugin-config FILE]
//!                 [picture options] [--plots DIR] [--frames DIR] [--animate FILE.html]
//! bubblemesh quality MESH [--size EXPR] [--json FILE.json]
//! bubblemesh draw MESH -o PICTURE [--size EXPR] [picture options] [--plots DIR]
//! ```
//!
//! OUTPUT's extension chooses the writer: `.svg`, `.png` and `.html` go to
//! `bubblemesh-viz` (pictures and the browser viewer), every other one to
//! `bubblemesh_io::write`. Picture options: `--color quality|entity`,
//! `--view X,Y,Z`, `--bubbles`, `--width PX`.
//!
//! This command line is a contract: later work and outside checks drive
//! `bubblemesh mesh INPUT -o OUTPUT --size EXPR --dim N` exactly so.
//! Exit status: 0 on success, 1 on a failure (with a message naming the file,
//! the entity and the reason), 2 on a usage error.

#![forbid(unsafe_code)]

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

mod error;
mod frames;
mod remesh;

use bubblemesh_core::engine::{Event, Integrator, VolumeLattice};
use bubblemesh_core::quality::{self, QualityReport};
use bubblemesh_core::spacing::Expr;
use bubblemesh_core::{mesh_model, Mesh, Model, Options, Report, Spacing, P3, V3};
use bubblemesh_io::output::{OutputKind, OutputPath, OutputSet};
use bubblemesh_plugin_host::{PluginSpacing, PluginSpec};
use bubblemesh_viz::geometry::{node_spacing, node_spacing_from_edges, Measures};
use bubblemesh_viz::{ColorBy, Kind, PictureOptions, ViewerOptions};
use clap::{Args, Parser, Subcommand, ValueEnum};

use error::CliError;

#[derive(Parser)]
#[command(
    name = "bubblemesh",
    version,
    about = "Mesh generation by bubble packing (Shimada 1993)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// parsed once per run: the size of `MeshArgs` costs nothing
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// Mesh a STEP file (.step .stp) or a domain file (.toml) into a mesh
    /// file (.msh .vtu .stl .obj .mesh) or a picture (.svg .png .html).
    Mesh(MeshArgs),
    /// Report the quality of any mesh file bubblemesh can read.
    Quality(QualityArgs),
    /// Draw any mesh file bubblemesh can read as a picture (.svg .png .html).
    Draw(DrawArgs),
    /// Mesh INPUT again starting from the bubbles of a state saved by
    /// `mesh --save-state` (thesis §4.8): matched entities start from their
    /// old bubbles; with --region only the bubbles near it move.
    Remesh(RemeshArgs),
}

#[derive(Parser)]
struct RemeshArgs {
    /// The state file written by `mesh --save-state` (or `remesh --save-state`).
    state: PathBuf,
    #[command(flatten)]
    mesh: MeshArgs,
    /// Local re-meshing: only bubbles in this region (and within 2 spacings
    /// of it) move, the other nodes are kept exactly:
    /// box:x0,y0,z0,x1,y1,z1 | sphere:x,y,z,r | faces:3,7.
    #[arg(long, allow_hyphen_values = true)]
    region: Option<String>,
}

#[derive(Clone, Copy, ValueEnum)]
enum ColorArg {
    /// Radius ratio q = 2 r_in / r_circ (3 r_in / r_circ for tetrahedra).
    Quality,
    /// The model entity (face) an element meshes.
    Entity,
}

/// Options of the pictures (-o .svg/.png/.html, --frames, --animate).
#[derive(Args, Clone)]
struct PictureArgs {
    /// Colour the elements by radius ratio or by source entity.
    #[arg(long, value_enum, default_value = "quality")]
    color: ColorArg,
    /// Direction towards the viewer, X,Y,Z, for surfaces (default: along the
    /// normal of a flat mesh, else 1,-1,1).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_view_arg)]
    view: Option<V3>,
    /// Draw the bubbles: circles of diameter the spacing at each node.
    #[arg(long)]
    bubbles: bool,
    /// Picture width in pixels (.svg, .png).
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(64..=20000))]
    width: u32,
    /// Write SVG plots into this directory: energy history of stage 2 and
    /// histograms of radius ratio, angles and L/d (with an index.html).
    #[arg(long)]
    plots: Option<PathBuf>,
}

/// The most threads `--threads` accepts: 4 per core, at least 64, at most
/// 1024 (more only cost memory and start-up time; far more make thread
/// creation fail).
fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    cores.saturating_mul(4).clamp(64, 1024)
}

/// Parses `--threads`.
fn parse_threads(s: &str) -> Result<usize, CliError> {
    let max = max_threads();
    let n: u64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number of threads"))?;
    if n == 0 || n > max as u64 {
        return Err(CliError::Message(format!(
            "{n} is not in 1..={max} (4 per core, at least 64, at most 1024)"
        )));
    }
    Ok(n as usize)
}

/// The threads of a run: `--threads`, else one per core.
fn thread_count(given: Option<usize>) -> usize {
    given.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(max_threads())
    })
}

/// Parses `--view`.
fn parse_view_arg(s: &str) -> Result<V3, CliError> {
    Ok(bubblemesh_viz::view::parse_view(s)?)
}

#[derive(Clone, Copy, ValueEnum)]
enum CombineArg {
    Min,
    Product,
}

#[derive(Clone, Copy, ValueEnum)]
enum IntegratorArg {
    Euler,
    Rk4,
}

#[derive(Parser)]
struct MeshArgs {
    /// The input: a STEP file (.step, .stp) or a bubblemesh domain file
    /// (.toml, see docs/domain-format.md).
    input: PathBuf,
    /// The output; the format follows the extension: a mesh (.msh .vtu .stl
    /// .obj .mesh) or a picture (.svg .png, or .html: the browser viewer).
    #[arg(short, long)]
    output: PathBuf,
    /// Node spacing d(x, y, z): a number or an expression such as
    /// "0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)". Default: 1/40 of the model's
    /// bounding-box diagonal (printed).
    #[arg(long, allow_hyphen_values = true)]
    size: Option<String>,
    /// STEP files: convert the coordinates from the file's length unit to
    /// this one (mm, cm, m, in, ft); --size and the output are then in it.
    /// Default: the file's own unit (printed).
    #[arg(long, value_name = "UNIT", value_parser = parse_unit)]
    unit: Option<bubblemesh_truck::LengthUnit>,
    /// Highest dimension to mesh: 1 edges, 2 faces, 3 volumes. Default: the
    /// model's for a domain file; 2 (the boundary surfaces) for a STEP file,
    /// whose solids mesh into tetrahedra with --dim 3.
    #[arg(long)]
    dim: Option<u8>,
    /// Stage 1 only (hierarchical placement, thesis §4.1): fast, lower quality.
    #[arg(long)]
    fast: bool,
    /// Volumes: start from the thesis's face-centred cubic packing and run
    /// stage 2 even where the spacing is uniform (default there: a
    /// body-centred cubic lattice, better tetrahedra in less time).
    #[arg(long)]
    fcc: bool,
    /// Write a JSON report (counts, timings, energy history, quality) here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Time integration of stage 2 (thesis §4.4).
    #[arg(long, value_enum, default_value = "euler")]
    integrator: IntegratorArg,
    /// Upper bound on stage-2 time steps per face.
    #[arg(long, default_value_t = 600)]
    max_steps: usize,
    /// Threads for stage 2's force and move computation (the result does
    /// not depend on it). Default: every core; 1 runs single-threaded; at
    /// most 4 per core (at least 64 allowed, never more than 1024).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    threads: Option<usize>,
    /// Curvature-based spacing (thesis eq. 4.6.1): triangles within EPS of
    /// the geometry (model units). Combines with --size and --view-spacing.
    #[arg(long, value_name = "EPS", allow_hyphen_values = true)]
    curvature: Option<f64>,
    /// View-based spacing d = A·|V0 − x| (thesis eq. 4.6.2), as "X,Y,Z,A".
    #[arg(long, value_name = "X,Y,Z,A", allow_hyphen_values = true)]
    view_spacing: Option<String>,
    /// How several spacing sources combine: their minimum (thesis §4.8.1)
    /// or their product (Fig. 5.10c).
    #[arg(long, value_enum, default_value = "min")]
    combine: CombineArg,
    /// A spacing plugin: a shared library (plugins/README.md). Repeat for
    /// several; each is followed by its --plugin-arg. Combines with the
    /// other sources by --combine.
    #[arg(long, value_name = "LIB")]
    plugin: Vec<PathBuf>,
    /// KEY=VALUE for the nearest --plugin before it.
    #[arg(long, value_name = "KEY=VALUE", allow_hyphen_values = true)]
    plugin_arg: Vec<String>,
    /// A TOML file of plugins: [[plugin]] tables with path (relative to the
    /// file) and args = { key = value, ... }.
    #[arg(long, value_name = "FILE")]
    plugin_config: Option<PathBuf>,
    /// The plugins of --plugin/--plugin-arg (in command-line order) and
    /// --plugin-config, filled in by `main`.
    #[arg(skip)]
    plugin_specs: Vec<PluginSpec>,
    /// Lower bound on the spacing (default for --curvature: EPS).
    #[arg(long, allow_hyphen_values = true)]
    d_min: Option<f64>,
    /// Upper bound on the spacing (default for --curvature: 1/10 of the
    /// bounding-box diagonal).
    #[arg(long, allow_hyphen_values = true)]
    d_max: Option<f64>,
    /// Print nothing but errors and warnings.
    #[arg(short, long)]
    quiet: bool,
    #[command(flatten)]
    picture: PictureArgs,
    /// Write pictures of the bubbles settling into this directory
    /// (frame_000.svg/.png, ...): stage 1, stage 2 after 1, 2, 4, ... steps
    /// (recorded during the run), then the mesh written.
    #[arg(long)]
    frames: Option<PathBuf>,
    /// Write a self-contained page animating the bubbles settling (the
    /// frames of --frames).
    #[arg(long)]
    animate: Option<PathBuf>,
    /// Save the packed bubbles of every entity here (a bubblemesh-state
    /// file, docs/state-format.md), for `bubblemesh remesh`.
    #[arg(long, value_name = "STATE")]
    save_state: Option<PathBuf>,
    /// The state and region of `remesh`, filled in by `main`.
    #[arg(skip)]
    remesh: Option<remesh::RemeshSpec>,
}

#[derive(Parser)]
struct DrawArgs {
    /// The mesh file (.msh .vtu .stl .obj .mesh).
    mesh: PathBuf,
    /// The picture: .svg, .png or .html.
    #[arg(short, long)]
    output: PathBuf,
    /// Spacing expression: the bubble diameters for --bubbles (default: the
    /// mean length of the edges at each node) and L/d in the report.
    #[arg(long, allow_hyphen_values = true)]
    size: Option<String>,
    #[command(flatten)]
    picture: PictureArgs,
}

#[derive(Parser)]
struct QualityArgs {
    /// The mesh file (.msh .vtu .stl .obj .mesh).
    mesh: PathBuf,
    /// Spacing expression to measure L/d against.
    #[arg(long, allow_hyphen_values = true)]
    size: Option<String>,
    /// Write the report as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

fn main() -> ExitCode {
    use clap::{CommandFactory, FromArgMatches};
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Command::Mesh(mut a) => plugin_specs(&matches, &a).and_then(|specs| {
            a.plugin_specs = specs;
            run_mesh(a)
        }),
        Command::Remesh(r) => {
            let mut a = r.mesh;
            a.remesh = Some(remesh::RemeshSpec {
                state: r.state,
                region: r.region,
            });
            plugin_specs(&matches, &a).and_then(|specs| {
                a.plugin_specs = specs;
                run_mesh(a)
            })
        }
        Command::Quality(a) => run_quality(a),
        Command::Draw(a) => run_draw(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}

/// The plugins to load: each --plugin with the --plugin-arg after it (clap
/// keeps the positions), then those of --plugin-config.
fn plugin_specs(matches: &clap::ArgMatches, a: &MeshArgs) -> Result<Vec<PluginSpec>, CliError> {
    let Some(m) = matches
        .subcommand_matches("mesh")
        .or_else(|| matches.subcommand_matches("remesh"))
    else {
        return Ok(Vec::new());
    };
    let positions =
        |id: &str| -> Vec<usize> { m.indices_of(id).map(|i| i.collect()).unwrap_or_default() };
    let plugins: Vec<(usize, PathBuf)> = positions("plugin")
        .into_iter()
        .zip(a.plugin.iter().cloned())
        .collect();
    let args: Vec<(usize, String)> = positions("plugin_arg")
        .into_iter()
        .zip(a.plugin_arg.iter().cloned())
        .collect();
    let mut specs = bubblemesh_plugin_host::specs_from_command_line(&plugins, &args)?;
    if let Some(file) = &a.plugin_config {
        specs.extend(bubblemesh_plugin_host::read_config(file)?);
    }
    Ok(specs)
}

/// What the STEP reader found, for the report: per face whose boundary
/// was off its surface, the largest gap (model units) it closed by
/// projection; the degenerate edges read as vertices.
fn step_summary(info: &bubblemesh_truck::StepInfo) -> serde_json::Value {
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

/// `--unit`'s value: a length unit the STEP reader converts to.
fn parse_unit(s: &str) -> Result<bubblemesh_truck::LengthUnit, String> {
    bubblemesh_truck::LengthUnit::parse(s)
        .ok_or_else(|| format!("unknown length unit '{s}'; expected mm, cm, m, in or ft"))
}

/// Reads the input model, choosing the reader by extension; for STEP files
/// also what the reader found ([`step_summary`]), converted to `unit` when
/// one is given.
fn read_model(
    path: &Path,
    unit: Option<&bubblemesh_truck::LengthUnit>,
) -> Result<(Model, Option<serde_json::Value>), CliError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "toml" if unit.is_some() => Err(CliError::Message(format!(
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
        _ => Err(CliError::Message(format!(
            "{}: unknown input type '.{ext}'; expected a domain file (.toml) or STEP (.step, .stp)",
            path.display()
        ))),
    }
}

/// `x` rounded to `digits` significant digits, printed in full (1e-6 model
/// units stay readable instead of rounding to 0.000000).
fn significant(x: f64, digits: usize) -> String {
    let rounded: f64 = format!("{:.*e}", digits.saturating_sub(1), x)
        .parse()
        .unwrap_or(x);
    format!("{rounded}")
}

/// Parses the spacing expression and checks it at sample points of the model.
fn parse_spacing(text: &str, model: &Model) -> Result<Expr, CliError> {
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

/// A spacing, its one-line description and the plugins among its sources.
type SpacingParts = (Box<dyn Spacing>, String, Vec<PluginSpacing>);

/// The spacing the command line asks for: the --size expression, the
/// curvature and view sources, combined by minimum or product and clamped
/// to --d-min/--d-max. Returns it with a one-line description and the
/// plugins among the sources (whose failures the caller must check).
fn build_spacing(
    a: &MeshArgs,
    size_text: &str,
    model: &Arc<Model>,
) -> Result<SpacingParts, CliError> {
    use bubblemesh_core::curvature::{Curvature, View};
    use bubblemesh_core::spacing::{Clamped, MinOf, ProductOf};
    let positive = |v: f64, what: &str| -> Result<f64, CliError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(CliError::Message(format!(
                "{what} must be a positive number (got {v})"
            )))
        }
    };
    let d_min = a.d_min.map(|v| positive(v, "--d-min")).transpose()?;
    let d_max = a.d_max.map(|v| positive(v, "--d-max")).transpose()?;
    if let (Some(lo), Some(hi)) = (d_min, d_max) {
        if lo > hi {
            return Err(CliError::Message(format!(
                "--d-min {lo} is larger than --d-max {hi}"
            )));
        }
    }
    let mut sources: Vec<Box<dyn Spacing>> = Vec::new();
    let mut words: Vec<String> = Vec::new();
    if !size_text.is_empty() {
        sources.push(Box::new(parse_spacing(size_text, model)?));
        words.push(format!("d = {size_text}"));
    }
    if let Some(eps) = a.curvature {
        let eps = positive(eps, "--curvature")?;
        let lo = d_min.unwrap_or(eps);
        let hi = d_max.unwrap_or(model.size() / 10.0).max(lo);
        sources.push(Box::new(Curvature::new(model.clone(), eps, lo, hi)));
        words.push(format!("curvature eps = {eps} (d in [{lo}, {hi}])"));
    }
    if let Some(v) = &a.view_spacing {
        let parts: Vec<f64> = v
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| {
                CliError::Message(format!(
                    "--view-spacing '{v}': expected four numbers X,Y,Z,A"
                ))
            })?;
        if parts.len() != 4 || parts.iter().any(|x| !x.is_finite()) {
            return Err(CliError::Message(format!(
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
    for spec in &a.plugin_specs {
        let p = PluginSpacing::load(spec, model.clone())?;
        words.push(format!(
            "plugin '{}' ({})",
            p.plugin().name(),
            spec.path.display()
        ));
        plugins.push(p.clone());
        sources.push(Box::new(p));
    }
    let joined = match a.combine {
        CombineArg::Min => words.join(", min with "),
        CombineArg::Product => words.join(" times "),
    };
    let combined: Box<dyn Spacing> = if sources.len() == 1 {
        sources.pop().expect("one source")
    } else {
        match a.combine {
            CombineArg::Min => Box::new(MinOf(sources)),
            CombineArg::Product => Box::new(ProductOf(sources)),
        }
    };
    let bounded: Box<dyn Spacing> = match (d_min, d_max) {
        (None, None) => combined,
        (lo, hi) => Box::new(Clamped {
            inner: combined,
            min: lo.unwrap_or(0.0),
            max: hi.unwrap_or(f64::INFINITY),
        }),
    };
    Ok((bounded, format!("spacing {joined}"), plugins))
}

/// `bubblemesh mesh`: checks the outputs, reads the model, builds the
/// spacing, meshes, then stages and writes every output at once.
fn run_mesh(a: MeshArgs) -> Result<(), CliError> {
    let t0 = Instant::now();
    let kind = output_kind(&a.output)?;
    if let Some(p) = &a.animate {
        if Kind::from_path(p) != Some(Kind::Html) {
            return Err(CliError::Message(format!(
                "{}: --animate writes a page: use .html",
                p.display()
            )));
        }
    }
    let threads = thread_count(a.threads);
    // every output is checked against the inputs and the other outputs, and
    // its directory made, before meshing; `out` removes what this run made
    // if it fails
    let mut out = prepare_mesh_outputs(&a)?;
    let (model, step_info) = read_model(&a.input, a.unit.as_ref())?;
    if let Some(d) = a.dim {
        if d == 0 || d > 3 {
            return Err(CliError::Message(format!(
                "--dim {d}: the dimension must be 1, 2 or 3"
            )));
        }
    }
    let model = Arc::new(model);
    let size_text = size_text(&a, &model)?;
    let (spacing, spacing_note, plugins) = build_spacing(&a, &size_text, &model)?;
    // a plugin's failure (refusal, panic, NaN, d <= 0) is the cause of any
    // meshing error, and must fail the run even when a minimum hid it
    let plugin_failure = || {
        plugins
            .iter()
            .find_map(|p| p.failure())
            .map(|f| CliError::Message(format!("{}: {f}", a.input.display())))
    };
    let spacing: &dyn Spacing = spacing.as_ref();
    let mut opts = engine_options(&a, &model, threads)?;
    let warm = match &a.remesh {
        Some(spec) => Some(remesh::prepare(spec, &a.input, &model, spacing, &mut opts)?),
        None => None,
    };
    let meshed = mesh_observed(&a, &model, spacing, opts);
    if let Some(f) = plugin_failure() {
        return Err(f);
    }
    let (mesh, report, recorded) = meshed?;
    let t_mesh = t0.elapsed().as_secs_f64();
    let q = quality::analyse(&mesh, Some(spacing));
    if let Some(f) = plugin_failure() {
        return Err(f);
    }
    let title = a.input.display().to_string();
    let low = quality::poor_elements(&mesh, quality::POOR_Q);
    let t_write = Instant::now();
    stage_output(
        &mut out,
        &mesh,
        &a.output,
        kind,
        &a.picture,
        &Drawing {
            title: &title,
            spacing: Some(spacing),
            quality: &q,
            notes: vec![spacing_note.clone()],
        },
    )?;
    let write_s = t_write.elapsed().as_secs_f64();
    let mut said: Vec<String> = Vec::new();
    if !a.quiet {
        said.extend(summary(&a, &report, step_info.as_ref(), write_s));
        said.extend(warm.as_ref().map(|w| w.said(&mesh)));
        said.push(q.table());
    }
    if let Some(path) = &a.save_state {
        let bytes = remesh::state_bytes(&model, &mesh, spacing, &size_text, &a.input);
        stage_bytes(&mut out, path, &bytes)?;
    }
    if let Some(path) = &a.report {
        let json = serde_json::json!({
            "input": a.input.display().to_string(),
            "output": a.output.display().to_string(),
            "size": size_text,
            "dim": report.dim,
            "fast": a.fast,
            "engine": report,
            "step": step_info,
            "quality": q,
            "poor_elements": low,
            "time_mesh_s": t_mesh,
            "time_write_s": write_s,
        });
        let mut json = json;
        if let Some(w) = &warm {
            json["remesh"] = w.report(&mesh, &report);
        }
        let text = serde_json::to_string_pretty(&json)?;
        stage_bytes(&mut out, path, text.as_bytes())?;
    }
    if let Some(dir) = &a.picture.plots {
        stage_plots(
            &mut out,
            dir,
            &mesh,
            Some(&report),
            Some(spacing),
            &q,
            &title,
        )?;
        if !a.quiet {
            said.push(format!("wrote plots into {}", dir.display()));
        }
    }
    if let Some(recorded) = recorded {
        let frames = frames::settle_frames(&recorded, spacing, &mesh, &report, a.max_steps.max(1));
        let notes = [spacing_note.clone(), ANIMATION_NOTE.to_string()];
        said.extend(stage_frames(
            &mut out, &a, &model, spacing, &title, &notes, &frames,
        )?);
    }
    out.commit().map_err(CliError::Write)?;
    for line in said {
        eprintln!("{line}");
    }
    warn_refined(&model, &report);
    warn_low_quality(&low);
    Ok(())
}

/// Checks the outputs of `mesh` against its inputs and each other and
/// makes their directories ([`prepare_outputs`]).
fn prepare_mesh_outputs(a: &MeshArgs) -> Result<OutputSet, CliError> {
    let mut inputs: Vec<&Path> = vec![&a.input];
    inputs.extend(a.remesh.as_ref().map(|r| r.state.as_path()));
    inputs.extend(a.plugin_specs.iter().map(|s| s.path.as_path()));
    inputs.extend(a.plugin_config.as_deref());
    let mut outputs = vec![file_output("-o", &a.output)];
    outputs.extend(a.report.as_deref().map(|p| file_output("--report", p)));
    outputs.extend(a.picture.plots.as_deref().map(|p| dir_output("--plots", p)));
    outputs.extend(a.frames.as_deref().map(|p| dir_output("--frames", p)));
    outputs.extend(a.animate.as_deref().map(|p| file_output("--animate", p)));
    outputs.extend(
        a.save_state
            .as_deref()
            .map(|p| file_output("--save-state", p)),
    );
    prepare_outputs(&inputs, &outputs)
}

/// The --size expression; without one (and no other spacing source) 1/40
/// of the model's bounding-box diagonal, said on stderr.
fn size_text(a: &MeshArgs, model: &Model) -> Result<String, CliError> {
    let others_given =
        a.curvature.is_some() || a.view_spacing.is_some() || !a.plugin_specs.is_empty();
    Ok(match &a.size {
        Some(s) => s.clone(),
        None if others_given => String::new(),
        None => {
            let diag = model.size();
            if !(diag > 0.0) {
                return Err(CliError::Message(format!(
                    "{}: the model is empty or has zero size",
                    a.input.display()
                )));
            }
            let d = diag / 40.0;
            if !a.quiet {
                eprintln!(
                    "no --size given: using d = {} (1/40 of the bounding-box diagonal)",
                    significant(d, 6)
                );
            }
            format!("{d}")
        }
    })
}

/// The engine's options of `mesh`; starts the `threads` every rayon loop
/// (relaxation, volume polish) runs on, so that `--threads 1` is
/// single-threaded throughout.
fn engine_options(a: &MeshArgs, model: &Model, threads: usize) -> Result<Options, CliError> {
    // a STEP solid meshes its boundary surfaces by default (fast, and what
    // a surface-mesh user expects); --dim 3 fills its solids with tetrahedra
    let is_step = a
        .input
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("step") || e.eq_ignore_ascii_case("stp"));
    let mut opts = Options {
        dim: a.dim.or((is_step && model.dim() == 3).then_some(2)),
        fast: a.fast,
        volume_lattice: if a.fcc {
            VolumeLattice::Fcc
        } else {
            VolumeLattice::Auto
        },
        ..Default::default()
    };
    opts.relax.integrator = match a.integrator {
        IntegratorArg::Euler => Integrator::Euler,
        IntegratorArg::Rk4 => Integrator::Rk4,
    };
    opts.relax.max_steps = a.max_steps.max(1);
    opts.relax.parallel = threads > 1;
    // the global pool is built once per process (here, its only builder)
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|source| CliError::Threads { threads, source })?;
    Ok(opts)
}

/// Meshes `model` in one run observed by the progress bar and, with
/// `--frames` or `--animate`, by the recorder of the bubbles settling
/// (returned with the mesh).
fn mesh_observed(
    a: &MeshArgs,
    model: &Model,
    spacing: &dyn Spacing,
    mut opts: Options,
) -> Result<(Mesh, Report, Option<frames::Recorder>), CliError> {
    let bar = progress_bar(a.quiet, model);
    let recorder = (a.frames.is_some() || a.animate.is_some())
        .then(|| Arc::new(std::sync::Mutex::new(frames::Recorder::default())));
    if bar.is_some() || recorder.is_some() {
        let b = bar.clone();
        let r = recorder.clone();
        opts.observer = Some(Arc::new(move |e: &Event<'_>| {
            if let (
                Some(b),
                &Event::Step {
                    entity,
                    step,
                    max_steps,
                    ..
                },
            ) = (&b, e)
            {
                b.set_length(max_steps as u64);
                b.set_position(step as u64);
                b.set_message(format!("stage 2 on {entity}"));
            }
            if let Some(r) = &r {
                r.lock().unwrap_or_else(|p| p.into_inner()).observe(e);
            }
        }));
    }
    let meshed = mesh_model(model, spacing, &opts);
    drop(opts);
    let (mesh, report) = meshed.map_err(|source| CliError::Mesh {
        input: a.input.display().to_string(),
        source,
    })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let recorded = recorder.map(|r| {
        Arc::try_unwrap(r)
            .map(|m| m.into_inner().unwrap_or_else(|p| p.into_inner()))
            .unwrap_or_default()
    });
    Ok((mesh, report, recorded))
}

/// What `mesh` says on stderr about the run (unless --quiet), before the
/// quality table.
fn summary(
    a: &MeshArgs,
    report: &Report,
    step_info: Option<&serde_json::Value>,
    write_s: f64,
) -> Vec<String> {
    let mut said = Vec::new();
    let lattice = if report.timings.lattice_s > 0.0005 {
        format!(", conformal lattice {:.3} s", report.timings.lattice_s)
    } else {
        String::new()
    };
    said.push(format!(
        "meshed {} in {:.3} s (stage 1 {:.3} s, stage 2 {:.3} s, connection {:.3} s{lattice}); wrote {} in {:.3} s",
        a.input.display(),
        report.timings.total_s,
        report.timings.stage1_s,
        report.timings.stage2_s,
        report.timings.connect_s,
        a.output.display(),
        write_s
    ));
    let unit = |key: &str| {
        step_info
            .and_then(|i| i.get(key))
            .filter(|u| !u.is_null())
            .map(|u| {
                (
                    u["name"].as_str().unwrap_or("?").to_string(),
                    u["metres"].clone(),
                )
            })
    };
    match (unit("length_unit"), unit("file_length_unit")) {
        (Some((name, metres)), Some((file_name, _))) if name != file_name => said.push(format!(
            "length unit: {name} ({metres} m), converted from the file's {file_name} (--unit); \
             coordinates and --size are in it"
        )),
        (Some((name, metres)), _) => said.push(format!(
            "length unit of the file: {name} ({metres} m); coordinates and --size are in it"
        )),
        _ => {}
    }
    said
}

/// What the animation page says about its frames.
const ANIMATION_NOTE: &str = "Frame 1 is stage 1 (hierarchical placement); frame k > 1 shows the \
     bubbles after the stage-2 step shown, recorded during the run that wrote the mesh, on the \
     edges' final segments; the last frame is the mesh written.";

/// Stages the frames as SVG and PNG in --frames and as a page in
/// --animate; returns what to say about them.
fn stage_frames(
    out: &mut OutputSet,
    a: &MeshArgs,
    model: &Model,
    spacing: &dyn Spacing,
    title: &str,
    notes: &[String],
    frames: &[frames::SettleFrame],
) -> Result<Vec<String>, CliError> {
    let mut said = Vec::new();
    let pictures = frame_pictures(model, spacing, &a.picture, frames)?;
    if let Some(dir) = &a.frames {
        for (k, (f, svg)) in frames.iter().zip(&pictures).enumerate() {
            stage_bytes(
                out,
                &dir.join(format!("frame_{k:03}.svg")),
                svg.svg.as_bytes(),
            )?;
            let png = bubblemesh_viz::png(&f.mesh, &frame_options(model, spacing, &a.picture, f))?;
            stage_bytes(out, &dir.join(format!("frame_{k:03}.png")), &png)?;
        }
        if !a.quiet {
            said.push(format!(
                "wrote {} frames into {}",
                frames.len(),
                dir.display()
            ));
        }
    }
    if let Some(path) = &a.animate {
        let page =
            bubblemesh_viz::anim::page(&format!("{title}: the bubbles settling"), notes, &pictures);
        stage_bytes(out, path, page.as_bytes())?;
        if !a.quiet {
            said.push(format!("wrote the animation {}", path.display()));
        }
    }
    Ok(said)
}

/// Faces the engine meshed finer than asked (`engine::refine`): the mesh
/// departs from the requested spacing there, so the user is told.
fn warn_refined(model: &Model, report: &Report) {
    for r in &report.refined {
        let face = model.describe(bubblemesh_core::EntityRef::new(2, r.face));
        let reason: String = r.reason.chars().take(200).collect();
        eprintln!(
            "warning: {face}: meshed with {} of the requested spacing, which could not give it a valid mesh ({reason})",
            r.spacing_factor
        );
    }
    if let Some(r) = report.refined_places.first() {
        let finest = report
            .refined_places
            .iter()
            .map(|p| p.spacing_factor)
            .fold(1.0, f64::min);
        let reason: String = r.reason.chars().take(200).collect();
        eprintln!(
            "warning: {} place(s) meshed finer than asked, down to {finest} of the requested spacing, \
             the first within {:.6} of ({:.6}, {:.6}, {:.6}): the tetrahedralization could not \
             recover the surface mesh there ({reason})",
            report.refined_places.len(),
            r.radius,
            r.centre[0],
            r.centre[1],
            r.centre[2]
        );
    }
}

/// `bubblemesh draw`.
fn run_draw(a: DrawArgs) -> Result<(), CliError> {
    let kind = match Kind::from_path(&a.output) {
        Some(k) => k,
        None => {
            return Err(CliError::Message(format!(
                "{}: draw writes pictures: use .svg, .png or .html",
                a.output.display()
            )))
        }
    };
    let mut outputs = vec![file_output("-o", &a.output)];
    outputs.extend(a.picture.plots.as_deref().map(|p| dir_output("--plots", p)));
    let mut out = prepare_outputs(&[&a.mesh], &outputs)?;
    let mesh = read_mesh(&a.mesh)?;
    let spacing = match &a.size {
        Some(s) => Some(parse_expr(s)?),
        None => None,
    };
    let q = quality::analyse(&mesh, spacing.as_ref().map(|s| s as &dyn Spacing));
    let title = a.mesh.display().to_string();
    let mut notes = Vec::new();
    if let Some(s) = &a.size {
        notes.push(format!("spacing d = {s}"));
    }
    stage_output(
        &mut out,
        &mesh,
        &a.output,
        Some(kind),
        &a.picture,
        &Drawing {
            title: &title,
            spacing: spacing.as_ref().map(|s| s as &dyn Spacing),
            quality: &q,
            notes,
        },
    )?;
    if let Some(dir) = &a.picture.plots {
        stage_plots(
            &mut out,
            dir,
            &mesh,
            None,
            spacing.as_ref().map(|s| s as &dyn Spacing),
            &q,
            &title,
        )?;
    }
    out.commit().map_err(CliError::Write)
}

/// Whether OUTPUT is a picture (`Some`) or a mesh file (`None`); an
/// extension that is neither is an error before any work is done.
fn output_kind(path: &Path) -> Result<Option<Kind>, CliError> {
    if let Some(k) = Kind::from_path(path) {
        return Ok(Some(k));
    }
    bubblemesh_io::Format::from_path(path)
        .map(|_| None)
        .map_err(CliError::OutputKind)
}

/// What a picture shows besides the mesh.
struct Drawing<'a> {
    title: &'a str,
    spacing: Option<&'a dyn Spacing>,
    quality: &'a QualityReport,
    notes: Vec<String>,
}

fn picture_options(
    mesh: &Mesh,
    pic: &PictureArgs,
    spacing: Option<&dyn Spacing>,
    title: &str,
) -> PictureOptions {
    PictureOptions {
        color: color_by(pic.color),
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

fn color_by(c: ColorArg) -> ColorBy {
    match c {
        ColorArg::Quality => ColorBy::Quality,
        ColorArg::Entity => ColorBy::Entity,
    }
}

/// Stages the mesh as `path` in `out`: a mesh file through
/// `bubblemesh_io`, or a picture or viewer page through `bubblemesh_viz`.
fn stage_output(
    out: &mut OutputSet,
    mesh: &Mesh,
    path: &Path,
    kind: Option<Kind>,
    pic: &PictureArgs,
    d: &Drawing,
) -> Result<(), CliError> {
    let Some(kind) = kind else {
        let format = bubblemesh_io::Format::from_path(path)?;
        if matches!(
            format,
            bubblemesh_io::Format::Stl | bubblemesh_io::Format::Obj
        ) && bubblemesh_io::surface_triangles(mesh).is_empty()
        {
            return Err(CliError::Message(format!(
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
    let fail = |source| CliError::Picture {
        path: path.to_path_buf(),
        source,
    };
    let bytes = match kind {
        Kind::Svg => bubblemesh_viz::svg(mesh, &picture_options(mesh, pic, d.spacing, d.title))
            .map_err(fail)?
            .into_bytes(),
        Kind::Png => bubblemesh_viz::png(mesh, &picture_options(mesh, pic, d.spacing, d.title))
            .map_err(fail)?,
        Kind::Html => {
            let m = Measures::of(mesh, d.spacing.map(|s| s as &dyn Spacing));
            let figures = bubblemesh_viz::plots::quality_histograms(&m)
                .into_iter()
                .map(|(stem, svg)| (stem.replace('_', " "), svg))
                .collect();
            bubblemesh_viz::viewer(
                mesh,
                &ViewerOptions {
                    title: d.title.to_string(),
                    color: color_by(pic.color),
                    view: pic.view,
                    quality: Some(d.quality),
                    figures,
                    notes: d.notes.clone(),
                },
            )
            .map_err(fail)?
            .into_bytes()
        }
    };
    stage_bytes(out, path, &bytes)
}

/// Stages the energy history (with a report) and the histograms as SVG
/// in `dir`, with an index.html showing them and the quality table.
fn stage_plots(
    out: &mut OutputSet,
    dir: &Path,
    mesh: &Mesh,
    report: Option<&Report>,
    spacing: Option<&dyn Spacing>,
    q: &QualityReport,
    title: &str,
) -> Result<(), CliError> {
    use bubblemesh_viz::plots;
    let mut files: Vec<(String, String)> = Vec::new();
    if let Some(r) = report {
        let faces: Vec<plots::FaceEnergy> = r
            .faces
            .iter()
            .map(|f| plots::FaceEnergy {
                name: f.name.clone().unwrap_or_else(|| format!("face {}", f.face)),
                samples: f.relax.as_ref().map_or(&[][..], |x| &x.energy[..]),
            })
            .collect();
        files.push(("energy".into(), plots::energy(&faces)));
    }
    let m = Measures::of(mesh, spacing.map(|s| s as &dyn Spacing));
    for (stem, svg) in plots::quality_histograms(&m) {
        files.push((stem.to_string(), svg));
    }
    let mut index = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t} · plots</title>\n\
         <style>body{{font:14px system-ui,sans-serif;margin:12px}}table{{border-collapse:collapse;font-size:12px}}\
         td,th{{padding:1px 8px;border-bottom:1px solid #ddd;text-align:left}}td.n{{text-align:right}}</style></head><body>\n\
         <h1>{t}</h1>\n",
        t = bubblemesh_viz::picture::xml_escape(title)
    );
    for (stem, svg) in &files {
        stage_bytes(out, &dir.join(format!("{stem}.svg")), svg.as_bytes())?;
        index.push_str(&format!("<p><img src=\"{stem}.svg\" alt=\"{stem}\"></p>\n"));
    }
    index.push_str("<h2>Quality</h2>\n");
    index.push_str(&bubblemesh_viz::html::quality_table(q));
    index.push_str("</body></html>\n");
    stage_bytes(out, &dir.join("index.html"), index.as_bytes())
}

/// Picture options of one frame: bubbles always drawn, every frame framed
/// on the model's box so that the pictures share one scale.
fn frame_options(
    model: &Model,
    spacing: &dyn Spacing,
    pic: &PictureArgs,
    f: &frames::SettleFrame,
) -> PictureOptions {
    let mut o = picture_options(&f.mesh, pic, Some(spacing), &f.label);
    o.bubbles = Some(f.bubbles.clone());
    o.fit = model.bbox();
    o.caption = Some(f.label.clone());
    o
}

/// The SVG picture of each frame.
fn frame_pictures(
    model: &Model,
    spacing: &dyn Spacing,
    pic: &PictureArgs,
    frames: &[frames::SettleFrame],
) -> Result<Vec<bubblemesh_viz::anim::Frame>, CliError> {
    frames
        .iter()
        .map(|f| {
            let svg = bubblemesh_viz::svg(&f.mesh, &frame_options(model, spacing, pic, f))?;
            Ok(bubblemesh_viz::anim::Frame {
                label: f.label.clone(),
                svg,
            })
        })
        .collect()
}

/// `bubblemesh quality`.
fn run_quality(a: QualityArgs) -> Result<(), CliError> {
    let outputs: Vec<OutputPath> = a
        .json
        .as_deref()
        .map(|p| file_output("--json", p))
        .into_iter()
        .collect();
    let mut out = prepare_outputs(&[&a.mesh], &outputs)?;
    let mesh = read_mesh(&a.mesh)?;
    let spacing = match &a.size {
        Some(s) => Some(parse_expr(s)?),
        None => None,
    };
    let q = quality::analyse(&mesh, spacing.as_ref().map(|s| s as &dyn Spacing));
    if let Some(path) = &a.json {
        let text = serde_json::to_string_pretty(&q)?;
        stage_bytes(&mut out, path, text.as_bytes())?;
    }
    out.commit().map_err(CliError::Write)?;
    println!("{}", q.table());
    warn_low_quality(&quality::poor_elements(&mesh, quality::POOR_Q));
    Ok(())
}

/// Reads a mesh file, printing on stderr what the reader skipped.
fn read_mesh(path: &Path) -> Result<Mesh, CliError> {
    let (mesh, notes) = bubblemesh_io::read_with_notes(path)?;
    for n in notes {
        eprintln!("warning: {}: {n}", path.display());
    }
    Ok(mesh)
}

/// Parses a --size expression.
fn parse_expr(text: &str) -> Result<Expr, CliError> {
    Ok(Expr::parse(text)?)
}

/// A file output of the command line.
fn file_output<'a>(label: &'a str, path: &'a Path) -> OutputPath<'a> {
    OutputPath {
        label,
        path,
        kind: OutputKind::File,
    }
}

/// A directory output of the command line.
fn dir_output<'a>(label: &'a str, path: &'a Path) -> OutputPath<'a> {
    OutputPath {
        label,
        path,
        kind: OutputKind::Dir,
    }
}

/// Checks the outputs against the inputs and each other and makes the
/// output directories; the returned set stages the files and removes all
/// this run made unless committed.
fn prepare_outputs(inputs: &[&Path], outputs: &[OutputPath]) -> Result<OutputSet, CliError> {
    bubblemesh_io::output::check_outputs(inputs, outputs)?;
    let mut out = OutputSet::new();
    for o in outputs.iter().filter(|o| o.kind == OutputKind::Dir) {
        out.dir(o.path).map_err(CliError::MakeDir)?;
    }
    Ok(out)
}

/// Stages a file of this run (written at commit).
fn stage_bytes(out: &mut OutputSet, path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    out.bytes(path, bytes).map_err(CliError::Write)
}

fn warn_low_quality(low: &[quality::PoorElements]) {
    for p in low {
        let kind = if p.dim == 3 { "volume" } else { "face" };
        let name = p
            .name
            .as_ref()
            .map(|n| format!(" '{n}'"))
            .unwrap_or_default();
        eprintln!(
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
        );
    }
}

/// A progress bar on stderr for interactive runs of non-trivial models.
fn progress_bar(quiet: bool, model: &Model) -> Option<indicatif::ProgressBar> {
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
