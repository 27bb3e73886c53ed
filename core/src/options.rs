//! What a run is asked to do: the engine's options, and the progress
//! callback long runs report to.

use std::sync::Arc;

use crate::bubbles::system::RelaxSettings;
use crate::model::EntityRef;

/// Progress of a long run, for progress bars.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub phase: &'static str,
    pub entity: EntityRef,
    pub step: usize,
    pub max_steps: usize,
}

/// A progress callback.
pub type ProgressFn = Arc<dyn Fn(Progress) + Send + Sync>;

/// The stage-2 step callback of `entity`: forwards each step to
/// `progress`, if there is one, as phase "relax".
pub(crate) fn relax_progress(
    progress: &Option<ProgressFn>,
    entity: EntityRef,
    max_steps: usize,
) -> impl FnMut(usize) + '_ {
    move |step| {
        if let Some(p) = progress {
            p(Progress {
                phase: "relax",
                entity,
                step,
                max_steps,
            });
        }
    }
}

/// Which lattice volumes start from (an engine option).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum VolumeLattice {
    /// BCC (and no stage 2 or ODT) where the spacing is uniform, FCC
    /// elsewhere.
    #[default]
    Auto,
    /// Always FCC followed by stage 2, as in the thesis.
    Fcc,
}

/// Engine options.
#[derive(Clone)]
pub struct Options {
    /// Highest dimension to mesh (default: the model's).
    pub dim: Option<u8>,
    /// Stage 1 only (§4.1): fast, lower quality.
    pub fast: bool,
    /// Stage-2 settings (integrator, step limit, tolerance).
    pub relax: RelaxSettings,
    /// The stage-1 lattice of volumes (BCC where the spacing is uniform,
    /// by default; see [`crate::volume`]).
    pub volume_lattice: VolumeLattice,
    pub progress: Option<ProgressFn>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            dim: None,
            fast: false,
            relax: RelaxSettings::default(),
            volume_lattice: VolumeLattice::default(),
            progress: None,
        }
    }
}

impl std::fmt::Debug for Options {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Options")
            .field("dim", &self.dim)
            .field("fast", &self.fast)
            .field("relax", &self.relax)
            .field("volume_lattice", &self.volume_lattice)
            .finish()
    }
}

/// Wall-clock seconds per phase; each stage adds its own.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Timings {
    pub edges_s: f64,
    pub stage1_s: f64,
    pub stage2_s: f64,
    pub connect_s: f64,
    /// The conformal-lattice restart of graded planar faces (flattening,
    /// its stage 2, connection and improvement; `conformal`).
    pub lattice_s: f64,
    pub total_s: f64,
}
