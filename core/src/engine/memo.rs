//! Edges and faces carried over from one attempt of [`super::mesh_model`]
//! to the next.
//!
//! A failed attempt refines a few faces or places and the whole model is
//! meshed again; most faces then see exactly what they saw before: the same
//! boundary nodes (positions, parameters, spacing) and the same spacing
//! inside. Meshing is deterministic, so such a face would get the same
//! triangles again: its mesh is replayed instead (as_0051 needed nine
//! rounds at diag/25, each meshing all its faces).
//!
//! What a face's mesh depends on, and so what its [`FaceMemo`] compares:
//! - its boundary: the nodes of its loops' and embedded edges and its
//!   embedded vertices, in order — position, parameters and spacing, bit
//!   for bit;
//! - the spacing on it: the caller's per-face key (refinement level,
//!   circle-point cap kept or released, `constant_on`) and the refined
//!   places that reach the box of its previous mesh (grown by its longest
//!   mesh edge, so that the surface between nodes is inside too).
//!
//! Edges the same way ([`EdgeMemo`]): their interior nodes depend on the
//! spacing along them (refinement level, cap state, `constant_on`, the
//! spacing at their vertices, the places reaching their box).
//!
//! Invariant: a replayed edge or face adds exactly the nodes (and
//! triangles) that meshing it again would add, a face's boundary nodes
//! renumbered to this attempt's ids.

use crate::face::FaceReport;
use crate::geom::P3;
use crate::mesh::{Element, Mesh, Node};
use crate::model::{EntityRef, Model};

use super::refine::Refinement;

/// A triangle corner of a remembered face: a boundary node (index into the
/// boundary's ids) or one of the face's own nodes.
#[derive(Clone, Copy, Debug)]
enum Corner {
    Boundary(u32),
    Own(u32),
}

/// Where a remembered edge or face lies and the refined places that
/// reached it: the box of its nodes grown by its longest mesh edge (the
/// geometry between two nodes bulges less than their distance).
struct Reach {
    lo: P3,
    hi: P3,
    /// [`Refinement::places_key`] of the box when it was meshed.
    places: Vec<u64>,
}

impl Reach {
    /// The box of `pts` grown by `by`, and the places reaching it.
    fn new(refinement: &Refinement, pts: impl Iterator<Item = P3>, by: f64) -> Reach {
        let (lo, hi) = crate::geom::bounds(pts);
        let grow = nalgebra::Vector3::repeat(by);
        let (lo, hi) = (lo - grow, hi + grow);
        Reach {
            places: refinement.places_key(&lo, &hi),
            lo,
            hi,
        }
    }

    /// Whether the places reaching the box are as they were.
    fn holds(&self, refinement: &Refinement) -> bool {
        self.places == refinement.places_key(&self.lo, &self.hi)
    }
}

/// One face's mesh from an earlier attempt and what it depended on.
pub(crate) struct FaceMemo {
    /// The boundary's and the spacing's fingerprint (see the module docs).
    key: Vec<u64>,
    reach: Reach,
    /// The face's own nodes, in the order it added them.
    nodes: Vec<Node>,
    triangles: Vec<[Corner; 3]>,
    report: FaceReport,
}

/// The faces' memos, by face id.
pub(crate) type FaceMemos = Vec<Option<FaceMemo>>;

/// What an attempt knows when it comes to its faces.
pub(crate) struct Attempted<'a> {
    pub model: &'a Model,
    pub refinement: &'a Refinement,
    /// The node ids along each edge, from its start to its end.
    pub edge_nodes: &'a [Vec<u32>],
    /// d at each node of the mesh so far.
    pub node_d: &'a [f64],
}

/// One edge's nodes from an earlier attempt and what they depended on:
/// the caller's key (refinement level, cap state, `constant_on`, the
/// spacing at its two vertices) and the places reaching its box.
pub(crate) struct EdgeMemo {
    key: Vec<u64>,
    reach: Reach,
    /// Its interior nodes, start to end, and their spacing.
    nodes: Vec<Node>,
    d: Vec<f64>,
}

/// The edges' memos, by edge id.
pub(crate) type EdgeMemos = Vec<Option<EdgeMemo>>;

/// Replays edge `ei`'s interior nodes into `mesh` and `node_d` if its memo
/// holds: returns its node ids from `start` to `end`, or `None` (nothing
/// added).
pub(crate) fn replay_edge(
    memos: &EdgeMemos,
    refinement: &Refinement,
    ei: usize,
    key: &[u64],
    (start, end): (u32, u32),
    mesh: &mut Mesh,
    node_d: &mut Vec<f64>,
) -> Option<Vec<u32>> {
    let memo = memos.get(ei)?.as_ref()?;
    if memo.key != key || !memo.reach.holds(refinement) {
        return None;
    }
    let first = mesh.nodes.len() as u32;
    mesh.nodes.extend_from_slice(&memo.nodes);
    node_d.extend_from_slice(&memo.d);
    let mut ids = vec![start];
    ids.extend(first..first + memo.nodes.len() as u32);
    ids.push(end);
    Some(ids)
}

/// Remembers edge `ei`'s nodes `ids` (start, the interior nodes it added
/// at the end of `mesh` and `node_d`, end); nothing when its interior
/// nodes are not those.
#[allow(clippy::too_many_arguments)]
pub(crate) fn record_edge(
    memos: &mut EdgeMemos,
    n_edges: usize,
    refinement: &Refinement,
    ei: usize,
    key: Vec<u64>,
    ids: &[u32],
    mesh: &Mesh,
    node_d: &[f64],
) {
    if memos.len() < n_edges {
        memos.resize_with(n_edges, || None);
    }
    memos[ei] = None;
    let n = ids.len();
    if n < 2 || node_d.len() != mesh.nodes.len() {
        return;
    }
    let interior = (mesh.nodes.len() + 2 - n)..mesh.nodes.len();
    if !ids[1..n - 1]
        .iter()
        .zip(interior.clone())
        .all(|(&v, k)| v as usize == k)
    {
        return;
    }
    let pts = || ids.iter().map(|&v| mesh.nodes[v as usize].pos);
    let longest = pts()
        .zip(pts().skip(1))
        .map(|(a, b)| (b - a).norm())
        .fold(0.0, f64::max);
    memos[ei] = Some(EdgeMemo {
        key,
        reach: Reach::new(refinement, pts(), longest),
        nodes: mesh.nodes[interior.clone()].to_vec(),
        d: node_d[interior].to_vec(),
    });
}

/// Per edge, the box its remembered nodes lie in.
pub(crate) fn edge_boxes(memos: &EdgeMemos) -> Vec<Option<(P3, P3)>> {
    memos
        .iter()
        .map(|m| m.as_ref().map(|m| (m.reach.lo, m.reach.hi)))
        .collect()
}

/// Per face, the box its remembered mesh lies in.
pub(crate) fn boxes(memos: &FaceMemos) -> Vec<Option<(P3, P3)>> {
    memos
        .iter()
        .map(|m| m.as_ref().map(|m| (m.reach.lo, m.reach.hi)))
        .collect()
}

/// The boundary node ids of face `fi` in a fixed order: its loops' edges,
/// its embedded edges (each edge's nodes from start to end), then its
/// embedded vertices.
fn boundary_ids(model: &Model, fi: usize, edge_nodes: &[Vec<u32>]) -> Vec<u32> {
    let face = &model.faces[fi];
    let mut ids = Vec::new();
    for lp in &face.loops {
        for u in &lp.edges {
            ids.extend(edge_nodes.get(u.edge as usize).into_iter().flatten());
        }
    }
    for &e in &face.embedded_edges {
        ids.extend(edge_nodes.get(e as usize).into_iter().flatten());
    }
    ids.extend(face.embedded_vertices.iter().copied());
    ids
}

/// The fingerprint of face `fi`'s inputs: `spacing_key`, then per boundary
/// node its entity, position, parameters and spacing.
fn key(ids: &[u32], mesh: &Mesh, node_d: &[f64], spacing_key: &[u64]) -> Vec<u64> {
    let mut k = Vec::with_capacity(spacing_key.len() + 1 + 7 * ids.len());
    k.extend_from_slice(spacing_key);
    k.push(ids.len() as u64);
    for &id in ids {
        let n = &mesh.nodes[id as usize];
        k.push(((n.entity.dim as u64) << 32) | n.entity.id as u64);
        k.extend([n.pos.x, n.pos.y, n.pos.z, n.params[0], n.params[1]].map(f64::to_bits));
        k.push(node_d.get(id as usize).map_or(u64::MAX, |d| d.to_bits()));
    }
    k
}

/// Replays face `fi`'s remembered mesh into `mesh` and returns its report,
/// for a face that [`replays`] (the caller asks first, on the same inputs;
/// faces meshed side by side ask before any is appended). `None`, nothing
/// added, when the face has no memo.
pub(crate) fn replay(
    memos: &FaceMemos,
    at: &Attempted<'_>,
    fi: usize,
    mesh: &mut Mesh,
) -> Option<FaceReport> {
    let memo = memos.get(fi)?.as_ref()?;
    let ids = boundary_ids(at.model, fi, at.edge_nodes);
    let first = mesh.nodes.len() as u32;
    mesh.nodes.extend_from_slice(&memo.nodes);
    let fe = EntityRef::new(2, fi as u32);
    mesh.triangles
        .extend(memo.triangles.iter().map(|t| Element {
            nodes: t.map(|c| match c {
                Corner::Boundary(k) => ids[k as usize],
                Corner::Own(k) => first + k,
            }),
            entity: fe,
        }));
    Some(memo.report.clone())
}

/// Whether face `fi`'s memo still holds, so that [`replay`] gives the mesh
/// meshing it would (it only reads `mesh`).
pub(crate) fn replays(
    memos: &FaceMemos,
    at: &Attempted<'_>,
    fi: usize,
    spacing_key: &[u64],
    mesh: &Mesh,
) -> bool {
    let Some(memo) = memos.get(fi).and_then(Option::as_ref) else {
        return false;
    };
    let ids = boundary_ids(at.model, fi, at.edge_nodes);
    memo.key == key(&ids, mesh, at.node_d, spacing_key) && memo.reach.holds(at.refinement)
}

/// Remembers what meshing face `fi` added to `mesh` (nodes from `n0`,
/// triangles from `t0`); `None` in `memos` when a triangle uses a node
/// that is neither its boundary's nor its own (then it is always meshed).
pub(crate) fn record(
    memos: &mut FaceMemos,
    at: &Attempted<'_>,
    fi: usize,
    spacing_key: &[u64],
    mesh: &Mesh,
    (n0, t0): (usize, usize),
    report: &FaceReport,
) {
    if memos.len() < at.model.faces.len() {
        memos.resize_with(at.model.faces.len(), || None);
    }
    memos[fi] = None;
    let ids = boundary_ids(at.model, fi, at.edge_nodes);
    let index: std::collections::HashMap<u32, u32> = ids
        .iter()
        .enumerate()
        .rev()
        .map(|(k, &id)| (id, k as u32))
        .collect();
    let mut triangles = Vec::with_capacity(mesh.triangles.len() - t0);
    let mut longest: f64 = 0.0;
    for t in &mesh.triangles[t0..] {
        let mut c = [Corner::Own(0); 3];
        for (k, &v) in t.nodes.iter().enumerate() {
            c[k] = if (v as usize) >= n0 {
                Corner::Own(v - n0 as u32)
            } else {
                match index.get(&v) {
                    Some(&b) => Corner::Boundary(b),
                    None => return,
                }
            };
            let p = mesh.nodes[v as usize].pos;
            let q = mesh.nodes[t.nodes[(k + 1) % 3] as usize].pos;
            longest = longest.max((p - q).norm());
        }
        triangles.push(c);
    }
    if triangles.is_empty() || !longest.is_finite() {
        return;
    }
    let corners = mesh.triangles[t0..]
        .iter()
        .flat_map(|t| t.nodes)
        .map(|v| mesh.nodes[v as usize].pos);
    memos[fi] = Some(FaceMemo {
        key: key(&ids, mesh, at.node_d, spacing_key),
        reach: Reach::new(at.refinement, corners, longest),
        nodes: mesh.nodes[n0..].to_vec(),
        triangles,
        report: report.clone(),
    });
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::bubbles::testing::Segment;
    use crate::geom::Plane;
    use crate::model::{Edge, EdgeUse, Face, Loop, Vertex};

    /// The unit square as one face of four edges, and a mesh of it: the
    /// four corners (the edges' only nodes) and a centre node, four
    /// triangles.
    fn square() -> (Model, Vec<Vec<u32>>, Mesh) {
        let mut m = Model::default();
        let pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        for p in pts {
            m.vertices.push(Vertex {
                point: P3::new(p[0], p[1], 0.0),
                name: None,
            });
        }
        let mut lp = Loop::default();
        for k in 0..4u32 {
            let (a, b) = (k, (k + 1) % 4);
            m.edges.push(Edge {
                curve: Arc::new(Segment(
                    m.vertices[a as usize].point,
                    m.vertices[b as usize].point,
                )),
                t0: 0.0,
                t1: 1.0,
                start: a,
                end: b,
                name: None,
            });
            lp.edges.push(EdgeUse {
                edge: k,
                forward: true,
            });
        }
        m.faces.push(Face {
            surface: Arc::new(Plane::xy()),
            loops: vec![lp],
            embedded_edges: vec![],
            embedded_vertices: vec![],
            name: None,
        });
        let edge_nodes = (0..4u32).map(|k| vec![k, (k + 1) % 4]).collect();
        let mut mesh = Mesh::default();
        for (k, v) in m.vertices.iter().enumerate() {
            mesh.nodes.push(Node {
                pos: v.point,
                entity: EntityRef::new(0, k as u32),
                params: [0.0; 2],
            });
        }
        (m, edge_nodes, mesh)
    }

    /// Face 0's own meshing, as `mesh_face` would add it.
    fn mesh_face_0(mesh: &mut Mesh) -> (usize, usize) {
        let before = (mesh.nodes.len(), mesh.triangles.len());
        let c = mesh.nodes.len() as u32;
        mesh.nodes.push(Node {
            pos: P3::new(0.5, 0.5, 0.0),
            entity: EntityRef::new(2, 0),
            params: [0.5, 0.5],
        });
        for k in 0..4u32 {
            mesh.triangles.push(Element {
                nodes: [k, (k + 1) % 4, c],
                entity: EntityRef::new(2, 0),
            });
        }
        before
    }

    fn recorded(
        m: &Model,
        edge_nodes: &[Vec<u32>],
        mesh: &mut Mesh,
        refinement: &Refinement,
    ) -> FaceMemos {
        let before = mesh_face_0(mesh);
        let node_d = vec![0.5; 4];
        let at = Attempted {
            model: m,
            refinement,
            edge_nodes,
            node_d: &node_d,
        };
        let mut memos = FaceMemos::new();
        record(
            &mut memos,
            &at,
            0,
            &[7],
            mesh,
            before,
            &FaceReport::default(),
        );
        memos
    }

    /// A face whose boundary and spacing are as before is replayed with
    /// its nodes and triangles, its boundary renumbered to the new ids.
    #[test]
    fn an_unchanged_face_is_replayed_with_its_boundary_renumbered() {
        let (m, edge_nodes, mut mesh) = square();
        let refinement = Refinement::new(&m);
        let memos = recorded(&m, &edge_nodes, &mut mesh, &refinement);
        let want: Vec<[P3; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.nodes.map(|v| mesh.nodes[v as usize].pos))
            .collect();
        // the next attempt: the same corners, after an extra node of some
        // other entity, so every id of face 0's nodes is new
        let (_, _, mut next) = square();
        next.nodes.insert(
            0,
            Node {
                pos: P3::new(9.0, 9.0, 0.0),
                entity: EntityRef::new(0, 99),
                params: [0.0; 2],
            },
        );
        let edge_nodes: Vec<Vec<u32>> = edge_nodes
            .iter()
            .map(|e| e.iter().map(|v| v + 1).collect())
            .collect();
        let node_d = vec![0.25, 0.5, 0.5, 0.5, 0.5];
        let at = Attempted {
            model: &m,
            refinement: &refinement,
            edge_nodes: &edge_nodes,
            node_d: &node_d,
        };
        assert!(replays(&memos, &at, 0, &[7], &next));
        assert!(replay(&memos, &at, 0, &mut next).is_some());
        let got: Vec<[P3; 3]> = next
            .triangles
            .iter()
            .map(|t| t.nodes.map(|v| next.nodes[v as usize].pos))
            .collect();
        assert_eq!(got, want);
        assert_eq!(next.nodes.len(), 6);
    }

    /// Anything the face's mesh depends on that changed makes it be meshed
    /// again: a boundary node moved by one ulp, a boundary node's spacing,
    /// the caller's spacing key, a refined place reaching it; a place far
    /// away does not.
    #[test]
    fn a_face_whose_inputs_changed_is_not_replayed() {
        let (m, edge_nodes, mut mesh) = square();
        let refinement = Refinement::new(&m);
        let memos = recorded(&m, &edge_nodes, &mut mesh, &refinement);
        let try_with = |refinement: &Refinement, node_d: &[f64], key: &[u64], nudge: bool| {
            let (_, _, mut next) = square();
            if nudge {
                next.nodes[2].pos.x = f64::from_bits(next.nodes[2].pos.x.to_bits() + 1);
            }
            let at = Attempted {
                model: &m,
                refinement,
                edge_nodes: &edge_nodes,
                node_d,
            };
            replays(&memos, &at, 0, key, &next)
        };
        let d = [0.5; 4];
        assert!(try_with(&refinement, &d, &[7], false));
        assert!(!try_with(&refinement, &d, &[7], true));
        assert!(!try_with(&refinement, &[0.5, 0.5, 0.4, 0.5], &[7], false));
        assert!(!try_with(&refinement, &d, &[8], false));
        let mut near = Refinement::new(&m);
        assert!(near.bump_spots(&[(P3::new(0.5, 0.5, 0.3), 0.1)], |_| 0.5, "test"));
        assert!(!try_with(&near, &d, &[7], false));
        let mut far = Refinement::new(&m);
        assert!(far.bump_spots(&[(P3::new(50.0, 0.0, 0.0), 0.1)], |_| 0.5, "test"));
        assert!(try_with(&far, &d, &[7], false));
    }

    /// An edge's interior nodes are replayed after the vertices, with
    /// their spacing, while its key and the places near it are unchanged.
    #[test]
    fn an_unchanged_edge_replays_its_interior_nodes() {
        let (m, _, mut mesh) = square();
        let mut node_d = vec![0.5; 4];
        // edge 0 from vertex 0 to 1 with two interior nodes
        for x in [0.3, 0.7] {
            mesh.nodes.push(Node {
                pos: P3::new(x, 0.0, 0.0),
                entity: EntityRef::new(1, 0),
                params: [x, 0.0],
            });
            node_d.push(0.4);
        }
        let refinement = Refinement::new(&m);
        let mut memos = EdgeMemos::new();
        record_edge(
            &mut memos,
            4,
            &refinement,
            0,
            vec![1, 2],
            &[0, 4, 5, 1],
            &mesh,
            &node_d,
        );
        let (_, _, mut next) = square();
        let mut next_d = vec![0.5; 4];
        let ids = replay_edge(
            &memos,
            &refinement,
            0,
            &[1, 2],
            (0, 1),
            &mut next,
            &mut next_d,
        );
        assert_eq!(ids, Some(vec![0, 4, 5, 1]));
        assert_eq!(next.nodes[5].pos, P3::new(0.7, 0.0, 0.0));
        assert_eq!(next_d, [0.5, 0.5, 0.5, 0.5, 0.4, 0.4]);
        let (_, _, mut again) = square();
        let mut again_d = vec![0.5; 4];
        let other_key = replay_edge(
            &memos,
            &refinement,
            0,
            &[1, 3],
            (0, 1),
            &mut again,
            &mut again_d,
        );
        assert!(other_key.is_none() && again.nodes.len() == 4 && again_d.len() == 4);
        let mut near = Refinement::new(&m);
        assert!(near.bump_spots(&[(P3::new(0.5, 0.1, 0.0), 0.05)], |_| 0.5, "test"));
        assert!(replay_edge(&memos, &near, 0, &[1, 2], (0, 1), &mut again, &mut again_d).is_none());
    }
}
