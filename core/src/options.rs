//! What a run is asked to do: the engine's options, and the observer that
//! a run reports its progress to.
//!
//! The observer is told of each stage of each entity as it happens: the
//! bubbles stage 1 placed, each stage-2 step, the improvement passes, the
//! entity finished. Snapshots are borrowed slices of the engine's own
//! arrays, so an observer that ignores them costs one call per event and
//! nothing else; one that wants to keep them (the animation of the
//! bubbles settling) copies what it needs.

use std::sync::Arc;

use crate::bubbles::system::RelaxSettings;
use crate::geom::P3;
use crate::mesh::Mesh;
use crate::model::EntityRef;
use crate::remesh::WarmStart;

/// What a run tells its observer ([`Options::observer`]).
///
/// In `positions` and `diameters` (one per bubble) the first `fixed`
/// bubbles are the fixed ones of lower dimensions (the entity's boundary),
/// the others the entity's own.
#[derive(Clone, Copy, Debug)]
pub enum Event<'a> {
    /// Stage 1 (§4.1) placed the bubbles of `entity`.
    Stage1 {
        /// The face or volume.
        entity: EntityRef,
        /// How many of the bubbles are fixed (they come first).
        fixed: usize,
        /// Bubble centres.
        positions: &'a [P3],
        /// Bubble diameters.
        diameters: &'a [f64],
    },
    /// Stage 2 (§4.3–4.7) made step `step` (from 1) of at most `max_steps`
    /// on `entity`.
    Step {
        /// The face or volume.
        entity: EntityRef,
        /// The step just made, from 1.
        step: usize,
        /// The step limit of this entity.
        max_steps: usize,
        /// How many of the bubbles are fixed (they come first).
        fixed: usize,
        /// Bubble centres after the step.
        positions: &'a [P3],
        /// Bubble diameters after the step.
        diameters: &'a [f64],
    },
    /// An improvement pass of `entity`'s elements finished, after `seconds`;
    /// `stats` are its counts by name.
    Pass {
        /// The volume.
        entity: EntityRef,
        /// The pass ("odt", "delaunay", "slivers", "polish").
        name: &'static str,
        /// Wall-clock seconds the pass took.
        seconds: f64,
        /// What the pass did, by name (e.g. `("iterations", 12.0)`).
        stats: &'a [(&'static str, f64)],
    },
    /// `entity` is meshed; `mesh` is the mesh so far.
    Done {
        /// The vertex, edge, face or volume.
        entity: EntityRef,
        /// Everything meshed so far, `entity` included.
        mesh: &'a Mesh,
    },
}

/// An observer of a run, told of each [`Event`]: on the meshing thread,
/// except that with [`RelaxSettings::parallel`](crate::RelaxSettings::parallel)
/// faces are meshed side by side and their `Stage1`, `Step` and `Pass`
/// events come from rayon's threads, interleaved between faces; `Done`
/// events always come from the meshing thread, in entity order. A panic in
/// it unwinds out of [`crate::mesh_model`].
pub type ObserverFn = Arc<dyn Fn(&Event<'_>) + Send + Sync>;

impl Options {
    /// Tells the observer, if there is one, of `event`.
    pub(crate) fn tell(&self, event: &Event<'_>) {
        if let Some(o) = &self.observer {
            o(event);
        }
    }

    /// Tells the observer that stage 1 placed `diameters.len()` bubbles on
    /// `entity`, the first `fixed` of them fixed.
    pub(crate) fn stage1_done(
        &self,
        entity: EntityRef,
        fixed: usize,
        positions: &[P3],
        diameters: &[f64],
    ) {
        self.tell(&Event::Stage1 {
            entity,
            fixed,
            positions,
            diameters,
        });
    }

    /// The stage-2 step callback of `entity` (for
    /// [`crate::bubbles::system::System::relax`]): tells the observer of
    /// each step.
    pub(crate) fn relax_observer(
        &self,
        entity: EntityRef,
        max_steps: usize,
        fixed: usize,
    ) -> impl FnMut(usize, &[P3], &[f64]) + '_ {
        move |step, positions, diameters| {
            self.tell(&Event::Step {
                entity,
                step,
                max_steps,
                fixed,
                positions,
                diameters,
            })
        }
    }
}

/// Which lattice volumes start from (an engine option).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum VolumeLattice {
    /// BCC (and no stage 2 or ODT) where the spacing is uniform, the same
    /// with its boundary layer relaxed where that is poor, FCC elsewhere.
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
    /// Told of each stage of each entity as the run goes ([`Event`]): the
    /// progress bar, the animation of the bubbles settling, a C caller's
    /// progress callback.
    pub observer: Option<ObserverFn>,
    /// Re-meshing (§4.8): the old bubbles each matched entity starts from
    /// ([`crate::remesh::plan`]); `None` meshes from scratch.
    pub warm: Option<Arc<WarmStart>>,
    /// At least this many nodes per full turn of a curved edge, the spacing
    /// graded away from it ([`crate::circle_points`]); 0 turns it off.
    /// Default [`DEFAULT_CIRCLE_POINTS`].
    pub circle_points: u32,
    /// Between refinement rounds, replay the nodes of an edge and the mesh
    /// of a face whose inputs (boundary, spacing) did not change instead of
    /// meshing them again (the same mesh, faster; `engine::memo`). On by
    /// default; off only to check that replaying changes nothing.
    pub replay_unchanged: bool,
}

/// Nodes per full turn of a curved edge at the least, by default (Gmsh's
/// `Mesh.MinimumCirclePoints` default).
pub const DEFAULT_CIRCLE_POINTS: u32 = 7;

/// The most nodes per turn one may ask for (`--circle-points`): beyond,
/// the cap is finer than any spacing a user means and only multiplies
/// the bubbles.
pub const MAX_CIRCLE_POINTS: u32 = 1000;

impl Default for Options {
    fn default() -> Self {
        Options {
            dim: None,
            fast: false,
            relax: RelaxSettings::default(),
            volume_lattice: VolumeLattice::default(),
            observer: None,
            warm: None,
            circle_points: DEFAULT_CIRCLE_POINTS,
            replay_unchanged: true,
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
            .field("warm", &self.warm.is_some())
            .field("circle_points", &self.circle_points)
            .field("replay_unchanged", &self.replay_unchanged)
            .finish()
    }
}

/// Wall-clock seconds per phase; each stage adds its own. Faces meshed
/// side by side ([`RelaxSettings::parallel`](crate::RelaxSettings::parallel))
/// add each face's own time, so on several threads the phases can sum past
/// `total_s`.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Timings {
    /// Meshing the edges (both stages).
    pub edges_s: f64,
    /// Stage 1 of faces and volumes.
    pub stage1_s: f64,
    /// Stage 2 of faces and volumes.
    pub stage2_s: f64,
    /// Connecting faces and volumes and improving their elements.
    pub connect_s: f64,
    /// The conformal-lattice restart of graded planar faces (flattening,
    /// its stage 2, connection and improvement; `conformal`).
    pub lattice_s: f64,
    /// The whole run, refinement rounds included.
    pub total_s: f64,
}

impl Timings {
    /// Adds `other`'s phases (not its total) to these.
    pub(crate) fn add(&mut self, other: &Timings) {
        self.edges_s += other.edges_s;
        self.stage1_s += other.stage1_s;
        self.stage2_s += other.stage2_s;
        self.connect_s += other.connect_s;
        self.lattice_s += other.lattice_s;
    }
}
