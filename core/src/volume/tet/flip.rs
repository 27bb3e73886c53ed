//! Topological improvement of a tetrahedral mesh: edge removal (3-2, 4-4,
//! 5-6, … flips, the best re-triangulation of an edge's ring by Klincsek's
//! dynamic programme) and 2-3 flips (not in the thesis; Freitag &
//! Ollivier-Gooch 1997, Shewchuk 2002 "Two discrete optimization
//! algorithms for the topological improvement of tetrahedral meshes").
//!
//! Two goals: [`raise_worst`] for the sliver pass (a flip must raise the
//! worst [`objective`](super::star::objective) of the tetrahedra it
//! replaces) and [`raise_mean`] for the polish (a flip must raise the
//! mesh's mean radius ratio without a new tetrahedron below
//! [`TARGET_Q`]). Invariants: every new tetrahedron is positively oriented
//! (exact `orient3d`), boundary faces are never flipped (a boundary face has
//! one tetrahedron and a boundary edge an open ring), nodes never move.

use crate::geom::{P3, V3};
use rustc_hash::FxHashMap;

use super::mesh::TetMesh;
use super::star::{node_tets, objective_of, TARGET_Q};
use crate::measure::{orient3d, tet_radius_ratio_of, TET_FACES};

/// The state of a flip sweep over a tetrahedral mesh: tets with a dead flag and their
/// [`objective`](super::star::objective) (`qv`, kept current: nodes
/// never move here), and per node the tets around it: the initial ones in
/// a compressed table (`start`, `csr`), those added by flips in `extra`;
/// dead ones are skipped when read.
///
/// The maps are only looked up, never iterated, so their hasher cannot
/// change a result; Fx instead of SipHash because `extra` is read for
/// every edge and face asked about (5 % of as_0082's tetrahedral run).
///
/// Why not a `Vec` per node: building 470k of them (case K) cost more than
/// the flips it serves; flips touch a few thousand nodes.
struct FlipState<'a> {
    pos: &'a [P3],
    tets: Vec<[u32; 4]>,
    qv: Vec<f64>,
    dead: Vec<bool>,
    start: Vec<u32>,
    csr: Vec<u32>,
    extra: FxHashMap<u32, Vec<u32>>,
    /// Edge removals found not to meet the goal, with the tets of the ring
    /// then: tets are never changed in place (only killed and added) and
    /// nodes do not move, so while the ring holds the same tets the answer
    /// is the same. A sweep asks again for every bad tet sharing the edge
    /// and in every later sweep; the dynamic programme was most of the
    /// sliver pass's time (as_0053 tetrahedra).
    failed_edges: FxHashMap<(u32, u32), [u32; 7]>,
    /// 2-3 flips found not to meet the goal (sorted face → its two tets),
    /// the same way.
    failed_faces: FxHashMap<[u32; 3], [u32; 2]>,
}

impl<'a> FlipState<'a> {
    /// `qv[i]` must be the objective of `tets[i]`.
    fn new(pos: &'a [P3], tets: Vec<[u32; 4]>, qv: Vec<f64>) -> Self {
        let (start, csr) = node_tets(pos.len(), &tets);
        FlipState {
            pos,
            dead: vec![false; tets.len()],
            tets,
            qv,
            start,
            csr,
            extra: Default::default(),
            failed_edges: Default::default(),
            failed_faces: Default::default(),
        }
    }

    fn q(&self, t: &[u32; 4]) -> f64 {
        objective_of(self.pos, t)
    }

    /// [`Goal::value`] of live tet `ti` (its objective is kept in `qv`).
    fn value(&self, goal: Goal, ti: u32) -> f64 {
        match goal {
            Goal::Worst => self.qv[ti as usize],
            Goal::Mean { .. } => goal.value(self.pos, &self.tets[ti as usize]),
        }
    }

    fn remove(&mut self, ti: u32) {
        self.dead[ti as usize] = true;
    }

    fn add(&mut self, t: [u32; 4]) {
        let ti = self.tets.len() as u32;
        self.qv.push(self.q(&t));
        self.tets.push(t);
        self.dead.push(false);
        for &v in &t {
            let list = self.extra.entry(v).or_default();
            list.push(ti);
            // a node that flips over and over gathers dead tets here, and
            // `around` reads them all (a sixth of the sliver pass on
            // pyocc_Ventilator): drop them whenever the list doubles
            if list.len() >= 16 && list.len().is_power_of_two() {
                let dead = &self.dead;
                list.retain(|&t| !dead[t as usize]);
            }
        }
    }

    /// The tets listed around node `v` (dead ones too), in increasing
    /// order: the initial ones, then those added by flips.
    fn listed(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let v0 = v as usize;
        let initial = &self.csr[self.start[v0] as usize..self.start[v0 + 1] as usize];
        let added = self.extra.get(&v).map(|x| &x[..]).unwrap_or(&[]);
        initial.iter().chain(added).copied()
    }

    /// How many tets are listed around node `v`.
    fn listed_len(&self, v: u32) -> usize {
        let v0 = v as usize;
        (self.start[v0 + 1] - self.start[v0]) as usize + self.extra.get(&v).map_or(0, Vec::len)
    }

    /// The node of `vs` with the shortest list: a tip of a thin wedge
    /// gathers thousands of flat tets, and reading its list for every edge
    /// at it was nearly all of a sliver pass (`as_0082` at diag/15).
    fn pivot(&self, vs: &[u32]) -> u32 {
        vs.iter()
            .copied()
            .min_by_key(|&v| self.listed_len(v))
            .unwrap_or(vs[0])
    }

    /// The live tets containing every node of `vs`, written to `out` in
    /// increasing order; their number, or `None` when there are more than
    /// `out` holds (no allocation: this is asked for every edge and face of
    /// every bad tet).
    fn around_at_most(&self, vs: &[u32], out: &mut [u32]) -> Option<usize> {
        let mut n = 0;
        for t in self.listed(self.pivot(vs)) {
            if !self.dead[t as usize] && vs.iter().all(|v| self.tets[t as usize].contains(v)) {
                *out.get_mut(n)? = t;
                n += 1;
            }
        }
        Some(n)
    }

    /// Whether a live tet has the edge (a, b).
    fn any_around(&self, a: u32, b: u32) -> bool {
        self.listed(self.pivot(&[a, b])).any(|t| {
            !self.dead[t as usize] && {
                let tt = &self.tets[t as usize];
                tt.contains(&a) && tt.contains(&b)
            }
        })
    }

    /// Sign of det(b−a, c−a, d−a) (exact).
    fn orient(&self, a: u32, b: u32, c: u32, d: u32) -> f64 {
        let [a, b, c, d] = [a, b, c, d].map(|k| self.pos[k as usize]);
        -orient3d(&a, &b, &c, &d)
    }

    /// Removes the interior edge (d, e) if a re-triangulation of its ring
    /// (at most 7 tets around it) meets `goal`.
    fn try_edge_removal(&mut self, d: u32, e: u32, goal: Goal) -> bool {
        let mut ring = [u32::MAX; 7];
        let Some(m) = self.around_at_most(&[d, e], &mut ring) else {
            return false;
        };
        if m < 3 {
            return false;
        }
        let key = (d.min(e), d.max(e));
        if self.failed_edges.get(&key) == Some(&ring) {
            return false;
        }
        if self.removes_edge(d, e, &ring[..m], goal) {
            return true;
        }
        self.failed_edges.insert(key, ring);
        false
    }

    /// [`Self::try_edge_removal`] given the edge's live tets.
    fn removes_edge(&mut self, d: u32, e: u32, ring_tets: &[u32], goal: Goal) -> bool {
        let m = ring_tets.len();
        // ring edges x–y of each tet, chained into a cycle
        let mut links: Vec<[u32; 2]> = ring_tets
            .iter()
            .map(|&t| {
                let mut o = [u32::MAX; 2];
                let mut k = 0;
                for &v in &self.tets[t as usize] {
                    if v != d && v != e && k < 2 {
                        o[k] = v;
                        k += 1;
                    }
                }
                o
            })
            .collect();
        let mut ring = vec![links[0][0], links[0][1]];
        links.swap_remove(0);
        while !links.is_empty() {
            let last = *ring.last().unwrap_or(&u32::MAX);
            let Some(k) = links.iter().position(|l| l[0] == last || l[1] == last) else {
                return false; // open ring: a boundary edge
            };
            let l = links.swap_remove(k);
            let next = if l[0] == last { l[1] } else { l[0] };
            if links.is_empty() {
                if next != ring[0] {
                    return false;
                }
            } else {
                ring.push(next);
            }
        }
        if ring.len() != m {
            return false;
        }
        // counter-clockwise seen from d: Newell normal towards d
        let p = |k: u32| self.pos[k as usize];
        let mut nrm = V3::zeros();
        for i in 0..m {
            nrm += p(ring[i]).coords.cross(&p(ring[(i + 1) % m]).coords);
        }
        if nrm.dot(&(p(d) - p(e))) < 0.0 {
            ring.reverse();
        }
        let old: Vec<f64> = ring_tets.iter().map(|&t| self.value(goal, t)).collect();
        let old_min = ring_tets
            .iter()
            .map(|&t| self.qv[t as usize])
            .fold(f64::INFINITY, f64::min);
        // Klincsek's dynamic programme over triangulations of the ring:
        // best[i][j] = the best value of the polygon ring[i..=j], its worst
        // radius ratio (Goal::Worst) or its sum (Goal::Mean)
        let floor = goal.floor(old_min);
        // a triangle whose worst tetrahedron is at most `useless` is in no
        // triangulation that meets a Worst goal: it counts as invalid (the
        // programme's answer is the same, and the second tetrahedron's
        // objective is spared)
        let useless = match goal {
            Goal::Worst => old_min + GAIN,
            Goal::Mean { .. } => f64::NEG_INFINITY,
        };
        let tri_q = |i: usize, j: usize, k: usize| -> f64 {
            let (a, b, c) = (ring[i], ring[j], ring[k]);
            if self.orient(a, b, c, d) <= 0.0 || self.orient(a, c, b, e) <= 0.0 {
                return f64::NEG_INFINITY;
            }
            let (t1, t2) = ([a, b, c, d], [a, c, b, e]);
            let q1 = self.q(&t1);
            if q1 <= useless {
                return f64::NEG_INFINITY;
            }
            let worst = q1.min(self.q(&t2));
            match goal {
                Goal::Worst => worst,
                Goal::Mean { .. } if worst < floor => f64::NEG_INFINITY,
                Goal::Mean { .. } => goal.value(self.pos, &t1) + goal.value(self.pos, &t2),
            }
        };
        let join = |x: f64, y: f64| match goal {
            Goal::Worst => x.min(y),
            Goal::Mean { .. } => x + y,
        };
        let unit = match goal {
            Goal::Worst => f64::INFINITY,
            Goal::Mean { .. } => 0.0,
        };
        // m ≤ 7 (checked by the caller)
        let mut best = [[unit; 7]; 7];
        let mut split = [[usize::MAX; 7]; 7];
        for len in 2..m {
            for i in 0..m - len {
                let j = i + len;
                best[i][j] = f64::NEG_INFINITY;
                for k in i + 1..j {
                    let v = join(join(tri_q(i, k, j), best[i][k]), best[k][j]);
                    if v > best[i][j] {
                        best[i][j] = v;
                        split[i][j] = k;
                    }
                }
            }
        }
        if !goal.gains(&old, best[0][m - 1], 2 * (m - 2)) {
            return false;
        }
        let mut new_tris = Vec::new();
        let mut stack = vec![(0usize, m - 1)];
        while let Some((i, j)) = stack.pop() {
            if j < i + 2 {
                continue;
            }
            let k = split[i][j];
            new_tris.push((ring[i], ring[k], ring[j]));
            stack.push((i, k));
            stack.push((k, j));
        }
        for &t in ring_tets {
            self.remove(t);
        }
        for (a, b, c) in new_tris {
            self.add([a, b, c, d]);
            self.add([a, c, b, e]);
        }
        true
    }

    /// Replaces the two tets sharing the interior face (a, b, c) by three
    /// around the edge joining their apexes, if that meets `goal`.
    fn try_2_3(&mut self, f: [u32; 3], goal: Goal) -> bool {
        let mut pair = [u32::MAX; 2];
        if self.around_at_most(&f, &mut pair) != Some(2) {
            return false;
        }
        let apex = |t: u32| -> u32 {
            self.tets[t as usize]
                .iter()
                .cloned()
                .find(|v| !f.contains(v))
                .unwrap_or(u32::MAX)
        };
        let (d, e) = (apex(pair[0]), apex(pair[1]));
        if d == u32::MAX || e == u32::MAX || self.any_around(d, e) {
            return false;
        }
        let mut key = f;
        key.sort_unstable();
        if self.failed_faces.get(&key) == Some(&pair) {
            return false;
        }
        if self.flips_2_3(f, pair, d, e, goal) {
            return true;
        }
        self.failed_faces.insert(key, pair);
        false
    }

    /// [`Self::try_2_3`] given the face's two tets and their apexes (not
    /// joined by an edge).
    fn flips_2_3(&mut self, f: [u32; 3], pair: [u32; 2], d: u32, e: u32, goal: Goal) -> bool {
        let old = [self.value(goal, pair[0]), self.value(goal, pair[1])];
        let old_min = self.qv[pair[0] as usize].min(self.qv[pair[1] as usize]);
        let mut new = Vec::new();
        for i in 0..3 {
            let (a, b) = (f[i], f[(i + 1) % 3]);
            let t = if self.orient(a, b, d, e) > 0.0 {
                [a, b, d, e]
            } else {
                [b, a, d, e]
            };
            new.push(t);
        }
        // valid only if the three have one orientation pattern: all
        // positive as built and the segment d–e crosses the face
        let signs: Vec<f64> = (0..3)
            .map(|i| self.orient(f[i], f[(i + 1) % 3], d, e))
            .collect();
        if !(signs.iter().all(|&s| s > 0.0) || signs.iter().all(|&s| s < 0.0)) {
            return false;
        }
        let new_min = new.iter().map(|t| self.q(t)).fold(f64::INFINITY, f64::min);
        let value = match goal {
            Goal::Worst => new_min,
            Goal::Mean { .. } if new_min < goal.floor(old_min) => f64::NEG_INFINITY,
            Goal::Mean { .. } => new.iter().map(|t| goal.value(self.pos, t)).sum(),
        };
        if !goal.gains(&old, value, 3) {
            return false;
        }
        self.remove(pair[0]);
        self.remove(pair[1]);
        for t in new {
            self.add(t);
        }
        true
    }

    /// The live tets and their objectives.
    fn into_tets(self) -> (Vec<[u32; 4]>, Vec<f64>) {
        self.tets
            .into_iter()
            .zip(self.qv)
            .zip(self.dead)
            .filter(|(_, d)| !d)
            .map(|(tq, _)| tq)
            .unzip()
    }
}

/// The least rise of the worst objective a Worst flip must bring.
const GAIN: f64 = 1e-6;

/// What a flip must improve to be accepted.
#[derive(Clone, Copy, Debug)]
enum Goal {
    /// The worst [`objective`](super::star::objective) of the
    /// tetrahedra it replaces must rise.
    Worst,
    /// The mesh's mean radius ratio must rise: the new tetrahedra's sum of
    /// radius ratios must beat the old ones' by more than `mu` (about the
    /// mesh's mean) per tetrahedron added, and none may fall below the
    /// smaller of the old worst and `floor`.
    Mean { mu: f64, floor: f64 },
}

impl Goal {
    /// What a tetrahedron contributes: its [`objective`] for `Worst`, its
    /// radius ratio (what the mean measures) for `Mean`.
    fn value(self, pos: &[P3], t: &[u32; 4]) -> f64 {
        match self {
            Goal::Worst => objective_of(pos, t),
            Goal::Mean { .. } => tet_radius_ratio_of(pos, t),
        }
    }

    fn floor(self, old_min: f64) -> f64 {
        match self {
            Goal::Worst => f64::NEG_INFINITY,
            Goal::Mean { floor, .. } => old_min.min(floor),
        }
    }

    /// Whether replacing tetrahedra of radius ratios `old` by `n_new` ones
    /// of value `new` (their worst, or their sum) is an improvement.
    fn gains(self, old: &[f64], new: f64, n_new: usize) -> bool {
        match self {
            Goal::Worst => new > old.iter().cloned().fold(f64::INFINITY, f64::min) + GAIN,
            Goal::Mean { mu, .. } => {
                new - old.iter().sum::<f64>() > (n_new as f64 - old.len() as f64) * mu + 1e-6
            }
        }
    }
}

/// The flips' tuning.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FlipParams {
    /// Sweeps of [`raise_worst`] (it stops earlier when a sweep flips
    /// nothing).
    pub worst_sweeps: usize,
}

impl Default for FlipParams {
    fn default() -> Self {
        FlipParams { worst_sweeps: 4 }
    }
}

/// Edge removals and 2-3 flips around every tetrahedron whose
/// [`objective`](super::star::objective) is below `target` (the sliver
/// pass's: [`TARGET_Q`] unless asked for more), each
/// accepted only when it raises the worst objective of the tetrahedra it
/// replaces (so it terminates); up to `params.worst_sweeps` sweeps. `qs[i]`
/// is the objective of `mesh.tets[i]`, on entry and on return. Nodes never
/// move. Returns the flips made.
pub(crate) fn raise_worst(
    mesh: &mut TetMesh,
    params: &FlipParams,
    target: f64,
    qs: &mut Vec<f64>,
) -> usize {
    let (pos, tets) = (&mesh.pos, &mut mesh.tets);
    sweep(pos, tets, qs, Goal::Worst, target, params.worst_sweeps)
}

/// One sweep of edge removals and 2-3 flips around every tetrahedron whose
/// objective is below `below`, each accepted when it raises the mesh's mean
/// radius ratio (about `mu` before the sweep; a flip adding k tetrahedra
/// must add more than k·`mu` to the sum) and no new tetrahedron falls below
/// min(the old worst, [`TARGET_Q`]). Returns the flips made.
///
/// Why: after smoothing, the mesh is no longer Delaunay, and a node's star
/// often holds a tetrahedron no move can fix. On case I (d = 0.02 + 0.1·x)
/// one sweep around tetrahedra below 0.7 made 1,737 flips among 117k
/// tetrahedra, the mean went 0.886 → 0.892, and the next smoothing pass
/// reached 0.901 where a pass without flips reaches 0.887.
pub(crate) fn raise_mean(mesh: &mut TetMesh, mu: f64, below: f64) -> usize {
    let (pos, tets) = (&mesh.pos, &mut mesh.tets);
    let goal = Goal::Mean {
        mu,
        floor: TARGET_Q,
    };
    let mut qs: Vec<f64> = tets.iter().map(|t| objective_of(pos, t)).collect();
    sweep(pos, tets, &mut qs, goal, below, 1)
}

/// Up to `sweeps` passes over the tetrahedra below `below`: for each, the
/// first of its edges whose removal meets `goal`, else the first of its
/// faces whose 2-3 flip does. Returns the flips made.
fn sweep(
    pos: &[P3],
    tets: &mut Vec<[u32; 4]>,
    qs: &mut Vec<f64>,
    goal: Goal,
    below: f64,
    sweeps: usize,
) -> usize {
    if !qs.iter().any(|&q| q < below) {
        return 0;
    }
    let mut tm = FlipState::new(pos, std::mem::take(tets), std::mem::take(qs));
    let mut flips = 0;
    for _ in 0..sweeps {
        let mut changed = 0;
        let work: Vec<u32> = (0..tm.tets.len() as u32)
            .filter(|&t| !tm.dead[t as usize] && tm.qv[t as usize] < below)
            .collect();
        for t in work {
            if tm.dead[t as usize] {
                continue;
            }
            let tt = tm.tets[t as usize];
            let flipped = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
                .iter()
                .any(|&(i, j)| tm.try_edge_removal(tt[i], tt[j], goal))
                || TET_FACES
                    .iter()
                    .any(|f| tm.try_2_3([tt[f[0]], tt[f[1]], tt[f[2]]], goal));
            if flipped {
                changed += 1;
            }
        }
        flips += changed;
        if changed == 0 {
            break;
        }
    }
    (*tets, *qs) = tm.into_tets();
    flips
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::tet::mesh::testing::{
        assert_positive, boundary_faces, jittered_mesh, mean_q, volume, worst_objective,
    };

    /// A mean-raising sweep on a jittered lattice: the mean rises, and the
    /// result is still a tetrahedralization of the same box with the same
    /// boundary: every tetrahedron positive, every face held by one or two,
    /// the one-tetrahedron faces exactly the old ones, the volume unchanged,
    /// and no new tetrahedron below min(old worst, TARGET_Q).
    #[test]
    fn raise_mean_keeps_a_conforming_tetrahedralization() {
        let mut mesh = jittered_mesh(8, 0.45);
        let (pos, tets0) = (mesh.pos.clone(), mesh.tets.clone());
        let m0 = mean_q(&pos, &tets0);
        let flips = raise_mean(&mut mesh, m0, 1.0);
        assert_eq!(mesh.pos, pos, "flips move no node");
        let tets = mesh.tets;
        assert!(flips > 0);
        let m1 = mean_q(&pos, &tets);
        assert!(m1 > m0 + 0.01, "mean {m0} -> {m1}");
        assert_positive(&pos, &tets);
        assert_eq!(boundary_faces(&tets0), boundary_faces(&tets));
        assert!((volume(&pos, &tets) - volume(&pos, &tets0)).abs() < 1e-9);
        assert!(worst_objective(&pos, &tets) >= worst_objective(&pos, &tets0).min(TARGET_Q));
    }

    /// The sliver goal never lowers the worst tetrahedron.
    #[test]
    fn raise_worst_lifts_the_worst_tetrahedron() {
        let mut mesh = jittered_mesh(8, 0.45);
        let (pos, tets0) = (mesh.pos.clone(), mesh.tets.clone());
        let w0 = worst_objective(&pos, &tets0);
        assert!(w0 < TARGET_Q);
        let mut qs = mesh.objectives();
        assert!(raise_worst(&mut mesh, &FlipParams::default(), TARGET_Q, &mut qs) > 0);
        assert_eq!(mesh.pos, pos, "flips move no node");
        let tets = mesh.tets;
        for (t, q) in tets.iter().zip(&qs) {
            assert_eq!(*q, objective_of(&pos, t), "the objectives stay current");
        }
        assert!(worst_objective(&pos, &tets) > w0);
        assert_positive(&pos, &tets);
        assert_eq!(boundary_faces(&tets0), boundary_faces(&tets));
        assert!((volume(&pos, &tets) - volume(&pos, &tets0)).abs() < 1e-9);
    }
}
