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
//! - degenerate edges (a LINE of zero length) as their one vertex.
//!
//! Any entity that cannot be converted makes the read fail with a
//! [`StepError`] naming it. Limits guard against hostile input: degree ≤
//! [`bubblemesh_analytic::MAX_NURBS_DEGREE`], at most
//! [`MAX_CONTROL_POINTS`] control points per curve or surface.
//!
//! Lengths are in the file's length unit; angles are converted to radians.

mod assembly;
mod build;
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
    /// The length unit the file's contexts assign (coordinates are in it).
    pub length_unit: Option<LengthUnit>,
}

/// One shell of the file.
#[derive(Debug, Clone)]
pub struct ShellInfo {
    pub step_id: u64,
    pub closed: bool,
    /// `true` for an outer shell, `false` for a void (its faces bound the
    /// solid from inside).
    pub outer: bool,
    pub volume: Option<u32>,
    pub faces: Vec<u32>,
}

/// A STEP file read as a model.
#[derive(Debug, Clone)]
pub struct StepModel {
    pub model: Model,
    pub info: StepInfo,
}

/// Reads a STEP file. Errors name the file, and the entity where one is at
/// fault.
pub fn read_step(path: &Path) -> Result<StepModel, StepError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| StepError::file(&name, format!("cannot read the STEP file: {e}")))?;
    let text = String::from_utf8_lossy(&bytes);
    parse_step(&text, &name)
}

/// Reads STEP text; `source_name` is used in messages and as the model's
/// source.
pub fn parse_step(text: &str, source_name: &str) -> Result<StepModel, StepError> {
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
        let table = table::Table::new(source_name, instances)?;
        build::build(&table).map(|mut m| {
            m.info.length_unit = units::length_unit(&table);
            m
        })
    });
    match result {
        Ok(r) => r,
        Err(_) => Err(StepError::file(
            source_name,
            "internal error while reading (a panic was caught); please report this file",
        )),
    }
}
