//! Moving points of a finished triangulation: the tets are kept and turned by
//! flips until every face is locally Delaunay again, instead of a new
//! tetrahedralization of all points.
//!
//! Why: smoothing passes (optimal-Delaunay smoothing in the volume mesher)
//! move every free node by a small fraction of its spacing and need the
//! Delaunay tetrahedralization of the new positions, twenty times over. Most
//! tets survive such a move; checking each face once and flipping the few
//! that are no longer Delaunay costs a fraction of a rebuild.
//!
//! How (Lawson's flips in 3D, Joe 1989; Edelsbrunner & Shah 1996):
//! 1. the vertices move; the moves of a tet's vertices that turn it inside
//!    out (or flat) are taken back, and of the tets that this turns in turn,
//!    until every tet is positive; a moved vertex on the convex hull sends
//!    the whole to a new build;
//! 2. every face with a moved vertex among its tets' five is checked with
//!    the perturbed in-sphere test of the batch build, and each face that
//!    fails is flipped: 2→3 where the segment between the two apexes crosses
//!    the face, 3→2 where it passes beside one edge shared by exactly three
//!    tets; the new tets' faces are checked in turn. A face that no flip can
//!    turn yet (the segment passes beside two edges, or through an edge's
//!    plane exactly) is retried after the others;
//! 3. the triangulation is now Delaunay; each vertex left behind in step 1 is
//!    taken out (its star filled with the Delaunay tets of its link, see
//!    `remove_vertex`) and inserted at its new position as in the batch
//!    build.
//!
//! Each flip lowers the lifted (perturbed) triangulation, so the flips end.
//! A triangulation whose faces are all locally Delaunay is the Delaunay
//! triangulation (Delaunay's lemma), unique under the symbolic
//! perturbation: where this succeeds, the tets are exactly those of a new
//! build. Where it cannot (a moved hull vertex, a face no flip turns, a
//! star whose fill does not match), [`Delaunay3::moved`] builds anew.
//!
//! Measured (optimal-Delaunay smoothing of block_holes at d = 0.8, 40,710
//! points, 20 iterations): 19 of 20 iterations kept their tets with 10 to
//! 1,251 flips and 0 to 93 vertices inserted again, each equal to a new
//! build's tets; the smoothing took 1.44 s instead of 3.33 s.

use crate::pred::orient;
use crate::{conflict, is_hull, Delaunay3, DelaunayError, DEAD, INF, NONE};

/// How [`Delaunay3::moved`] reached the new positions' triangulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Moved {
    /// The tets were kept: `flips` flips turned them Delaunay, and
    /// `reinserted` vertices, whose move would have turned a tet inside
    /// out, were taken out and inserted again at their new position.
    Kept {
        /// Flips done.
        flips: usize,
        /// Vertices taken out and inserted again.
        reinserted: usize,
    },
    /// The flips could not (see the module docs): a new build.
    Rebuilt,
}

/// Flips per point at most before giving up (a guard: each flip lowers the
/// lifted triangulation, so they end anyway; a small move needs a handful).
const MAX_FLIPS_PER_POINT: usize = 64;

impl Delaunay3 {
    /// The Delaunay tetrahedralization of `points`, the same number of points
    /// as this triangulation's (vertex `i` at `points[i]`), from this one by
    /// flips where the points moved little, else built anew. Either way the
    /// tets are those of `Delaunay3::new(points)` (as a set), and vertex ids
    /// are the same.
    ///
    /// Errors: those of [`Delaunay3::new`] (a non-finite coordinate, all
    /// points coplanar, …) where a new build is needed.
    pub fn moved(mut self, points: &[[f64; 3]]) -> Result<(Self, Moved), DelaunayError> {
        match self.relocate(points) {
            Some((flips, reinserted)) => Ok((self, Moved::Kept { flips, reinserted })),
            None => Ok((Delaunay3::new(points)?, Moved::Rebuilt)),
        }
    }

    /// Moves the points and flips; `None` (with `self` spoiled) where a new
    /// build is needed.
    fn relocate(&mut self, points: &[[f64; 3]]) -> Option<(usize, usize)> {
        let n = self.pts.len();
        if points.len() != n || !self.dups.is_empty() {
            return None;
        }
        let mut moved = vec![false; n];
        let mut any = false;
        for (e, p) in points.iter().enumerate() {
            if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
                return None;
            }
            let i = self.int[e] as usize;
            if self.pts[i] != *p {
                moved[i] = true;
                any = true;
            }
        }
        if !any {
            return Some((0, 0));
        }
        // Move them all, then take back the moves of the vertices of every
        // tet turned inside out (or flat), and of the tets that this turns
        // in turn, until every tet is positive: in the end each tet has its
        // vertices where it was valid or where it was checked.
        let old = self.pts.clone();
        for (i, m) in moved.iter().enumerate() {
            if *m {
                self.pts[i] = points[self.ext[i] as usize];
            }
        }
        let touches =
            |v: &[u32; 4], moved: &[bool]| v.iter().any(|&x| x != INF && moved[x as usize]);
        let mut back: Vec<u32> = Vec::new();
        for v in self
            .tv
            .iter()
            .filter(|v| v[0] != DEAD && touches(v, &moved))
        {
            if is_hull(v) {
                return None;
            }
            if !self.positive(v) {
                back.extend(v.iter().filter(|&&x| moved[x as usize]));
            }
        }
        let mut deferred = Vec::new();
        let mut star = Vec::new();
        while let Some(x) = back.pop() {
            if !moved[x as usize] {
                continue;
            }
            moved[x as usize] = false;
            self.pts[x as usize] = old[x as usize];
            deferred.push(x);
            self.star_of(x, &mut star);
            for &t in &star {
                let v = &self.tv[t as usize];
                if !self.positive(v) {
                    back.extend(v.iter().filter(|&&y| moved[y as usize]));
                }
            }
        }
        deferred.sort_unstable();
        // The faces that are no longer locally Delaunay, each once: from its
        // lower tet, or from the only one of its two tets that touches a
        // moved vertex.
        let mut queue: Vec<(u32, u8)> = Vec::new();
        for (t, v) in self.tv.iter().enumerate() {
            if v[0] == DEAD || is_hull(v) || !touches(v, &moved) {
                continue;
            }
            for (i, &l) in self.tn[t].iter().enumerate() {
                let u = (l >> 2) as usize;
                if u > t && touches(&self.tv[u], &moved) {
                    continue;
                }
                if !self.locally_delaunay(t as u32, i) {
                    queue.push((t as u32, i as u8));
                }
            }
        }
        let cap = MAX_FLIPS_PER_POINT * n + 1000;
        let mut flips = 0;
        let mut stuck: Vec<(u32, u8)> = Vec::new();
        loop {
            let before = flips;
            while let Some((t, i)) = queue.pop() {
                if self.tv[t as usize][0] == DEAD || self.locally_delaunay(t, i as usize) {
                    continue;
                }
                if self.flip(t, i as usize, &mut queue) {
                    flips += 1;
                    if flips > cap {
                        return None;
                    }
                } else {
                    stuck.push((t, i));
                }
            }
            // Faces no flip could turn: retried while flips since their
            // last try changed their neighbourhoods; given up when none did.
            if stuck.is_empty() || flips == before {
                break;
            }
            queue.append(&mut stuck);
        }
        if !stuck.is_empty() {
            return None;
        }
        // The vertices that could not move in place: taken out (the
        // triangulation stays Delaunay) and inserted at their new position.
        for &x in &deferred {
            let start = self.remove_vertex(x)?;
            self.pts[x as usize] = points[self.ext[x as usize] as usize];
            self.insert_vertex(x, start).ok()?;
        }
        self.last = (0..self.tv.len() as u32)
            .find(|&t| self.tv[t as usize][0] != DEAD && !is_hull(&self.tv[t as usize]))
            .unwrap_or(0);
        Some((flips, deferred.len()))
    }

    /// Takes vertex `x` out of the (Delaunay) triangulation: its star is
    /// filled with the tets of the Delaunay tetrahedralization of its link's
    /// vertices that lie inside the star, which is the Delaunay
    /// triangulation of the remaining points there (Devillers 2002, "On
    /// deletion in Delaunay triangulations"). Returns a tet of the fill, or
    /// `None` (nothing changed) where `x` is on the hull, a duplicate, or the
    /// fill does not match the star's boundary.
    fn remove_vertex(&mut self, x: u32) -> Option<u32> {
        if self.vtet[x as usize] == NONE {
            return None;
        }
        let mut star = Vec::new();
        self.star_of(x, &mut star);
        if star.iter().any(|&t| is_hull(&self.tv[t as usize])) {
            return None;
        }
        // The star's boundary: each star tet's face opposite x.
        let mut link: Vec<u32> = Vec::with_capacity(3 * star.len());
        let mut boundary: Vec<[u32; 3]> = Vec::with_capacity(star.len());
        for &t in &star {
            let v = self.tv[t as usize];
            let jx = v.iter().position(|&y| y == x)?;
            boundary.push(face_key(&v, jx));
            link.extend(v.iter().filter(|&&y| y != x));
        }
        link.sort_unstable();
        link.dedup();
        let coords: Vec<[f64; 3]> = link.iter().map(|&y| self.pts[y as usize]).collect();
        let local = Delaunay3::new(&coords).ok()?.tetrahedralization();
        let global = |t: &[u32; 4]| t.map(|y| link[y as usize]);
        let xp = self.pts[x as usize];
        // Seeds: the local tets on x's side of a boundary face.
        let mut inner = vec![false; local.tets.len()];
        let mut stack = Vec::new();
        for (lt, t) in local.tets.iter().enumerate() {
            let g = global(t);
            for f in 0..4 {
                let key = face_key(&g, f);
                if !boundary.contains(&key) {
                    continue;
                }
                let [a, b, c] = key.map(|y| &self.pts[y as usize]);
                let apex = &self.pts[g[f] as usize];
                if (orient(a, b, c, apex) > 0.0) == (orient(a, b, c, &xp) > 0.0) && !inner[lt] {
                    inner[lt] = true;
                    stack.push(lt);
                }
            }
        }
        // Flood through the faces that are not on the star's boundary.
        while let Some(lt) = stack.pop() {
            let g = global(&local.tets[lt]);
            for f in 0..4 {
                if boundary.contains(&face_key(&g, f)) {
                    continue;
                }
                let u = local.neighbours[lt][f];
                if u == crate::HULL {
                    return None;
                }
                if !inner[u as usize] {
                    inner[u as usize] = true;
                    stack.push(u as usize);
                }
            }
        }
        let fill: Vec<[u32; 4]> = (0..local.tets.len())
            .filter(|&lt| inner[lt])
            .map(|lt| global(&local.tets[lt]))
            .collect();
        // The fill's own boundary must be the star's, face for face.
        let mut faces: Vec<[u32; 3]> = fill
            .iter()
            .flat_map(|t| (0..4).map(move |f| face_key(t, f)))
            .collect();
        faces.sort_unstable();
        let mut once: Vec<[u32; 3]> = Vec::new();
        let mut i = 0;
        while i < faces.len() {
            let mut j = i + 1;
            while j < faces.len() && faces[j] == faces[i] {
                j += 1;
            }
            match j - i {
                1 => once.push(faces[i]),
                2 => {}
                _ => return None,
            }
            i = j;
        }
        let mut want = boundary.clone();
        want.sort_unstable();
        if once != want {
            return None;
        }
        let first = self.replace(&star, &fill, None)?;
        self.vtet[x as usize] = NONE;
        Some(first)
    }

    /// Whether the finite tet `v` is positive at the current positions.
    fn positive(&self, v: &[u32; 4]) -> bool {
        let p = |k: usize| &self.pts[v[k] as usize];
        orient(p(0), p(1), p(2), p(3)) > 0.0
    }

    /// The tets around vertex `x` (a depth-first walk from `vtet[x]` across
    /// the faces that hold `x`), into `out`.
    fn star_of(&self, x: u32, out: &mut Vec<u32>) {
        out.clear();
        out.push(self.vtet[x as usize]);
        let mut k = 0;
        while k < out.len() {
            let t = out[k] as usize;
            k += 1;
            for (j, &vj) in self.tv[t].iter().enumerate() {
                let u = self.tn[t][j] >> 2;
                if vj != x && !out.contains(&u) {
                    out.push(u);
                }
            }
        }
    }

    /// Whether face `i` of live tet `t` is locally Delaunay: the apex across
    /// it is not in conflict with `t` (perturbed test, so the answer is the
    /// same from both sides). Faces of hull tets always are: the hull's
    /// vertices did not move.
    fn locally_delaunay(&self, t: u32, i: usize) -> bool {
        let l = self.tn[t as usize][i];
        let (u, j) = (l >> 2, (l & 3) as usize);
        if is_hull(&self.tv[t as usize]) || is_hull(&self.tv[u as usize]) {
            return true;
        }
        let q = self.tv[u as usize][j];
        !conflict(&self.pts, &self.tv, &self.tn, t, q, &self.pts[q as usize])
    }

    /// Flips face `i` of tet `t` (2→3 or 3→2, module docs) and queues the
    /// new tets' faces; `false` (nothing changed) where neither applies.
    fn flip(&mut self, t: u32, i: usize, queue: &mut Vec<(u32, u8)>) -> bool {
        let v = self.tv[t as usize];
        let l = self.tn[t as usize][i];
        let (u, j) = (l >> 2, (l & 3) as usize);
        let (p, q) = (v[i], self.tv[u as usize][j]);
        let pt = |x: u32| &self.pts[x as usize];
        // For each face vertex c (position k in t), the edge opposite it in
        // the face, and which side of the plane (edge, p) q is on.
        let mut reflex = None;
        for k in (0..4).filter(|&k| k != i) {
            let (a, b) = other_two(i, k);
            let (a, b, c) = (v[a], v[b], v[k]);
            let sc = orient(pt(a), pt(b), pt(p), pt(c));
            let sq = orient(pt(a), pt(b), pt(p), pt(q));
            if sq == 0.0 {
                return false;
            }
            if (sq > 0.0) != (sc > 0.0) {
                if reflex.is_some() {
                    return false;
                }
                reflex = Some(k);
            }
        }
        match reflex {
            None => {
                // 2→3: the three tets around the segment pq.
                let f: Vec<u32> = (0..4).filter(|&k| k != i).map(|k| v[k]).collect();
                let new = [[f[0], f[1], p, q], [f[1], f[2], p, q], [f[2], f[0], p, q]];
                self.replace(&[t, u], &new, Some(queue)).is_some()
            }
            Some(k) => {
                // 3→2 around the edge (a, b) opposite c: the third tet is
                // t's neighbour across (a, b, p), and must hold q and be u's
                // neighbour across (a, b, q).
                let c = v[k];
                let w = self.tn[t as usize][k] >> 2;
                let wv = self.tv[w as usize];
                if is_hull(&wv) || !wv.contains(&q) {
                    return false;
                }
                let Some(kc) = self.tv[u as usize].iter().position(|&x| x == c) else {
                    return false;
                };
                if self.tn[u as usize][kc] >> 2 != w {
                    return false;
                }
                let (a, b) = other_two(i, k);
                let (a, b) = (v[a], v[b]);
                self.replace(&[t, u, w], &[[p, q, c, a], [p, q, c, b]], Some(queue))
                    .is_some()
            }
        }
    }

    /// Replaces the tets `old` by `new` (the same polyhedron; vertex order
    /// of `new` free, oriented here), links them to the outside and to each
    /// other, and queues every face of the new tets. Returns the first new
    /// tet, or `None` (nothing changed) if a new tet would be flat.
    fn replace(
        &mut self,
        old: &[u32],
        new: &[[u32; 4]],
        mut queue: Option<&mut Vec<(u32, u8)>>,
    ) -> Option<u32> {
        let mut tets = Vec::with_capacity(new.len());
        for &w in new {
            let p = |k: usize| &self.pts[w[k] as usize];
            let o = orient(p(0), p(1), p(2), p(3));
            if o == 0.0 {
                return None;
            }
            let mut w = w;
            if o < 0.0 {
                w.swap(0, 1);
            }
            tets.push(w);
        }
        // The outer faces of the old tets, by sorted vertex triple.
        let mut outer: Vec<([u32; 3], u32)> = Vec::with_capacity(2 * old.len() + 2);
        for &o in old {
            for (k, &l) in self.tn[o as usize].iter().enumerate() {
                if !old.contains(&(l >> 2)) {
                    outer.push((face_key(&self.tv[o as usize], k), l));
                }
            }
        }
        let ids: Vec<u32> = (0..tets.len())
            .map(|k| old.get(k).copied().unwrap_or_else(|| self.new_slot()))
            .collect();
        for &o in &old[tets.len().min(old.len())..] {
            self.tv[o as usize] = [DEAD; 4];
            self.free.push(o);
        }
        // Faces between two new tets wait here for their second tet.
        let mut open: Vec<([u32; 3], u32)> = Vec::new();
        for (&id, w) in ids.iter().zip(&tets) {
            self.tv[id as usize] = *w;
            self.mark[id as usize] = 0;
            for k in 0..4 {
                let key = face_key(w, k);
                let here = 4 * id + k as u32;
                let link = if let Some(&(_, l)) = outer.iter().find(|(f, _)| *f == key) {
                    l
                } else if let Some(m) = open.iter().position(|(f, _)| *f == key) {
                    open.swap_remove(m).1
                } else {
                    open.push((key, here));
                    continue;
                };
                self.tn[id as usize][k] = link;
                self.tn[(link >> 2) as usize][(link & 3) as usize] = here;
            }
            for &x in w {
                self.vtet[x as usize] = id;
            }
            if let Some(q) = queue.as_deref_mut() {
                q.extend((0..4).map(|k| (id, k as u8)));
            }
        }
        debug_assert!(
            open.is_empty(),
            "the new tets fill the old ones' polyhedron"
        );
        self.n_finite = self.n_finite + tets.len() - old.len();
        Some(ids[0])
    }
}

/// The two positions of a tet other than `i` and `k`.
fn other_two(i: usize, k: usize) -> (usize, usize) {
    crate::OTHER[i][k]
}

/// Sorted vertex ids of face `k` of tet `v`.
fn face_key(v: &[u32; 4], k: usize) -> [u32; 3] {
    let mut f = [v[(k + 1) & 3], v[(k + 2) & 3], v[(k + 3) & 3]];
    f.sort_unstable();
    f
}
