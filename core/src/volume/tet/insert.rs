//! Insertion of a free node into a finished tetrahedral mesh by a
//! Bowyer–Watson cavity that stops at the volume's boundary faces (not in
//! the thesis; Bowyer 1981, Watson 1981, the cavity bounded as in
//! constrained Delaunay refinement, Shewchuk 1998).
//!
//! Why: the Steiner points of [`super::steiner`] are added by connecting
//! every node again, and the boundary recovery then removes each free node
//! inside the diametral sphere of a boundary triangle. In a wall thinner
//! than about a spacing every interior point is in such a sphere, so the
//! slivers among its boundary nodes (a flat rectangle across a rib, a
//! tetrahedron on a needle of a face the geometry makes thin) never get
//! their point. Inserted here, the point stays: the cavity never crosses a
//! boundary face, so the boundary triangles stay faces of the mesh whatever
//! the circumspheres.
//!
//! Invariants: every tetrahedron stays positively oriented (exact
//! `orient3d`), the union of the tetrahedra and the boundary faces are
//! unchanged, and an insertion that cannot keep both is not made.

use super::mesh::TetMesh;
use crate::geom::P3;
use crate::measure::{c3, orient3d, sorted3, tet_volume6, TET_FACES};
use rustc_hash::{FxHashMap, FxHashSet};

/// A tetrahedral mesh with its face → tetrahedra table, for a series of
/// insertions. Removed tetrahedra are marked dead and dropped by
/// [`Inserter::finish`].
pub(crate) struct Inserter<'a> {
    mesh: &'a mut TetMesh,
    dead: Vec<bool>,
    /// Sorted face → the (one or two) live tetrahedra that have it.
    faces: FxHashMap<[u32; 3], [u32; 2]>,
}

const NONE: u32 = u32::MAX;

/// Whether `p` lies strictly inside the circumsphere of the positive
/// tetrahedron `t` (exact `insphere`; its sign flips with the orientation,
/// and a positive tetrahedron has `orient3d` < 0).
fn in_sphere(pos: &[P3], t: &[u32; 4], p: &P3) -> bool {
    let q = t.map(|k| c3(&pos[k as usize]));
    robust::insphere(q[0], q[1], q[2], q[3], c3(p)) < 0.0
}

/// `t` with corner `i` replaced by `p`'s index `n`.
fn with_corner(t: &[u32; 4], i: usize, n: u32) -> [u32; 4] {
    let mut u = *t;
    u[i] = n;
    u
}

impl<'a> Inserter<'a> {
    pub(crate) fn new(mesh: &'a mut TetMesh) -> Self {
        let mut faces: FxHashMap<[u32; 3], [u32; 2]> = FxHashMap::default();
        for (i, t) in mesh.tets.iter().enumerate() {
            for f in TET_FACES {
                let e = faces.entry(sorted3(f.map(|k| t[k]))).or_insert([NONE; 2]);
                e[usize::from(e[0] != NONE)] = i as u32;
            }
        }
        Inserter {
            dead: vec![false; mesh.tets.len()],
            mesh,
            faces,
        }
    }

    /// Tetrahedron `t`, if no insertion has removed it.
    #[cfg(test)]
    fn live(&self, t: usize) -> Option<[u32; 4]> {
        (!self.dead[t]).then(|| self.mesh.tets[t])
    }

    /// The tetrahedron across face `k` of tetrahedron `t`, if any.
    fn across(&self, t: usize, k: usize) -> Option<usize> {
        let tet = &self.mesh.tets[t];
        let f = sorted3(TET_FACES[k].map(|i| tet[i]));
        let [a, b] = self.faces[&f];
        let o = if a as usize == t { b } else { a };
        (o != NONE).then_some(o as usize)
    }

    /// The live tetrahedron containing `p` (in it or on its boundary),
    /// walking from `from`; `None` when the walk leaves the mesh.
    fn locate(&self, from: usize, p: &P3) -> Option<usize> {
        let pos = &self.mesh.pos;
        let mut t = from;
        // a visibility walk: at most one step per tetrahedron in practice;
        // the bound only guards against cycling on degenerate input
        for _ in 0..self.mesh.tets.len().min(100_000) {
            let tet = self.mesh.tets[t];
            let p4 = tet.map(|k| pos[k as usize]);
            // face k is opposite corner k; p is beyond it when the
            // tetrahedron with p for corner k is negative
            let next = (0..4).find(|&k| {
                let mut q = p4;
                q[k] = *p;
                orient3d(&q[0], &q[1], &q[2], &q[3]) > 0.0
            });
            match next {
                None => return Some(t),
                Some(k) => t = self.across(t, k)?,
            }
        }
        None
    }

    /// Inserts a free node at `p` with spacing `d`, starting the search at
    /// the live tetrahedron `near`. Returns its index, or `None` (the mesh
    /// unchanged) when `p` is outside the mesh, on a boundary face, or no
    /// cavity around it keeps every new tetrahedron positive.
    pub(crate) fn insert(&mut self, near: usize, p: P3, d: f64) -> Option<u32> {
        if self.dead[near] {
            return None;
        }
        let start = self.locate(near, &p)?;
        let pos = &self.mesh.pos;
        // the cavity: tetrahedra reached across inner faces whose
        // circumspheres hold p
        let mut cavity: Vec<usize> = vec![start];
        let mut inside: FxHashSet<usize> = [start].into_iter().collect();
        let mut k = 0;
        while k < cavity.len() {
            let t = cavity[k];
            k += 1;
            for f in 0..4 {
                if let Some(o) = self.across(t, f) {
                    if !inside.contains(&o) && in_sphere(pos, &self.mesh.tets[o], &p) {
                        inside.insert(o);
                        cavity.push(o);
                    }
                }
            }
        }
        let n = pos.len() as u32;
        // shrink until p sees every face of the cavity's boundary from
        // inside: a tetrahedron behind a face p does not see leaves it
        let new = loop {
            let mut new: Vec<[u32; 4]> = Vec::new();
            let mut behind = None;
            'cavity: for &t in &cavity {
                for f in 0..4 {
                    let o = self.across(t, f);
                    if o.is_some_and(|o| inside.contains(&o)) {
                        continue;
                    }
                    let u = with_corner(&self.mesh.tets[t], f, n);
                    let q = u.map(|k| if k == n { p } else { pos[k as usize] });
                    if orient3d(&q[0], &q[1], &q[2], &q[3]) >= 0.0 {
                        behind = Some(t);
                        break 'cavity;
                    }
                    new.push(u);
                }
            }
            match behind {
                None => break new,
                Some(t) if t == start => return None,
                Some(t) => {
                    inside.remove(&t);
                    cavity.retain(|&c| c != t);
                }
            }
        };
        // the new tetrahedra must fill the cavity exactly: the same volume
        // (a cavity left disconnected by the shrinking would not) and each
        // new inner face (p and an edge) in two of them
        let vol = |ts: &mut dyn Iterator<Item = [u32; 4]>| -> f64 {
            ts.map(|t| {
                let q = t.map(|k| if k == n { p } else { pos[k as usize] });
                tet_volume6(&q[0], &q[1], &q[2], &q[3])
            })
            .sum()
        };
        let before = vol(&mut cavity.iter().map(|&t| self.mesh.tets[t]));
        let after = vol(&mut new.iter().cloned());
        if !((after - before).abs() <= 1e-9 * before.abs()) {
            return None;
        }
        let mut edges: FxHashMap<(u32, u32), u32> = FxHashMap::default();
        for t in &new {
            let others: Vec<u32> = t.iter().cloned().filter(|&k| k != n).collect();
            for (a, b) in [(0, 1), (0, 2), (1, 2)] {
                let e = (others[a].min(others[b]), others[a].max(others[b]));
                *edges.entry(e).or_default() += 1;
            }
        }
        if edges.values().any(|&c| c != 2) {
            return None;
        }
        // apply
        for &t in &cavity {
            self.dead[t] = true;
            let tet = self.mesh.tets[t];
            for f in TET_FACES {
                let key = sorted3(f.map(|i| tet[i]));
                let e = self
                    .faces
                    .get_mut(&key)
                    .expect("a face of a live tetrahedron");
                if e[0] == t as u32 {
                    e[0] = e[1];
                }
                e[1] = NONE;
                if e[0] == NONE {
                    self.faces.remove(&key);
                }
            }
        }
        self.mesh.pos.push(p);
        self.mesh.d.push(d);
        self.mesh.movable.push(true);
        for t in new {
            let i = self.mesh.tets.len() as u32;
            for f in TET_FACES {
                let e = self
                    .faces
                    .entry(sorted3(f.map(|k| t[k])))
                    .or_insert([NONE; 2]);
                e[usize::from(e[0] != NONE)] = i;
            }
            self.mesh.tets.push(t);
            self.dead.push(false);
        }
        Some(n)
    }

    /// Drops the removed tetrahedra.
    pub(crate) fn finish(self) {
        let mut k = 0;
        let dead = self.dead;
        self.mesh.tets.retain(|_| {
            k += 1;
            !dead[k - 1]
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::tet::mesh::testing::assert_positive;

    /// The Delaunay tetrahedralization of a box `w` × `w` × `h` at the
    /// origin, its eight corners fixed.
    fn slab(w: f64, h: f64) -> TetMesh {
        let mut pos = Vec::new();
        for z in [0.0, h] {
            for y in [0.0, w] {
                for x in [0.0, w] {
                    pos.push(P3::new(x, y, z));
                }
            }
        }
        let coords: Vec<[f64; 3]> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tets = bubblemesh_delaunay::tetrahedralize(&coords).unwrap().tets;
        TetMesh {
            movable: vec![false; 8],
            d: vec![1.0; 8],
            pos,
            tets,
        }
    }

    /// A point inside a cube's tetrahedralization goes in: the mesh gets
    /// one more node, stays positive, fills the same volume, and its
    /// boundary faces are the cube's as before; a point outside does not.
    #[test]
    fn an_inserted_point_keeps_the_volume_and_its_boundary() {
        let mut mesh = slab(1.0, 1.0);
        let boundary = |m: &TetMesh| {
            let mut c: FxHashMap<[u32; 3], usize> = FxHashMap::default();
            for t in &m.tets {
                for f in TET_FACES {
                    *c.entry(sorted3(f.map(|k| t[k]))).or_default() += 1;
                }
            }
            let mut b: Vec<[u32; 3]> = c.into_iter().filter(|e| e.1 == 1).map(|e| e.0).collect();
            b.sort_unstable();
            b
        };
        let volume = |m: &TetMesh| -> f64 {
            m.tets
                .iter()
                .map(|t| {
                    let q = t.map(|k| m.pos[k as usize]);
                    tet_volume6(&q[0], &q[1], &q[2], &q[3]) / 6.0
                })
                .sum()
        };
        let faces = boundary(&mesh);
        let mut ins = Inserter::new(&mut mesh);
        let live = |ins: &Inserter| (0..).find(|&t| ins.live(t).is_some()).unwrap();
        assert_eq!(ins.insert(0, P3::new(0.5, 0.4, 0.3), 0.5), Some(8));
        assert_eq!(
            ins.insert(0, P3::new(0.2, 0.7, 0.8), 0.5),
            None,
            "0 is gone"
        );
        let t = live(&ins);
        assert_eq!(ins.insert(t, P3::new(1.5, 0.4, 0.3), 0.5), None, "outside");
        assert_eq!(ins.insert(t, P3::new(0.2, 0.7, 0.8), 0.5), Some(9));
        ins.finish();
        assert_eq!(mesh.pos.len(), 10);
        assert!(mesh.movable[8] && mesh.movable[9]);
        assert_positive(&mesh.pos, &mesh.tets);
        assert!((volume(&mesh) - 1.0).abs() < 1e-12);
        assert_eq!(boundary(&mesh), faces);
        for n in [8, 9] {
            assert!(mesh.tets.iter().any(|t| t.contains(&n)));
        }
    }

    /// The point of this module: a wall's boundary face whose circumsphere
    /// holds the new point stays a face (the boundary recovery of a
    /// re-connection would have removed the point instead).
    #[test]
    fn a_point_inside_a_boundary_faces_sphere_keeps_the_face() {
        // a flat slab 0.2 thick, 2 × 2: its top and bottom faces' spheres
        // hold every interior point near the middle
        let mut mesh = slab(2.0, 0.2);
        let top: Vec<[u32; 3]> = mesh
            .tets
            .iter()
            .flat_map(|t| TET_FACES.map(|f| sorted3(f.map(|k| t[k]))))
            .filter(|f| f.iter().all(|&k| mesh.pos[k as usize].z == 0.2))
            .collect();
        assert_eq!(top.len(), 2);
        let mut ins = Inserter::new(&mut mesh);
        ins.insert(0, P3::new(1.0, 1.1, 0.1), 0.2).unwrap();
        ins.finish();
        assert_positive(&mesh.pos, &mesh.tets);
        for f in &top {
            assert!(mesh
                .tets
                .iter()
                .any(|t| TET_FACES.iter().any(|g| sorted3(g.map(|k| t[k])) == *f)));
        }
    }
}
