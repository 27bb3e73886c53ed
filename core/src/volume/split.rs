//! Boundary recovery by splitting on the geometry (not in the thesis,
//! whose §3.1.3 connection assumes a Delaunay boundary): before a volume
//! is tetrahedralized, every boundary triangle that is not a face of the
//! Delaunay tetrahedralization of the boundary nodes — after the flips of
//! [`super::recover`] — has its longest edge split at a point on the CAD
//! geometry, until every boundary triangle is such a face.
//!
//! Why: a triangle missing from the Delaunay tetrahedralization of the
//! boundary nodes alone is missing from every tetrahedralization of the
//! volume's points (added points only destroy Delaunay faces among the old
//! ones), so no choice of interior bubbles can recover it. The causes are
//! a wall thinner than the triangle (the other side's nodes inside its
//! circumsphere) and a face meeting another at a sharp angle. Splitting
//! shrinks the triangles' circumspheres where, and only where, they are
//! blocked: the surface stays on the geometry (the new node is the
//! midpoint of the edge's curve parameters when the edge lies on a CAD
//! edge, the projection of the chord's midpoint onto the face otherwise),
//! and every face and edge sharing the split edge is split with it, so
//! the face meshes stay conforming. The tetrahedra's boundary is then
//! exactly the (split) face meshes, as without splits.
//!
//! Invariants: a split replaces triangle (x, y, c) on edge x→y by
//! (x, m, c) and (m, y, c) — orientation kept, same face — and a mesh line
//! a–b by a–m, m–b; the triangles of a face that bounds a volume meshed
//! before are never split (its tetrahedra are written); the number of
//! splits is bounded ([`MAX_ROUNDS`], [`max_splits`], [`STALL_ROUNDS`]),
//! after which the triangles still missing go to the refinement by places
//! ([`crate::engine::refine`]), as before.

use super::recover::{
    by_edge, earlier_faces, key, mesh_lines, triangles_of, BoundaryDelaunay, PassTurns, Quad,
};
use crate::geom::P3;
use crate::measure::sorted3;
use crate::mesh::{Element, Mesh, Node};
use crate::model::{EntityRef, Model};
use std::collections::{HashMap, HashSet};

/// At most this many rounds (each: one Delaunay tetrahedralization of the
/// boundary nodes, then one split of the longest edge of each missing
/// triangle).
pub const MAX_ROUNDS: usize = 80;

/// The most splits of one volume: four times its boundary triangles (each
/// split adds two triangles, so the surface grows at most ninefold), at
/// least 256. A wall far thinner than the spacing needs many splits per
/// triangle (the triangles must shrink to its thickness).
pub fn max_splits(boundary_triangles: usize) -> usize {
    (4 * boundary_triangles).max(256)
}

/// Rounds without a new least number of missing triangles after which
/// the splits stop.
pub const STALL_ROUNDS: usize = 8;

/// An edge shorter than this fraction of the boundary's bounding-box
/// diagonal is not split further (a cascade at a needle-sharp edge).
const MIN_EDGE: f64 = 1e-7;

/// What the splits did to a volume's boundary.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Splits {
    /// Edges split (each added one node).
    pub count: usize,
    /// Nodes added per entity, `[dim, id, count]` (dim 1: on a CAD edge,
    /// dim 2: inside a face): there the surface mesh is finer than
    /// requested.
    pub by_entity: Vec<[u32; 3]>,
    /// Boundary triangles still missing from the Delaunay
    /// tetrahedralization of the boundary nodes when the splits stopped.
    pub left: usize,
}

/// Splits the boundary of volume `vi` of `model` in `mesh` as the module
/// docs say. The new nodes are appended to `mesh.nodes`. `delaunay` is the
/// tetrahedralization of the boundary's nodes (`None`: they have none, and
/// nothing is split); the split nodes are added to it.
pub(crate) fn split_to_delaunay(
    model: &Model,
    mesh: &mut Mesh,
    vi: usize,
    delaunay: Option<&mut BoundaryDelaunay>,
) -> Splits {
    let faces: HashSet<u32> = model.volumes[vi].faces.iter().copied().collect();
    let locked = earlier_faces(model, vi);
    let mut out = Splits::default();
    let mut per: HashMap<EntityRef, u32> = HashMap::new();
    let idx = triangles_of(mesh, &faces);
    let Some(bd) = delaunay else {
        return out;
    };
    if idx.is_empty() {
        return out;
    }
    let budget = max_splits(idx.len());
    let min_len = MIN_EDGE * diagonal(mesh, &idx);
    let mut best = (usize::MAX, 0);
    // the nodes' points, bit for bit: a split node on one of them (the
    // two diagonals of a parallelogram share a midpoint) is not made, as
    // two nodes at one point cannot be tetrahedralized
    let bits = |p: &P3| [p.x, p.y, p.z].map(|c| (c + 0.0).to_bits()); // −0 as +0
    let mut taken: HashSet<[u64; 3]> = mesh.nodes.iter().map(|n| bits(&n.pos)).collect();
    for round in 0..MAX_ROUNDS {
        let idx = triangles_of(mesh, &faces);
        let delaunay = bd.faces();
        let missing: Vec<usize> = idx
            .iter()
            .copied()
            .filter(|&k| !delaunay.contains(&sorted3(mesh.triangles[k].nodes)))
            .collect();
        out.left = missing.len();
        // stop where splitting no longer gains: faces that touch or
        // overlap (no split separates them) grow missing triangles as
        // fast as they are split
        if missing.len() < best.0 {
            best = (missing.len(), round);
        } else if round - best.1 >= STALL_ROUNDS {
            break;
        }
        if missing.is_empty() || out.count >= budget {
            break;
        }
        // every triangle of the mesh by undirected edge
        let by_edge = by_edge(mesh, 0..mesh.triangles.len());
        let lines: HashMap<(u32, u32), usize> = mesh
            .lines
            .iter()
            .enumerate()
            .map(|(k, l)| (key(l.nodes[0], l.nodes[1]), k))
            .collect();
        // one split per triangle and round: the longest edge of each
        // missing triangle, the longest first
        let mut wanted: Vec<(f64, u32, u32)> = missing
            .iter()
            .filter_map(|&k| {
                let t = mesh.triangles[k].nodes;
                (0..3)
                    .map(|i| {
                        let (a, b) = (t[i], t[(i + 1) % 3]);
                        let l = (mesh.nodes[a as usize].pos - mesh.nodes[b as usize].pos).norm();
                        (l, a, b)
                    })
                    .max_by(|x, y| x.0.total_cmp(&y.0))
            })
            .collect();
        wanted.sort_by(|x, y| y.0.total_cmp(&x.0).then((x.1, x.2).cmp(&(y.1, y.2))));
        let mut touched: HashSet<usize> = HashSet::new();
        let mut done = 0;
        for (len, a, b) in wanted {
            if out.count >= budget {
                break;
            }
            if !(len > min_len) {
                continue;
            }
            let Some(users) = by_edge.get(&key(a, b)) else {
                continue;
            };
            if users
                .iter()
                .any(|k| touched.contains(k) || locked.contains(&mesh.triangles[*k].entity.id))
            {
                continue;
            }
            let line = lines.get(&key(a, b)).copied();
            let Some(node) = midpoint(model, mesh, a, b, line, users) else {
                continue;
            };
            if !taken.insert(bits(&node.pos)) {
                continue;
            }
            *per.entry(node.entity).or_default() += 1;
            touched.extend(users.iter().copied());
            split_edge(mesh, a, b, node, users, line);
            out.count += 1;
            done += 1;
        }
        if done == 0 {
            break;
        }
        // a split node on one already there: the boundary cannot be
        // tetrahedralized (the volume stage reports it)
        let first_new = mesh.nodes.len() - done;
        if !(first_new..mesh.nodes.len()).all(|g| bd.add(mesh, g as u32)) {
            break;
        }
        // the split faces' triangles back to Delaunay in their surface
        // (a bisected long edge leaves long thin triangles beside it,
        // whose spheres are blocked again), then the co-spherical
        // quadrilaterals to the 3D Delaunay diagonal
        let split_faces: HashSet<u32> = touched
            .iter()
            .map(|&k| mesh.triangles[k].entity)
            .filter(|e| e.dim == 2 && !locked.contains(&e.id))
            .map(|e| e.id)
            .collect();
        lawson_flips(mesh, &split_faces);
        let idx = triangles_of(mesh, &faces);
        super::recover::flip_with(mesh, &idx, bd.faces());
    }
    let mut by: Vec<[u32; 3]> = per
        .into_iter()
        .map(|(e, n)| [e.dim as u32, e.id, n])
        .collect();
    by.sort_unstable();
    out.by_entity = by;
    out
}

/// Splits mesh edge a–b at `node` (appended to the mesh): each triangle
/// of `users` (x, y, c) on the edge becomes (x, m, c) and (m, y, c), the
/// mesh line `line` a–b becomes a–m and m–b.
fn split_edge(mesh: &mut Mesh, a: u32, b: u32, node: Node, users: &[usize], line: Option<usize>) {
    let m = mesh.nodes.len() as u32;
    mesh.nodes.push(node);
    for &k in users {
        let t = mesh.triangles[k];
        let Some(i) = (0..3).find(|&i| key(t.nodes[i], t.nodes[(i + 1) % 3]) == key(a, b)) else {
            continue;
        };
        let (x, y, c) = (t.nodes[i], t.nodes[(i + 1) % 3], t.nodes[(i + 2) % 3]);
        mesh.triangles[k].nodes = [x, m, c];
        mesh.triangles.push(Element {
            nodes: [m, y, c],
            entity: t.entity,
        });
    }
    if let Some(l) = line {
        let [p, q] = mesh.lines[l].nodes;
        mesh.lines[l].nodes = [p, m];
        let entity = mesh.lines[l].entity;
        mesh.lines.push(Element {
            nodes: [m, q],
            entity,
        });
    }
}

/// At most this many passes of [`lawson_flips`].
const LAWSON_PASSES: usize = 12;

/// Turns every edge inside a face of `faces` (not on a mesh line) whose
/// two triangles' opposite angles sum to more than π (the surface
/// version of the Delaunay criterion), where the new pair is not flat and
/// faces the old pair's way and the new edge is not an edge already.
fn lawson_flips(mesh: &mut Mesh, faces: &HashSet<u32>) {
    if faces.is_empty() {
        return;
    }
    let idx = triangles_of(mesh, faces);
    let lines = mesh_lines(mesh);
    let pos = |mesh: &Mesh, g: u32| mesh.nodes[g as usize].pos;
    for _ in 0..LAWSON_PASSES {
        let by_edge = by_edge(mesh, idx.iter().copied());
        let mut turns = PassTurns::default();
        let mut turned = 0;
        for &k in &idx {
            if turns.touched(k) {
                continue;
            }
            for i in 0..3 {
                let Some(q) = Quad::across(mesh, &by_edge, &lines, &turns, k, i) else {
                    continue;
                };
                let angle = |o: u32, p: u32, r: u32| {
                    (pos(mesh, p) - pos(mesh, o)).angle(&(pos(mesh, r) - pos(mesh, o)))
                };
                // a little beyond π, so that co-circular pairs stay
                if angle(q.c, q.a, q.b) + angle(q.d, q.b, q.a) <= std::f64::consts::PI + 1e-9 {
                    continue;
                }
                if !q.turn_keeps_facing(mesh) {
                    continue;
                }
                turns.record(k, &q);
                let (m, [t1, t2]) = (q.m, q.turned());
                mesh.triangles[k].nodes = t1;
                mesh.triangles[m].nodes = t2;
                turned += 1;
                break;
            }
        }
        if turned == 0 {
            break;
        }
    }
}

/// The bounding-box diagonal of the triangles `idx`' nodes.
fn diagonal(mesh: &Mesh, idx: &[usize]) -> f64 {
    let mut lo = P3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let mut hi = -lo;
    for &k in idx {
        for &v in &mesh.triangles[k].nodes {
            let p = mesh.nodes[v as usize].pos;
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
    }
    (hi - lo).norm()
}

/// The node splitting mesh edge a–b on the geometry: on the CAD edge of
/// mesh line `line` at the mean of the end nodes' curve parameters, else
/// on the one face of the triangles `users` at the projection of the
/// chord's midpoint. `None` where the parameters cannot be had or the
/// point strays from the chord by more than half its length (a bad
/// inverse mapping): the edge is then left as it is.
fn midpoint(
    model: &Model,
    mesh: &Mesh,
    a: u32,
    b: u32,
    line: Option<usize>,
    users: &[usize],
) -> Option<Node> {
    let (na, nb) = (mesh.nodes[a as usize], mesh.nodes[b as usize]);
    let chord = (nb.pos - na.pos).norm();
    let mid = P3::from((na.pos.coords + nb.pos.coords) * 0.5);
    let node = if let Some(l) = line {
        let entity = mesh.lines[l].entity;
        if entity.dim != 1 {
            return None;
        }
        let edge = model.edges.get(entity.id as usize)?;
        let ta = curve_param(model, entity.id, &na, None)?;
        let tb = curve_param(model, entity.id, &nb, Some(ta))?;
        let ta = curve_param(model, entity.id, &na, Some(tb))?;
        let t = 0.5 * (ta + tb);
        Node {
            pos: edge.curve.point(t),
            entity,
            params: [t, 0.0],
        }
    } else {
        let entity = mesh.triangles[*users.first()?].entity;
        if users.iter().any(|&k| mesh.triangles[k].entity != entity) || entity.dim != 2 {
            return None;
        }
        let surface = &model.faces.get(entity.id as usize)?.surface;
        let hint = [na, nb]
            .iter()
            .find(|n| n.entity == entity)
            .map(|n| n.params);
        let uv = surface.inverse(&mid, hint)?;
        Node {
            pos: surface.point(uv[0], uv[1]),
            entity,
            params: uv,
        }
    };
    let ok = node.pos.iter().all(|x| x.is_finite())
        && (node.pos - mid).norm() <= 0.5 * chord
        && (node.pos - na.pos).norm() > 0.0
        && (node.pos - nb.pos).norm() > 0.0;
    ok.then_some(node)
}

/// The curve parameter of node `n` on edge `e`: its own parameter when it
/// lies on the edge, the parameter of its end when it is one of the edge's
/// vertices (the end nearer `near` on a closed edge).
fn curve_param(model: &Model, e: u32, n: &Node, near: Option<f64>) -> Option<f64> {
    let edge = &model.edges[e as usize];
    match n.entity.dim {
        1 if n.entity.id == e => Some(n.params[0]),
        0 => {
            let v = n.entity.id;
            match (v == edge.start, v == edge.end) {
                (true, true) => Some(match near {
                    Some(t) if (t - edge.t1).abs() < (t - edge.t0).abs() => edge.t1,
                    _ => edge.t0,
                }),
                (true, false) => Some(edge.t0),
                (false, true) => Some(edge.t1),
                _ => None,
            }
        }
        _ => None,
    }
}
