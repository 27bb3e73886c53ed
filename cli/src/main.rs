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

mod frames;
mod remesh;

use bubblemesh_core::engine::{Event, Integrator};
use bubblemesh_core::quality::{self, QualityReport};
use bubblemesh_core::spacing::Expr;
use bubblemesh_core::{mesh_model, Mesh, Model, Options, Report, Spacing, V3};
use bubblemesh_io::output::{OutputKind, OutputPath, OutputSet};
use bubblemesh_plugin_host::PluginSpec;
use bubblemesh_run::{
    output_kind, parse_threads, parse_unit, read_model, significant, stage_bytes, stage_output,
    thread_count, Combine, Drawing, EngineSettings, PictureSettings, SpacingRequest,
};
use bubblemesh_viz::geometry::Measures;
use bubblemesh_viz::{ColorBy, Kind, PictureOptions};
use clap::{Args, Parser, Subcommand, ValueEnum};

/// The command line's error: [`bubblemesh_run::Error`], whose text is
/// printed after `error: `.
type CliError = bubblemesh_run::Error;

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

/// Parses `--view`.
fn parse_view_arg(s: &str) -> Result<V3, CliError> {
    Ok(bubblemesh_viz::view::parse_view(s)?)
}

impl PictureArgs {
    /// The picture settings these options ask for.
    fn settings(&self) -> PictureSettings {
        PictureSettings {
            color: match self.color {
                ColorArg::Quality => ColorBy::Quality,
                ColorArg::Entity => ColorBy::Entity,
            },
            view: self.view,
            bubbles: self.bubbles,
            width: self.width,
        }
    }
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
    /// Upper bound on stage-2 time steps per face (a face of a surface mesh
    /// whose size is uniform takes at most half as many, each twice as long).
    #[arg(long, default_value_t = 600)]
    max_steps: usize,
    /// At least N nodes per full turn of a curved edge: where the size is
    /// larger than 2πρ/N (ρ the edge's radius of curvature) the edge takes
    /// 2πρ/N and the faces around it grade back to the size (Gmsh's
    /// Mesh.MinimumCirclePoints); a face whose own lines turn as far (a
    /// hole's wall, a pin, a pipe) takes 2πρ/N inside too, unless that is
    /// below a sixth of the size; the spacing also grades from edges
    /// shorter than 0.6 times the size. 0 keeps the size as given; at most
    /// 1000.
    #[arg(
        long,
        value_name = "N",
        default_value_t = bubblemesh_core::DEFAULT_CIRCLE_POINTS,
        value_parser = clap::value_parser!(u32).range(0..=bubblemesh_core::MAX_CIRCLE_POINTS as i64)
    )]
    circle_points: u32,
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
    bubblemesh_run::check_dim(a.dim)?;
    let model = Arc::new(model);
    let request = spacing_request(&a);
    let (size_text, default_d) =
        bubblemesh_run::size_text(a.size.as_deref(), request.others_given(), &model, &a.input)?;
    if let (Some(d), false) = (default_d, a.quiet) {
        eprintln!(
            "no --size given: using d = {} (1/40 of the bounding-box diagonal)",
            significant(d, 6)
        );
    }
    let built = bubblemesh_run::build_spacing(request, &size_text, &model)?;
    let spacing_note = built.note.clone();
    // a plugin's failure (refusal, panic, NaN, d <= 0) is the cause of any
    // meshing error, and must fail the run even when a minimum hid it
    let input_name = a.input.display().to_string();
    let plugin_failure = || built.plugin_failure(&input_name);
    let spacing: &dyn Spacing = built.spacing.as_ref();
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
        &a.picture.settings(),
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
        said.extend(bubblemesh_run::circle_points_note(&model, &report));
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
    for line in bubblemesh_run::refined_warnings(&model, &report) {
        eprintln!("{line}");
    }
    if let Some(line) = bubblemesh_run::touching_warning(&report) {
        eprintln!("{line}");
    }
    if let Some(line) = bubblemesh_run::open_shell_warning(&report) {
        eprintln!("{line}");
    }
    if let Some(line) = bubblemesh_run::self_crossing_warning(&report) {
        eprintln!("{line}");
    }
    warn_low_quality(&low);
    Ok(())
}

/// The spacing sources of `mesh` besides --size.
fn spacing_request(a: &MeshArgs) -> SpacingRequest<'_> {
    SpacingRequest {
        custom: None,
        curvature: a.curvature,
        view_spacing: a.view_spacing.as_deref(),
        combine: match a.combine {
            CombineArg::Min => Combine::Min,
            CombineArg::Product => Combine::Product,
        },
        plugins: &a.plugin_specs,
        d_min: a.d_min,
        d_max: a.d_max,
    }
}

/// The engine's options of `mesh`; starts the `threads` every rayon loop
/// (relaxation, volume polish) runs on, so that `--threads 1` is
/// single-threaded throughout.
fn engine_options(a: &MeshArgs, model: &Model, threads: usize) -> Result<Options, CliError> {
    let settings = EngineSettings {
        dim: a.dim,
        fast: a.fast,
        fcc: a.fcc,
        integrator: match a.integrator {
            IntegratorArg::Euler => Integrator::Euler,
            IntegratorArg::Rk4 => Integrator::Rk4,
        },
        max_steps: a.max_steps,
        threads,
        circle_points: a.circle_points,
    };
    let mut opts = settings.options(&a.input, model);
    // the energy history (a sweep over every pair per sample) is only
    // shown by the report and the plots; it never changes the mesh
    opts.relax.record_energy = a.report.is_some() || a.picture.plots.is_some();
    // the global pool is built once per process (here, its only builder)
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|source| CliError::Threads { threads, source })?;
    Ok(opts)
}

fn warn_low_quality(low: &[quality::PoorElements]) {
    for line in bubblemesh_run::poor_element_warnings(low) {
        eprintln!("{line}");
    }
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

/// Meshes `model` in one run observed by the progress bar and, with
/// `--frames` or `--animate`, by the recorder of the bubbles settling
/// (returned with the mesh).
fn mesh_observed(
    a: &MeshArgs,
    model: &Model,
    spacing: &dyn Spacing,
    mut opts: Options,
) -> Result<(Mesh, Report, Option<frames::Recorder>), CliError> {
    let bar = bubblemesh_run::progress_bar(a.quiet, model);
    let recorder = (a.frames.is_some() || a.animate.is_some())
        .then(|| Arc::new(std::sync::Mutex::new(frames::Recorder::default())));
    if bar.is_some() || recorder.is_some() {
        let b = bar.clone();
        let r = recorder.clone();
        opts.observer = Some(Arc::new(move |e: &Event<'_>| {
            if let Some(b) = &b {
                bubblemesh_run::show_step(b, e);
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
        &a.picture.settings(),
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
    let mut o = bubblemesh_run::picture_options(&f.mesh, &pic.settings(), Some(spacing), &f.label);
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
