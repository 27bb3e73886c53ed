//! 3D Delaunay tetrahedralization for bubblemesh's volume mesher.
//!
//! Bowyer–Watson insertion (cavity search from the tetrahedron that contains
//! the new point, found by a stochastic visibility walk from the last created
//! tetrahedron), in BRIO + Hilbert order, on flat arrays. Predicates are exact
//! (Shewchuk's adaptive `orient3d`/`insphere` from the `robust` crate) and
//! `insphere == 0` ties are broken by a symbolic perturbation of the lifting
//! map (points ranked lexicographically; see `src/pred.rs`), so degenerate
//! inputs (lattices, cospherical and coplanar sets) give a valid triangulation
//! of the convex hull, and the result (as a set of tets) is the same for every
//! insertion order: it is the unique Delaunay triangulation of the perturbed
//! points.
//!
//! Points of a finished triangulation can be moved ([`Delaunay3::moved`]):
//! the tets are flipped to the Delaunay ones of the new positions (or built
//! anew where flips cannot), the same tets as a new build.
//!
//! Why written here: the `delaunay` crate takes ~56 s for 7,500 points and
//! `spade` is 2D only; the volume mesher needs ≥ 1 M tets/s, incremental
//! Steiner-point insertion and moving points.
//!
//! # Invariants of a [`Tetrahedralization`]
//! - `tets[t]` are indices into the input points; every tet is *positive*:
//!   `(b - a) · ((c - a) × (d - a)) > 0` (right-handed, as in
//!   `bubblemesh_core::mesh`), i.e. `robust::orient3d(a, b, c, d) < 0` in
//!   Shewchuk's sign convention. Never zero volume (checked exactly).
//! - `neighbours[t][i]` is the tet across the face opposite `tets[t][i]`, or
//!   [`HULL`] (`u32::MAX`) on the convex hull; the relation is symmetric.
//! - The union of the tets is the convex hull of the distinct input points;
//!   every distinct point is a vertex; no circumsphere has a point strictly
//!   inside (points *on* a circumsphere are resolved by the perturbation).
//! - `duplicates` lists `(index, kept_index)` for every input point equal to
//!   another, kept one (which copy is kept follows the internal insertion
//!   order); such points are in no tet.
//!
//! Limits: up to 2^30 tetrahedra (≈ 1.6·10^8 points) because neighbour links
//! pack `4 * tet + face` into a `u32`; coordinates must be finite and, for the
//! predicates to stay exact, between about 1e-60 and 1e60 in magnitude (no
//! underflow/overflow of the degree-5 in-sphere products).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod pred;
mod relocate;
mod sort;

pub use relocate::Moved;

use pred::{insph, orient, perturbed_inside};

/// Neighbour value for a face on the convex hull.
pub const HULL: u32 = u32::MAX;

/// Internal id of the vertex at infinity. Hull tets hold it at position 3:
/// the initial ones are built so, and a new tet inherits its vertex positions
/// from a cavity tet with only the vertex opposite the boundary face replaced
/// (a finite face of a hull tet gives a finite new tet), so it stays there.
const INF: u32 = u32::MAX;

/// Whether tet vertices `v` (of a live tet) form a hull tet.
#[inline(always)]
fn is_hull(v: &[u32; 4]) -> bool {
    v[3] == INF
}

/// `OTHER[i][j]`: the two positions of a tet other than `i` and `j`.
const OTHER: [[(usize, usize); 4]; 4] = [
    [(0, 0), (2, 3), (1, 3), (1, 2)],
    [(2, 3), (0, 0), (0, 3), (0, 2)],
    [(1, 3), (0, 3), (0, 0), (0, 1)],
    [(1, 2), (0, 2), (0, 1), (0, 0)],
];
/// Vertex id stored in freed tet slots.
const DEAD: u32 = u32::MAX - 1;
/// "No tet" in the vertex → tet map.
const NONE: u32 = u32::MAX;
/// Largest number of tet slots (neighbour links are `4 * tet + face`).
const MAX_TETS: usize = 1 << 30;
/// Seed of the (deterministic) BRIO shuffle.
const SEED: u64 = 0x5EED_DE1A_0A11;

/// Why a tetrahedralization or an insertion failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DelaunayError {
    /// A 3D tetrahedralization needs at least four points.
    #[error("need at least 4 points for a tetrahedralization, got {0}")]
    TooFewPoints(usize),
    /// All distinct points lie in one plane (or on one line, or coincide).
    #[error(
        "all {0} points are coplanar (or collinear or coincident): no tetrahedron can be formed"
    )]
    Coplanar(usize),
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a non-finite coordinate {point:?}")]
    NonFinite {
        /// Index of the offending point (for `insert`: the index it would have got).
        index: usize,
        /// Its coordinates.
        point: [f64; 3],
    },
    /// `insert` was given a point equal to an existing vertex; nothing changed.
    #[error("point {point:?} duplicates existing vertex {existing}")]
    Duplicate {
        /// The existing vertex with the same coordinates.
        existing: u32,
        /// The rejected coordinates.
        point: [f64; 3],
    },
    /// More points or tetrahedra than the `u32` indices can address.
    #[error("too many points or tetrahedra for 32-bit indices ({0} points)")]
    TooLarge(usize),
}

/// A finished tetrahedralization (finite tets only). See the crate docs for
/// the invariants.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tetrahedralization {
    /// Positive (right-handed) tets, as indices into the input points.
    pub tets: Vec<[u32; 4]>,
    /// `neighbours[t][i]`: tet across the face opposite `tets[t][i]`, or [`HULL`].
    pub neighbours: Vec<[u32; 4]>,
    /// `(duplicate_index, kept_index)` for each skipped duplicate point.
    pub duplicates: Vec<(u32, u32)>,
}

/// Delaunay tetrahedralization of `points` (indices of the output refer to
/// `points`). Duplicates are skipped and reported, not an error.
///
/// Errors: fewer than 4 points, a non-finite coordinate (with its index), all
/// points coplanar.
pub fn tetrahedralize(points: &[[f64; 3]]) -> Result<Tetrahedralization, DelaunayError> {
    Ok(Delaunay3::new(points)?.tetrahedralization())
}

/// An incremental 3D Delaunay triangulation (build with [`Delaunay3::new`],
/// add Steiner points with [`Delaunay3::insert`]).
///
/// Internally it also stores *hull tets*: each hull face plus the vertex at
/// infinity, oriented so that replacing that vertex by any point strictly
/// outside the hull gives a positive tet. They make insertion outside the
/// current hull the same operation as inside, and are never returned.
#[derive(Debug, Clone)]
pub struct Delaunay3 {
    /// Coordinates by *internal* vertex id: the insertion (BRIO + Hilbert)
    /// order, so that spatially close vertices are close in memory (with the
    /// input order, every predicate's point loads were cache misses).
    pts: Vec<[f64; 3]>,
    /// Internal id → caller's id (input index, or the id `insert` returned).
    ext: Vec<u32>,
    /// Caller's id → internal id.
    int: Vec<u32>,
    /// Tet vertex ids (`INF` in hull tets, `[DEAD; 4]` for freed slots).
    tv: Vec<[u32; 4]>,
    /// `tn[t][i] = 4 * u + j`: face `i` of `t` is face `j` of `u`.
    tn: Vec<[u32; 4]>,
    /// Per-tet stamp of the cavity search (`2s` in conflict, `2s+1` not).
    mark: Vec<u32>,
    free: Vec<u32>,
    /// Some live tet incident to each vertex (`NONE` for duplicates). Not
    /// maintained during the batch build of `new` (rebuilt once at its end).
    vtet: Vec<u32>,
    track_vtet: bool,
    dups: Vec<(u32, u32)>,
    n_finite: usize,
    last: u32,
    stamp: u32,
    rng: u64,
    // Scratch reused by every insertion (no per-insertion allocation).
    stack: Vec<u32>,
    cavity: Vec<u32>,
    boundary: Vec<(u32, u32)>,
    newtets: Vec<([u32; 4], u32, u32)>,
    edges: EdgeTable,
}

/// Why `insert_vertex` did nothing.
enum Fail {
    Duplicate(u32),
    TooLarge,
}

enum Located {
    Tet(u32),
    Duplicate(u32),
}

impl Delaunay3 {
    /// Delaunay tetrahedralization of `points`; vertex `i` is `points[i]`.
    /// Points are inserted in BRIO + Hilbert order; duplicates are recorded
    /// (see [`Delaunay3::duplicates`]) and skipped.
    pub fn new(points: &[[f64; 3]]) -> Result<Self, DelaunayError> {
        let n = points.len();
        if n < 4 {
            return Err(DelaunayError::TooFewPoints(n));
        }
        if n > (u32::MAX - 2) as usize {
            return Err(DelaunayError::TooLarge(n));
        }
        if let Some(index) = points
            .iter()
            .position(|p| !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()))
        {
            return Err(DelaunayError::NonFinite {
                index,
                point: points[index],
            });
        }
        let order = sort::brio_hilbert(points, SEED);
        let pts: Vec<[f64; 3]> = order.iter().map(|&i| points[i as usize]).collect();
        let first = initial_tet(&pts).ok_or(DelaunayError::Coplanar(n))?;
        let mut int = vec![0; n];
        for (k, &i) in order.iter().enumerate() {
            int[i as usize] = k as u32;
        }
        let mut d = Delaunay3 {
            pts,
            ext: order,
            int,
            tv: Vec::with_capacity(7 * n),
            tn: Vec::with_capacity(7 * n),
            mark: Vec::with_capacity(7 * n),
            free: Vec::new(),
            vtet: vec![NONE; n],
            track_vtet: false,
            dups: Vec::new(),
            n_finite: 0,
            last: 0,
            stamp: 0,
            rng: SEED,
            stack: Vec::new(),
            cavity: Vec::new(),
            boundary: Vec::new(),
            newtets: Vec::new(),
            edges: EdgeTable::default(),
        };
        d.init(first);
        for i in 0..n as u32 {
            if first.contains(&i) {
                continue;
            }
            match d.insert_vertex(i, d.last) {
                Ok(()) => {}
                Err(Fail::Duplicate(kept)) => {
                    d.dups.push((d.ext[i as usize], d.ext[kept as usize]))
                }
                Err(Fail::TooLarge) => return Err(DelaunayError::TooLarge(n)),
            }
        }
        for (t, v) in d.tv.iter().enumerate() {
            if v[0] != DEAD {
                for &x in v {
                    if x != INF {
                        d.vtet[x as usize] = t as u32;
                    }
                }
            }
        }
        d.track_vtet = true;
        Ok(d)
    }

    /// Inserts one point and returns its vertex id ([`Delaunay3::num_points`]
    /// before the call). `hint` is an existing vertex near `p` (the walk starts
    /// there); `None` starts from the last created tet. Points outside the
    /// current hull are fine.
    ///
    /// Errors: non-finite coordinate; `Duplicate` if `p` equals an existing
    /// vertex (the triangulation is then unchanged); `TooLarge`.
    pub fn insert(&mut self, p: [f64; 3], hint: Option<u32>) -> Result<u32, DelaunayError> {
        let id = self.pts.len();
        if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
            return Err(DelaunayError::NonFinite {
                index: id,
                point: p,
            });
        }
        if id >= (u32::MAX - 2) as usize {
            return Err(DelaunayError::TooLarge(id));
        }
        let start = hint
            .and_then(|h| self.int.get(h as usize))
            .map(|&h| self.vtet[h as usize])
            .filter(|&t| t != NONE)
            .unwrap_or(self.last);
        // Appended ids are the same inside and outside.
        self.pts.push(p);
        self.ext.push(id as u32);
        self.int.push(id as u32);
        self.vtet.push(NONE);
        let r = self.insert_vertex(id as u32, start);
        if r.is_err() {
            self.pts.pop();
            self.ext.pop();
            self.int.pop();
            self.vtet.pop();
        }
        match r {
            Ok(()) => Ok(id as u32),
            Err(Fail::Duplicate(existing)) => Err(DelaunayError::Duplicate {
                existing: self.ext[existing as usize],
                point: p,
            }),
            Err(Fail::TooLarge) => Err(DelaunayError::TooLarge(id)),
        }
    }

    /// Number of points given so far (duplicates included): vertex ids are
    /// `0..num_points()`.
    pub fn num_points(&self) -> usize {
        self.pts.len()
    }

    /// Coordinates of vertex `id` (as given to `new` or `insert`).
    pub fn point(&self, id: u32) -> [f64; 3] {
        self.pts[self.int[id as usize] as usize]
    }

    /// `(duplicate_index, kept_index)` pairs skipped by [`Delaunay3::new`].
    pub fn duplicates(&self) -> &[(u32, u32)] {
        &self.dups
    }

    /// Number of finite tets.
    pub fn num_tets(&self) -> usize {
        self.n_finite
    }

    /// The finite tets (positive orientation), in storage order.
    pub fn tets(&self) -> impl Iterator<Item = [u32; 4]> + '_ {
        self.tv
            .iter()
            .filter(|v| v[0] != DEAD && !v.contains(&INF))
            .map(|v| v.map(|x| self.ext[x as usize]))
    }

    /// Whether the triangle `f` (vertex ids, any order) is a face of some
    /// finite tet. Costs O(number of tets around `f[0]`).
    pub fn has_face(&self, f: [u32; 3]) -> bool {
        let n = self.pts.len() as u32;
        if f.iter().any(|&x| x >= n) || f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
            return false;
        }
        let f = f.map(|x| self.int[x as usize]);
        let t0 = self.vtet[f[0] as usize];
        if t0 == NONE {
            return false;
        }
        // Depth-first search over the tets around vertex f[0].
        let mut seen = vec![t0];
        let mut stack = vec![t0];
        while let Some(t) = stack.pop() {
            let v = self.tv[t as usize];
            if v.contains(&f[1]) && v.contains(&f[2]) {
                // The face is in a hull tet only if it is a hull face, which
                // also belongs to the finite tet across it.
                return true;
            }
            for (j, &vj) in v.iter().enumerate() {
                if vj != f[0] {
                    let u = self.tn[t as usize][j] >> 2;
                    if !seen.contains(&u) {
                        seen.push(u);
                        stack.push(u);
                    }
                }
            }
        }
        false
    }

    /// Compacted copy of the finite tets with neighbours (see the crate docs).
    pub fn tetrahedralization(&self) -> Tetrahedralization {
        let mut map = vec![HULL; self.tv.len()];
        let mut tets = Vec::with_capacity(self.n_finite);
        for (t, v) in self.tv.iter().enumerate() {
            if v[0] != DEAD && !v.contains(&INF) {
                map[t] = tets.len() as u32;
                tets.push(v.map(|x| self.ext[x as usize]));
            }
        }
        let mut neighbours = Vec::with_capacity(tets.len());
        for t in 0..self.tv.len() {
            if map[t] != HULL {
                neighbours.push(self.tn[t].map(|l| map[(l >> 2) as usize]));
            }
        }
        Tetrahedralization {
            tets,
            neighbours,
            duplicates: self.dups.clone(),
        }
    }

    // ---- construction -------------------------------------------------

    /// First positive tet plus its four hull tets, linked.
    fn init(&mut self, first: [u32; 4]) {
        let mut v = first;
        let p = |i: u32| &self.pts[i as usize];
        if orient(p(v[0]), p(v[1]), p(v[2]), p(v[3])) < 0.0 {
            v.swap(0, 1);
        }
        let mut tets = vec![v];
        for i in 0..4 {
            // Replace vertex i by INF and flip: outside points make it positive.
            let mut w = v;
            w[i] = INF;
            w.swap((i + 1) & 3, (i + 2) & 3);
            // Move INF to position 3 by an even permutation (two swaps).
            let k = w.iter().position(|&x| x == INF).unwrap();
            if k != 3 {
                w.swap(k, 3);
                w.swap(0, 1);
            }
            tets.push(w);
        }
        let face = |w: &[u32; 4], i: usize| {
            let mut f = [w[(i + 1) & 3], w[(i + 2) & 3], w[(i + 3) & 3]];
            f.sort_unstable();
            f
        };
        for (t, w) in tets.iter().enumerate() {
            let mut links = [0u32; 4];
            for (i, link) in links.iter_mut().enumerate() {
                let fi = face(w, i);
                let (u, j) = (0..5)
                    .filter(|&u| u != t)
                    .flat_map(|u| (0..4).map(move |j| (u, j)))
                    .find(|&(u, j)| face(&tets[u], j) == fi)
                    .expect("the five initial tets are closed");
                *link = (4 * u + j) as u32;
            }
            self.tv.push(*w);
            self.tn.push(links);
            self.mark.push(0);
        }
        for &x in &v {
            self.vtet[x as usize] = 0;
        }
        self.n_finite = 1;
        self.last = 0;
    }

    /// A tet slot for a new tet: a freed one, else a new one at the end
    /// (its contents are the caller's to write).
    fn new_slot(&mut self) -> u32 {
        self.free.pop().unwrap_or_else(|| {
            self.tv.push([DEAD; 4]);
            self.tn.push([0; 4]);
            self.mark.push(0);
            (self.tv.len() - 1) as u32
        })
    }

    #[inline(always)]
    fn pt(&self, v: u32) -> &[f64; 3] {
        &self.pts[v as usize]
    }

    /// Orientation of tet `v` with vertex `i` replaced by `p` (see
    /// [`orient_replaced`]).
    #[inline(always)]
    fn orient_replaced(&self, v: &[u32; 4], i: usize, p: &[f64; 3]) -> f64 {
        orient_replaced(&self.pts, v, i, p)
    }

    /// Finds a tet in conflict with `p`: a finite tet whose closure contains
    /// `p`, or a hull tet whose hull face `p` sees strictly. Or the vertex
    /// equal to `p`.
    fn locate(&mut self, p: &[f64; 3], start: u32) -> Located {
        let (pts, tv, tn) = (&self.pts[..], &self.tv[..], &self.tn[..]);
        let mut t = start;
        if is_hull(&tv[t as usize]) {
            if orient_replaced(pts, &tv[t as usize], 3, p) > 0.0 {
                return Located::Tet(t);
            }
            t = tn[t as usize][3] >> 2;
        }
        let mut prev = NONE;
        let mut rng = self.rng;
        // A visibility walk in a (perturbed) Delaunay triangulation cannot
        // cycle (Edelsbrunner's acyclicity theorem) and the random face order
        // makes it terminate on any triangulation with probability 1; the
        // step cap is a guard that falls back to a scan.
        let cap = 64 + 4 * tv.len();
        let mut found = None;
        'walk: for _ in 0..cap {
            let v = tv[t as usize];
            let n = tn[t as usize];
            // xorshift64: only used to randomise the walk's face order.
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            let r = rng as usize;
            for s in 0..4 {
                let i = (r + s) & 3;
                let u = n[i] >> 2;
                if u == prev {
                    continue;
                }
                if orient_replaced(pts, &v, i, p) < 0.0 {
                    prev = t;
                    t = u;
                    if is_hull(&tv[t as usize]) {
                        found = Some(Located::Tet(t));
                        break 'walk;
                    }
                    continue 'walk;
                }
            }
            found = Some(self.closed_tet(t, p));
            break;
        }
        self.rng = rng;
        found.unwrap_or_else(|| self.locate_by_scan(p))
    }

    fn closed_tet(&self, t: u32, p: &[f64; 3]) -> Located {
        for &x in &self.tv[t as usize] {
            if self.pt(x) == p {
                return Located::Duplicate(x);
            }
        }
        Located::Tet(t)
    }

    /// O(n) fallback of `locate`.
    fn locate_by_scan(&self, p: &[f64; 3]) -> Located {
        for (t, v) in self.tv.iter().enumerate() {
            if v[0] != DEAD && !is_hull(v) && (0..4).all(|i| self.orient_replaced(v, i, p) >= 0.0) {
                return self.closed_tet(t as u32, p);
            }
        }
        for (t, v) in self.tv.iter().enumerate() {
            if v[0] != DEAD && is_hull(v) && self.orient_replaced(v, 3, p) > 0.0 {
                return Located::Tet(t as u32);
            }
        }
        unreachable!("a point is inside the hull or sees a hull face")
    }

    /// Bowyer–Watson insertion of vertex `pid` (already in `pts`); walk from
    /// tet `start`. Fails (changing nothing) if it duplicates a vertex or
    /// the tets would no longer fit the `4 * tet + face` links.
    fn insert_vertex(&mut self, pid: u32, start: u32) -> Result<(), Fail> {
        let p = self.pts[pid as usize];
        let t0 = match self.locate(&p, start) {
            Located::Duplicate(x) => return Err(Fail::Duplicate(x)),
            Located::Tet(t) => t,
        };
        debug_assert!(conflict(&self.pts, &self.tv, &self.tn, t0, pid, &p));
        if self.stamp >= (u32::MAX >> 1) - 1 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.stamp = 0;
        }
        self.stamp += 1;
        let (inside, outside) = (2 * self.stamp, 2 * self.stamp + 1);

        // Cavity: the connected set of tets in conflict (star-shaped from p).
        // Local slices: the compiler then keeps their bounds in registers.
        {
            let (pts, tv, tn) = (&self.pts[..], &self.tv[..], &self.tn[..]);
            let mark = &mut self.mark[..];
            let (cavity, boundary, stack) = (&mut self.cavity, &mut self.boundary, &mut self.stack);
            cavity.clear();
            boundary.clear();
            stack.clear();
            mark[t0 as usize] = inside;
            cavity.push(t0);
            stack.push(t0);
            while let Some(t) = stack.pop() {
                let n = tn[t as usize];
                for (i, &l) in n.iter().enumerate() {
                    let u = l >> 2;
                    let m = mark[u as usize];
                    if m == inside {
                        continue;
                    }
                    if m != outside && conflict(pts, tv, tn, u, pid, &p) {
                        mark[u as usize] = inside;
                        cavity.push(u);
                        stack.push(u);
                    } else {
                        mark[u as usize] = outside;
                        boundary.push((t, i as u32));
                    }
                }
            }
        }

        // New tets: each boundary face joined to p (p replaces the vertex
        // opposite the face, which keeps the orientation since p and that
        // vertex are on the same side of the face). Slots: the cavity's,
        // then freed ones, then new ones.
        if self.tv.len() + self.boundary.len() > MAX_TETS {
            return Err(Fail::TooLarge);
        }
        self.newtets.clear();
        for k in 0..self.boundary.len() {
            let (t, i) = self.boundary[k];
            let mut v = self.tv[t as usize];
            v[i as usize] = pid;
            let id = if self.newtets.len() < self.cavity.len() {
                self.cavity[self.newtets.len()]
            } else {
                self.new_slot()
            };
            self.newtets.push((v, i, id));
        }
        let reused = self.newtets.len().min(self.cavity.len());
        for &t in &self.cavity {
            if !is_hull(&self.tv[t as usize]) {
                self.n_finite -= 1;
            }
        }
        // Outer links are read before any slot is overwritten.
        for k in 0..self.newtets.len() {
            let (t, i) = self.boundary[k];
            self.boundary[k].0 = self.tn[t as usize][i as usize];
        }
        self.edges.reset(self.newtets.len());
        let (tv, tn, vtet) = (&mut self.tv[..], &mut self.tn[..], &mut self.vtet[..]);
        let mark = &mut self.mark[..];
        let track = self.track_vtet;
        let mut last = self.last;
        for (k, &(v, i, id)) in self.newtets.iter().enumerate() {
            let outer = self.boundary[k].0;
            let idx = id as usize;
            tv[idx] = v;
            mark[idx] = 0;
            tn[idx][i as usize] = outer;
            tn[(outer >> 2) as usize][(outer & 3) as usize] = 4 * id + i;
            let finite = !is_hull(&v);
            if finite {
                self.n_finite += 1;
                last = id;
            }
            for (j, &(a, b)) in OTHER[i as usize].iter().enumerate() {
                if j == i as usize {
                    continue;
                }
                // Face j = p + the edge (v[a], v[b]) of the boundary face.
                let (a, b) = (v[a], v[b]);
                let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
                if let Some(l) = self.edges.pair(key, 4 * id + j as u32) {
                    tn[idx][j] = l;
                    tn[(l >> 2) as usize][(l & 3) as usize] = 4 * id + j as u32;
                }
            }
            if track {
                for &x in &v {
                    if x != INF {
                        vtet[x as usize] = id;
                    }
                }
            }
        }
        self.last = last;
        for &t in &self.cavity[reused..] {
            self.tv[t as usize] = [DEAD; 4];
            self.free.push(t);
        }
        Ok(())
    }
}

/// Orientation of tet `v` with vertex `i` replaced by `p` (`v` finite
/// except possibly at `i`): `> 0` iff `p` is on the same side of face `i` as
/// a point that makes `v` positive.
#[inline(always)]
fn orient_replaced(pts: &[[f64; 3]], v: &[u32; 4], i: usize, p: &[f64; 3]) -> f64 {
    let q = |k: usize| if k == i { p } else { &pts[v[k] as usize] };
    orient(q(0), q(1), q(2), q(3))
}

/// Whether point `p` (vertex id `pid`) is in conflict with tet `t`: inside
/// its perturbed circumball, or for a hull tet: strictly beyond the hull
/// face, or in the face's plane and inside its perturbed circumcircle.
#[inline(always)]
fn conflict(
    pts: &[[f64; 3]],
    tv: &[[u32; 4]],
    tn: &[[u32; 4]],
    t: u32,
    pid: u32,
    p: &[f64; 3],
) -> bool {
    let v = tv[t as usize];
    if is_hull(&v) {
        let o = orient_replaced(pts, &v, 3, p);
        if o != 0.0 {
            return o > 0.0;
        }
        // p is in the plane of the hull face: inside its circumcircle iff
        // inside the sphere through the face and any point off the plane,
        // e.g. the vertex d across the face (the tet is then negative).
        let l = tn[t as usize][3];
        let d = tv[(l >> 2) as usize][(l & 3) as usize];
        let mut w = v;
        w[3] = d;
        let q = |k: usize| &pts[w[k] as usize];
        let s = insph(q(0), q(1), q(2), q(3), p);
        if s != 0.0 {
            return s < 0.0;
        }
        return perturbed_inside(pts, w, -1.0, pid);
    }
    let q = |k: usize| &pts[v[k] as usize];
    let s = insph(q(0), q(1), q(2), q(3), p);
    if s != 0.0 {
        return s > 0.0;
    }
    perturbed_inside(pts, v, 1.0, pid)
}

/// First four affinely independent points of `pts` (as ids), or `None` if all
/// points are coplanar (exact tests).
fn initial_tet(pts: &[[f64; 3]]) -> Option<[u32; 4]> {
    let p = |i: u32| &pts[i as usize];
    let order: Vec<u32> = (0..pts.len() as u32).collect();
    let a = order[0];
    let b = *order.iter().find(|&&i| p(i) != p(a))?;
    let collinear = |i: u32| {
        use robust::{orient2d, Coord};
        let (x, y, z) = (p(a), p(b), p(i));
        (0..3).all(|k| {
            let (u, w) = (k, (k + 1) % 3);
            let c = |q: &[f64; 3]| Coord { x: q[u], y: q[w] };
            orient2d(c(x), c(y), c(z)) == 0.0
        })
    };
    let c = *order.iter().find(|&&i| !collinear(i))?;
    let d = *order
        .iter()
        .find(|&&i| orient(p(a), p(b), p(c), p(i)) != 0.0)?;
    Some([a, b, c, d])
}

/// Open-addressing map from cavity-boundary edges to the new-tet face that
/// first claimed them; cleared in O(1) per insertion by a generation counter.
/// Why not `HashMap`: it would be cleared (or reallocated) on every insertion
/// and hashes with SipHash; this is one cache-friendly array.
#[derive(Debug, Clone, Default)]
struct EdgeTable {
    /// `(key, generation, value)`.
    slots: Vec<(u64, u32, u32)>,
    gen: u32,
    shift: u32,
}

impl EdgeTable {
    /// Prepares for a cavity with `faces` boundary faces (3·faces/2 edges).
    fn reset(&mut self, faces: usize) {
        let need = (faces * 6).next_power_of_two().max(256);
        if need > self.slots.len() {
            self.slots = vec![(0, 0, 0); need];
            self.gen = 0;
            self.shift = 64 - need.trailing_zeros();
        }
        self.gen = self.gen.wrapping_add(1);
        if self.gen == 0 {
            self.slots.iter_mut().for_each(|s| s.1 = 0);
            self.gen = 1;
        }
    }

    /// If `key` was stored in this generation, returns its value; otherwise
    /// stores `val` under it.
    #[inline]
    fn pair(&mut self, key: u64, val: u32) -> Option<u32> {
        let mask = self.slots.len() - 1;
        let mut h = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> self.shift) as usize;
        loop {
            let s = &mut self.slots[h];
            if s.1 != self.gen {
                *s = (key, self.gen, val);
                return None;
            }
            if s.0 == key {
                return Some(s.2);
            }
            h = (h + 1) & mask;
        }
    }
}
