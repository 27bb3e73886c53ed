//! The bubble engine (placeholder; being written).
use crate::{mesh::Mesh, model::Model, spacing::Spacing};

/// Engine options.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Highest dimension to mesh (default: the model's).
    pub dim: Option<u8>,
    /// Stage 1 only (thesis §4.1): fast, lower quality.
    pub fast: bool,
}

/// What the run did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Report {}

/// A meshing failure.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{0}")]
    Invalid(String),
}

/// Meshes `model` with spacing `d`.
pub fn mesh_model(_model: &Model, _d: &dyn Spacing, _opts: &Options) -> Result<(Mesh, Report), MeshError> {
    Err(MeshError::Invalid("not yet".into()))
}
