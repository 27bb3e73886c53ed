//! STEP topology (ISO 10303-42 §5) into a [`Model`]: vertices, trimmed
//! edges, faces with loops on a [`FaceView`], volumes from solids.

use std::collections::{HashMap, HashSet};
use std::f64::consts::TAU;
use std::sync::Arc;

use bubblemesh_analytic::{CircleArc, EllipseArc, HyperbolaArc, Line};
use bubblemesh_core::geom::{Curve, P3};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex, Volume};

pub use super::geometry::MAX_CONTROL_POINTS;
use super::geometry::{CurveGeom, Geo};
use super::table::Table;
use super::{ShellInfo, StepError, StepInfo, StepModel};
use crate::curve_tools::{closest_parameter, WrappedCurve};

/// One EDGE_CURVE: its vertices, geometry and sense.
struct EdgeRec {
    v1: u64,
    v2: u64,
    geom: u64,
    same_sense: bool,
}

/// One use of an EDGE_CURVE in a loop, `dir` true when the loop runs from
/// its edge_start to its edge_end.
#[derive(Clone, Copy, Debug)]
struct Use {
    edge: u64,
    dir: bool,
}

struct FaceRaw {
    id: u64,
    surface: u64,
    same_sense: bool,
    /// Each bound's uses, in loop order (bound orientation applied).
    bounds: Vec<Vec<Use>>,
    vertex_loops: Vec<u64>,
}

/// The entities one build pass turns into model entities, by STEP id
/// (sorted): the whole file, or what one placed shape item reaches.
#[derive(Default)]
struct Scope {
    vertices: Vec<u64>,
    edges: Vec<u64>,
    faces: Vec<u64>,
    /// Solids, each a volume.
    solids: Vec<u64>,
    /// Shells recorded even when in no solid.
    shells: Vec<u64>,
}

impl Scope {
    /// Every topological entity of the file.
    fn everything(t: &Table) -> Self {
        let both = |a: &str, b: &str| {
            let mut v = t.ids_of(a);
            v.extend(t.ids_of(b));
            v.sort_unstable();
            v.dedup();
            v
        };
        Scope {
            vertices: t.ids_of("VERTEX_POINT"),
            edges: t.ids_of("EDGE_CURVE"),
            faces: both("ADVANCED_FACE", "FACE_SURFACE"),
            solids: {
                let mut v = both("MANIFOLD_SOLID_BREP", "BREP_WITH_VOIDS");
                v.extend(t.ids_of("FACETED_BREP"));
                v.sort_unstable();
                v.dedup();
                v
            },
            shells: both("CLOSED_SHELL", "OPEN_SHELL"),
        }
    }

    /// What the shape items `roots` (solids, shell-based surface models,
    /// shells) reach.
    fn reachable(
        t: &Table,
        roots: &[u64],
        erec: &HashMap<u64, EdgeRec>,
    ) -> Result<Self, StepError> {
        let mut sc = Scope::default();
        let mut shells = Vec::new();
        for &r in roots {
            let e = t.get(r)?;
            if e.is("MANIFOLD_SOLID_BREP") || e.is("BREP_WITH_VOIDS") || e.is("FACETED_BREP") {
                sc.solids.push(r);
                shells.extend(solid_shells(t, r)?.into_iter().map(|(s, _)| s));
            } else if e.is("SHELL_BASED_SURFACE_MODEL") {
                let a = t.args(r, &["SHELL_BASED_SURFACE_MODEL"], 2)?;
                shells.extend(t.refs(r, &a[1], "sbsm_boundary")?);
            } else {
                shells.push(r);
            }
        }
        for s in shells {
            let (sid, _) = resolve_shell(t, s)?;
            sc.shells.push(sid);
            let a = t.args(sid, &["CLOSED_SHELL", "OPEN_SHELL"], 2)?;
            for f in t.refs(sid, &a[1], "cfs_faces")? {
                let fid = if t.get(f)?.is("ORIENTED_FACE") {
                    let b = t.args(f, &["ORIENTED_FACE"], 4)?;
                    t.r(f, &b[2], "face_element")?
                } else {
                    f
                };
                sc.faces.push(fid);
            }
        }
        sc.faces.sort_unstable();
        sc.faces.dedup();
        for &f in &sc.faces {
            let raw = read_face(t, f, erec)?;
            for u in raw.bounds.iter().flatten() {
                sc.edges.push(u.edge);
                let r = &erec[&u.edge];
                sc.vertices.extend([r.v1, r.v2]);
            }
            sc.vertices.extend(raw.vertex_loops);
        }
        for v in [
            &mut sc.vertices,
            &mut sc.edges,
            &mut sc.solids,
            &mut sc.shells,
        ] {
            v.sort_unstable();
            v.dedup();
        }
        Ok(sc)
    }
}

/// The shells of a solid: (shell reference, `true` for the outer one).
fn solid_shells(t: &Table, id: u64) -> Result<Vec<(u64, bool)>, StepError> {
    let e = t.get(id)?;
    let a = t.args(
        id,
        &["MANIFOLD_SOLID_BREP", "BREP_WITH_VOIDS", "FACETED_BREP"],
        2,
    )?;
    let mut shells = vec![(t.r(id, &a[1], "outer")?, true)];
    if e.is("BREP_WITH_VOIDS") {
        let voids = match e.part("BREP_WITH_VOIDS") {
            Some(p) if e.records.len() > 1 => p.first(),
            _ => a.get(2),
        };
        if let Some(v) = voids {
            for s in t.refs(id, v, "voids")? {
                shells.push((s, false));
            }
        }
    }
    Ok(shells)
}

/// Every EDGE_CURVE's vertices, geometry and sense.
fn edge_records(t: &Table) -> Result<HashMap<u64, EdgeRec>, StepError> {
    let mut erec: HashMap<u64, EdgeRec> = HashMap::new();
    for id in t.ids_of("EDGE_CURVE") {
        let a = t.args(id, &["EDGE_CURVE"], 5)?;
        let v1 = t.r(id, &a[1], "edge_start")?;
        let v2 = t.r(id, &a[2], "edge_end")?;
        for v in [v1, v2] {
            if !t.get(v)?.is("VERTEX_POINT") {
                return Err(t.err(
                    id,
                    format!(
                        "its vertex #{v} is a {}, not a VERTEX_POINT",
                        t.type_name(v)
                    ),
                ));
            }
        }
        let geom = t.r(id, &a[3], "edge_geometry")?;
        let same_sense = t.boolean(id, &a[4], "same_sense")?;
        erec.insert(
            id,
            EdgeRec {
                v1,
                v2,
                geom,
                same_sense,
            },
        );
    }
    Ok(erec)
}

pub(crate) fn build(t: &Table, scale: f64) -> Result<StepModel, StepError> {
    let geo = Geo::with_scale(t, scale);
    let mut model = Model {
        source: Some(t.source.clone()),
        ..Default::default()
    };
    let mut info = StepInfo::default();
    let erec = edge_records(t)?;
    let insts = super::assembly::instances(t, &geo)?;
    let mut roots_seen: HashSet<u64> = HashSet::new();
    let in_place = insts
        .iter()
        .all(|i| i.xf.is_identity(geo.extent) && roots_seen.insert(i.root));
    if in_place {
        // every part where the file draws it, once: the whole file in one
        // pass, solids named after their products
        let names: HashMap<u64, String> = insts.iter().map(|i| (i.root, i.name.clone())).collect();
        add_scope(
            &geo,
            &Scope::everything(t),
            &erec,
            &names,
            &mut model,
            &mut info,
        )?;
        return Ok(StepModel { model, info });
    }
    // an assembly: each instance is built from its part's entities, placed
    for inst in &insts {
        let scope = Scope::reachable(t, &[inst.root], &erec)?;
        let names = HashMap::from([(inst.root, inst.name.clone())]);
        add_scope(
            &geo.moved(inst.xf),
            &scope,
            &erec,
            &names,
            &mut model,
            &mut info,
        )?;
    }
    // solids of no product stay where the file draws them
    let placed: HashSet<u64> = insts.iter().map(|i| i.root).collect();
    let mut rest = Scope::everything(t).solids;
    rest.retain(|s| !placed.contains(s));
    if !rest.is_empty() {
        let scope = Scope::reachable(t, &rest, &erec)?;
        add_scope(&geo, &scope, &erec, &HashMap::new(), &mut model, &mut info)?;
    }
    Ok(StepModel { model, info })
}

/// Builds the entities of `scope` with `geo` (its motion applied) and
/// appends them to `model` and `info`. `names`: volume names by solid id
/// (`#id` otherwise).
fn add_scope(
    geo: &Geo,
    scope: &Scope,
    erec: &HashMap<u64, EdgeRec>,
    names: &HashMap<u64, String>,
    model: &mut Model,
    info: &mut StepInfo,
) -> Result<(), StepError> {
    let t = geo.t;
    let mut points: HashMap<u64, P3> = HashMap::new();
    for &id in &scope.vertices {
        let a = t.args(id, &["VERTEX_POINT"], 2)?;
        points.insert(id, geo.point(t.r(id, &a[1], "vertex_geometry")?)?);
    }

    // degenerate edges: on a LINE, from a vertex to itself or to one within
    // the tolerance (written at poles and collapsed boundaries): the
    // vertices are one vertex and the edge is no model edge
    let line_tol = (REL_TOL * geo.vertex_extent).max(geo.uncertainty);
    let mut parent: HashMap<u64, u64> = HashMap::new();
    fn find(parent: &HashMap<u64, u64>, mut v: u64) -> u64 {
        while let Some(&p) = parent.get(&v) {
            v = p;
        }
        v
    }
    let mut degenerate: HashSet<u64> = HashSet::new();
    for &id in &scope.edges {
        let r = &erec[&id];
        if !is_line(t, r.geom, 0) {
            continue;
        }
        if r.v1 == r.v2 || (points[&r.v1] - points[&r.v2]).norm() <= line_tol {
            degenerate.insert(id);
            let (a, b) = (find(&parent, r.v1), find(&parent, r.v2));
            if a != b {
                parent.insert(a.max(b), a.min(b));
            }
        }
    }
    // the scope's edges with merged vertices
    let erec_own: HashMap<u64, EdgeRec>;
    let erec = if parent.is_empty() {
        erec
    } else {
        erec_own = scope
            .edges
            .iter()
            .map(|&id| {
                let r = &erec[&id];
                (
                    id,
                    EdgeRec {
                        v1: find(&parent, r.v1),
                        v2: find(&parent, r.v2),
                        geom: r.geom,
                        same_sense: r.same_sense,
                    },
                )
            })
            .collect();
        &erec_own
    };

    // vertices: one per merged class
    let mut vmap: HashMap<u64, u32> = HashMap::new();
    for &id in &scope.vertices {
        if parent.contains_key(&id) {
            continue;
        }
        vmap.insert(id, model.vertices.len() as u32);
        info.vertex_ids.push(id);
        model.vertices.push(Vertex {
            point: points[&id],
            name: Some(format!("#{id}")),
        });
    }
    for &id in &scope.vertices {
        let root = find(&parent, id);
        if root != id {
            vmap.insert(id, vmap[&root]);
        }
    }

    // faces, raw, without their degenerate edges (a bound made of
    // degenerate edges only is its vertex)
    let mut raws = Vec::with_capacity(scope.faces.len());
    for &id in &scope.faces {
        let mut raw = read_face(t, id, erec)?;
        if !degenerate.is_empty() {
            let mut bounds = Vec::with_capacity(raw.bounds.len());
            for b in std::mem::take(&mut raw.bounds) {
                let kept: Vec<Use> = b
                    .iter()
                    .copied()
                    .filter(|u| !degenerate.contains(&u.edge))
                    .collect();
                if kept.is_empty() {
                    raw.vertex_loops.push(erec[&b[0].edge].v1);
                } else {
                    bounds.push(kept);
                }
            }
            raw.bounds = bounds;
        }
        raws.push(raw);
    }

    // seams: edges used twice by one face
    let mut seam_of_face: Vec<HashSet<u64>> = Vec::with_capacity(raws.len());
    let mut non_seam_use: HashSet<u64> = HashSet::new();
    let mut any_use: HashSet<u64> = HashSet::new();
    for f in &raws {
        let mut count: HashMap<u64, (usize, usize)> = HashMap::new();
        for u in f.bounds.iter().flatten() {
            let c = count.entry(u.edge).or_default();
            if u.dir {
                c.0 += 1
            } else {
                c.1 += 1
            }
            any_use.insert(u.edge);
        }
        let mut seams = HashSet::new();
        for (&e, &(fw, bw)) in &count {
            if fw + bw == 1 {
                non_seam_use.insert(e);
            } else if fw == 1 && bw == 1 {
                seams.insert(e);
            } else {
                return Err(t.err(
                    f.id,
                    format!(
                        "uses edge #{e} {} times ({fw} forward, {bw} backward); only seams (once each way) may repeat",
                        fw + bw
                    ),
                ));
            }
        }
        seam_of_face.push(seams);
    }

    // model edges: every EDGE_CURVE but the seams used only as seams
    let mut emap: HashMap<u64, u32> = HashMap::new();
    for &id in &scope.edges {
        if degenerate.contains(&id) {
            info.degenerate_edges.push(id);
            continue;
        }
        if any_use.contains(&id) && !non_seam_use.contains(&id) {
            info.seams.push(id);
            continue;
        }
        let r = &erec[&id];
        let edge = build_edge(geo, id, r, &vmap, model)?;
        emap.insert(id, model.edges.len() as u32);
        info.edge_ids.push(id);
        model.edges.push(edge);
    }

    // faces
    let mut fmap: HashMap<u64, u32> = HashMap::new();
    for (f, seams) in raws.iter().zip(&seam_of_face) {
        let (face, gap) = build_face(geo, f, seams, erec, &emap, &vmap, model)?;
        info.face_gap.push(gap);
        fmap.insert(f.id, model.faces.len() as u32);
        info.face_ids.push(f.id);
        info.face_same_sense.push(f.same_sense);
        model.faces.push(face);
    }

    // solids and shells
    let mut shell_seen: HashSet<u64> = HashSet::new();
    for &id in &scope.solids {
        let vol = model.volumes.len() as u32;
        let mut faces = Vec::new();
        for (s, outer) in solid_shells(t, id)? {
            // a void's ORIENTED_CLOSED_SHELL is normally .F.: its faces, as
            // read, point into the void; the role is what `outer` records
            let (sid, _orient) = resolve_shell(t, s)?;
            let sf = shell_faces(t, sid, &fmap, info)?;
            shell_seen.insert(sid);
            faces.extend(sf.iter().cloned());
            info.shells.push(ShellInfo {
                step_id: sid,
                closed: t.get(sid)?.is("CLOSED_SHELL"),
                outer,
                volume: Some(vol),
                faces: sf,
            });
        }
        model.volumes.push(Volume {
            faces,
            geometry: None,
            name: Some(names.get(&id).cloned().unwrap_or_else(|| format!("#{id}"))),
        });
    }
    for &sid in &scope.shells {
        if shell_seen.contains(&sid) {
            continue;
        }
        let sf = shell_faces(t, sid, &fmap, info)?;
        info.shells.push(ShellInfo {
            step_id: sid,
            closed: t.get(sid)?.is("CLOSED_SHELL"),
            outer: true,
            volume: None,
            faces: sf,
        });
    }
    Ok(())
}

/// Whether curve `id` is a LINE (possibly as the 3D curve of a
/// SURFACE_CURVE / SEAM_CURVE or the basis of a TRIMMED_CURVE).
fn is_line(t: &Table, id: u64, depth: usize) -> bool {
    let Ok(e) = t.get(id) else {
        return false;
    };
    if e.is("LINE") {
        return true;
    }
    if depth > 8 {
        return false;
    }
    for n in ["SURFACE_CURVE", "SEAM_CURVE", "TRIMMED_CURVE"] {
        if let Some(p) = e.part(n) {
            return p
                .get(1)
                .and_then(|x| t.r(id, x, "curve").ok())
                .is_some_and(|c| is_line(t, c, depth + 1));
        }
    }
    false
}

/// A shell reference, through ORIENTED_CLOSED_SHELL: (shell id, orientation).
fn resolve_shell(t: &Table, id: u64) -> Result<(u64, bool), StepError> {
    let e = t.get(id)?;
    if e.is("ORIENTED_CLOSED_SHELL") || e.is("ORIENTED_OPEN_SHELL") {
        let a = t.args(id, &["ORIENTED_CLOSED_SHELL", "ORIENTED_OPEN_SHELL"], 4)?;
        let inner = t.r(id, &a[2], "closed_shell_element")?;
        let o = t.boolean(id, &a[3], "orientation")?;
        let (s, o2) = resolve_shell(t, inner)?;
        return Ok((s, o == o2));
    }
    if e.is("CLOSED_SHELL") || e.is("OPEN_SHELL") {
        return Ok((id, true));
    }
    Err(t.err(
        id,
        "expected a CLOSED_SHELL, OPEN_SHELL or ORIENTED_CLOSED_SHELL",
    ))
}

/// The model faces of a shell; an ORIENTED_FACE .F. flips the face's
/// recorded sense.
fn shell_faces(
    t: &Table,
    sid: u64,
    fmap: &HashMap<u64, u32>,
    info: &mut StepInfo,
) -> Result<Vec<u32>, StepError> {
    let a = t.args(sid, &["CLOSED_SHELL", "OPEN_SHELL"], 2)?;
    let mut out = Vec::new();
    for f in t.refs(sid, &a[1], "cfs_faces")? {
        let (fid, o) = if t.get(f)?.is("ORIENTED_FACE") {
            let b = t.args(f, &["ORIENTED_FACE"], 4)?;
            (
                t.r(f, &b[2], "face_element")?,
                t.boolean(f, &b[3], "orientation")?,
            )
        } else {
            (f, true)
        };
        let m = *fmap
            .get(&fid)
            .ok_or_else(|| t.err(sid, format!("face #{fid} is not an ADVANCED_FACE")))?;
        if !o {
            info.face_same_sense[m as usize] = !info.face_same_sense[m as usize];
        }
        out.push(m);
    }
    Ok(out)
}

/// An ORIENTED_EDGE (or a bare EDGE_CURVE) as a use.
fn read_use(t: &Table, id: u64, depth: usize) -> Result<Use, StepError> {
    if depth > 8 {
        return Err(t.err(id, "oriented edges nest too deeply"));
    }
    let e = t.get(id)?;
    if e.is("EDGE_CURVE") {
        return Ok(Use {
            edge: id,
            dir: true,
        });
    }
    let a = t.args(id, &["ORIENTED_EDGE"], 5)?;
    let inner = read_use(t, t.r(id, &a[3], "edge_element")?, depth + 1)?;
    let o = t.boolean(id, &a[4], "orientation")?;
    Ok(Use {
        edge: inner.edge,
        dir: inner.dir == o,
    })
}

fn read_face(t: &Table, id: u64, erec: &HashMap<u64, EdgeRec>) -> Result<FaceRaw, StepError> {
    let a = t.args(id, &["ADVANCED_FACE", "FACE_SURFACE"], 4)?;
    let surface = t.r(id, &a[2], "face_geometry")?;
    let same_sense = t.boolean(id, &a[3], "same_sense")?;
    let mut bounds = Vec::new();
    let mut vertex_loops = Vec::new();
    for b in t.refs(id, &a[1], "bounds")? {
        let ba = t.args(b, &["FACE_OUTER_BOUND", "FACE_BOUND"], 3)?;
        let lp = t.r(b, &ba[1], "bound")?;
        let orient = t.boolean(b, &ba[2], "orientation")?;
        let le = t.get(lp)?;
        if le.is("VERTEX_LOOP") {
            let la = t.args(lp, &["VERTEX_LOOP"], 2)?;
            vertex_loops.push(t.r(lp, &la[1], "loop_vertex")?);
            continue;
        }
        if !le.is("EDGE_LOOP") {
            return Err(t.err(
                lp,
                "unsupported loop type (supported: EDGE_LOOP, VERTEX_LOOP)",
            ));
        }
        let la = t.args(lp, &["EDGE_LOOP"], 2)?;
        let mut uses = Vec::new();
        for oe in t.refs(lp, &la[1], "edge_list")? {
            let u = read_use(t, oe, 0)?;
            if !erec.contains_key(&u.edge) {
                return Err(t.err(oe, format!("edge #{} is not an EDGE_CURVE", u.edge)));
            }
            uses.push(u);
        }
        if uses.is_empty() {
            return Err(t.err(lp, "empty edge loop"));
        }
        if !orient {
            uses.reverse();
            for u in &mut uses {
                u.dir = !u.dir;
            }
        }
        // the loop must be connected
        let ends = |u: &Use| {
            let r = &erec[&u.edge];
            if u.dir {
                (r.v1, r.v2)
            } else {
                (r.v2, r.v1)
            }
        };
        for k in 0..uses.len() {
            let (_, e0) = ends(&uses[k]);
            let (s1, _) = ends(&uses[(k + 1) % uses.len()]);
            if e0 != s1 {
                return Err(t.err(
                    lp,
                    format!(
                        "is not connected: edge #{} ends at #{e0} but the next edge #{} starts at #{s1}",
                        uses[k].edge,
                        uses[(k + 1) % uses.len()].edge
                    ),
                ));
            }
        }
        bounds.push(uses);
    }
    Ok(FaceRaw {
        id,
        surface,
        same_sense,
        bounds,
        vertex_loops,
    })
}

/// Tolerance on distances, relative to the file's extent (raised to the
/// file's `UNCERTAINTY_MEASURE_WITH_UNIT` where that is larger).
const REL_TOL: f64 = 1e-6;

/// An EDGE_CURVE as a model edge running along its curve's direction: from
/// edge_start to edge_end when same_sense, else the other way.
fn build_edge(
    geo: &Geo,
    id: u64,
    r: &EdgeRec,
    vmap: &HashMap<u64, u32>,
    model: &Model,
) -> Result<Edge, StepError> {
    let t = geo.t;
    let (va, vb) = if r.same_sense {
        (r.v1, r.v2)
    } else {
        (r.v2, r.v1)
    };
    let (ma, mb) = (vmap[&va], vmap[&vb]);
    let (a, b) = (
        model.vertices[ma as usize].point,
        model.vertices[mb as usize].point,
    );
    let closed = va == vb;
    let bad = |g: bubblemesh_analytic::GeometryError| t.err(id, g.to_string());
    // the file's own uncertainty where it is larger
    let tol = (REL_TOL * geo.extent).max(geo.uncertainty);
    // angles of a conic: the second after the first, a full turn if closed
    let sweep = |ta: f64, tb: f64| {
        let mut tb = ta + (tb - ta).rem_euclid(TAU);
        if closed || tb - ta <= 1e-12 {
            tb = ta + TAU;
        }
        tb
    };
    let (curve, t0, t1): (Arc<dyn Curve>, f64, f64) = match geo.curve(r.geom)? {
        CurveGeom::Line { p: _, d: _ } => {
            // degenerate lines were taken out before: what is left is refused
            if closed || (b - a).norm() <= 1e-12 * geo.extent {
                return Err(t.err(id, "a closed edge on a LINE"));
            }
            (Arc::new(Line::new(a, b).map_err(bad)?), 0.0, 1.0)
        }
        CurveGeom::Circle { pl, r: rad } => {
            let ang = |p: &bubblemesh_core::geom::P3| {
                let d = p - pl.o;
                d.dot(&pl.y).atan2(d.dot(&pl.x))
            };
            let ta = ang(&a);
            let tb = sweep(ta, ang(&b));
            let c = CircleArc::with_basis(pl.o, pl.x, pl.y, rad, ta, tb).map_err(bad)?;
            (Arc::new(c), ta, tb)
        }
        CurveGeom::Ellipse { pl, a: sa, b: sb } => {
            let full = EllipseArc::new(pl.o, pl.x, pl.y, sa, sb, 0.0, TAU).map_err(bad)?;
            let ta = full.angle_of(&a);
            let tb = sweep(ta, full.angle_of(&b));
            let c = EllipseArc::new(pl.o, pl.x, pl.y, sa, sb, ta, tb).map_err(bad)?;
            (Arc::new(c), ta, tb)
        }
        CurveGeom::Hyperbola { pl, a: sa, b: sb } => {
            let probe = HyperbolaArc::new(pl.o, pl.x, pl.y, sa, sb, -1.0, 1.0).map_err(bad)?;
            let (ta, tb) = (probe.parameter_of(&a), probe.parameter_of(&b));
            if closed || !(tb > ta) {
                return Err(t.err(id, "its vertices are out of order along its hyperbola"));
            }
            let c = HyperbolaArc::new(pl.o, pl.x, pl.y, sa, sb, ta, tb).map_err(bad)?;
            (Arc::new(c), ta, tb)
        }
        CurveGeom::Parabola { pl, f } => {
            let probe = crate::step::curves::Parabola {
                o: pl.o,
                x: pl.x,
                y: pl.y,
                f,
                t0: -1.0,
                t1: 1.0,
            };
            let (ta, tb) = (probe.parameter_of(&a), probe.parameter_of(&b));
            if closed || !(tb > ta) {
                return Err(t.err(id, "its vertices are out of order along its parabola"));
            }
            let c = crate::step::curves::Parabola {
                t0: ta,
                t1: tb,
                ..probe
            };
            (Arc::new(c), ta, tb)
        }
        CurveGeom::Spline(n) => {
            let samples = (16 * n.span_count()).clamp(32, 4000);
            trim_general(t, id, r, n.clone(), (a, b), samples, closed, tol, false)?
        }
        CurveGeom::General(c) => trim_general(t, id, r, c, (a, b), 1024, closed, tol, true)?,
    };
    Ok(Edge {
        curve,
        t0,
        t1,
        start: ma,
        end: mb,
        name: Some(format!("#{id}")),
    })
}

/// A bounded curve trimmed to the edge's vertices `a`, `b` (in the edge's
/// direction) by closest-point inversion, across the start of a closed
/// curve where needed. `general`: not a B-spline but a curve that may pass
/// a point more than once (a pcurve line on a cylinder winds around it):
/// the edge starts at the first pass near `a` and ends at the first pass
/// near `b` after it.
#[allow(clippy::too_many_arguments)]
fn trim_general(
    t: &Table,
    id: u64,
    r: &EdgeRec,
    n: Arc<dyn Curve>,
    (a, b): (P3, P3),
    samples: usize,
    closed: bool,
    tol: f64,
    general: bool,
) -> Result<(Arc<dyn Curve>, f64, f64), StepError> {
    let what = if general { "curve" } else { "B-spline curve" };
    let (lo, hi) = n.interval();
    let per = hi - lo;
    let curve_closed = (n.point(lo) - n.point(hi)).norm() <= tol.max(1e-9);
    let far = 1e3 * tol;
    let (mut ta, da, mut tb, db) = if general {
        let (ta, da) = first_near(n.as_ref(), &a, lo, hi, samples, far);
        let from = if curve_closed { lo } else { ta };
        let (tb, db) = first_near(n.as_ref(), &b, from, hi, samples, far);
        (ta, da, tb, db)
    } else {
        let (ta, da) = closest_parameter(n.as_ref(), &a, lo, hi, samples);
        let (tb, db) = closest_parameter(n.as_ref(), &b, lo, hi, samples);
        (ta, da, tb, db)
    };
    if da > far || db > far {
        return Err(t.err(
            id,
            format!(
                "its vertices lie {:.3e} and {:.3e} from its {what} #{}",
                da, db, r.geom
            ),
        ));
    }
    Ok(if curve_closed {
        if hi - ta <= 1e-12 * per {
            ta = lo;
        }
        tb = ta + (tb - ta).rem_euclid(per);
        if closed || tb - ta <= 1e-12 * per {
            tb = ta + per;
        }
        if tb > hi + 1e-12 * per {
            (Arc::new(WrappedCurve::new(n.clone())), ta, tb)
        } else {
            (n.clone(), ta, tb.min(hi))
        }
    } else {
        if closed {
            return Err(t.err(id, format!("a closed edge on an open {what}")));
        }
        if !(tb > ta) {
            return Err(t.err(
                id,
                format!(
                    "its vertices are out of order along its curve #{} (t = {ta} then {tb}; same_sense = {})",
                    r.geom, r.same_sense
                ),
            ));
        }
        (n.clone(), ta, tb)
    })
}

/// The first parameter in `[lo, hi]` where `c` passes within `near` of `p`
/// (a local minimum of the distance among `samples` + 1 samples, refined),
/// else the closest overall. Returns (t, distance).
fn first_near(c: &dyn Curve, p: &P3, lo: f64, hi: f64, samples: usize, near: f64) -> (f64, f64) {
    let n = samples.max(2);
    let h = (hi - lo) / n as f64;
    let d: Vec<f64> = (0..=n)
        .map(|k| (c.point(lo + h * k as f64) - p).norm())
        .collect();
    for k in 0..=n {
        let left = k == 0 || d[k] <= d[k - 1];
        let right = k == n || d[k] <= d[k + 1];
        if left && right {
            let a = lo + h * k.saturating_sub(1) as f64;
            let b = (lo + h * (k + 1) as f64).min(hi);
            let (t, dist) = closest_parameter(c, p, a, b, 8);
            if dist <= near {
                return (t, dist);
            }
        }
    }
    closest_parameter(c, p, lo, hi, samples)
}

/// The face: loops without its seams, on a view of its surface.
#[allow(clippy::too_many_arguments)]
fn build_face(
    geo: &Geo,
    f: &FaceRaw,
    seams: &HashSet<u64>,
    erec: &HashMap<u64, EdgeRec>,
    emap: &HashMap<u64, u32>,
    vmap: &HashMap<u64, u32>,
    model: &Model,
) -> Result<(Face, f64), StepError> {
    let t = geo.t;
    let ends = |u: &Use| {
        let r = &erec[&u.edge];
        if u.dir {
            (r.v1, r.v2)
        } else {
            (r.v2, r.v1)
        }
    };
    // chains of non-seam uses
    let mut chains: Vec<Vec<Use>> = Vec::new();
    let mut seam_vertices: Vec<u64> = Vec::new();
    for b in &f.bounds {
        let first_seam = b.iter().position(|u| seams.contains(&u.edge));
        match first_seam {
            None => chains.push(b.clone()),
            Some(s) => {
                let n = b.len();
                let mut cur: Vec<Use> = Vec::new();
                for k in 1..=n {
                    let u = b[(s + k) % n];
                    if seams.contains(&u.edge) {
                        let (x, y) = ends(&u);
                        seam_vertices.extend([x, y]);
                        if !cur.is_empty() {
                            chains.push(std::mem::take(&mut cur));
                        }
                    } else {
                        cur.push(u);
                    }
                }
                if !cur.is_empty() {
                    chains.push(cur);
                }
            }
        }
    }
    // join chains into closed loops
    let mut loops_step: Vec<Vec<Use>> = Vec::new();
    while let Some(mut c) = chains.pop() {
        loop {
            let start = ends(&c[0]).0;
            let end = ends(c.last().expect("chains are non-empty")).1;
            if start == end {
                break;
            }
            match chains.iter().position(|d| ends(&d[0]).0 == end) {
                Some(k) => {
                    let d = chains.swap_remove(k);
                    c.extend(d);
                }
                None => {
                    return Err(t.err(
                        f.id,
                        format!(
                            "its boundary does not close without its seam edges (open at vertex #{end})"
                        ),
                    ))
                }
            }
        }
        loops_step.push(c);
    }
    let loops: Vec<Loop> = loops_step
        .iter()
        .map(|l| Loop {
            edges: l
                .iter()
                .map(|u| EdgeUse {
                    edge: emap[&u.edge],
                    forward: u.dir == erec[&u.edge].same_sense,
                })
                .collect(),
        })
        .collect();
    // embedded vertices: vertex loops, seam ends on no loop
    let on_loops: HashSet<u64> = loops_step.iter().flatten().map(|u| ends(u).0).collect();
    let mut embedded: Vec<u32> = Vec::new();
    for v in f.vertex_loops.iter().chain(&seam_vertices) {
        let m = *vmap
            .get(v)
            .ok_or_else(|| t.err(f.id, format!("vertex #{v} is not a VERTEX_POINT")))?;
        if !on_loops.contains(v) && !embedded.contains(&m) {
            embedded.push(m);
        }
    }

    let sg = geo.surface(f.surface)?;
    // boundary points off their surface: 1e-3 of the file, or of the parts
    // (1e-2), or ten times the file's own uncertainty, whichever is largest
    // (OpenCascade heals and meshes faces whose boundaries are that far off)
    let far = (1e-3 * geo.extent)
        .max(1e-2 * geo.vertex_extent)
        .max(10.0 * geo.uncertainty);
    crate::face_build::face_from_loops_within(
        sg.surface.clone(),
        sg.planar,
        f.same_sense,
        loops,
        embedded,
        model,
        far,
        format!("#{}", f.id),
        crate::face_build::LoopSense::Oriented { sphere: sg.sphere },
    )
    .map_err(|m| t.err(f.id, format!("{m} (surface #{})", f.surface)))
}
