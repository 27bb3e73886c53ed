//! STEP (ISO 10303-21) B-rep files as bubblemesh models.
//!
//! # Why not truck-stepio
//!
//! truck-stepio 0.3's conversion to truck geometry is not usable on
//! OpenCascade-written files: periodic B-splines come with
//! unclamped knot vectors that truck evaluates over the whole knot range
//! (NaN, runaway memory), edges prefer 2D pcurves and B-spline edge curves
//! are not trimmed to their vertices, failures are printed and the entity
//! dropped, `VERTEX_LOOP`s are dropped, and which shells make up which solid
//! is not kept. Its parser (the re-exported `ruststep`) recursed per nesting
//! level and rejected legal files (see [`part21`]). So the exchange
//! structure is read by our own parser, [`part21`], into ruststep's AST
//! types, and the entities are converted here into bubblemesh-analytic
//! geometry, which evaluates B-splines only on their valid span [u_p, u_n].
//!
//! # What the model contains
//!
//! - one vertex per `VERTEX_POINT`;
//! - one edge per `EDGE_CURVE`, its 3D curve trimmed to its vertices (a
//!   line as the segment between them, a circle or ellipse as the arc, a
//!   B-spline by closest-point inversion of the vertices, across the start of
//!   a closed B-spline when needed) — except *seam* edges, used twice by one
//!   face on a periodic surface: the face then closes through the surface's
//!   period and the seam is not a boundary (listed in [`StepInfo::seams`]);
//! - one face per `ADVANCED_FACE` / `FACE_SURFACE`, on a [`FaceView`] of its
//!   surface (periodic only where the face wraps around), its loops made of
//!   the non-seam edge uses; vertices of `VERTEX_LOOP`s and of seams that are
//!   on no loop (a sphere's pole, a cone's apex) are embedded vertices;
//! - one volume per `MANIFOLD_SOLID_BREP` / `BREP_WITH_VOIDS` with the faces
//!   of its outer and void shells, named after its product;
//! - in an assembly (module `assembly`), all of that once per placed
//!   instance of a part, moved by the instance's placement: a part used
//!   twice is two volumes with their own faces, edges and vertices;
//! - degenerate edges (a LINE of zero length) as their one vertex;
//! - a `FACETED_BREP` as a solid like a `MANIFOLD_SOLID_BREP`: each
//!   `POLY_LOOP` side a straight edge shared by the faces on both sides, a
//!   `FACE` without geometry on the plane of its polygon (module `faceted`);
//! - a `CURVE_BOUNDED_SURFACE` that no face uses as its geometry as a face of
//!   its basis surface, each boundary curve one closed edge; used as a
//!   face's geometry, as its basis surface;
//! - curves: besides the conics, lines and B-splines, `PARABOLA`,
//!   `OFFSET_CURVE_3D` (along ref_direction × tangent, as OpenCascade reads
//!   it; a line or a circle offset in its plane exactly, other bases
//!   evaluated), `COMPOSITE_CURVE` (its segments joined, trimmed
//!   curves by their trims), and `PCURVE`s (the 2D curve of its
//!   `DEFINITIONAL_REPRESENTATION` evaluated on a plane, cylinder, sphere or
//!   B-spline surface) where an edge or a `SURFACE_CURVE` whose 3D curve
//!   cannot be read gives its geometry only through one;
//! - wireframe-only content (`GEOMETRIC_CURVE_SET`, `GEOMETRIC_SET`,
//!   `…WIREFRAME…` representations) is not B-rep: it is listed in
//!   [`StepInfo::notes`] and skipped; a file with nothing else is an error
//!   naming the entity.
//!
//! Any entity that cannot be converted makes the read fail with a
//! [`StepError`] naming it. Limits guard against hostile input: degree ≤
//! [`bubblemesh_analytic::MAX_NURBS_DEGREE`], at most
//! [`MAX_CONTROL_POINTS`] control points per curve or surface.
//!
//! Lengths are in the file's length unit unless a conversion is asked for;
//! angles are converted to radians.
//!
//! # Units
//!
//! [`read_step`] keeps the coordinates in the file's length unit
//! ([`StepInfo::length_unit`]). [`read_step_with`] / [`parse_step_with`]
//! with [`StepOptions::unit`] set convert them to another unit exactly as
//! they are read: every point (vertices, placements, control points of
//! B-splines), every length (radii, semi-axes, vector magnitudes, offset
//! distances, focal distances) and the file's tolerances are multiplied by
//! the ratio of the units; directions, angles, weights and knots are
//! unchanged. The file must name its length unit then (a file without one is
//! refused: its unit is unknown).
//!
//! ```no_run
//! use bubblemesh_truck::step::{read_step_with, LengthUnit, StepOptions};
//! let opts = StepOptions { unit: Some(LengthUnit::parse("mm").unwrap()) };
//! let m = read_step_with(std::path::Path::new("part_in_inches.stp"), &opts).unwrap();
//! assert_eq!(m.info.length_unit.unwrap().name, "millimetre");
//! assert_eq!(m.info.file_length_unit.unwrap().name, "inch");
//! ```

mod assembly;
mod build;
mod curve_read;
mod curves;
mod faceted;
mod geometry;
pub mod part21;
mod table;
mod units;

use std::path::Path;

use bubblemesh_core::model::Model;

pub use assembly::{volume_bbox, MAX_INSTANCES};
pub use build::MAX_CONTROL_POINTS;
pub use units::LengthUnit;

/// Why a STEP file could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}: {}{reason}", entity.as_ref().map(|(id, t)| format!("#{id} {t}: ")).unwrap_or_default())]
pub struct StepError {
    /// The file (or the name given to [`parse_step`]).
    pub source_name: String,
    /// The entity at fault: id and type name.
    pub entity: Option<(u64, String)>,
    /// What went wrong: the Part 21 syntax error, a missing or malformed
    /// attribute, a geometry or topology the reader cannot convert, ...
    pub reason: String,
}

impl StepError {
    pub(crate) fn file(source: &str, reason: impl Into<String>) -> Self {
        StepError {
            source_name: source.to_string(),
            entity: None,
            reason: reason.into(),
        }
    }
    pub(crate) fn entity(source: &str, id: u64, ty: String, reason: impl Into<String>) -> Self {
        StepError {
            source_name: source.to_string(),
            entity: Some((id, ty)),
            reason: reason.into(),
        }
    }
}

/// What the model's entities are in the STEP file.
#[derive(Debug, Clone, Default)]
pub struct StepInfo {
    /// STEP id of each model vertex.
    pub vertex_ids: Vec<u64>,
    /// STEP id (`EDGE_CURVE`) of each model edge.
    pub edge_ids: Vec<u64>,
    /// STEP id of each model face.
    pub face_ids: Vec<u64>,
    /// For each model face, whether its outward normal (the face's
    /// `same_sense`, combined with an `ORIENTED_FACE`'s orientation) agrees
    /// with S_u × S_v of its surface in the model.
    pub face_same_sense: Vec<bool>,
    /// The shells: (STEP id, whether closed, orientation: `false` for a void
    /// shell, whose faces' normals point into the void as read, index of
    /// the model volume or `None`, the model faces).
    pub shells: Vec<ShellInfo>,
    /// `EDGE_CURVE`s absorbed as seams of periodic faces (not model edges).
    pub seams: Vec<u64>,
    /// For each model face, the largest distance of its boundary (edge
    /// samples, embedded vertices) from its surface, in the file's length
    /// unit: boundaries off their surface are accepted up to a tolerance
    /// and projected onto it.
    pub face_gap: Vec<f64>,
    /// Degenerate `EDGE_CURVE`s (zero-length lines): their vertices are one
    /// model vertex and they are not model edges.
    pub degenerate_edges: Vec<u64>,
    /// The length unit the coordinates are in: the one the file's contexts
    /// assign, or the one asked for in [`StepOptions::unit`].
    pub length_unit: Option<LengthUnit>,
    /// The length unit the file's contexts assign.
    pub file_length_unit: Option<LengthUnit>,
    /// What was read but is not part of the model, one line each
    /// (wireframe-only representations such as `GEOMETRIC_CURVE_SET`,
    /// named with their entity).
    pub notes: Vec<String>,
}

/// How to read a STEP file.
#[derive(Debug, Clone, Default)]
pub struct StepOptions {
    /// Convert every coordinate and length from the file's length unit to
    /// this one (`None`: keep the file's unit).
    pub unit: Option<LengthUnit>,
}

/// One shell of the file.
#[derive(Debug, Clone)]
pub struct ShellInfo {
    /// The STEP id of the `CLOSED_SHELL` or `OPEN_SHELL` (through any
    /// `ORIENTED_CLOSED_SHELL` that refers to it).
    pub step_id: u64,
    /// Whether the shell is a `CLOSED_SHELL` (`false`: an `OPEN_SHELL`).
    pub closed: bool,
    /// `true` for an outer shell, `false` for a void (its faces bound the
    /// solid from inside).
    pub outer: bool,
    /// Index into the model's volumes of the solid this shell bounds;
    /// `None` for a shell that belongs to no solid (a surface model).
    pub volume: Option<u32>,
    /// The shell's faces, as indices into the model's faces, in the order
    /// the shell lists them.
    pub faces: Vec<u32>,
}

/// A STEP file read as a model.
#[derive(Debug, Clone)]
pub struct StepModel {
    /// The model, its coordinates in [`StepInfo::length_unit`].
    pub model: Model,
    /// How the model's entities map back to the file, and what the reader
    /// found on the way (units, seams, gaps, notes).
    pub info: StepInfo,
}

/// Reads a STEP file. Errors name the file, and the entity where one is at
/// fault.
pub fn read_step(path: &Path) -> Result<StepModel, StepError> {
    read_step_with(path, &StepOptions::default())
}

/// Reads a STEP file with `options` (a unit conversion).
pub fn read_step_with(path: &Path, options: &StepOptions) -> Result<StepModel, StepError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| StepError::file(&name, format!("cannot read the STEP file: {e}")))?;
    let text = String::from_utf8_lossy(&bytes);
    parse_step_with(&text, &name, options)
}

/// Reads STEP text; `source_name` is used in messages and as the model's
/// source.
pub fn parse_step(text: &str, source_name: &str) -> Result<StepModel, StepError> {
    parse_step_with(text, source_name, &StepOptions::default())
}

/// Reads STEP text with `options` (a unit conversion).
pub fn parse_step_with(
    text: &str,
    source_name: &str,
    options: &StepOptions,
) -> Result<StepModel, StepError> {
    if text.trim_start_matches('\u{feff}').trim().is_empty() {
        return Err(StepError::file(source_name, "the file is empty"));
    }
    // the parser and the conversion must never take the process down
    let result = std::panic::catch_unwind(|| {
        let exchange =
            part21::parse(text).map_err(|e| StepError::file(source_name, e.to_string()))?;
        let instances = exchange.instances;
        if instances.is_empty() {
            return Err(StepError::file(source_name, "the DATA section is empty"));
        }
        let mut table = table::Table::new(source_name, instances)?;
        faceted::expand(&mut table)?;
        let notes = faceted::expand_curve_bounded(&mut table)?;
        let file_unit = units::length_unit(&table);
        let scale = match (&options.unit, &file_unit) {
            (None, _) => 1.0,
            (Some(to), Some(from)) => from.factor_to(to),
            (Some(to), None) => {
                return Err(StepError::file(
                    source_name,
                    format!(
                        "the file names no length unit, so it cannot be converted to {}",
                        to.name
                    ),
                ))
            }
        };
        let mut m = build::build(&table, scale)?;
        m.info.length_unit = options.unit.clone().or_else(|| file_unit.clone());
        m.info.file_length_unit = file_unit;
        m.info.notes = notes;
        wireframes(&table, &mut m)?;
        Ok(m)
    });
    match result {
        Ok(r) => r,
        Err(_) => Err(StepError::file(
            source_name,
            "internal error while reading (a panic was caught); please report this file",
        )),
    }
}

/// Wireframe-only content (`GEOMETRIC_CURVE_SET`, `GEOMETRIC_SET`, the
/// `…WIREFRAME…` shape representations): not B-rep, so not in the model.
/// Each is noted in [`StepInfo::notes`]; a file with nothing else is an
/// error naming the first of them.
fn wireframes(t: &table::Table, m: &mut StepModel) -> Result<(), StepError> {
    let mut ids: Vec<u64> = t
        .ents
        .iter()
        .filter(|(_, e)| {
            e.is("GEOMETRIC_CURVE_SET")
                || e.is("GEOMETRIC_SET")
                || e.records.iter().any(|r| r.name.contains("WIREFRAME"))
        })
        .map(|(&id, _)| id)
        .collect();
    ids.sort_unstable();
    for &id in &ids {
        m.info.notes.push(format!(
            "#{id} {}: wireframe geometry, not a B-rep: skipped",
            t.type_name(id)
        ));
    }
    if m.model.faces.is_empty() && m.model.edges.is_empty() {
        if let Some(&id) = ids.first() {
            return Err(t.err(
                id,
                "the file has only wireframe geometry (curves, no B-rep faces or solids) \
                 and nothing to mesh",
            ));
        }
    }
    Ok(())
}
