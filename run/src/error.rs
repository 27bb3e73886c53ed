//! The error of a run: what failed, worded for the user. The text of each
//! variant is the message the command line prints after `error: ` (its
//! tests read it) and the Python package raises, so a variant wraps a
//! library error without adding to its words unless the command line
//! always said more.

use std::path::PathBuf;

use bubblemesh_core::MeshError;

/// A failure of a run (the command line's exit status 1).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A check of the command line or its inputs, already worded.
    #[error("{0}")]
    Message(String),
    /// The domain file (.toml) could not be read.
    #[error(transparent)]
    Domain(#[from] bubblemesh_analytic::DomainError),
    /// The STEP file could not be read.
    #[error(transparent)]
    Step(#[from] bubblemesh_truck::StepError),
    /// A --size expression does not parse or is not positive.
    #[error(transparent)]
    Expr(#[from] bubblemesh_core::spacing::ExprError),
    /// A plugin could not be loaded.
    #[error(transparent)]
    Plugin(#[from] bubblemesh_plugin_host::PluginError),
    /// Reading a mesh, choosing a format, checking the outputs.
    #[error(transparent)]
    Io(#[from] bubblemesh_io::IoError),
    /// The report could not be serialised.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A picture could not be drawn.
    #[error(transparent)]
    Viz(#[from] bubblemesh_viz::VizError),
    /// The picture `path` could not be drawn.
    #[error("{}: {source}", path.display())]
    Picture {
        /// The picture asked for.
        path: PathBuf,
        /// Why it could not be drawn.
        source: bubblemesh_viz::VizError,
    },
    /// Meshing `input` failed.
    #[error("{input}: {source}")]
    Mesh {
        /// The input file, as given.
        input: String,
        /// Why.
        source: MeshError,
    },
    /// A file or the whole set of outputs could not be written.
    #[error("cannot write: {0}")]
    Write(bubblemesh_io::IoError),
    /// An output directory could not be made.
    #[error("{0} (cannot create the directory)")]
    MakeDir(bubblemesh_io::IoError),
    /// OUTPUT's extension is neither a mesh format nor a picture.
    #[error("{0}, or a picture: .svg, .png, .html")]
    OutputKind(bubblemesh_io::IoError),
    /// The thread pool of --threads could not be started.
    #[error("--threads {threads}: cannot start the threads: {source}")]
    Threads {
        /// The threads asked for.
        threads: usize,
        /// Why they could not be started.
        source: rayon::ThreadPoolBuildError,
    },
}

impl From<String> for Error {
    fn from(message: String) -> Self {
        Error::Message(message)
    }
}
