//! STEP topology (ISO 10303-42 §5) into a [`Model`]: vertices, trimmed
//! edges, faces with loops on a [`FaceView`], volumes from solids.

use std::collections::{HashMap, HashSet};
use std::f64::consts::TAU;
use std::sync::Arc;

use bubblemesh_analytic::{CircleArc, EllipseArc, HyperbolaArc, Line};
use bubblemesh_core::geom::{Curve, Surface};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex, Volume};

pub use super::geometry::MAX_CONTROL_POINTS;
use super::geometry::{CurveGeom, Geo};
use super::table::Table;
use super::{ShellInfo, StepError, StepInfo, StepModel};
use crate::curve_tools::{closest_parameter, WrappedCurve};
use crate::face_view::FaceView;

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

pub(crate) fn build(t: &Table) -> Result<StepModel, StepError> {
    let geo = Geo::new(t);
    let mut model = Model {
        source: Some(t.source.clone()),
        ..Default::default()
    };
    let mut info = StepInfo::default();

    // vertices
    let mut vmap: HashMap<u64, u32> = HashMap::new();
    for id in t.ids_of("VERTEX_POINT") {
        let a = t.args(id, &["VERTEX_POINT"], 2)?;
        let point = geo.point(t.r(id, &a[1], "vertex_geometry")?)?;
        vmap.insert(id, model.vertices.len() as u32);
        info.vertex_ids.push(id);
        model.vertices.push(Vertex {
            point,
            name: Some(format!("#{id}")),
        });
    }

    // edge records
    let mut erec: HashMap<u64, EdgeRec> = HashMap::new();
    let edge_ids = t.ids_of("EDGE_CURVE");
    for &id in &edge_ids {
        let a = t.args(id, &["EDGE_CURVE"], 5)?;
        let v1 = t.r(id, &a[1], "edge_start")?;
        let v2 = t.r(id, &a[2], "edge_end")?;
        for v in [v1, v2] {
            if !vmap.contains_key(&v) {
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

    // faces, raw
    let mut face_ids = t.ids_of("ADVANCED_FACE");
    face_ids.extend(t.ids_of("FACE_SURFACE"));
    face_ids.sort_unstable();
    face_ids.dedup();
    let mut raws = Vec::with_capacity(face_ids.len());
    for &id in &face_ids {
        raws.push(read_face(t, id, &erec)?);
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
    for &id in &edge_ids {
        if any_use.contains(&id) && !non_seam_use.contains(&id) {
            info.seams.push(id);
            continue;
        }
        let r = &erec[&id];
        let edge = build_edge(&geo, id, r, &vmap, &model)?;
        emap.insert(id, model.edges.len() as u32);
        info.edge_ids.push(id);
        model.edges.push(edge);
    }

    // faces
    let mut fmap: HashMap<u64, u32> = HashMap::new();
    for (f, seams) in raws.iter().zip(&seam_of_face) {
        let face = build_face(&geo, f, seams, &erec, &emap, &vmap, &model)?;
        fmap.insert(f.id, model.faces.len() as u32);
        info.face_ids.push(f.id);
        info.face_same_sense.push(f.same_sense);
        model.faces.push(face);
    }

    // solids and shells
    let mut shell_seen: HashSet<u64> = HashSet::new();
    let mut solids = t.ids_of("MANIFOLD_SOLID_BREP");
    solids.extend(t.ids_of("BREP_WITH_VOIDS"));
    solids.sort_unstable();
    solids.dedup();
    for id in solids {
        let e = t.get(id)?;
        let a = t.args(id, &["MANIFOLD_SOLID_BREP", "BREP_WITH_VOIDS"], 2)?;
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
        let vol = model.volumes.len() as u32;
        let mut faces = Vec::new();
        for (s, outer) in shells {
            // a void's ORIENTED_CLOSED_SHELL is normally .F.: its faces, as
            // read, point into the void; the role is what `outer` records
            let (sid, _orient) = resolve_shell(t, s)?;
            let sf = shell_faces(t, sid, &fmap, &mut info)?;
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
            name: Some(format!("#{id}")),
        });
    }
    let mut others = t.ids_of("CLOSED_SHELL");
    others.extend(t.ids_of("OPEN_SHELL"));
    others.sort_unstable();
    for sid in others {
        if shell_seen.contains(&sid) {
            continue;
        }
        let sf = shell_faces(t, sid, &fmap, &mut info)?;
        info.shells.push(ShellInfo {
            step_id: sid,
            closed: t.get(sid)?.is("CLOSED_SHELL"),
            outer: true,
            volume: None,
            faces: sf,
        });
    }
    Ok(StepModel { model, info })
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

/// Tolerance on distances, relative to the file's extent.
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
    let tol = REL_TOL * geo.extent;
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
            if closed || (b - a).norm() <= tol {
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
        CurveGeom::Spline(n) => {
            let (lo, hi) = n.interval();
            let per = hi - lo;
            let curve_closed = (n.point(lo) - n.point(hi)).norm() <= tol.max(1e-9);
            let samples = (16 * n.span_count()).clamp(32, 4000);
            let (mut ta, da) = closest_parameter(n.as_ref(), &a, lo, hi, samples);
            let (mut tb, db) = closest_parameter(n.as_ref(), &b, lo, hi, samples);
            let far = 1e3 * tol;
            if da > far || db > far {
                return Err(t.err(
                    id,
                    format!(
                        "its vertices lie {:.3e} and {:.3e} from its B-spline curve #{}",
                        da, db, r.geom
                    ),
                ));
            }
            if curve_closed {
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
                    (n.clone() as Arc<dyn Curve>, ta, tb.min(hi))
                }
            } else {
                if closed {
                    return Err(t.err(id, "a closed edge on an open B-spline curve"));
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
                (n.clone() as Arc<dyn Curve>, ta, tb)
            }
        }
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
) -> Result<Face, StepError> {
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
    let base = sg.surface.clone();
    // boundary samples in the base surface's (u,v), each loop unwrapped
    let far = 1e-3 * geo.extent;
    let mut hint: Option<[f64; 2]> = None;
    let mut loops_uv: Vec<Vec<[f64; 2]>> = Vec::new();
    let invert = |p: &bubblemesh_core::geom::P3,
                  hint: Option<[f64; 2]>,
                  what: &str|
     -> Result<[f64; 2], StepError> {
        let uv = base.inverse(p, hint).ok_or_else(|| {
            t.err(
                f.id,
                format!(
                    "{what} ({:.6}, {:.6}, {:.6}) cannot be mapped onto its surface #{}",
                    p.x, p.y, p.z, f.surface
                ),
            )
        })?;
        let d = (base.point(uv[0], uv[1]) - p).norm();
        if !(d <= far) {
            return Err(t.err(
                f.id,
                format!(
                    "{what} ({:.6}, {:.6}, {:.6}) lies {d:.3e} off its surface #{}",
                    p.x, p.y, p.z, f.surface
                ),
            ));
        }
        Ok(uv)
    };
    const K: usize = 8;
    for l in &loops.iter().map(|l| l.edges.clone()).collect::<Vec<_>>() {
        let mut pts = Vec::new();
        for u in l {
            let e = &model.edges[u.edge as usize];
            for k in 0..K {
                let s = k as f64 / K as f64;
                let s = if u.forward { s } else { 1.0 - s };
                let p = e.curve.point(e.t0 + (e.t1 - e.t0) * s);
                let uv = invert(&p, hint, "boundary point")?;
                hint = Some(uv);
                pts.push(uv);
            }
        }
        loops_uv.push(pts);
    }
    let periods = base.periods();
    let (bu, bv) = base.domain();
    let bdom = [bu, bv];
    let mut keep = [false, false];
    // each loop's net displacement in the periodic directions
    let mut nets: Vec<[f64; 2]> = Vec::with_capacity(loops_uv.len());
    for l in loops_uv.iter_mut() {
        let mut net = [0.0f64; 2];
        for k in 1..=l.len() {
            let prev = l[k - 1];
            let cur = if k < l.len() { l[k] } else { l[0] };
            for c in 0..2 {
                if let Some(p) = periods[c] {
                    let d = cur[c] - prev[c];
                    let d = d - p * (d / p).round();
                    net[c] += d;
                    if k < l.len() {
                        l[k][c] = prev[c] + d;
                    }
                }
            }
        }
        for c in 0..2 {
            if let Some(p) = periods[c] {
                if net[c].abs() > 0.5 * p {
                    keep[c] = true;
                }
            }
        }
        nets.push(net);
    }
    if loops_uv.is_empty() {
        keep = [periods[0].is_some(), periods[1].is_some()];
    }
    // other loops (and embedded vertices) moved next to the first loop
    let centre = |l: &[[f64; 2]]| {
        let n = l.len().max(1) as f64;
        [
            l.iter().map(|x| x[0]).sum::<f64>() / n,
            l.iter().map(|x| x[1]).sum::<f64>() / n,
        ]
    };
    let c0 = loops_uv.first().map(|l| centre(l));
    let mut extra: Vec<[f64; 2]> = Vec::new();
    for &v in &embedded {
        let p = model.vertices[v as usize].point;
        extra.push(invert(&p, hint, "vertex")?);
    }
    if let Some(c0) = c0 {
        for l in loops_uv.iter_mut().skip(1) {
            let c = centre(l);
            for k in 0..2 {
                if let (Some(p), false) = (periods[k], keep[k]) {
                    let s = p * ((c0[k] - c[k]) / p).round();
                    for x in l.iter_mut() {
                        x[k] += s;
                    }
                }
            }
        }
        for x in extra.iter_mut() {
            for k in 0..2 {
                if let (Some(p), false) = (periods[k], keep[k]) {
                    x[k] += p * ((c0[k] - x[k]) / p).round();
                }
            }
        }
    }
    if sg.planar {
        let mut order: Vec<usize> = (0..loops.len()).collect();
        order.sort_by(|&i, &j| area(&loops_uv[j]).total_cmp(&area(&loops_uv[i])));
        return Ok(Face {
            surface: base,
            loops: order.iter().map(|&i| loops[i].clone()).collect(),
            embedded_edges: vec![],
            embedded_vertices: embedded,
            name: Some(format!("#{}", f.id)),
        });
    }
    if keep[0] && keep[1] && !loops.is_empty() {
        return Err(t.err(
            f.id,
            "a face with boundary loops that wraps around its surface in both directions is not supported",
        ));
    }
    // A face that wraps around in one direction c may run from its
    // wrapping loops to an end of the other direction o where the surface
    // collapses (a cap to a sphere's pole): which end follows from the
    // loops' sense. A loop keeps the face on its left, seen from the face's
    // normal (S_u × S_v when same_sense): running +u it has the face at +v,
    // running +v it has the face at −u. `open_end` is Some(1) when the face
    // reaches the +o end, Some(0) the −o end, None when wrapping loops
    // bound it on both sides (a band).
    let mut open_end: Option<usize> = None;
    let wrap_dir = match keep {
        [true, false] => Some(0),
        [false, true] => Some(1),
        _ => None,
    };
    if let (Some(c), false) = (wrap_dir, loops_uv.is_empty()) {
        let p = periods[c].expect("a kept direction is periodic");
        let sense = if f.same_sense { 1 } else { -1 };
        let towards_plus: i32 = nets
            .iter()
            .filter(|n| n[c].abs() > 0.5 * p)
            .map(|n| if n[c] > 0.0 { 1 } else { -1 })
            .sum::<i32>()
            * sense
            * if c == 0 { 1 } else { -1 };
        open_end = match towards_plus {
            0 => None,
            1 => Some(1),
            -1 => Some(0),
            k => return Err(t.err(
                f.id,
                format!(
                    "its boundary wraps around its surface {k} times more one way than the other"
                ),
            )),
        };
    }
    // the view's box
    let mut dom = bdom;
    for c in 0..2 {
        if keep[c] {
            continue;
        }
        // a face without edge loops (a whole sphere bounded only by the
        // VERTEX_LOOP at its pole) spans the surface's whole range: its
        // pole points alone would collapse the range to a line
        let vals: Vec<f64> = if loops_uv.iter().any(|l| !l.is_empty()) {
            loops_uv
                .iter()
                .flatten()
                .chain(&extra)
                .map(|x| x[c])
                .collect()
        } else {
            Vec::new()
        };
        if vals.is_empty() {
            if !(bdom[c][0].is_finite() && bdom[c][1].is_finite()) {
                return Err(t.err(f.id, "a face with no boundary on an unbounded surface"));
            }
            continue;
        }
        let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        // exactly the boundary's range: on a periodic view the engine reads
        // the ends of the domain as where the face ends (or caps at a pole)
        let (mut a, mut b) = (lo, hi);
        if periods[c].is_none() {
            a = a.max(bdom[c][0]);
            b = b.min(bdom[c][1]);
        } else if let Some(p) = periods[c] {
            if b - a > p {
                let m = 0.5 * (a + b);
                a = m - 0.5 * p;
                b = m + 0.5 * p;
            }
        }
        dom[c] = [a, b];
        // the face runs on past its loops to a collapsed end in c: its
        // pole or apex vertex when the file has one (the range already
        // reaches it), else the surface's end
        let loop_lo = loops_uv
            .iter()
            .flatten()
            .map(|x| x[c])
            .fold(f64::INFINITY, f64::min);
        let loop_hi = loops_uv
            .iter()
            .flatten()
            .map(|x| x[c])
            .fold(f64::NEG_INFINITY, f64::max);
        let reached = |end: usize| {
            let tol = 1e-9 * (bdom[c][1] - bdom[c][0]).abs().min(1e6).max(1.0);
            if end == 1 {
                dom[c][1] > loop_hi + tol
            } else {
                dom[c][0] < loop_lo - tol
            }
        };
        if let Some(end) = open_end.filter(|&e| wrap_dir == Some(1 - c) && !reached(e)) {
            let e = bdom[c][end];
            if !e.is_finite() {
                return Err(t.err(
                    f.id,
                    "it is bounded on one side only by its loops around an unbounded surface",
                ));
            }
            dom[c][end] = e;
        }
    }
    let view_periods = [
        periods[0].filter(|_| keep[0]),
        periods[1].filter(|_| keep[1]),
    ];
    let mut view = FaceView::new(base, (dom[0], dom[1]), view_periods);
    if open_end == Some(1) {
        // the engine reads the far (+) end of the wrapped face's range as
        // outside: turn the view so the face's open end is at the near end
        view = view.turned();
    }
    let loops = if view_periods.iter().all(|p| p.is_none()) {
        let mut order: Vec<usize> = (0..loops.len()).collect();
        order.sort_by(|&i, &j| area(&loops_uv[j]).total_cmp(&area(&loops_uv[i])));
        order.iter().map(|&i| loops[i].clone()).collect()
    } else {
        loops
    };
    let surface: Arc<dyn Surface> = Arc::new(view);
    Ok(Face {
        surface,
        loops,
        embedded_edges: vec![],
        embedded_vertices: embedded,
        name: Some(format!("#{}", f.id)),
    })
}

/// |signed area| of a closed polygon in (u,v).
fn area(l: &[[f64; 2]]) -> f64 {
    let n = l.len();
    (0..n)
        .map(|k| {
            let (a, b) = (l[k], l[(k + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        .abs()
        * 0.5
}
