//! Boundary recovery by flips on the surface: before a volume is
//! tetrahedralized, pairs of its boundary triangles that are not faces of
//! the Delaunay tetrahedralization of the boundary nodes are turned across
//! their shared edge when the other diagonal gives two faces that are (not
//! in the thesis, whose §3.1.3 connection assumes a Delaunay boundary).
//!
//! Why: the face meshes are made in each face's own (u,v) or tangent plane,
//! and where four of their nodes are (nearly) co-spherical — rings of nodes
//! on a cylinder or cone, a planar quadrilateral strip along a fillet —
//! either diagonal of the quadrilateral is Delaunay in 2D, while the 3D
//! Delaunay tetrahedralization (unique under its symbolic perturbation, see
//! `bubblemesh_delaunay`) picks one. When the face picked the other, the
//! two triangles are missing from every tetrahedralization, no free bubble
//! blocks them, and refining the face does not help (the finer rings are
//! co-spherical again; seen on `as_0042` and `as_0048` of
//! `../shared/realstep` at diag/20). Turning the diagonal keeps every node
//! on the CAD face and the face's boundary segments; only which diagonal
//! of a quadrilateral of the face is an edge changes.
//!
//! After the connection, the same turn removes a flat tetrahedron that
//! lies on such a quadrilateral inside the volume ([`turn_flat_quads`]).
//!
//! Invariants: only two triangles of the same face are turned together,
//! never across a mesh line (a CAD edge or seam), never into an edge the
//! mesh already has, and only when both new triangles are non-degenerate
//! and face the way the old pair did; orientation is kept (the pair's
//! boundary loop a→d→b→c is split along c–d).

use crate::geom::P3;
use crate::measure::{sorted3, TET_FACES};
use crate::mesh::Mesh;
use std::collections::{HashMap, HashSet};

/// At most this many passes over the missing triangles (each pass turns
/// every pair it can; a later pass sees pairs whose neighbour turned).
const PASSES: usize = 8;

pub(crate) fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Faces of a tetrahedralization as sorted global node ids.
pub(crate) type FaceSet = rustc_hash::FxHashSet<[u32; 3]>;

/// The Delaunay tetrahedralization of a volume's boundary nodes, kept as
/// split nodes are added ([`BoundaryDelaunay::add`]) instead of made again:
/// the tetrahedralization is unique under `bubblemesh_delaunay`'s symbolic
/// perturbation, so adding a node gives the tetrahedra of the enlarged set
/// built from scratch, and turning triangles (which keeps the nodes)
/// leaves it as it is.
pub(crate) struct BoundaryDelaunay {
    dt: bubblemesh_delaunay::Delaunay3,
    /// Global node id of each vertex of `dt`.
    global: Vec<u32>,
    /// The faces of `dt`, when they are up to date.
    faces: Option<FaceSet>,
}

impl BoundaryDelaunay {
    /// The tetrahedralization of the nodes of the triangles `idx` of
    /// `mesh`; `None` when those nodes cannot be tetrahedralized or two of
    /// them coincide (the volume stage reports that itself).
    pub(crate) fn of(mesh: &Mesh, idx: &[usize]) -> Option<Self> {
        let mut global: Vec<u32> = idx.iter().flat_map(|&k| mesh.triangles[k].nodes).collect();
        global.sort_unstable();
        global.dedup();
        let coords: Vec<[f64; 3]> = global
            .iter()
            .map(|&g| {
                let p = mesh.nodes[g as usize].pos;
                [p.x, p.y, p.z]
            })
            .collect();
        let dt = bubblemesh_delaunay::Delaunay3::new(&coords).ok()?;
        if !dt.duplicates().is_empty() {
            return None;
        }
        Some(BoundaryDelaunay {
            dt,
            global,
            faces: None,
        })
    }

    /// Adds node `g` of `mesh`; `false` when it coincides with a node
    /// already there (then nothing is added and the caller stops, as
    /// [`BoundaryDelaunay::of`] would have refused the set).
    pub(crate) fn add(&mut self, mesh: &Mesh, g: u32) -> bool {
        let p = mesh.nodes[g as usize].pos;
        match self.dt.insert([p.x, p.y, p.z], None) {
            Ok(id) => {
                debug_assert_eq!(id as usize, self.global.len());
                self.global.push(g);
                self.faces = None;
                true
            }
            Err(_) => false,
        }
    }

    /// The faces of the tetrahedralization (sorted global node ids).
    pub(crate) fn faces(&mut self) -> &FaceSet {
        let (dt, global) = (&self.dt, &self.global);
        self.faces.get_or_insert_with(|| {
            let mut set = FaceSet::default();
            set.reserve(2 * dt.num_tets() + 16);
            for t in dt.tets() {
                for f in &TET_FACES {
                    set.insert(sorted3(f.map(|i| global[t[i] as usize])));
                }
            }
            set
        })
    }
}

/// The triangles `idx` of `mesh` by undirected edge.
pub(crate) fn by_edge(
    mesh: &Mesh,
    idx: impl IntoIterator<Item = usize>,
) -> HashMap<(u32, u32), Vec<usize>> {
    let mut out: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for k in idx {
        let t = mesh.triangles[k].nodes;
        for i in 0..3 {
            out.entry(key(t[i], t[(i + 1) % 3])).or_default().push(k);
        }
    }
    out
}

/// The mesh lines (CAD edges, seams) of `mesh` as undirected node pairs:
/// no pair of triangles is turned across one.
pub(crate) fn mesh_lines(mesh: &Mesh) -> HashSet<(u32, u32)> {
    mesh.lines
        .iter()
        .map(|l| key(l.nodes[0], l.nodes[1]))
        .collect()
}

/// Two triangles of one face on a shared edge that is no mesh line: the
/// triangle `k` = (a, b, c) and its neighbour `m` = (b, a, d), the
/// quadrilateral a→d→b→c.
pub(crate) struct Quad {
    pub m: usize,
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pub d: u32,
}

/// The turns of one pass over triangles whose edge table (`by_edge`) is
/// of the pass's start: the triangles turned (each at most once a pass)
/// and the diagonals made. A diagonal an earlier turn of the pass made is
/// an edge already, which the table does not know: two turns making one
/// diagonal left it in four triangles (rp_7_020 of the random parts, two
/// dimples' coarse spheres, refused as "the boundary is not closed").
#[derive(Default)]
pub(crate) struct PassTurns {
    touched: HashSet<usize>,
    made: HashSet<(u32, u32)>,
}

impl PassTurns {
    /// Whether triangle `k` was turned in this pass.
    pub(crate) fn touched(&self, k: usize) -> bool {
        self.touched.contains(&k)
    }

    /// Records the turn of `q`, the quadrilateral across triangle `k`.
    pub(crate) fn record(&mut self, k: usize, q: &Quad) {
        self.touched.insert(k);
        self.touched.insert(q.m);
        self.made.insert(key(q.c, q.d));
    }
}

impl Quad {
    /// The quadrilateral across edge `i` of triangle `k`, where it may be
    /// turned: the edge is no mesh line, has exactly two triangles, both
    /// of the same face and neither turned in this pass (`turns`), and the
    /// other diagonal c–d is not an edge already (in `by_edge`, the
    /// triangles of each edge at the pass's start, or made by the pass).
    pub(crate) fn across(
        mesh: &Mesh,
        by_edge: &HashMap<(u32, u32), Vec<usize>>,
        lines: &HashSet<(u32, u32)>,
        turns: &PassTurns,
        k: usize,
        i: usize,
    ) -> Option<Quad> {
        let t = mesh.triangles[k];
        let (a, b, c) = (t.nodes[i], t.nodes[(i + 1) % 3], t.nodes[(i + 2) % 3]);
        if lines.contains(&key(a, b)) {
            return None;
        }
        let users = by_edge.get(&key(a, b))?;
        if users.len() != 2 {
            return None;
        }
        let m = if users[0] == k { users[1] } else { users[0] };
        if turns.touched(m) || mesh.triangles[m].entity != t.entity {
            return None;
        }
        // the neighbour as (b, a, d): the shared edge reversed
        let u = mesh.triangles[m].nodes;
        let j = (0..3).find(|&j| u[j] == b && u[(j + 1) % 3] == a)?;
        let d = u[(j + 2) % 3];
        if d == c || by_edge.contains_key(&key(c, d)) || turns.made.contains(&key(c, d)) {
            return None;
        }
        Some(Quad { m, a, b, c, d })
    }

    /// The pair along the other diagonal, (a, d, c) and (d, b, c): the
    /// quadrilateral's orientation kept.
    pub(crate) fn turned(&self) -> [[u32; 3]; 2] {
        let Quad { a, b, c, d, .. } = *self;
        [[a, d, c], [d, b, c]]
    }

    /// Whether the turned pair faces the way the old one did, neither
    /// triangle flat.
    pub(crate) fn turn_keeps_facing(&self, mesh: &Mesh) -> bool {
        let pos = |g: u32| -> P3 { mesh.nodes[g as usize].pos };
        let normal = |t: [u32; 3]| {
            let (p, q, r) = (pos(t[0]), pos(t[1]), pos(t[2]));
            (q - p).cross(&(r - p))
        };
        let Quad { a, b, c, d, .. } = *self;
        let (n1, n2) = (normal([a, b, c]), normal([b, a, d]));
        let (l1, l2) = (n1.norm(), n2.norm());
        if !(l1 > 0.0 && l2 > 0.0) {
            return false;
        }
        let old = n1 / l1 + n2 / l2;
        self.turned().iter().all(|&t| {
            let n = normal(t);
            n.norm() > 1e-12 * (l1 + l2) && n.dot(&old) > 0.0
        })
    }
}

/// Turns pairs of the triangles of `faces` in `mesh` (global node ids)
/// whose quadrilateral's other diagonal is Delaunay in 3D, as the module
/// docs say. Returns how many pairs were turned; 0 when the boundary nodes
/// cannot be tetrahedralized (the volume stage reports that itself).
#[cfg(test)]
pub(crate) fn flip_to_delaunay(mesh: &mut Mesh, faces: &HashSet<u32>) -> usize {
    let idx = triangles_of(mesh, faces);
    match BoundaryDelaunay::of(mesh, &idx) {
        Some(mut bd) => flip_with(mesh, &idx, bd.faces()),
        None => 0,
    }
}

/// The triangles of `mesh` on the faces `faces`.
pub(crate) fn triangles_of(mesh: &Mesh, faces: &HashSet<u32>) -> Vec<usize> {
    (0..mesh.triangles.len())
        .filter(|&k| {
            let e = mesh.triangles[k].entity;
            e.dim == 2 && faces.contains(&e.id)
        })
        .collect()
}

/// [`flip_to_delaunay`] on the triangles `idx`, with `delaunay` the faces
/// of the Delaunay tetrahedralization of their nodes.
pub(crate) fn flip_with(mesh: &mut Mesh, idx: &[usize], delaunay: &FaceSet) -> usize {
    if idx.is_empty() {
        return 0;
    }
    let missing = |mesh: &Mesh, k: usize| !delaunay.contains(&sorted3(mesh.triangles[k].nodes));
    if !idx.iter().any(|&k| missing(mesh, k)) {
        return 0;
    }
    let lines = mesh_lines(mesh);
    let mut turned = 0;
    for _ in 0..PASSES {
        let by_edge = by_edge(mesh, idx.iter().copied());
        let mut turns = PassTurns::default();
        let mut flips: Vec<(usize, [u32; 3], usize, [u32; 3])> = Vec::new();
        for &k in idx {
            if turns.touched(k) || !missing(mesh, k) {
                continue;
            }
            for i in 0..3 {
                let Some(q) = Quad::across(mesh, &by_edge, &lines, &turns, k, i) else {
                    continue;
                };
                let (m, [t1, t2]) = (q.m, q.turned());
                if !delaunay.contains(&sorted3(t1)) || !delaunay.contains(&sorted3(t2)) {
                    continue;
                }
                if !q.turn_keeps_facing(mesh) {
                    continue;
                }
                turns.record(k, &q);
                flips.push((k, t1, m, t2));
                break;
            }
        }
        if flips.is_empty() {
            break;
        }
        for (k, t1, m, t2) in flips {
            mesh.triangles[k].nodes = t1;
            mesh.triangles[m].nodes = t2;
            turned += 1;
        }
    }
    turned
}

/// The faces of the volumes meshed before volume `vi` (volumes are meshed
/// in order): their triangles are faces of tetrahedra already, so they are
/// neither split nor turned for `vi`.
pub(crate) fn earlier_faces(model: &crate::model::Model, vi: usize) -> HashSet<u32> {
    model.volumes[..vi]
        .iter()
        .flat_map(|v| v.faces.iter().copied())
        .collect()
}

/// The faces of volume `vi` that it may change (turn or split): those no
/// volume meshed before it uses ([`earlier_faces`]).
pub(crate) fn own_faces(model: &crate::model::Model, vi: usize) -> HashSet<u32> {
    let earlier = earlier_faces(model, vi);
    model.volumes[vi]
        .faces
        .iter()
        .copied()
        .filter(|f| !earlier.contains(f))
        .collect()
}

/// Removes the flat tetrahedra that lie on a boundary quadrilateral and
/// turns the quadrilateral's diagonal: a tetrahedron of four boundary
/// nodes, flat, two of whose faces are boundary triangles of one
/// face sharing an edge, a planar quadrilateral whose corners are
/// co-circular (a rectangular face smaller than the spacing, meshed as two
/// triangles). The Delaunay tetrahedralization, unique under its symbolic
/// perturbation, may hold the flat tetrahedron on the inside of the
/// quadrilateral, its two other faces (the other diagonal's triangles)
/// shared with the tetrahedra inside. Steiner points do not remove it
/// (every in-sphere test against four co-circular points is decided by the
/// perturbation) and a finer spacing does not either while the face stays
/// two triangles (the short-edge rule keeps an edge shorter than the
/// spacing one segment). Without it, and with the quadrilateral split
/// along the other diagonal, the remaining tetrahedra are a complex whose
/// boundary is the turned face mesh: nothing else changes.
///
/// `tets` are in local node ids; the first `global.len()` local nodes are
/// the boundary nodes, `global` their ids in `mesh`; `flat` indexes the
/// flat tetrahedra of `tets` among boundary nodes. Only triangles of
/// `faces` are turned (the caller leaves out the faces of volumes already
/// meshed, whose tetrahedra use the triangles as they are), under the
/// conditions of [`Quad::across`] and [`Quad::turn_keeps_facing`]. Returns
/// the indices into `tets` of the tetrahedra to remove; their pairs are
/// turned in `mesh`.
pub(crate) fn turn_flat_quads(
    mesh: &mut Mesh,
    faces: &HashSet<u32>,
    global: &[u32],
    tets: &[[u32; 4]],
    flat: &[usize],
) -> Vec<usize> {
    if flat.is_empty() {
        return Vec::new();
    }
    let idx = triangles_of(mesh, faces);
    let of_nodes: HashMap<[u32; 3], usize> = idx
        .iter()
        .map(|&k| (sorted3(mesh.triangles[k].nodes), k))
        .collect();
    let lines = mesh_lines(mesh);
    let by_edge = by_edge(mesh, idx.iter().copied());
    let mut turns = PassTurns::default();
    let mut removed = Vec::new();
    for &ti in flat {
        let g = tets[ti].map(|k| global[k as usize]);
        let on: Vec<usize> = TET_FACES
            .iter()
            .filter_map(|f| of_nodes.get(&sorted3(f.map(|i| g[i]))).copied())
            .collect();
        let &[k, m] = on.as_slice() else {
            continue;
        };
        // the edge of triangle k shared with m
        let (t, u) = (mesh.triangles[k].nodes, mesh.triangles[m].nodes);
        let Some(i) = (0..3).find(|&i| u.contains(&t[i]) && u.contains(&t[(i + 1) % 3])) else {
            continue;
        };
        let Some(q) = Quad::across(mesh, &by_edge, &lines, &turns, k, i) else {
            continue;
        };
        if q.m != m || turns.touched(k) || !q.turn_keeps_facing(mesh) {
            continue;
        }
        turns.record(k, &q);
        let [t1, t2] = q.turned();
        mesh.triangles[k].nodes = t1;
        mesh.triangles[m].nodes = t2;
        removed.push(ti);
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::orient3d;
    use crate::mesh::{Element, Node};
    use crate::model::EntityRef;

    /// The nodes of a pyramid on the unit square at z = 0 (its corners
    /// 0–3 co-circular) with its apex, node 4, at height `apex`.
    fn square_pyramid(apex: f64) -> Mesh {
        let mut mesh = Mesh::default();
        for p in [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, apex],
        ] {
            mesh.nodes.push(Node {
                pos: P3::new(p[0], p[1], p[2]),
                entity: EntityRef::new(2, 0),
                params: [0.0, 0.0],
            });
        }
        mesh
    }

    /// A square pyramid's corners (base co-circular at z = 0, apex above)
    /// and the faces of their Delaunay tetrahedralization, which splits the
    /// base along one diagonal.
    fn pyramid() -> (Mesh, HashSet<[u32; 3]>) {
        let mesh = square_pyramid(0.8);
        let faces = delaunay_faces(&mesh, &[0, 1, 2, 3, 4]);
        (mesh, faces)
    }

    /// The faces (sorted, local ids: positions in `nodes`) of the Delaunay
    /// tetrahedralization of `mesh`'s nodes `nodes`.
    fn delaunay_faces(mesh: &Mesh, nodes: &[usize]) -> HashSet<[u32; 3]> {
        let coords: Vec<[f64; 3]> = nodes
            .iter()
            .map(|&k| {
                let p = mesh.nodes[k].pos;
                [p.x, p.y, p.z]
            })
            .collect();
        let dt = bubblemesh_delaunay::tetrahedralize(&coords).unwrap();
        dt.tets
            .iter()
            .flat_map(|t| TET_FACES.iter().map(move |f| sorted3(f.map(|i| t[i]))))
            .collect()
    }

    fn tri(nodes: [u32; 3], face: u32) -> Element<3> {
        Element {
            nodes,
            entity: EntityRef::new(2, face),
        }
    }

    /// The base split along the diagonal the Delaunay tetrahedralization
    /// does not use (its four corners are co-circular, so either diagonal
    /// is Delaunay in the plane): the pass turns it, keeps it outward and
    /// leaves the sides alone.
    #[test]
    fn cocircular_base_turns_to_the_delaunay_diagonal() {
        let (mut mesh, faces) = pyramid();
        // the base (outward: normal −z) along the diagonal Delaunay did
        // not take
        let (base, other) = if faces.contains(&[0, 1, 2]) {
            ([[0, 3, 1], [1, 3, 2]], [[0, 2, 1], [0, 3, 2]])
        } else {
            ([[0, 2, 1], [0, 3, 2]], [[0, 3, 1], [1, 3, 2]])
        };
        for t in base {
            mesh.triangles.push(tri(t, 0));
        }
        for t in [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]] {
            mesh.triangles.push(tri(t, 1));
        }
        let n = flip_to_delaunay(&mut mesh, &[0, 1].into_iter().collect());
        assert_eq!(n, 1);
        let got: HashSet<[u32; 3]> = mesh.triangles[..2]
            .iter()
            .map(|t| sorted3(t.nodes))
            .collect();
        let want: HashSet<[u32; 3]> = other.iter().map(|&t| sorted3(t)).collect();
        assert_eq!(got, want);
        for t in &mesh.triangles {
            assert!(faces.contains(&sorted3(t.nodes)));
        }
        // still outward: the base's normals point down
        for t in &mesh.triangles[..2] {
            let [p, q, r] = t.nodes.map(|g| mesh.nodes[g as usize].pos);
            assert!((q - p).cross(&(r - p)).z < 0.0);
        }
    }

    /// Two pyramids on one square base, the upper one meshed first: the
    /// base is a face of both volumes, split along the diagonal the lower
    /// one's Delaunay tetrahedralization does not take. Recovering the
    /// lower volume's boundary must leave the base as the upper volume's
    /// tetrahedra have it (turning it would break that volume's
    /// conformity); for the upper volume alone it turns as before.
    #[test]
    fn a_face_of_an_earlier_volume_is_not_turned() {
        let mut mesh = square_pyramid(0.8);
        mesh.nodes.push(Node {
            pos: P3::new(0.5, 0.5, -0.8),
            entity: EntityRef::new(2, 0),
            params: [0.0, 0.0],
        });
        // local ids 0–3 are nodes 0–3, local 4 is node 5
        let lower_faces = delaunay_faces(&mesh, &[0, 1, 2, 3, 5]);
        // the base along the diagonal the lower volume's Delaunay does not
        // use (normals up, as the upper volume's boundary has them)
        let base = if lower_faces.contains(&[0, 1, 2]) {
            [[0, 1, 3], [1, 2, 3]]
        } else {
            [[0, 1, 2], [0, 2, 3]]
        };
        for t in base {
            mesh.triangles.push(tri(t, 0));
        }
        for t in [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]] {
            mesh.triangles.push(tri(t, 1));
        }
        for t in [[1, 0, 5], [2, 1, 5], [3, 2, 5], [0, 3, 5]] {
            mesh.triangles.push(tri(t, 2));
        }
        let volume = |faces: Vec<u32>| crate::model::Volume {
            faces,
            geometry: None,
            name: None,
        };
        let model = crate::model::Model {
            volumes: vec![volume(vec![0, 1]), volume(vec![0, 2])],
            ..Default::default()
        };
        let before: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.nodes).collect();
        let (turned, splits) = super::super::recover_boundary(&model, 1, &mut mesh);
        assert_eq!(turned, 0);
        assert_eq!(splits.count, 0);
        let after: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.nodes).collect();
        assert_eq!(
            after, before,
            "the shared base must stay as volume 0 has it"
        );
        // the same base is turned when it belongs to the lower volume alone
        let alone = crate::model::Model {
            volumes: vec![volume(vec![0, 2])],
            ..Default::default()
        };
        let (turned, _) = super::super::recover_boundary(&alone, 0, &mut mesh);
        assert_eq!(turned, 1);
    }

    /// A square pyramid pointing down (apex at z = −1, the volume below
    /// its base), its base split along 0–2, and its tetrahedra as the
    /// perturbed Delaunay tetrahedralization can have them: the flat
    /// tetrahedron of the four co-circular base corners, on the inside of
    /// the base, and the two tetrahedra of the other split, 1–3, below it.
    fn flat_under_base() -> (Mesh, Vec<[u32; 4]>) {
        let mut mesh = square_pyramid(-1.0);
        // outward: the base's normals +z, the sides' away from the axis
        for t in [[0, 1, 2], [0, 2, 3]] {
            mesh.triangles.push(tri(t, 0));
        }
        for t in [[1, 0, 4], [2, 1, 4], [3, 2, 4], [0, 3, 4]] {
            mesh.triangles.push(tri(t, 1));
        }
        let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
        let positive = |mut t: [u32; 4]| {
            let [a, b, c, d] = t.map(|k| pos[k as usize]);
            if orient3d(&a, &b, &c, &d) < 0.0 {
                t.swap(0, 1);
            }
            t
        };
        let tets = vec![[0, 1, 2, 3], positive([0, 1, 3, 4]), positive([1, 2, 3, 4])];
        (mesh, tets)
    }

    /// The faces of `tets` that are in one of them, sorted.
    fn hull_of(tets: &[[u32; 4]]) -> HashSet<[u32; 3]> {
        let mut count: HashMap<[u32; 3], usize> = HashMap::new();
        for t in tets {
            for f in &TET_FACES {
                *count.entry(sorted3(f.map(|i| t[i]))).or_default() += 1;
            }
        }
        count
            .into_iter()
            .filter(|&(_, n)| n == 1)
            .map(|(f, _)| f)
            .collect()
    }

    /// The flat tetrahedron goes, the base turns to the other diagonal and
    /// keeps facing out, and the tetrahedra left have exactly the turned
    /// face mesh as their boundary.
    #[test]
    fn a_flat_tetrahedron_on_a_boundary_quad_goes_and_the_quad_turns() {
        let (mut mesh, tets) = flat_under_base();
        // before: the flat tetrahedron's faces on the base make the hull
        // differ from the face mesh
        let faces_of = |mesh: &Mesh| -> HashSet<[u32; 3]> {
            mesh.triangles.iter().map(|t| sorted3(t.nodes)).collect()
        };
        assert_ne!(hull_of(&tets[1..]), faces_of(&mesh));
        let global: Vec<u32> = (0..5).collect();
        let [a, b, c, d] = tets[0].map(|k| mesh.nodes[k as usize].pos);
        assert_eq!(orient3d(&a, &b, &c, &d), 0.0);
        let gone = turn_flat_quads(
            &mut mesh,
            &[0, 1].into_iter().collect(),
            &global,
            &tets,
            &[0],
        );
        assert_eq!(gone, vec![0]);
        let left: Vec<[u32; 4]> = tets[1..].to_vec();
        assert_eq!(hull_of(&left), faces_of(&mesh));
        let base: HashSet<[u32; 3]> = mesh.triangles[..2]
            .iter()
            .map(|t| sorted3(t.nodes))
            .collect();
        assert_eq!(base, [[0, 1, 3], [1, 2, 3]].into_iter().collect());
        for t in &mesh.triangles[..2] {
            let [p, q, r] = t.nodes.map(|g| mesh.nodes[g as usize].pos);
            assert!((q - p).cross(&(r - p)).z > 0.0);
        }
    }

    /// With the base's diagonal on a mesh line, or the base a face the
    /// caller leaves out, nothing goes and nothing turns.
    #[test]
    fn a_flat_tetrahedron_on_a_line_or_a_kept_face_stays() {
        for (line, faces) in [(true, [0u32, 1]), (false, [1, 1])] {
            let (mut mesh, tets) = flat_under_base();
            if line {
                mesh.lines.push(Element {
                    nodes: [0, 2],
                    entity: EntityRef::new(1, 0),
                });
            }
            let before: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.nodes).collect();
            let global: Vec<u32> = (0..5).collect();
            let gone = turn_flat_quads(
                &mut mesh,
                &faces.into_iter().collect(),
                &global,
                &tets,
                &[0],
            );
            assert!(gone.is_empty());
            let after: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.nodes).collect();
            assert_eq!(before, after);
        }
    }

    /// The same base with its diagonal on a mesh line (a CAD edge) is never
    /// turned.
    #[test]
    fn a_mesh_line_is_never_turned() {
        let (mut mesh, faces) = pyramid();
        let (base, diag) = if faces.contains(&[0, 1, 2]) {
            ([[0, 3, 1], [1, 3, 2]], [1, 3])
        } else {
            ([[0, 2, 1], [0, 3, 2]], [0, 2])
        };
        for t in base {
            mesh.triangles.push(tri(t, 0));
        }
        mesh.lines.push(Element {
            nodes: diag,
            entity: EntityRef::new(1, 0),
        });
        let before: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.nodes).collect();
        assert_eq!(flip_to_delaunay(&mut mesh, &[0].into_iter().collect()), 0);
        let after: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.nodes).collect();
        assert_eq!(before, after);
    }

    /// Nodes added one by one to a boundary's tetrahedralization give the
    /// faces of the tetrahedralization made from scratch — on a cube's
    /// lattice, whose points are co-spherical by the dozen (the perturbation
    /// decides) — and a node on one already there is refused.
    #[test]
    fn added_nodes_give_the_faces_made_from_scratch() {
        let mut mesh = Mesh::default();
        let node = |x: f64, y: f64, z: f64| Node {
            pos: P3::new(x, y, z),
            entity: EntityRef::new(2, 0),
            params: [0.0, 0.0],
        };
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    mesh.nodes.push(node(i as f64, j as f64, k as f64));
                }
            }
        }
        let first = mesh.nodes.len() as u32;
        // the triangles only say which nodes are the boundary's
        let chunk = |a: u32| tri([a, a + 1, a + 2], 0);
        for a in (0..first - 2).step_by(3) {
            mesh.triangles.push(chunk(a));
        }
        mesh.triangles
            .push(tri([first - 3, first - 2, first - 1], 0));
        let idx: Vec<usize> = (0..mesh.triangles.len()).collect();
        let mut bd = BoundaryDelaunay::of(&mesh, &idx).unwrap();
        // midpoints of lattice edges and cell centres: more co-spherical sets
        for p in [
            [0.5, 0.0, 0.0],
            [1.5, 1.5, 1.5],
            [2.0, 2.5, 3.0],
            [0.5, 0.5, 0.0],
        ] {
            mesh.nodes.push(node(p[0], p[1], p[2]));
            assert!(bd.add(&mesh, mesh.nodes.len() as u32 - 1));
        }
        let n = mesh.nodes.len() as u32;
        mesh.triangles.push(tri([first, first + 1, first + 2], 0));
        mesh.triangles.push(tri([first + 1, first + 2, n - 1], 0));
        let idx: Vec<usize> = (0..mesh.triangles.len()).collect();
        let mut scratch = BoundaryDelaunay::of(&mesh, &idx).unwrap();
        assert_eq!(bd.faces(), scratch.faces());
        mesh.nodes.push(node(1.5, 1.5, 1.5));
        assert!(!bd.add(&mesh, n), "a node on one already there");
    }
}
