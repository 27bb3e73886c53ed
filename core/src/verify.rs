//! The last check before a mesh leaves the engine: a mesh that fails it is
//! an error naming the face or volume, never a file.
//!
//! What is checked (each a property a simulation code relies on):
//! - **faces**: no triangle with a repeated node or zero area (area ≤
//!   `ZERO_AREA` × diag², the threshold of the independent checker
//!   `shared/meshkit/meshcheck.py`); every segment of a boundary edge of the
//!   face lies in as many triangles of the face as the face uses the edge
//!   (once per loop use, twice for an embedded edge); every other segment of
//!   the face lies in exactly two of its triangles, traversed in opposite
//!   directions (the face is a consistently oriented, closed-up 2-manifold
//!   with exactly its loops as boundary); no two neighbouring triangles fold
//!   back onto each other (their normals turn by more than `FOLD_COS`);
//!   every embedded vertex of the face (a `VERTEX_LOOP`'s, a pole's, an
//!   apex's) is a corner of one of its triangles, and every node of the
//!   face's own is (a face meshed as the wrong side of its loops, or capped
//!   flat across a pole it left out, fails here: the independent checker
//!   calls such a node unreferenced);
//! - **across faces**: a segment of a model edge lies in exactly as many
//!   triangles as the model has face uses of the edge, and a segment that is
//!   on no model edge belongs to one face only; where an edge joins exactly
//!   two triangles, they traverse it in opposite directions (the surface is
//!   consistently oriented, as meshcheck demands);
//! - **nodes**: no two nodes of one connected part of the mesh closer than
//!   `DUPLICATE` × diag (separate solids of an assembly may touch);
//! - **volumes**: every tetrahedron positive (exact `orient3d`); every
//!   triangle of the volume's faces is a face of exactly one of its
//!   tetrahedra, every other tetrahedron face is shared by exactly two, so
//!   the tetrahedra's boundary is exactly the volume's face meshes; every
//!   node of the volume's own is a corner of one of its tetrahedra;
//! - **every node** is a corner of an element (a line, a triangle or a
//!   tetrahedron): the node of a model vertex on no edge and in no face
//!   fails here (meshcheck calls such a node unreferenced).
//!
//! The checks are O(n) hash-map passes; on case K (1.3 M tetrahedra) they
//! cost a small fraction of the meshing time.

use std::collections::HashMap;

use crate::geom::P3;
use crate::measure::TET_FACES as FACE;
use crate::mesh::Mesh;
use crate::model::{EntityRef, Model};

/// Triangles with |cross product| ≤ this × diag² count as zero-area
/// (meshcheck's threshold).
const ZERO_AREA: f64 = 1e-14;
/// Nodes closer than this × diag are duplicates (meshcheck's threshold).
const DUPLICATE: f64 = 1e-10;
/// Two triangles of one face sharing an interior segment whose unit normals
/// have a dot product below this are folded onto each other (a turn of more
/// than 160°; a coarse sphere at d = r turns by about 60°).
const FOLD_COS: f64 = -0.94;

/// Why a mesh failed the last check. `entity` is the face, volume or node's
/// entity at fault; `at` a point near the defect.
#[derive(Debug, Clone, thiserror::Error)]
#[error("the mesh failed its final check: {what} near ({x:.6}, {y:.6}, {z:.6})", x = at.x, y = at.y, z = at.z)]
pub struct CheckError {
    /// The entity whose mesh is wrong.
    pub entity: EntityRef,
    /// Other entities involved (the other faces at an edge, the edge); for
    /// a refinable defect of the face checks, also the entities of the
    /// further refinable defects found in the same pass.
    pub also: Vec<EntityRef>,
    /// Whether a finer spacing on `entity` and `also` may cure the defect
    /// (not for orientation or coinciding model vertices).
    pub refinable: bool,
    /// What is wrong.
    pub what: String,
    /// Where, in model coordinates.
    pub at: P3,
}

/// The face checks of [`verify`] without orientation, for face meshes
/// not yet oriented (before the volume stage walks their shells): every
/// face covers its loops exactly, no mesh edge joins more triangles than
/// the model has faces there.
pub fn verify_face_topology(model: &Model, mesh: &Mesh) -> Result<(), CheckError> {
    match mesh.bbox() {
        Some((lo, hi)) if !mesh.triangles.is_empty() => {
            check_faces(model, mesh, (hi - lo).norm(), false)
        }
        _ => Ok(()),
    }
}

/// Checks `mesh`, meshed from `model` up to dimension `dim`, for the
/// properties listed in the module docs; also that every face has triangles
/// when `dim ≥ 2` and every volume tetrahedra when `dim ≥ 3`.
pub fn verify(model: &Model, mesh: &Mesh, dim: u8) -> Result<(), CheckError> {
    let diag = match mesh.bbox() {
        Some((lo, hi)) => (hi - lo).norm(),
        None => return Ok(()),
    };
    check_duplicates(mesh, diag)?;
    let mut has = [
        vec![false; model.faces.len()],
        vec![false; model.volumes.len()],
    ];
    for t in &mesh.triangles {
        if let Some(h) = has[0].get_mut(t.entity.id as usize) {
            *h = true;
        }
    }
    for t in &mesh.tetrahedra {
        if let Some(h) = has[1].get_mut(t.entity.id as usize) {
            *h = true;
        }
    }
    for (k, (d, what)) in [(2u8, "triangles"), (3, "tetrahedra")]
        .into_iter()
        .enumerate()
    {
        if dim < d {
            continue;
        }
        if let Some(i) = has[k].iter().position(|h| !h) {
            let e = EntityRef::new(d, i as u32);
            return Err(CheckError {
                also: vec![],
                refinable: true,
                entity: e,
                what: format!("{} has no {what}", model.describe(e)),
                at: P3::origin(),
            });
        }
    }
    if !mesh.triangles.is_empty() {
        check_faces(model, mesh, diag, true)?;
    }
    if !mesh.tetrahedra.is_empty() {
        check_volumes(model, mesh)?;
    }
    // (a line mesh of a model with faces leaves their poles and apexes
    // out by design)
    if dim >= 2 {
        check_referenced(model, mesh)?;
    }
    Ok(())
}

/// Every node is a corner of an element: a line, a triangle or a
/// tetrahedron (the independent checker calls any other node unreferenced
/// and the mesh invalid). The per-face and per-volume checks cover the
/// nodes of a face's or a volume's own; this one also the nodes of the
/// model's vertices, which no element has where the model has a vertex on
/// no edge and in no face (a free vertex of the file, or one a reader left
/// out of its face). Nodes of mixed models' lower entities (a wire's edges
/// in a surface mesh, a sheet beside a solid) are corners of their lines
/// and triangles, as the order of dimensions meshes them.
fn check_referenced(model: &Model, mesh: &Mesh) -> Result<(), CheckError> {
    let mut used = vec![false; mesh.nodes.len()];
    let mut mark = |nodes: &[u32]| {
        for &n in nodes {
            if let Some(u) = used.get_mut(n as usize) {
                *u = true;
            }
        }
    };
    mesh.lines.iter().for_each(|l| mark(&l.nodes));
    mesh.triangles.iter().for_each(|t| mark(&t.nodes));
    mesh.tetrahedra.iter().for_each(|t| mark(&t.nodes));
    match used.iter().position(|u| !u) {
        None => Ok(()),
        Some(i) => {
            let node = &mesh.nodes[i];
            Err(CheckError {
                entity: node.entity,
                also: vec![],
                refinable: false,
                what: format!(
                    "the node of {} is in no element (a vertex on no edge and in no face: \
                     the mesh would hold a node nothing uses)",
                    model.describe(node.entity)
                ),
                at: node.pos,
            })
        }
    }
}

fn pos(mesh: &Mesh, i: u32) -> P3 {
    mesh.nodes[i as usize].pos
}

fn mid(mesh: &Mesh, a: u32, b: u32) -> P3 {
    let (p, q) = (pos(mesh, a), pos(mesh, b));
    P3::from((p.coords + q.coords) * 0.5)
}

fn key2(a: u32, b: u32) -> (u32, u32) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// No two nodes of the highest-dimensional elements of one connected part
/// closer than `DUPLICATE` × diag ([`coinciding`]).
fn check_duplicates(mesh: &Mesh, diag: f64) -> Result<(), CheckError> {
    let mut found = None;
    coinciding(mesh, diag, |i, j, same_part| {
        if same_part {
            found = Some((i, j));
        }
        !same_part
    });
    match found {
        None => Ok(()),
        Some((i, j)) => {
            let (ei, ej) = (mesh.nodes[i as usize].entity, mesh.nodes[j as usize].entity);
            Err(CheckError {
                also: vec![],
                refinable: false,
                entity: ei,
                what: format!("two mesh nodes coincide (one on {ei}, one on {ej})"),
                at: pos(mesh, i),
            })
        }
    }
}

/// Where separate parts of a mesh touch (the solids of an assembly meshed
/// apart): nodes of different connected parts that coincide, within
/// `DUPLICATE` × diag. The parts are not joined there; a simulation
/// needs contact or tie conditions, and a checker that wants one connected
/// mesh (meshcheck) counts the pairs as duplicate nodes.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Touching {
    /// Pairs of coinciding nodes of different parts.
    pub node_pairs: usize,
    /// The entities of the first pairs (at most [`TOUCHING_LISTED`]
    /// distinct ones), e.g. `["face 3", "face 17"]`.
    pub entities: Vec<[String; 2]>,
    /// The first pair's place, model coordinates.
    pub at: [f64; 3],
}

/// A volume of the model whose faces do not close it: some of its edges
/// are used by one of its faces only (a CAD file's closed shell with a
/// face missing or an edge not shared). Its tetrahedra cannot be made;
/// its surface mesh is written but is open there.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OpenShell {
    /// The volume, e.g. `volume 0 ("Part 1")`.
    pub volume: String,
    /// How many of its edges one face only uses.
    pub edges: usize,
    /// The first such edge, e.g. `edge 12 ("#345")`.
    pub first: String,
    /// A point of that edge, model coordinates.
    pub at: [f64; 3],
}

/// The first volume of `model` with an edge that one of its faces only
/// uses ([`OpenShell`]); `None` when every volume is closed.
pub fn open_shell(model: &Model) -> Option<OpenShell> {
    for (vi, v) in model.volumes.iter().enumerate() {
        let mut uses: HashMap<u32, u32> = HashMap::new();
        for &f in &v.faces {
            let Some(face) = model.faces.get(f as usize) else {
                continue;
            };
            for u in face.loops.iter().flat_map(|l| l.edges.iter()) {
                *uses.entry(u.edge).or_default() += 1;
            }
            for &e in &face.embedded_edges {
                *uses.entry(e).or_default() += 2;
            }
        }
        let mut open: Vec<u32> = uses
            .iter()
            .filter(|(_, &c)| c == 1)
            .map(|(&e, _)| e)
            .collect();
        if let Some(&first) = open.iter().min() {
            open.sort_unstable();
            let e = &model.edges[first as usize];
            let p = e.curve.point(0.5 * (e.t0 + e.t1));
            return Some(OpenShell {
                volume: model.describe(EntityRef::new(3, vi as u32)),
                edges: open.len(),
                first: model.describe(EntityRef::new(1, first)),
                at: [p.x, p.y, p.z],
            });
        }
    }
    None
}

/// A volume of the model whose surface mesh passes through itself: two of
/// its faces' triangles with no corner in common, one's side through the
/// other's inside. Where the CAD faces themselves cross the solid is
/// invalid; otherwise two faces closer than their triangles' sag cross.
/// Either way the surface mesh encloses no solid (its tetrahedra would
/// have failed); it is written as the faces are. Found by the volume
/// room's `volume::crossing::self_crossing`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SelfCrossing {
    /// The volume, e.g. `volume 0 ("Part 1")`.
    pub volume: String,
    /// The two faces, e.g. `face 12 ("#1881")`.
    pub faces: [String; 2],
    /// A point of the crossing, model coordinates.
    pub at: [f64; 3],
}

/// Entity pairs listed in [`Touching::entities`].
pub const TOUCHING_LISTED: usize = 10;

/// Where separate parts of `mesh` touch ([`Touching`]); `None` where none do.
pub fn touching_parts(mesh: &Mesh) -> Option<Touching> {
    let (lo, hi) = mesh.bbox()?;
    let mut t = Touching::default();
    coinciding(mesh, (hi - lo).norm(), |i, j, same_part| {
        if !same_part {
            if t.node_pairs == 0 {
                let p = pos(mesh, i);
                t.at = [p.x, p.y, p.z];
            }
            t.node_pairs += 1;
            let pair = [i, j].map(|k| mesh.nodes[k as usize].entity.to_string());
            if t.entities.len() < TOUCHING_LISTED && !t.entities.contains(&pair) {
                t.entities.push(pair);
            }
        }
        true
    });
    (t.node_pairs > 0).then_some(t)
}

/// Calls `f(i, j, same_part)` for every pair of nodes of the
/// highest-dimensional elements closer than `DUPLICATE` × diag, with
/// whether they are in one connected part of the mesh (union-find over the
/// elements); stops when `f` returns false. Sorted by x, each node is
/// compared with the following ones while their x is within the tolerance.
fn coinciding(mesh: &Mesh, diag: f64, mut f: impl FnMut(u32, u32, bool) -> bool) {
    let tol = DUPLICATE * diag;
    // among the nodes of the highest-dimensional elements, as meshcheck
    // counts them (wire edges outside every face may overlap)
    let mut used = vec![false; mesh.nodes.len()];
    let mut mark = |nodes: &[u32]| {
        for &n in nodes {
            used[n as usize] = true;
        }
    };
    if !mesh.tetrahedra.is_empty() {
        mesh.tetrahedra.iter().for_each(|t| mark(&t.nodes));
    } else if !mesh.triangles.is_empty() {
        mesh.triangles.iter().for_each(|t| mark(&t.nodes));
    } else if !mesh.lines.is_empty() {
        mesh.lines.iter().for_each(|t| mark(&t.nodes));
    } else {
        used.iter_mut().for_each(|u| *u = true);
    }
    // connected parts of the mesh (union-find over the element edges):
    // touching solids of an assembly are separate parts, and their nodes
    // may coincide where they touch
    let mut parent: Vec<u32> = (0..mesh.nodes.len() as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    let mut join = |nodes: &[u32]| {
        let r0 = root(&mut parent, nodes[0]);
        for &n in &nodes[1..] {
            let r = root(&mut parent, n);
            parent[r as usize] = r0;
        }
    };
    mesh.tetrahedra.iter().for_each(|t| join(&t.nodes));
    mesh.triangles.iter().for_each(|t| join(&t.nodes));
    mesh.lines.iter().for_each(|t| join(&t.nodes));
    let mut order: Vec<u32> = (0..mesh.nodes.len() as u32)
        .filter(|&i| used[i as usize])
        .collect();
    order.sort_by(|&a, &b| pos(mesh, a).x.total_cmp(&pos(mesh, b).x));
    for (k, &i) in order.iter().enumerate() {
        let p = pos(mesh, i);
        for &j in &order[k + 1..] {
            let q = pos(mesh, j);
            if q.x - p.x > tol {
                break;
            }
            if (q - p).norm() <= tol {
                let same = root(&mut parent, i) == root(&mut parent, j);
                if !f(i, j, same) {
                    return;
                }
            }
        }
    }
}

/// One triangle's use of a segment: the face and whether it runs from the
/// lower node index to the higher.
#[derive(Clone, Copy)]
struct SegUse {
    face: u32,
    ascending: bool,
    tri: u32,
}

/// How the model's faces use its edges: the edge of each segment of a
/// model edge, and how many times each face (and all faces) use each edge.
struct EdgeUses {
    /// Segment (sorted node pair) of a model edge → the edge.
    edge_of: HashMap<(u32, u32), u32>,
    /// Edge → uses by all faces (an embedded edge counts twice).
    total: Vec<u32>,
    /// (face, edge) → uses by that face.
    in_face: HashMap<(u32, u32), u32>,
}

impl EdgeUses {
    fn of(model: &Model, mesh: &Mesh) -> EdgeUses {
        // segments of model edges -> the edge
        let mut edge_of: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.lines.len());
        for l in &mesh.lines {
            edge_of.insert(key2(l.nodes[0], l.nodes[1]), l.entity.id);
        }
        // face uses of each edge: per face, and in all
        let mut total = vec![0u32; model.edges.len()];
        let mut in_face: HashMap<(u32, u32), u32> = HashMap::new();
        for (fi, f) in model.faces.iter().enumerate() {
            for u in f.loops.iter().flat_map(|l| l.edges.iter()) {
                *in_face.entry((fi as u32, u.edge)).or_default() += 1;
                total[u.edge as usize] += 1;
            }
            for &e in &f.embedded_edges {
                *in_face.entry((fi as u32, e)).or_default() += 2;
                total[e as usize] += 2;
            }
        }
        EdgeUses {
            edge_of,
            total,
            in_face,
        }
    }
}

/// Segment (sorted node pair) → its uses by triangles.
type Segments = HashMap<(u32, u32), Vec<SegUse>>;

/// The segments of the triangles (sorted node pair → its uses) and each
/// triangle's unit normal; an error for a triangle that repeats a node or
/// has zero area (below `zero`, twice the area).
fn triangle_segments(
    model: &Model,
    mesh: &Mesh,
    zero: f64,
) -> Result<(Segments, Vec<nalgebra::Vector3<f64>>), CheckError> {
    let mut segs: Segments = HashMap::with_capacity(mesh.triangles.len() * 2);
    let mut normals: Vec<nalgebra::Vector3<f64>> = Vec::with_capacity(mesh.triangles.len());
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = t.nodes;
        let face = EntityRef::new(2, t.entity.id);
        if a == b || b == c || c == a {
            return Err(CheckError {
                also: vec![],
                refinable: true,
                entity: face,
                what: format!("a triangle of {} repeats a node", model.describe(face)),
                at: pos(mesh, a),
            });
        }
        let (pa, pb, pc) = (pos(mesh, a), pos(mesh, b), pos(mesh, c));
        let cr = (pb - pa).cross(&(pc - pa));
        let n = cr.norm();
        if n.is_nan() || n <= zero {
            return Err(CheckError {
                also: vec![],
                refinable: true,
                entity: face,
                what: format!("a triangle of {} has zero area", model.describe(face)),
                at: pa,
            });
        }
        normals.push(cr / n);
        for (p, q) in [(a, b), (b, c), (c, a)] {
            segs.entry(key2(p, q)).or_default().push(SegUse {
                face: t.entity.id,
                ascending: p < q,
                tri: ti as u32,
            });
        }
    }
    Ok((segs, normals))
}

/// The face checks of the module docs; `orientation`: also orientation and
/// folds.
fn check_faces(model: &Model, mesh: &Mesh, diag: f64, orientation: bool) -> Result<(), CheckError> {
    let uses = EdgeUses::of(model, mesh);
    let (segs, normals) = triangle_segments(model, mesh, ZERO_AREA * diag * diag)?;
    // every segment of an edge that bounds a face is in some triangle
    for l in &mesh.lines {
        let e = l.entity.id;
        let key = key2(l.nodes[0], l.nodes[1]);
        if uses.total.get(e as usize).copied().unwrap_or(0) > 0 && !segs.contains_key(&key) {
            let edge = EntityRef::new(1, e);
            return Err(CheckError {
                also: vec![],
                refinable: true,
                entity: edge,
                what: format!(
                    "a segment of {} lies in no triangle, but {} face(s) use the edge",
                    model.describe(edge),
                    uses.total[e as usize]
                ),
                at: mid(mesh, key.0, key.1),
            });
        }
    }
    check_face_corners(model, mesh)?;
    // first the counts (gaps, non-manifold edges, overlapping faces), then
    // orientation and folds: the message names the most basic defect
    // segments in node order, so that the error names the same defect
    // first in every run (a HashMap's order differs from run to run)
    let mut order: Vec<(&(u32, u32), &Vec<SegUse>)> = segs.iter().collect();
    order.sort_unstable_by_key(|(k, _)| **k);
    for orientation_pass in [false, true] {
        if orientation_pass && !orientation {
            break;
        }
        // the first defect is the error; the entities of further refinable
        // ones join its `also`, so that one refinement round takes them
        // all (as_0053's six countersink cones took twelve rounds, one
        // face at a time)
        let mut first: Option<CheckError> = None;
        // the entities named so far (a broken face repeats them per segment)
        let mut named: std::collections::HashSet<EntityRef> = Default::default();
        for &(&(p, q), us) in &order {
            let seg = Segment { p, q, uses: us };
            if let Err(e) = check_segment(model, mesh, &uses, &normals, seg, orientation_pass) {
                match first.as_mut() {
                    None if !e.refinable => return Err(e),
                    None => {
                        named.extend(std::iter::once(e.entity).chain(e.also.iter().copied()));
                        first = Some(e);
                    }
                    Some(f) if e.refinable => {
                        for x in std::iter::once(e.entity).chain(e.also) {
                            if named.insert(x) {
                                f.also.push(x);
                            }
                        }
                    }
                    Some(_) => {}
                }
            }
        }
        if let Some(f) = first {
            return Err(f);
        }
    }
    Ok(())
}

/// Every embedded vertex of a face is a corner of one of the face's
/// triangles, and every node on a face itself is a corner of one of that
/// face's triangles. Refinable: a face that left a pole or a vertex loop's
/// vertex out at this spacing may take it at a finer one.
fn check_face_corners(model: &Model, mesh: &Mesh) -> Result<(), CheckError> {
    let mut vertex_node: HashMap<u32, u32> = HashMap::new();
    for (i, n) in mesh.nodes.iter().enumerate() {
        if n.entity.dim == 0 {
            vertex_node.insert(n.entity.id, i as u32);
        }
    }
    // (face, node) for every corner of every triangle
    let mut corner: std::collections::HashSet<(u32, u32)> = Default::default();
    for t in &mesh.triangles {
        for &v in &t.nodes {
            corner.insert((t.entity.id, v));
        }
    }
    let missing = |face: u32, node: u32, what: String| CheckError {
        also: vec![],
        refinable: true,
        entity: EntityRef::new(2, face),
        what,
        at: pos(mesh, node),
    };
    for (fi, f) in model.faces.iter().enumerate() {
        let fe = EntityRef::new(2, fi as u32);
        for &v in &f.embedded_vertices {
            if let Some(&node) = vertex_node.get(&v) {
                if !corner.contains(&(fi as u32, node)) {
                    return Err(missing(
                        fi as u32,
                        node,
                        format!(
                            "{} is no corner of any triangle of {}, which contains it (the face's mesh leaves out a vertex of its boundary)",
                            model.describe(EntityRef::new(0, v)),
                            model.describe(fe)
                        ),
                    ));
                }
            }
        }
    }
    for (i, n) in mesh.nodes.iter().enumerate() {
        if n.entity.dim == 2 && !corner.contains(&(n.entity.id, i as u32)) {
            return Err(missing(
                n.entity.id,
                i as u32,
                format!(
                    "a node of {} is no corner of any of its triangles",
                    model.describe(n.entity)
                ),
            ));
        }
    }
    Ok(())
}

/// One segment of the triangles: its nodes and its uses.
struct Segment<'a> {
    p: u32,
    q: u32,
    uses: &'a [SegUse],
}

/// The checks of one segment: on a model edge, the counts per face and in
/// all and (in the orientation pass) the orientation across faces; inside
/// a face, one face only, two triangles, and (in the orientation pass)
/// consistent orientation and no fold.
fn check_segment(
    model: &Model,
    mesh: &Mesh,
    uses: &EdgeUses,
    normals: &[nalgebra::Vector3<f64>],
    seg: Segment<'_>,
    orientation_pass: bool,
) -> Result<(), CheckError> {
    let Segment { p, q, uses: us } = seg;
    let face0 = EntityRef::new(2, us[0].face);
    let err = |what: String, also: Vec<EntityRef>, refinable: bool| CheckError {
        also,
        refinable,
        entity: face0,
        what,
        at: mid(mesh, p, q),
    };
    match uses.edge_of.get(&(p, q)) {
        Some(&e) => {
            let edge = EntityRef::new(1, e);
            // per face: as many triangles as the face uses the edge
            let mut per_face: Vec<(u32, u32)> = Vec::new();
            for u in us {
                match per_face.iter_mut().find(|(f, _)| *f == u.face) {
                    Some((_, n)) => *n += 1,
                    None => per_face.push((u.face, 1)),
                }
            }
            for &(f, n) in &per_face {
                let want = uses.in_face.get(&(f, e)).copied().unwrap_or(0);
                if n != want {
                    let fe = EntityRef::new(2, f);
                    return Err(CheckError {
                        also: vec![],
                        refinable: true,
                        entity: fe,
                        what: if want == 0 {
                            format!(
                                "{} has a triangle on a segment of {}, which does not bound it",
                                model.describe(fe),
                                model.describe(edge)
                            )
                        } else {
                            format!(
                            "a segment of {} lies in {n} triangle(s) of {}, which uses the edge {want} time(s)",
                            model.describe(edge),
                            model.describe(fe)
                        )
                        },
                        at: mid(mesh, p, q),
                    });
                }
            }
            let total = us.len() as u32;
            if total != uses.total[e as usize] {
                return Err(err(format!(
                "a segment of {} lies in {total} triangle(s) but the model's faces use the edge {} time(s)",
                model.describe(edge),
                uses.total[e as usize]
            ), us.iter().map(|u| EntityRef::new(2, u.face)).chain([edge]).collect(), true));
            }
            if orientation_pass && us.len() == 2 && us[0].ascending == us[1].ascending {
                return Err(err(
                    format!(
                "the triangles of {} and {} on either side of {} are oriented inconsistently",
                model.describe(EntityRef::new(2, us[0].face)),
                model.describe(EntityRef::new(2, us[1].face)),
                model.describe(edge)
            ),
                    vec![],
                    false,
                ));
            }
        }
        None => {
            if let Some(u) = us.iter().find(|u| u.face != us[0].face) {
                return Err(err(
                    format!(
                "{} and {} share a mesh edge that is on no model edge (the faces overlap or touch)",
                model.describe(face0),
                model.describe(EntityRef::new(2, u.face))
            ),
                    us.iter().map(|u| EntityRef::new(2, u.face)).collect(),
                    true,
                ));
            }
            match us.len() {
                1 => {
                    return Err(err(
                        format!(
                            "{} has a gap: a mesh edge inside it lies in one triangle only",
                            model.describe(face0)
                        ),
                        vec![],
                        true,
                    ))
                }
                2 if orientation_pass => {
                    if us[0].ascending == us[1].ascending {
                        return Err(err(format!(
                        "{} is not consistently oriented: two neighbouring triangles run the same way along their shared edge",
                        model.describe(face0)
                    ), vec![], false));
                    }
                    let (n0, n1) = (normals[us[0].tri as usize], normals[us[1].tri as usize]);
                    if n0.dot(&n1) < FOLD_COS {
                        return Err(err(
                            format!(
                        "{} folds back onto itself: two neighbouring triangles face opposite ways",
                        model.describe(face0)
                    ),
                            vec![],
                            true,
                        ));
                    }
                }
                2 => {}
                n => {
                    return Err(err(
                        format!(
                            "{} is not a manifold: a mesh edge inside it lies in {n} triangles",
                            model.describe(face0)
                        ),
                        vec![],
                        true,
                    ))
                }
            }
        }
    }
    Ok(())
}

fn check_volumes(model: &Model, mesh: &Mesh) -> Result<(), CheckError> {
    // triangles of each face, by sorted node triple
    let mut face_tris: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        let mut k = t.nodes;
        k.sort_unstable();
        face_tris.insert(k, t.entity.id);
    }
    let mut by_volume: Vec<Vec<[u32; 4]>> = vec![Vec::new(); model.volumes.len()];
    for t in &mesh.tetrahedra {
        let vol = EntityRef::new(3, t.entity.id);
        let [a, b, c, d] = t.nodes.map(|k| pos(mesh, k));
        if crate::measure::orient3d(&a, &b, &c, &d) >= 0.0 {
            let at = pos(mesh, t.nodes[0]);
            return Err(CheckError {
                also: vec![],
                refinable: true,
                entity: vol,
                what: format!(
                    "a tetrahedron of {} is inverted or flat",
                    model.describe(vol)
                ),
                at,
            });
        }
        match by_volume.get_mut(t.entity.id as usize) {
            Some(v) => v.push(t.nodes),
            None => {
                return Err(CheckError {
                    also: vec![],
                    refinable: true,
                    entity: vol,
                    what: format!("a tetrahedron names {vol}, which the model does not have"),
                    at: pos(mesh, t.nodes[0]),
                })
            }
        }
    }
    // every node of a volume's own is a corner of one of its tetrahedra
    let mut in_tet = vec![false; mesh.nodes.len()];
    for t in &mesh.tetrahedra {
        for &v in &t.nodes {
            if let Some(x) = in_tet.get_mut(v as usize) {
                *x = true;
            }
        }
    }
    if let Some(i) = (0..mesh.nodes.len()).find(|&i| mesh.nodes[i].entity.dim == 3 && !in_tet[i]) {
        let vol = mesh.nodes[i].entity;
        return Err(CheckError {
            also: vec![],
            refinable: true,
            entity: vol,
            what: format!(
                "a node of {} is no corner of any of its tetrahedra",
                model.describe(vol)
            ),
            at: pos(mesh, i as u32),
        });
    }
    for (vi, tets) in by_volume.iter().enumerate() {
        let vol = EntityRef::new(3, vi as u32);
        let faces = &model.volumes[vi].faces;
        let mut count: HashMap<[u32; 3], u32> = HashMap::with_capacity(tets.len() * 3);
        for t in tets {
            for f in FACE {
                let mut k = [t[f[0]], t[f[1]], t[f[2]]];
                k.sort_unstable();
                *count.entry(k).or_default() += 1;
            }
        }
        for (k, &n) in &count {
            let on_face = face_tris.get(k).filter(|f| faces.contains(f));
            let ok = match on_face {
                Some(_) => n == 1,
                None => n == 2,
            };
            if !ok {
                let what = match (on_face, n) {
                    (Some(f), _) => format!(
                        "a triangle of {} is a face of {n} tetrahedra of {}",
                        model.describe(EntityRef::new(2, *f)),
                        model.describe(vol)
                    ),
                    (None, 1) => format!(
                        "the tetrahedra of {} have a boundary face that is on none of its faces",
                        model.describe(vol)
                    ),
                    (None, _) => format!(
                        "a face inside {} is shared by {n} tetrahedra",
                        model.describe(vol)
                    ),
                };
                return Err(CheckError {
                    also: vec![],
                    refinable: true,
                    entity: vol,
                    what,
                    at: pos(mesh, k[0]),
                });
            }
        }
        if tets.is_empty() {
            continue;
        }
        for t in &mesh.triangles {
            if !faces.contains(&t.entity.id) {
                continue;
            }
            let mut k = t.nodes;
            k.sort_unstable();
            if !count.contains_key(&k) {
                let fe = EntityRef::new(2, t.entity.id);
                return Err(CheckError {
                    also: vec![],
                    refinable: true,
                    entity: vol,
                    what: format!(
                        "a triangle of {} is not a face of any tetrahedron of {}",
                        model.describe(fe),
                        model.describe(vol)
                    ),
                    at: pos(mesh, k[0]),
                });
            }
        }
    }
    Ok(())
}
