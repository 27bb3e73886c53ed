//! A bubble system for one entity: fixed bubbles (its boundary, already
//! meshed) and free bubbles that move on the entity (thesis §3.2.3).
//!
//! Layout: structure of arrays; fixed bubbles occupy indices `0..n_fixed`,
//! free bubbles the rest. Deleting a free bubble swaps the last one into its
//! place, so indices of free bubbles are not stable across population control.
//!
//! The relaxation of a system (stage 2) is in [`crate::bubbles::relax`],
//! population control in [`crate::bubbles::population`]; both work on the
//! types here, which import neither.

use crate::geom::{P3, V3};
use crate::spacing::{Spacing, SpacingQuery};

use crate::bubbles::constraint::Carrier;
use crate::bubbles::dynamics::{self, Integrator};
use crate::bubbles::force;
use crate::bubbles::grid::Grid;
use crate::error::MeshError;

/// One pass's bubbles.
pub struct System<'a, C: Carrier> {
    pub carrier: C,
    pub spacing: &'a dyn Spacing,
    /// The meshing dimension (2 for faces), for the physical constants.
    pub dim: u8,
    pub n_fixed: usize,
    pub pos: Vec<P3>,
    pub params: Vec<[f64; 2]>,
    pub vel: Vec<V3>,
    /// Bubble diameters d(x) at the current positions.
    pub d: Vec<f64>,
    /// Global node ids of the fixed bubbles ([`KEPT_ID`]: a kept bubble of
    /// a warm start, not yet a node).
    pub fixed_ids: Vec<u32>,
    /// Factor on the stable distance in the force: the packing is held
    /// slightly compressed ([`PRESSURE`]).
    pub pressure: f64,
    /// `Some(d)` when the spacing is d everywhere on the carrier's entity,
    /// asked once ([`Spacing::constant_on`] may walk the model).
    pub uniform: Option<f64>,
}

/// Result of the stage-2 relaxation.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RelaxStats {
    /// Steps run.
    pub steps: usize,
    /// Whether it stopped on the tolerance or the energy plateau (not on
    /// the step limit).
    pub converged: bool,
    /// Bubbles deleted by population control (§4.7).
    pub deleted: usize,
    /// Bubbles added by population control (§4.7).
    pub added: usize,
    /// max |Δx|/d over free bubbles in the last step.
    pub final_max_move: f64,
    /// The time step h in engine units (√(m/k0)): [`dynamics::time_step`],
    /// or [`dynamics::LONG_STEP`] times it with [`RelaxSettings::long_steps`].
    pub time_step: f64,
    /// The energy history, when [`RelaxSettings::record_energy`].
    pub energy: Vec<EnergySample>,
}

/// Stage-2 settings.
#[derive(Clone, Copy, Debug)]
pub struct RelaxSettings {
    /// Euler or RK4 (§4.4).
    pub integrator: Integrator,
    /// Step limit.
    pub max_steps: usize,
    /// Converged when max |Δx|/d over free bubbles is below this.
    pub tol: f64,
    /// Population control every this many steps.
    pub population_every: usize,
    /// No population changes after this fraction of `max_steps`, so the last
    /// steps only relax.
    pub population_until: f64,
    /// Record the energy history (about 150 samples per relaxation) into
    /// [`RelaxStats::energy`]. Observation only: the mesh is the same
    /// either way. A sample is a sweep over every pair, as dear as a step
    /// (a volume's 100 steps are all sampled): 3–4 % of a tetrahedral run
    /// (block_holes at d = 0.8: 7.9 → 7.6 s), so the CLI records it only
    /// for `--report` and `--plots`.
    pub record_energy: bool,
    /// Stop when the potential energy fell by less than this fraction of
    /// k0·Σd² over the last 25 steps ([`PLATEAU`], [`PLATEAU_BOUNDARY`]).
    pub plateau: f64,
    /// Compute the forces and moves of a step on rayon's thread pool (the
    /// caller's pool: `ThreadPool::install`, or the global one), and mesh
    /// the faces side by side there (thesis §3.2.3: faces are independent
    /// once their edges are meshed). The result is identical to the serial
    /// run: every bubble's force is taken at the start of the step (eq.
    /// 4.4.6) and its move depends on itself alone, and each face reads only
    /// its edges' mesh and is appended in face order. Off by default: the
    /// geometry, the spacing and the observer are then only ever asked from
    /// the calling thread (the C ABI promises its hosts that).
    pub parallel: bool,
    /// Steps [`dynamics::LONG_STEP`] times longer, and at most
    /// `max_steps / LONG_STEP` of them: the same simulated time in fewer
    /// steps. Euler only. Set for the faces of a surface mesh whose
    /// spacing is uniform (`face::FaceJob::stage2`), which otherwise
    /// run most of their 600 steps: on the STEP fixtures as surfaces
    /// 27.5 → 20.6 s, radius ratios within ±0.0008 of the short steps'
    /// (docs/decisions.md, session 43). Not where the spacing varies (the
    /// graded cases B and C: their smallest radius ratio moved 0.90 → 0.82
    /// with it) nor for faces that bound a volume (the fixtures'
    /// tetrahedra: 7 % faster and lower means on 19 of 31).
    pub long_steps: bool,
}

impl RelaxSettings {
    /// The most steps this relaxation takes: `max_steps`, or with
    /// [`RelaxSettings::long_steps`] (Euler) its share at the long step.
    pub fn step_limit(&self) -> usize {
        if self.long_steps && self.integrator == Integrator::Euler {
            (self.max_steps as f64 / dynamics::LONG_STEP).ceil() as usize
        } else {
            self.max_steps
        }
    }

    /// The time step for entities of dimension `dim` (§4.3.3,
    /// [`dynamics::time_step`]; longer with [`RelaxSettings::long_steps`]).
    pub fn time_step(&self, dim: u8) -> f64 {
        if self.long_steps && self.integrator == Integrator::Euler {
            dynamics::LONG_STEP * dynamics::time_step(dim)
        } else {
            dynamics::time_step(dim)
        }
    }
}

impl Default for RelaxSettings {
    fn default() -> Self {
        RelaxSettings {
            integrator: Integrator::Euler,
            max_steps: 600,
            tol: 1e-3,
            population_every: 8,
            population_until: 0.75,
            record_energy: true,
            plateau: PLATEAU,
            parallel: false,
            long_steps: false,
        }
    }
}

/// A pair of interacting bubbles (i < j not implied), for population
/// control's overlap ratios.
#[derive(Clone, Copy, Debug)]
pub struct Pair {
    pub i: u32,
    pub j: u32,
    /// distance / stable distance (0 for coincident bubbles)
    pub w: f64,
}

/// The id of a fixed bubble that a warm start kept from an earlier packing
/// (thesis §4.8.1) and that becomes a mesh node only when the entity is
/// emitted. The packing around it is kept too, so population control never
/// inserts a bubble next to it.
pub const KEPT_ID: u32 = u32::MAX;

impl<'a, C: Carrier> System<'a, C> {
    /// A system of fixed bubbles only (positions, parameters, diameters,
    /// node ids; free ones follow with [`System::push_free`]), at rest. The
    /// packing is held at [`PRESSURE`] where the spacing varies and at 1
    /// where it is uniform: the pressure helps graded packings anneal, and
    /// only slows a uniform lattice down (measured on cases E and G).
    pub fn with_fixed(
        carrier: C,
        spacing: &'a dyn Spacing,
        dim: u8,
        pos: Vec<P3>,
        params: Vec<[f64; 2]>,
        d: Vec<f64>,
        fixed_ids: Vec<u32>,
    ) -> Self {
        let n_fixed = fixed_ids.len();
        let uniform = spacing.constant_on(carrier.entity());
        let pressure = if uniform.is_some() { 1.0 } else { PRESSURE };
        System {
            carrier,
            spacing,
            dim,
            n_fixed,
            pos,
            params,
            vel: vec![V3::zeros(); n_fixed],
            d,
            fixed_ids,
            pressure,
            uniform,
        }
    }

    pub fn n(&self) -> usize {
        self.pos.len()
    }

    /// Whether bubble `i` is a kept bubble of a warm start ([`KEPT_ID`]).
    #[inline]
    pub fn is_kept(&self, i: usize) -> bool {
        i < self.n_fixed && self.fixed_ids.get(i) == Some(&KEPT_ID)
    }

    /// `Some(d)` when the spacing is d everywhere on this entity (then a
    /// moved bubble keeps its diameter).
    pub fn uniform(&self) -> Option<f64> {
        self.uniform
    }

    /// d at a point of this entity, checked finite and > 0.
    pub fn spacing_at(&self, p: &P3, params: [f64; 2]) -> Result<f64, MeshError> {
        let d = self.spacing.spacing(&SpacingQuery {
            point: *p,
            entity: self.carrier.entity(),
            params,
        });
        if d.is_finite() && d > 0.0 {
            Ok(d)
        } else {
            Err(MeshError::BadSpacing {
                value: d,
                point: *p,
                entity: self.carrier.entity(),
            })
        }
    }

    /// Re-evaluates d at the bubbles `idx` with one [`Spacing::spacing_batch`]
    /// call, checking every value.
    pub(crate) fn respace(&mut self, idx: &[u32]) -> Result<(), MeshError> {
        if idx.is_empty() {
            return Ok(());
        }
        let entity = self.carrier.entity();
        let qs: Vec<SpacingQuery> = idx
            .iter()
            .map(|&i| SpacingQuery {
                point: self.pos[i as usize],
                entity,
                params: self.params[i as usize],
            })
            .collect();
        let mut out = vec![0.0; qs.len()];
        self.spacing.spacing_batch(&qs, &mut out);
        for (k, &i) in idx.iter().enumerate() {
            let d = out[k];
            if !(d.is_finite() && d > 0.0) {
                return Err(MeshError::BadSpacing {
                    value: d,
                    point: qs[k].point,
                    entity,
                });
            }
            self.d[i as usize] = d;
        }
        Ok(())
    }

    /// Adds a free bubble at rest.
    pub fn push_free(&mut self, p: P3, params: [f64; 2], d: f64) {
        self.pos.push(p);
        self.params.push(params);
        self.vel.push(V3::zeros());
        self.d.push(d);
    }

    /// Removes free bubble `i` (swap-remove).
    pub fn remove_free(&mut self, i: usize) {
        debug_assert!(i >= self.n_fixed);
        self.pos.swap_remove(i);
        self.params.swap_remove(i);
        self.vel.swap_remove(i);
        self.d.swap_remove(i);
    }

    /// A neighbour grid over the current positions.
    pub fn grid(&self) -> Grid {
        Grid::for_spacings(&self.pos, &self.d, force::CUTOFF)
    }

    /// Every interacting pair (w < 1.5) with at least one free bubble, each
    /// once.
    ///
    /// Bubble i searches radius 1.5·d_i and keeps neighbours j with
    /// d_j < d_i (ties by index): a pair's cutoff 1.5·(d_i+d_j)/2 never
    /// exceeds 1.5·max(d_i, d_j), so the larger bubble always finds it.
    /// With `mask`, only pairs of two masked bubbles.
    pub fn pairs(&self, grid: &Grid, out: &mut Vec<Pair>, mask: Option<&[bool]>) {
        out.clear();
        let nf = self.n_fixed;
        // a fixed bubble looks for free ones only (see `neighbours`)
        let free = grid.only_from(&self.pos, nf);
        for i in 0..self.n() {
            if mask.is_some_and(|m| !m[i]) {
                continue;
            }
            let (pi, di) = (self.pos[i], self.d[i]);
            let search = match &free {
                Some(free) if i < nf => free,
                _ => grid,
            };
            search.query(&pi, force::CUTOFF * di, |j| {
                let j = j as usize;
                if mask.is_some_and(|m| !m[j]) {
                    return;
                }
                let dj = self.d[j];
                if !(dj < di || (dj == di && j > i)) || (i < nf && j < nf) {
                    return;
                }
                let delta = pi - self.pos[j];
                let r = delta.norm();
                let r0 = 0.5 * (di + dj);
                let w = r / r0;
                if w < force::CUTOFF && r > 0.0 {
                    out.push(Pair {
                        i: i as u32,
                        j: j as u32,
                        w,
                    });
                } else if r == 0.0 {
                    // coincident bubbles: the most overlapping pair
                    out.push(Pair {
                        i: i as u32,
                        j: j as u32,
                        w: 0.0,
                    });
                }
            });
        }
    }
}

/// Stage 2 packs with the force's zero at 1.05·r0 instead of r0, so the
/// free bubbles are slightly compressed against the fixed boundary (as
/// DistMesh's "Fscale"). The pressure pushes bubbles into gaps and out of
/// dislocations, so the packing anneals better; population control and the
/// edge relaxation after connection still use r0, so the mesh keeps the
/// requested spacing. Measured with `bench/run_2d.py`: min radius ratio on
/// cases B/C from 0.83/0.80 to 0.90/0.82 at equal mean. Used for varying
/// spacings only: with a uniform one it cost case E 60 % more steps and
/// case G 0.006 of mean radius ratio.
pub const PRESSURE: f64 = 1.05;

/// Relative potential-energy drop per window below which stage 2 stops
/// (the default of [`RelaxSettings::plateau`]).
pub const PLATEAU: f64 = 1e-5;
/// [`RelaxSettings::plateau`] for a face with a uniform spacing that bounds
/// a volume about to be meshed. There the late energy drop is dislocations
/// creeping along the face's boundary: on case K's cube faces it took steps
/// 100–450 of each relaxation (1.2 s of 2.5 s), and the tetrahedra came
/// out the same (q 0.550 / 0.9404, dihedral angles 26.8°–135.3° against
/// 136.2°; the boundary triangles' min 0.800 against 0.805, mean 0.997;
/// H and J the same; measured after the sliver pass began to flip
/// first: before that K's worst angle fell to 25.4° with it). Not for
/// surface meshes (`--dim 2`), where the triangles are the product: there
/// it cost case F (sphere) its min, 0.900 → 0.873, and case E 0.00003 of
/// mean.
pub const PLATEAU_BOUNDARY: f64 = 3e-5;

/// One sample of the energy history (thesis Fig. 5.7), in engine units
/// (k0 · model length²).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct EnergySample {
    /// The step.
    pub step: usize,
    /// Kinetic energy Σ m|v|²/2.
    pub kinetic: f64,
    /// Potential energy of the interbubble forces (eq. 4.2.6 integrated).
    pub potential: f64,
    /// Kinetic plus potential.
    pub total: f64,
    /// Bubbles at that step (fixed and free).
    pub bubbles: usize,
}
