//! A bubble system for one entity: fixed bubbles (its boundary, already
//! meshed) and free bubbles that move on the entity (thesis §3.2.3).
//!
//! Layout: structure of arrays; fixed bubbles occupy indices `0..n_fixed`,
//! free bubbles the rest. Deleting a free bubble swaps the last one into its
//! place, so indices of free bubbles are not stable across population control.

use crate::geom::{P3, V3};
use crate::spacing::{Spacing, SpacingQuery};

use crate::bubbles::constraint::Carrier;
use crate::bubbles::dynamics::{self, Integrator, K0, MASS};
use crate::bubbles::force;
use crate::bubbles::grid::Grid;
use crate::bubbles::population;
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
    /// Global node ids of the fixed bubbles.
    pub fixed_ids: Vec<u32>,
    /// Factor on the stable distance in the force: the packing is held
    /// slightly compressed ([`PRESSURE`]).
    pub pressure: f64,
}

/// Result of the stage-2 relaxation.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RelaxStats {
    pub steps: usize,
    pub converged: bool,
    pub deleted: usize,
    pub added: usize,
    /// max |Δx|/d over free bubbles in the last step.
    pub final_max_move: f64,
    pub energy: Vec<EnergySample>,
}

/// What one Euler step does to one bubble.
#[derive(Clone, Copy)]
enum Move {
    /// Balanced and at rest: held where it is.
    Sleep,
    /// New position, parameters and velocity.
    To(P3, [f64; 2], V3),
    /// The carrier refused the move (it would leave the entity): stopped.
    Blocked,
}

/// Stage-2 settings.
#[derive(Clone, Copy, Debug)]
pub struct RelaxSettings {
    pub integrator: Integrator,
    pub max_steps: usize,
    /// Converged when max |Δx|/d over free bubbles is below this.
    pub tol: f64,
    /// Population control every this many steps.
    pub population_every: usize,
    /// No population changes after this fraction of `max_steps`, so the last
    /// steps only relax.
    pub population_until: f64,
    pub record_energy: bool,
    /// Stop when the potential energy fell by less than this fraction of
    /// k0·Σd² over the last 25 steps ([`PLATEAU`], [`PLATEAU_BOUNDARY`]).
    pub plateau: f64,
    /// Compute the forces and moves of a step on rayon's thread pool (the
    /// caller's pool: `ThreadPool::install`, or the global one). The result
    /// is identical to the serial step: every bubble's force is taken at the
    /// start of the step (eq. 4.4.6) and its move depends on itself alone.
    /// Off by default: the geometry and spacing are then only ever asked
    /// from the calling thread (the C ABI promises its hosts that).
    pub parallel: bool,
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
        }
    }
}

/// A pair of interacting bubbles (i < j not implied).
#[derive(Clone, Copy, Debug)]
pub struct Pair {
    pub i: u32,
    pub j: u32,
    /// distance / stable distance
    pub w: f64,
    /// unit vector from j to i
    pub dir: V3,
    pub r0: f64,
}

impl<'a, C: Carrier> System<'a, C> {
    pub fn n(&self) -> usize {
        self.pos.len()
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
    fn respace(&mut self, idx: &[u32]) -> Result<(), MeshError> {
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
        let dmin = self.d.iter().cloned().fold(f64::INFINITY, f64::min);
        Grid::new(&self.pos, force::CUTOFF * dmin)
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
        for i in 0..self.n() {
            if mask.is_some_and(|m| !m[i]) {
                continue;
            }
            let (pi, di) = (self.pos[i], self.d[i]);
            grid.query(&pi, force::CUTOFF * di, |j| {
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
                        dir: delta / r,
                        r0,
                    });
                } else if r == 0.0 {
                    // coincident bubbles: push apart along an arbitrary but
                    // deterministic tangent direction
                    let (t1, _) = self.carrier.frame(self.params[i]);
                    out.push(Pair {
                        i: i as u32,
                        j: j as u32,
                        w: 0.0,
                        dir: t1,
                        r0,
                    });
                }
            });
        }
    }

    /// Neighbour lists with a skin (Verlet lists): every pair closer than
    /// (1.5 + SKIN)·r0, both directions, in compressed rows. Reused until a
    /// bubble has moved far enough to use up the skin.
    fn neighbours(&self) -> Neighbours {
        let grid = self.grid();
        let reach = force::CUTOFF + SKIN;
        let nf = self.n_fixed;
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for i in 0..self.n() {
            let (pi, di) = (self.pos[i], self.d[i]);
            grid.query(&pi, reach * di, |j| {
                let j = j as usize;
                let dj = self.d[j];
                if !(dj < di || (dj == di && j > i)) || (i < nf && j < nf) {
                    return;
                }
                if (pi - self.pos[j]).norm() < reach * 0.5 * (di + dj) {
                    pairs.push((i as u32, j as u32));
                }
            });
        }
        let n = self.n();
        let mut start = vec![0u32; n + 1];
        for &(i, j) in &pairs {
            start[i as usize + 1] += 1;
            start[j as usize + 1] += 1;
        }
        for k in 0..n {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        let mut adj = vec![0u32; start[n] as usize];
        for &(i, j) in &pairs {
            adj[fill[i as usize] as usize] = j;
            fill[i as usize] += 1;
            adj[fill[j as usize] as usize] = i;
            fill[j as usize] += 1;
        }
        Neighbours {
            start,
            adj,
            built_pos: self.pos.clone(),
            stale: false,
        }
    }

    /// Net force on bubble i from its neighbour list.
    #[inline]
    fn force_on(&self, nb: &Neighbours, i: usize) -> V3 {
        let (pi, di) = (self.pos[i], self.d[i]);
        let mut f = V3::zeros();
        for &j in nb.of(i) {
            let j = j as usize;
            let delta = pi - self.pos[j];
            let r = delta.norm();
            let r0 = 0.5 * (di + self.d[j]) * self.pressure;
            if r > 0.0 && r < force::CUTOFF * r0 {
                f += delta * (force::magnitude(r, r0, K0) / r);
            } else if r == 0.0 && i > j {
                // coincident bubbles: separate along a deterministic tangent
                f += self.carrier.frame(self.params[i]).0 * force::magnitude(0.0, r0, K0);
            }
        }
        f
    }

    /// Potential energy of all pairs in the neighbour lists.
    fn potential(&self, nb: &Neighbours) -> f64 {
        let mut u = 0.0;
        for i in 0..self.n() {
            for &j in nb.of(i) {
                let j = j as usize;
                if j < i {
                    continue;
                }
                let r0 = 0.5 * (self.d[i] + self.d[j]);
                u += force::potential((self.pos[i] - self.pos[j]).norm(), r0, K0);
            }
        }
        u
    }

    /// Stage 2: relaxes the free bubbles to a force balance with adaptive
    /// population control (§4.3–4.7). `progress(step, positions, diameters)`
    /// is called after each step.
    ///
    /// Work per step is proportional to the bubbles still moving: a bubble
    /// whose net force and velocity are negligible *sleeps* (it is held
    /// where it is) until a neighbour moves; with a uniform spacing the
    /// stage-1 lattice is already balanced and only the bubbles near the
    /// boundary ever wake. Neighbour lists are Verlet lists with a skin.
    pub fn relax(
        &mut self,
        s: &RelaxSettings,
        mut progress: impl FnMut(usize, &[P3], &[f64]),
    ) -> Result<RelaxStats, MeshError> {
        let h = dynamics::time_step(self.dim);
        let c = dynamics::damping(self.dim);
        let mut stats = RelaxStats::default();
        let pop_until = (s.max_steps as f64 * s.population_until) as usize;
        let mut quiet_checks = 0;
        let mut last_pop_step = 0;
        let mut nb = self.neighbours();
        let mut awake: Vec<u32> = (self.n_fixed as u32..self.n() as u32).collect();
        let mut stamp = vec![0u32; self.n()];
        let mut cand: Vec<u32> = Vec::new();
        let mut moves: Vec<Move> = Vec::new();
        let mut respace: Vec<u32> = Vec::new();
        // at most about ENERGY_SAMPLES samples: a sample is a sweep over
        // every pair, as dear as a step when most bubbles sleep
        let energy_stride = s.max_steps.div_ceil(ENERGY_SAMPLES).max(1);
        let mut last_energy: Option<f64> = None;
        for step in 1..=s.max_steps {
            if self.n() == self.n_fixed {
                stats.converged = true;
                break;
            }
            if s.record_energy && (step % energy_stride == 0 || step == 1) {
                let kinetic: f64 = self.vel[self.n_fixed..]
                    .iter()
                    .map(|v| 0.5 * MASS * v.norm_squared())
                    .sum();
                let potential = self.potential(&nb);
                stats.energy.push(EnergySample {
                    step,
                    kinetic,
                    potential,
                    total: kinetic + potential,
                    bubbles: self.n() - self.n_fixed,
                });
            }
            let max_move = match s.integrator {
                Integrator::Euler => {
                    // candidates: awake bubbles and their free neighbours
                    cand.clear();
                    let tag = step as u32;
                    for &i in &awake {
                        if stamp[i as usize] != tag {
                            stamp[i as usize] = tag;
                            cand.push(i);
                        }
                        for &j in nb.of(i as usize) {
                            if j as usize >= self.n_fixed && stamp[j as usize] != tag {
                                stamp[j as usize] = tag;
                                cand.push(j);
                            }
                        }
                    }
                    // forces at the start of the step (eq. 4.4.6), then each
                    // bubble's move from its own state alone: x <- x + h v,
                    // v <- v + h (f - c v)/m
                    let step_one = |i: u32| -> Move {
                        let i = i as usize;
                        let f = self.force_on(&nb, i);
                        let v = self.vel[i];
                        let fscale = K0 * self.d[i];
                        if f.norm() < SLEEP_FORCE * fscale && v.norm() * h < SLEEP_MOVE * self.d[i]
                        {
                            return Move::Sleep;
                        }
                        match self.carrier.advance(&self.pos[i], self.params[i], &(v * h)) {
                            Some((p, uv)) => {
                                let nv = v + (f - v * c) * (h / MASS);
                                Move::To(p, uv, self.carrier.project(uv, &nv))
                            }
                            None => Move::Blocked,
                        }
                    };
                    moves.clear();
                    if s.parallel {
                        use rayon::prelude::*;
                        cand.par_iter()
                            .map(|&i| step_one(i))
                            .collect_into_vec(&mut moves);
                    } else {
                        moves.extend(cand.iter().map(|&i| step_one(i)));
                    }
                    awake.clear();
                    let mut max_move: f64 = 0.0;
                    for (k, &i) in cand.iter().enumerate() {
                        let i = i as usize;
                        match moves[k] {
                            Move::Sleep => {
                                self.vel[i] = V3::zeros();
                                continue;
                            }
                            Move::To(p, uv, nv) => {
                                max_move = max_move.max((p - self.pos[i]).norm() / self.d[i]);
                                self.pos[i] = p;
                                self.params[i] = uv;
                                self.vel[i] = nv;
                            }
                            Move::Blocked => self.vel[i] = V3::zeros(),
                        }
                        awake.push(i as u32);
                        if self.spacing.constant().is_none() {
                            respace.push(i as u32);
                        }
                        let moved = (self.pos[i] - nb.built_pos[i]).norm();
                        if moved > 0.25 * SKIN * self.d[i] {
                            nb.stale = true;
                        }
                    }
                    // the moved bubbles' new diameters, in one batch (one
                    // call per step for a plugin spacing)
                    self.respace(&respace)?;
                    respace.clear();
                    max_move
                }
                Integrator::Rk4 => {
                    let m = self.step_rk4(h, c, &nb)?;
                    awake = (self.n_fixed as u32..self.n() as u32).collect();
                    if self
                        .pos
                        .iter()
                        .zip(&nb.built_pos)
                        .zip(&self.d)
                        .any(|((p, q), d)| (p - q).norm() > 0.25 * SKIN * d)
                    {
                        nb.stale = true;
                    }
                    m
                }
            };
            stats.steps = step;
            stats.final_max_move = max_move;
            progress(step, &self.pos, &self.d);
            let population_open = step <= pop_until && quiet_checks < 3;
            if population_open && step % s.population_every == 0 {
                // the first round looks at every bubble; later rounds only at
                // the bubbles still moving (a sleeping bubble is balanced)
                let grid = self.grid();
                let mut pairs = Vec::new();
                let focus: Option<Vec<bool>> = (step > s.population_every).then(|| {
                    let mut f = vec![false; self.n()];
                    for &i in &awake {
                        f[i as usize] = true;
                    }
                    f
                });
                let near: Option<Vec<bool>> = focus.as_ref().map(|f| {
                    let mut e = f.clone();
                    for &i in &awake {
                        for &j in nb.of(i as usize) {
                            e[j as usize] = true;
                        }
                    }
                    e
                });
                self.pairs(&grid, &mut pairs, near.as_deref());
                let (del, add) = if self.carrier.dim() == 3 {
                    population::control_volume(self, &pairs, &grid, focus.as_deref())?
                } else {
                    population::control(self, &pairs, &grid, focus.as_deref())?
                };
                stats.deleted += del;
                stats.added += add;

                if del + add == 0 {
                    quiet_checks += 1;
                } else {
                    quiet_checks = 0;
                    last_pop_step = step;
                    last_energy = None;
                    nb = self.neighbours();
                    stamp = vec![0u32; self.n()];
                    // everything near a change must move again
                    awake = (self.n_fixed as u32..self.n() as u32).collect();
                }
                continue;
            }
            if nb.stale {
                nb = self.neighbours();
            }
            let settled_since_pop = step >= last_pop_step + s.population_every;
            // energy plateau: the potential energy fell by less than
            // PLATEAU·k0·Σd² over the last PLATEAU_WINDOW steps (bubbles still
            // creeping, e.g. a dislocation gliding along a boundary, no longer
            // change the mesh they make)
            let mut plateau = false;
            if settled_since_pop
                && step % PLATEAU_WINDOW == 0
                && (!population_open || quiet_checks >= 1)
            {
                let u = self.potential(&nb);
                let scale: f64 = self.d[self.n_fixed..].iter().map(|d| K0 * d * d).sum();
                if let Some(prev) = last_energy {
                    plateau = prev - u < s.plateau * scale;
                }
                last_energy = Some(u);
            }
            if plateau {
                stats.converged = true;
                break;
            }
            if (awake.is_empty() || max_move < s.tol)
                && settled_since_pop
                && (!population_open || quiet_checks >= 1)
            {
                stats.converged = true;
                break;
            }
        }
        Ok(stats)
    }

    /// One fourth-order Runge–Kutta step (eq. 4.4.9) over all free bubbles.
    /// Intermediate states are kept on the entity through the same
    /// constraint as the final move.
    fn step_rk4(&mut self, h: f64, c: f64, nb: &Neighbours) -> Result<f64, MeshError> {
        let nf = self.n_fixed;
        let n = self.n();
        let x0: Vec<(P3, [f64; 2])> = (nf..n).map(|i| (self.pos[i], self.params[i])).collect();
        let v0: Vec<V3> = self.vel[nf..].to_vec();
        let accel = |sys: &Self, v: &[V3]| -> Vec<V3> {
            (nf..n)
                .map(|i| (sys.force_on(nb, i) - v[i - nf] * c) / MASS)
                .collect()
        };
        let set = |sys: &mut Self, s: f64, v: &[V3]| {
            for i in nf..n {
                let k = i - nf;
                let (p, uv) = sys
                    .carrier
                    .advance(&x0[k].0, x0[k].1, &(v[k] * s))
                    .unwrap_or(x0[k]);
                sys.pos[i] = p;
                sys.params[i] = uv;
            }
        };
        let a1 = accel(self, &v0);
        let v2: Vec<V3> = (0..v0.len()).map(|k| v0[k] + a1[k] * (0.5 * h)).collect();
        set(self, 0.5 * h, &v0);
        let a2 = accel(self, &v2);
        let v3: Vec<V3> = (0..v0.len()).map(|k| v0[k] + a2[k] * (0.5 * h)).collect();
        set(self, 0.5 * h, &v2);
        let a3 = accel(self, &v3);
        let v4: Vec<V3> = (0..v0.len()).map(|k| v0[k] + a3[k] * h).collect();
        set(self, h, &v3);
        let a4 = accel(self, &v4);
        let mut max_move: f64 = 0.0;
        for i in nf..n {
            let k = i - nf;
            let v = (v0[k] + v2[k] * 2.0 + v3[k] * 2.0 + v4[k]) / 6.0;
            let a = (a1[k] + a2[k] * 2.0 + a3[k] * 2.0 + a4[k]) / 6.0;
            match self.carrier.advance(&x0[k].0, x0[k].1, &(v * h)) {
                Some((p, uv)) => {
                    max_move = max_move.max((p - x0[k].0).norm() / self.d[i]);
                    self.pos[i] = p;
                    self.params[i] = uv;
                    self.vel[i] = v0[k] + a * h;
                }
                None => {
                    self.pos[i] = x0[k].0;
                    self.params[i] = x0[k].1;
                    self.vel[i] = V3::zeros();
                }
            }
            if self.spacing.constant().is_none() {
                self.d[i] = self.spacing_at(&self.pos[i], self.params[i])?;
            }
        }
        Ok(max_move)
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

/// Extra reach of the neighbour lists beyond the force cutoff, in units of
/// the stable distance.
const SKIN: f64 = 0.3;
/// Steps between energy-plateau checks.
const PLATEAU_WINDOW: usize = 25;

/// Samples of the energy history per relaxation, at most (plus the first
/// step's): enough for the curves of Fig. 5.7.
const ENERGY_SAMPLES: usize = 150;
/// Relative potential-energy drop per window below which stage 2 stops
/// (the default of [`RelaxSettings::plateau`]).
pub const PLATEAU: f64 = 1e-5;
/// [`RelaxSettings::plateau`] for a face with a uniform spacing that bounds
/// a volume about to be meshed. There the late energy drop is dislocations
/// creeping along the face's boundary: on case K's cube faces it took steps
/// 100–450 of each relaxation (1.2 s of 2.5 s), and the tetrahedra came
/// out the same (q 0.550 / 0.9404, dihedral angles 26.8°–135.3° against
/// 136.2°; the boundary triangles' min 0.800 against 0.805, mean 0.997;
/// H and J the same; session 9, after the sliver pass began to flip
/// first: before that K's worst angle fell to 25.4° with it). Not for
/// surface meshes (`--dim 2`), where the triangles are the product: there
/// it cost case F (sphere) its min, 0.900 → 0.873, and case E 0.00003 of
/// mean.
pub const PLATEAU_BOUNDARY: f64 = 3e-5;
/// A bubble sleeps when its net force is below this fraction of k0·d ...
const SLEEP_FORCE: f64 = 1e-3;
/// ... and its last move below this fraction of d.
const SLEEP_MOVE: f64 = 1e-4;

/// Verlet neighbour lists in compressed rows.
pub struct Neighbours {
    start: Vec<u32>,
    adj: Vec<u32>,
    built_pos: Vec<P3>,
    stale: bool,
}

impl Neighbours {
    #[inline]
    fn of(&self, i: usize) -> &[u32] {
        &self.adj[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// One sample of the energy history (thesis Fig. 5.7), in engine units
/// (k0 · model length²).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct EnergySample {
    pub step: usize,
    pub kinetic: f64,
    pub potential: f64,
    pub total: f64,
    pub bubbles: usize,
}
