//! Stage 2 (thesis §4.3–4.7): the damped dynamics of a [`System`] to a
//! force balance, with adaptive population control every few steps.
//!
//! Kept apart from [`crate::bubbles::system`] (the bubbles and their pairs)
//! so that population control ([`crate::bubbles::population`]), which works
//! on a system, and the relaxation, which calls it, import in one direction:
//! relax → population → system.
//!
//! Work per step is proportional to the bubbles still moving: a bubble whose
//! net force and velocity are negligible *sleeps* (it is held where it is)
//! until a neighbour moves; with a uniform spacing the stage-1 lattice is
//! already balanced and only the bubbles near the boundary ever wake.
//! Neighbour lists are Verlet lists with a skin.

use crate::geom::{P3, V3};

use crate::bubbles::constraint::{Carrier, Kept};
use crate::bubbles::dynamics::{self, Integrator, K0, MASS};
use crate::bubbles::force;
use crate::bubbles::grid::Levels;
use crate::bubbles::population;
use crate::bubbles::system::{EnergySample, RelaxSettings, RelaxStats, System};
use crate::error::MeshError;

/// What one Euler step does to one bubble.
#[derive(Clone, Copy)]
enum Move {
    /// Balanced and at rest: held where it is.
    Sleep,
    /// New position, parameters and velocity, and what the carrier handed
    /// back for the next move ([`Carrier::advance_kept`]).
    To(P3, [f64; 2], V3, Option<Kept>),
    /// The carrier refused the move (it would leave the entity): stopped.
    Blocked,
}

/// Extra reach of the neighbour lists beyond the force cutoff, in units of
/// the stable distance. The lists reach 1.65·r0, short of an FCC packing's
/// third shell at √3·r0 (24 neighbours, which 0.3 took in: most of each
/// list was beyond the force's reach), at the cost of building them after
/// shorter moves ([`System::rebuild_move`]). Same meshes; stage 2 of
/// block_holes' volume at 0.8 3.04 → 2.27 s, the torus fixture's surface
/// 1.23 → 1.11 s (best of 3–4, one thread).
const SKIN: f64 = 0.15;
/// Steps between energy-plateau checks.
const PLATEAU_WINDOW: usize = 25;

/// Samples of the energy history per relaxation, at most (plus the first
/// step's): enough for the curves of Fig. 5.7.
const ENERGY_SAMPLES: usize = 150;
/// A bubble sleeps when its net force is below this fraction of k0·d ...
const SLEEP_FORCE: f64 = 1e-3;
/// ... and its last move below this fraction of d.
const SLEEP_MOVE: f64 = 1e-4;

#[cfg(test)]
thread_local! {
    /// Tests: build the neighbour lists at every step.
    static REBUILD_EVERY_STEP: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether the lists are built at every step: in tests that ask for it;
/// otherwise only when a bubble used up the skin.
#[inline(always)]
fn rebuild_every_step() -> bool {
    #[cfg(test)]
    return REBUILD_EVERY_STEP.get();
    #[cfg(not(test))]
    false
}

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

/// A moved bubble's d is evaluated again once it is this fraction of d
/// from where it was last evaluated. A graded spacing changes by at most
/// its gradient (0.4 around capped and short edges) times the distance,
/// so d lags by under 0.1 % (after a population round, which renumbers
/// the bubbles, every d is evaluated afresh); near equilibrium bubbles
/// move by thousandths of
/// d per step, and evaluating d at every step was a third of a graded
/// part's face time (as_40mm_capot: the cone tree of `circle_points`;
/// 2.45 → 1.85 s). 0.02 and 0.005 were faster still but lowered case B's
/// worst triangle (`bench/run_2d.py`: 0.887 → 0.817 at 0.005, and its mean
/// below 0.99 at 0.02).
pub(crate) const RESPACE_MOVE: f64 = 0.002;

/// The state a relaxation carries from one step to the next.
struct Relaxation {
    nb: Neighbours,
    /// Free bubbles that moved in the last step (they and their free
    /// neighbours are the next step's candidates).
    awake: Vec<u32>,
    /// `stamp[i] == step` once bubble i is a candidate of that step.
    stamp: Vec<u32>,
    cand: Vec<u32>,
    moves: Vec<Move>,
    respace: Vec<u32>,
    /// Where each bubble's d was last evaluated (see [`RESPACE_MOVE`]);
    /// every free bubble's is evaluated again when population control
    /// renumbers the bubbles.
    spaced_at: Vec<P3>,
    /// Population rounds in a row that changed nothing.
    quiet_checks: usize,
    last_pop_step: usize,
    /// Potential energy at the last plateau check.
    last_energy: Option<f64>,
    /// Per bubble, what its last move's carrier handed back, with the
    /// parameters' bits it belongs to: used only while they are the
    /// bubble's parameters (population control renumbers bubbles).
    kept: Vec<Option<([u64; 2], Kept)>>,
}

impl<'a, C: Carrier> System<'a, C> {
    /// Neighbour lists with a skin (Verlet lists): every pair closer than
    /// (1.5 + SKIN)·r0, both directions, in compressed rows. Reused until a
    /// bubble has moved far enough to use up the skin.
    fn neighbours(&self) -> Neighbours {
        let reach = force::CUTOFF + SKIN;
        let nf = self.n_fixed;
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        let mut keep = |i: usize, j: usize| {
            if (i >= nf || j >= nf)
                && (self.pos[i] - self.pos[j]).norm() < reach * 0.5 * (self.d[i] + self.d[j])
            {
                pairs.push((i as u32, j as u32));
            }
        };
        if Levels::needed(&self.d) {
            // by spacing class: beside a boundary refined to d/64, a bubble
            // of the requested spacing then searches its own class, not the
            // thousands of small ones in its reach
            Levels::new(&self.pos, &self.d, reach).candidates(&self.pos, &self.d, reach, keep);
        } else {
            // one grid, each pair asked for by its larger bubble (cheaper
            // than the classes where the spacings spread little)
            let grid = self.grid();
            for i in 0..self.n() {
                let di = self.d[i];
                grid.query(&self.pos[i], reach * di, |j| {
                    let j = j as usize;
                    let dj = self.d[j];
                    if dj < di || (dj == di && j > i) {
                        keep(i, j);
                    }
                });
            }
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
        // each list in increasing index: a bubble's forces are summed in
        // that order whatever the search and whenever the lists were built
        // (the pairs beyond the cutoff, which differ, add nothing)
        for w in start.windows(2) {
            adj[w[0] as usize..w[1] as usize].sort_unstable();
        }
        Neighbours {
            start,
            adj,
            built_pos: self.pos.clone(),
            stale: false,
        }
    }

    /// How far, in units of its own d, a bubble may move from where the
    /// lists were built before they must be built again. Two bubbles that
    /// were not listed were at least (1.5 + SKIN)·(d_i + d_j)/2 apart and
    /// approach by at most this times (d_i + d_j) while neither has moved
    /// further, so they stay beyond the force's reach, 1.5·pressure·(d_i +
    /// d_j)/2, while this is below half the difference (0.075 at pressure
    /// 1, 0.0375 at [`crate::bubbles::system::PRESSURE`]); 2 % is kept
    /// for rounding.
    fn rebuild_move(&self) -> f64 {
        0.98 * 0.5 * (force::CUTOFF + SKIN - force::CUTOFF * self.pressure)
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
    /// population control (§4.3–4.7; see the module docs). `progress(step, positions, diameters)`
    /// is called each step.
    pub fn relax(
        &mut self,
        s: &RelaxSettings,
        mut progress: impl FnMut(usize, &[P3], &[f64]),
    ) -> Result<RelaxStats, MeshError> {
        let h = s.time_step(self.dim);
        let c = dynamics::damping(self.dim);
        let max_steps = s.step_limit();
        let mut stats = RelaxStats {
            time_step: h,
            ..Default::default()
        };
        let pop_until = (max_steps as f64 * s.population_until) as usize;
        let mut st = Relaxation {
            nb: self.neighbours(),
            awake: (self.n_fixed as u32..self.n() as u32).collect(),
            stamp: vec![0u32; self.n()],
            cand: Vec::new(),
            moves: Vec::new(),
            respace: Vec::new(),
            spaced_at: self.pos.clone(),
            quiet_checks: 0,
            last_pop_step: 0,
            last_energy: None,
            kept: Vec::new(),
        };
        // at most about ENERGY_SAMPLES samples: a sample is a sweep over
        // every pair, as dear as a step when most bubbles sleep
        let energy_stride = max_steps.div_ceil(ENERGY_SAMPLES).max(1);
        for step in 1..=max_steps {
            if self.n() == self.n_fixed {
                stats.converged = true;
                break;
            }
            if s.record_energy && (step % energy_stride == 0 || step == 1) {
                stats.energy.push(self.energy_sample(step, &st.nb));
            }
            let max_move = match s.integrator {
                Integrator::Euler => self.step_euler(&mut st, step, h, c, s.parallel)?,
                Integrator::Rk4 => {
                    let m = self.step_rk4(h, c, &st.nb)?;
                    let rebuild = self.rebuild_move();
                    st.awake = (self.n_fixed as u32..self.n() as u32).collect();
                    if self
                        .pos
                        .iter()
                        .zip(&st.nb.built_pos)
                        .zip(&self.d)
                        .any(|((p, q), d)| (p - q).norm() > rebuild * d)
                    {
                        st.nb.stale = true;
                    }
                    m
                }
            };
            stats.steps = step;
            stats.final_max_move = max_move;
            progress(step, &self.pos, &self.d);
            let population_open = step <= pop_until && st.quiet_checks < 3;
            if population_open && step % s.population_every == 0 {
                let (del, add) = self.population_round(&mut st, step, s.population_every)?;
                stats.deleted += del;
                stats.added += add;
                if del + add > 0 && self.uniform().is_none() {
                    // renumbered: every free bubble's d is evaluated where
                    // it is now, so the lag never adds up across rounds
                    let free: Vec<u32> = (self.n_fixed as u32..self.n() as u32).collect();
                    self.respace(&free)?;
                    st.spaced_at.clone_from(&self.pos);
                }
                continue;
            }
            if st.nb.stale || rebuild_every_step() {
                st.nb = self.neighbours();
            }
            if self.settled(&mut st, s, step, max_move, population_open) {
                stats.converged = true;
                break;
            }
        }
        Ok(stats)
    }

    /// The energy history's sample at `step` (thesis Fig. 5.7).
    fn energy_sample(&self, step: usize, nb: &Neighbours) -> EnergySample {
        let kinetic: f64 = self.vel[self.n_fixed..]
            .iter()
            .map(|v| 0.5 * MASS * v.norm_squared())
            .sum();
        let potential = self.potential(nb);
        EnergySample {
            step,
            kinetic,
            potential,
            total: kinetic + potential,
            bubbles: self.n() - self.n_fixed,
        }
    }

    /// One Euler step (eq. 4.4.6) of the awake bubbles and their free
    /// neighbours. Returns max |Δx|/d.
    fn step_euler(
        &mut self,
        st: &mut Relaxation,
        step: usize,
        h: f64,
        c: f64,
        parallel: bool,
    ) -> Result<f64, MeshError> {
        if st.spaced_at.len() != self.n() {
            st.spaced_at.clone_from(&self.pos);
        }
        // candidates: awake bubbles and their free neighbours
        st.cand.clear();
        let tag = step as u32;
        for &i in &st.awake {
            if st.stamp[i as usize] != tag {
                st.stamp[i as usize] = tag;
                st.cand.push(i);
            }
            for &j in st.nb.of(i as usize) {
                if j as usize >= self.n_fixed && st.stamp[j as usize] != tag {
                    st.stamp[j as usize] = tag;
                    st.cand.push(j);
                }
            }
        }
        // forces at the start of the step (eq. 4.4.6), then each
        // bubble's move from its own state alone: x <- x + h v,
        // v <- v + h (f - c v)/m
        if st.kept.len() < self.n() {
            st.kept.resize(self.n(), None);
        }
        let this = &*self;
        let nb = &st.nb;
        let kept = &st.kept;
        let step_one = |i: u32| -> Move {
            let i = i as usize;
            let f = this.force_on(nb, i);
            let v = this.vel[i];
            let fscale = K0 * this.d[i];
            if f.norm() < SLEEP_FORCE * fscale && v.norm() * h < SLEEP_MOVE * this.d[i] {
                return Move::Sleep;
            }
            let uv = this.params[i];
            let held = kept[i]
                .filter(|(key, _)| *key == [uv[0].to_bits(), uv[1].to_bits()])
                .map(|(_, k)| k);
            match this.carrier.advance_kept(&this.pos[i], uv, &(v * h), held) {
                Some((p, uv, k)) => {
                    let nv = v + (f - v * c) * (h / MASS);
                    Move::To(p, uv, this.carrier.project(uv, &nv), k)
                }
                None => Move::Blocked,
            }
        };
        st.moves.clear();
        if parallel {
            use rayon::prelude::*;
            st.cand
                .par_iter()
                .map(|&i| step_one(i))
                .collect_into_vec(&mut st.moves);
        } else {
            st.moves.extend(st.cand.iter().map(|&i| step_one(i)));
        }
        st.awake.clear();
        let mut max_move: f64 = 0.0;
        let rebuild = self.rebuild_move();
        for (k, &i) in st.cand.iter().enumerate() {
            let i = i as usize;
            match st.moves[k] {
                Move::Sleep => {
                    self.vel[i] = V3::zeros();
                    continue;
                }
                Move::To(p, uv, nv, k) => {
                    max_move = max_move.max((p - self.pos[i]).norm() / self.d[i]);
                    self.pos[i] = p;
                    self.params[i] = uv;
                    self.vel[i] = nv;
                    st.kept[i] = k.map(|k| ([uv[0].to_bits(), uv[1].to_bits()], k));
                }
                Move::Blocked => self.vel[i] = V3::zeros(),
            }
            st.awake.push(i as u32);
            if self.uniform().is_none()
                && (self.pos[i] - st.spaced_at[i]).norm() > RESPACE_MOVE * self.d[i]
            {
                st.respace.push(i as u32);
                st.spaced_at[i] = self.pos[i];
            }
            let moved = (self.pos[i] - st.nb.built_pos[i]).norm();
            if moved > rebuild * self.d[i] {
                st.nb.stale = true;
            }
        }
        // the moved bubbles' new diameters, in one batch (one
        // call per step for a plugin spacing)
        self.respace(&st.respace)?;
        st.respace.clear();
        Ok(max_move)
    }

    /// One round of population control (§4.7). The first round looks at
    /// every bubble; later rounds only at the bubbles still moving (a
    /// sleeping bubble is balanced). Returns (deleted, added).
    fn population_round(
        &mut self,
        st: &mut Relaxation,
        step: usize,
        population_every: usize,
    ) -> Result<(usize, usize), MeshError> {
        let grid = self.grid();
        let mut pairs = Vec::new();
        let focus: Option<Vec<bool>> = (step > population_every).then(|| {
            let mut f = vec![false; self.n()];
            for &i in &st.awake {
                f[i as usize] = true;
            }
            f
        });
        let near: Option<Vec<bool>> = focus.as_ref().map(|f| {
            let mut e = f.clone();
            for &i in &st.awake {
                for &j in st.nb.of(i as usize) {
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
        if del + add == 0 {
            st.quiet_checks += 1;
        } else {
            st.quiet_checks = 0;
            st.last_pop_step = step;
            st.last_energy = None;
            st.nb = self.neighbours();
            st.stamp = vec![0u32; self.n()];
            // everything near a change must move again
            st.awake = (self.n_fixed as u32..self.n() as u32).collect();
        }
        Ok((del, add))
    }

    /// Whether stage 2 is done after `step`: the potential energy reached a
    /// plateau, or nothing moves more than the tolerance, in both cases
    /// with population control settled.
    #[allow(clippy::manual_is_multiple_of)] // is_multiple_of needs Rust 1.87
    fn settled(
        &self,
        st: &mut Relaxation,
        s: &RelaxSettings,
        step: usize,
        max_move: f64,
        population_open: bool,
    ) -> bool {
        let settled_since_pop = step >= st.last_pop_step + s.population_every;
        // energy plateau: the potential energy fell by less than
        // PLATEAU·k0·Σd² over the last PLATEAU_WINDOW steps (bubbles still
        // creeping, e.g. a dislocation gliding along a boundary, no longer
        // change the mesh they make)
        let mut plateau = false;
        if settled_since_pop
            && step % PLATEAU_WINDOW == 0
            && (!population_open || st.quiet_checks >= 1)
        {
            let u = self.potential(&st.nb);
            let scale: f64 = self.d[self.n_fixed..].iter().map(|d| K0 * d * d).sum();
            if let Some(prev) = st.last_energy {
                plateau = prev - u < s.plateau * scale;
            }
            st.last_energy = Some(u);
        }
        if plateau {
            return true;
        }
        (st.awake.is_empty() || max_move < s.tol)
            && settled_since_pop
            && (!population_open || st.quiet_checks >= 1)
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
            if self.uniform().is_none() {
                self.d[i] = self.spacing_at(&self.pos[i], self.params[i])?;
            }
        }
        Ok(max_move)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bubbles::testing::{self, Line};
    use crate::spacing::Constant;

    /// Positions of all bubbles along the line, sorted.
    fn sorted_x(sys: &System<'_, Line>) -> Vec<f64> {
        let mut x: Vec<f64> = sys.pos.iter().map(|p| p.x).collect();
        x.sort_by(|a, b| a.total_cmp(b));
        x
    }

    /// Free bubbles between two fixed ones on a line reach the force
    /// balance (§4.3): every neighbour at the stable distance r0 = d, so
    /// the chain ends equally spaced; and the damped dynamics lose energy
    /// on the way (the potential ends at its minimum, every gap at r0). A
    /// bubble sleeps once its net force is below SLEEP_FORCE·k0·d, so each
    /// gap is r0 to a few times that fraction.
    #[test]
    fn a_chain_between_two_fixed_bubbles_ends_equally_spaced() {
        let d = 0.2;
        let s = Constant(d);
        let mut sys = testing::system(Line, &s, vec![[0.0, 0.0], [1.0, 0.0]], 1);
        for x in [0.15, 0.35, 0.6, 0.85] {
            sys.push_free(P3::new(x, 0.0, 0.0), [x, 0.0], d);
        }
        let settings = RelaxSettings {
            max_steps: 3000,
            tol: 1e-7,
            // no population control and no plateau stop: relaxation alone
            population_until: 0.0,
            plateau: f64::NEG_INFINITY,
            ..Default::default()
        };
        let u0 = sys.potential(&sys.neighbours());
        let stats = sys.relax(&settings, |_, _, _| {}).unwrap();
        assert!(stats.converged, "not converged in {} steps", stats.steps);
        assert_eq!(sys.n(), 6);
        let x = sorted_x(&sys);
        for w in x.windows(2) {
            assert!(
                (w[1] - w[0] - d).abs() < 4.0 * SLEEP_FORCE * d,
                "gaps {:?}",
                x.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>()
            );
        }
        let u1 = sys.potential(&sys.neighbours());
        let minimum = 5.0 * force::potential(d, d, K0);
        assert!(u1 < u0, "energy {u0} -> {u1}");
        assert!(
            (u1 - minimum).abs() < 1e-4 * K0 * d * d,
            "{u1} vs {minimum}"
        );
        // the recorded history falls from its first sample to its last
        let (first, last) = (stats.energy[0], *stats.energy.last().unwrap());
        assert!(last.total < first.total, "{first:?} -> {last:?}");
    }

    /// The forces do not depend on when the neighbour lists were built:
    /// relaxing with the lists reused until a bubble moved `rebuild_move`
    /// ends at the same bits as with them rebuilt at every step (each list
    /// in increasing index, and no unlisted pair comes within the force's
    /// reach in between), at pressure 1 and at `PRESSURE`.
    #[test]
    fn lists_reused_within_the_skin_give_the_bits_of_lists_rebuilt_every_step() {
        for pressure in [1.0, crate::bubbles::system::PRESSURE] {
            let s = Constant(0.1);
            let run = |every_step: bool| {
                let mut sys = testing::square_system(&s);
                sys.pressure = pressure;
                // scattered: bubbles cross several spacings on the way
                let mut rnd = testing::uniform(31);
                for _ in 0..90 {
                    let uv = [0.05 + 0.9 * rnd(), 0.05 + 0.9 * rnd()];
                    sys.push_free(P3::new(uv[0], uv[1], 0.0), uv, 0.1);
                }
                let settings = RelaxSettings {
                    max_steps: 300,
                    population_until: 0.0,
                    plateau: f64::NEG_INFINITY,
                    ..Default::default()
                };
                REBUILD_EVERY_STEP.set(every_step);
                let stats = sys.relax(&settings, |_, _, _| {}).unwrap();
                REBUILD_EVERY_STEP.set(false);
                (sys.pos.clone(), stats.steps)
            };
            let (reused, steps) = run(false);
            let (rebuilt, steps_rebuilt) = run(true);
            assert!(steps > 100, "{steps} steps");
            assert_eq!(steps, steps_rebuilt);
            assert_eq!(reused, rebuilt, "pressure {pressure}");
        }
    }

    /// A bubble started between two fixed bubbles off the middle comes to
    /// rest in the middle, whatever side it starts on.
    #[test]
    fn one_bubble_between_two_fixed_ones_stops_in_the_middle() {
        for x0 in [0.3, 0.7] {
            let s = Constant(0.5);
            let mut sys = testing::system(Line, &s, vec![[0.0, 0.0], [1.0, 0.0]], 1);
            sys.push_free(P3::new(x0, 0.0, 0.0), [x0, 0.0], 0.5);
            let settings = RelaxSettings {
                max_steps: 3000,
                tol: 1e-7,
                population_until: 0.0,
                plateau: f64::NEG_INFINITY,
                ..Default::default()
            };
            sys.relax(&settings, |_, _, _| {}).unwrap();
            assert!(
                (sys.pos[2].x - 0.5).abs() < 1e-3,
                "from {x0}: {}",
                sys.pos[2].x
            );
        }
    }
}
