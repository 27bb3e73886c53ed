//! `FACETED_BREP`s and `POLY_LOOP`s (ISO 10303-42 §5.4.11), rewritten into
//! the topology the rest of the reader builds from: each polygon side a
//! straight `EDGE_CURVE` between `VERTEX_POINT`s (one per distinct point,
//! one edge per pair of points, shared by the faces on both sides), each
//! `POLY_LOOP` an `EDGE_LOOP` of `ORIENTED_EDGE`s under the same id, and a
//! `FACE` without geometry a `FACE_SURFACE` on the plane of its outer
//! polygon (its normal by Newell's formula, so the polygon runs counter-
//! clockwise about it as ISO 10303-42 orients faces of a solid). The
//! entities added get ids above the file's largest; a `FACETED_BREP` itself
//! is read like a `MANIFOLD_SOLID_BREP`.

use std::collections::HashMap;

use truck_stepio::r#in::ruststep::ast::{Name, Parameter, Record};

use super::table::{Entity, Table};
use super::StepError;

fn rf(id: u64) -> Parameter {
    Parameter::Ref(Name::Entity(id))
}

fn simple(name: &str, params: Vec<Parameter>) -> Entity {
    Entity {
        records: vec![Record {
            name: name.to_string(),
            parameter: Parameter::List(params),
        }],
    }
}

fn enum_bool(b: bool) -> Parameter {
    Parameter::Enumeration(if b { "T" } else { "F" }.to_string())
}

fn reals(v: [f64; 3]) -> Parameter {
    Parameter::List(v.iter().map(|&x| Parameter::Real(x)).collect())
}

struct Writer<'t> {
    t: &'t mut Table,
    next: u64,
}

impl Writer<'_> {
    fn add(&mut self, e: Entity) -> u64 {
        let id = self.next;
        self.next += 1;
        self.t.ents.insert(id, e);
        id
    }
    fn point(&mut self, p: [f64; 3]) -> u64 {
        self.add(simple(
            "CARTESIAN_POINT",
            vec![Parameter::String(String::new()), reals(p)],
        ))
    }
    fn direction(&mut self, d: [f64; 3]) -> u64 {
        self.add(simple(
            "DIRECTION",
            vec![Parameter::String(String::new()), reals(d)],
        ))
    }
}

/// Rewrites the file's POLY_LOOPs and geometry-less FACEs in place (see the
/// module documentation). Files without POLY_LOOP are left as they are.
pub(crate) fn expand(t: &mut Table) -> Result<(), StepError> {
    let loops = t.ids_of("POLY_LOOP");
    if loops.is_empty() {
        return Ok(());
    }
    let next = t.ents.keys().max().copied().unwrap_or(0) + 1;
    // the polygons, read before anything changes
    // (loop, its points: (CARTESIAN_POINT, coordinates))
    type Polygon = (u64, Vec<(u64, [f64; 3])>);
    let mut polys: Vec<Polygon> = Vec::with_capacity(loops.len());
    for &lp in &loops {
        let a = t.args(lp, &["POLY_LOOP"], 2)?;
        let ids = t.refs(lp, &a[1], "polygon")?;
        let mut pts = Vec::with_capacity(ids.len());
        for q in ids {
            let pa = t.args(q, &["CARTESIAN_POINT"], 2)?;
            let c = t.coords(q, &pa[1], "coordinates")?;
            let [x, y, z] = c[..] else {
                return Err(t.err(
                    q,
                    format!("has {} coordinates, a 3D point is needed", c.len()),
                ));
            };
            pts.push((q, [x, y, z]));
        }
        polys.push((lp, pts));
    }
    let mut w = Writer { t, next };
    // one vertex per distinct point (by coordinates)
    let mut vertex_of: HashMap<[u64; 3], (u64, [f64; 3])> = HashMap::new();
    let mut edge_of: HashMap<(u64, u64), u64> = HashMap::new();
    // FACE → its outer polygon's Newell normal and a point
    let mut normal_of_loop: HashMap<u64, ([f64; 3], [f64; 3])> = HashMap::new();
    for (lp, pts) in polys {
        let mut vs: Vec<(u64, [f64; 3])> = Vec::with_capacity(pts.len());
        for (q, p) in &pts {
            let key = p.map(|x| (x + 0.0).to_bits());
            let v = match vertex_of.get(&key) {
                Some(v) => *v,
                None => {
                    let vp = w.add(simple(
                        "VERTEX_POINT",
                        vec![Parameter::String(String::new()), rf(*q)],
                    ));
                    vertex_of.insert(key, (vp, *p));
                    (vp, *p)
                }
            };
            if vs.last().map(|l| l.0) != Some(v.0) {
                vs.push(v);
            }
        }
        while vs.len() > 1 && vs.first().map(|f| f.0) == vs.last().map(|l| l.0) {
            vs.pop();
        }
        if vs.len() < 3 {
            return Err(w
                .t
                .err(lp, format!("a polygon of {} distinct points", vs.len())));
        }
        // Newell's normal
        let mut n = [0.0f64; 3];
        for k in 0..vs.len() {
            let (a, b) = (vs[k].1, vs[(k + 1) % vs.len()].1);
            n[0] += (a[1] - b[1]) * (a[2] + b[2]);
            n[1] += (a[2] - b[2]) * (a[0] + b[0]);
            n[2] += (a[0] - b[0]) * (a[1] + b[1]);
        }
        normal_of_loop.insert(lp, (n, vs[0].1));
        let mut oes = Vec::with_capacity(vs.len());
        for k in 0..vs.len() {
            let (a, b) = (vs[k], vs[(k + 1) % vs.len()]);
            let key = (a.0.min(b.0), a.0.max(b.0));
            let e = match edge_of.get(&key) {
                Some(&e) => e,
                None => {
                    let (s, f) = if a.0 == key.0 { (a, b) } else { (b, a) };
                    let d = [f.1[0] - s.1[0], f.1[1] - s.1[1], f.1[2] - s.1[2]];
                    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let dir = w.direction(d);
                    let vec = w.add(simple(
                        "VECTOR",
                        vec![
                            Parameter::String(String::new()),
                            rf(dir),
                            Parameter::Real(len),
                        ],
                    ));
                    let p0 = w.point(s.1);
                    let line = w.add(simple(
                        "LINE",
                        vec![Parameter::String(String::new()), rf(p0), rf(vec)],
                    ));
                    let e = w.add(simple(
                        "EDGE_CURVE",
                        vec![
                            Parameter::String(String::new()),
                            rf(s.0),
                            rf(f.0),
                            rf(line),
                            enum_bool(true),
                        ],
                    ));
                    edge_of.insert(key, e);
                    e
                }
            };
            oes.push(w.add(simple(
                "ORIENTED_EDGE",
                vec![
                    Parameter::String(String::new()),
                    Parameter::NotProvided,
                    Parameter::NotProvided,
                    rf(e),
                    enum_bool(a.0 == key.0),
                ],
            )));
        }
        w.t.ents.insert(
            lp,
            simple(
                "EDGE_LOOP",
                vec![
                    Parameter::String(String::new()),
                    Parameter::List(oes.into_iter().map(rf).collect()),
                ],
            ),
        );
    }
    // FACEs without geometry: on the plane of their outer polygon
    let faces: Vec<u64> =
        w.t.ids_of("FACE")
            .into_iter()
            .filter(|&f| w.t.ents[&f].records.len() == 1)
            .collect();
    for f in faces {
        let a = w.t.args(f, &["FACE"], 2)?.to_vec();
        let bounds = w.t.refs(f, &a[1], "bounds")?;
        let mut plane = None;
        for &b in &bounds {
            let be = w.t.get(b)?;
            let outer = be.is("FACE_OUTER_BOUND");
            let ba = w.t.args(b, &["FACE_OUTER_BOUND", "FACE_BOUND"], 3)?;
            let lp = w.t.r(b, &ba[1], "bound")?;
            let orient = w.t.boolean(b, &ba[2], "orientation")?;
            if let Some(&(n, p)) = normal_of_loop.get(&lp) {
                if plane.is_none() || outer {
                    let n = if orient { n } else { n.map(|x| -x) };
                    plane = Some((n, p));
                }
            }
        }
        let Some((n, p)) = plane else {
            return Err(w
                .t
                .err(f, "a FACE without geometry whose bounds are no POLY_LOOP"));
        };
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if !(len > 0.0) {
            return Err(w.t.err(f, "its polygon encloses no area"));
        }
        let o = w.point(p);
        let z = w.direction(n.map(|x| x / len));
        let ax = w.add(simple(
            "AXIS2_PLACEMENT_3D",
            vec![
                Parameter::String(String::new()),
                rf(o),
                rf(z),
                Parameter::NotProvided,
            ],
        ));
        let pl = w.add(simple(
            "PLANE",
            vec![Parameter::String(String::new()), rf(ax)],
        ));
        w.t.ents.insert(
            f,
            simple(
                "FACE_SURFACE",
                vec![a[0].clone(), a[1].clone(), rf(pl), enum_bool(true)],
            ),
        );
    }
    Ok(())
}

/// Each `CURVE_BOUNDED_SURFACE(name, basis_surface, boundaries,
/// implicit_outer)` that no face uses as its geometry becomes a
/// `FACE_SURFACE` on its basis surface bounded by its boundary curves: each
/// boundary one closed `EDGE_CURVE` on the curve, its vertex where the curve
/// starts (an `OUTER_BOUNDARY_CURVE` the outer bound). Added under new ids,
/// in an `OPEN_SHELL` of their own.
///
/// One that cannot be read fails the read when the file has no other faces;
/// beside other faces it is skipped, and the returned notes say why.
pub(crate) fn expand_curve_bounded(t: &mut Table) -> Result<Vec<String>, StepError> {
    let mut notes = Vec::new();
    let cbs = t.ids_of("CURVE_BOUNDED_SURFACE");
    if cbs.is_empty() {
        return Ok(notes);
    }
    let other_faces = !t.ids_of("ADVANCED_FACE").is_empty()
        || !t.ids_of("FACE_SURFACE").is_empty()
        || !t.ids_of("FACE").is_empty();
    // surfaces some face already uses
    let mut used = std::collections::HashSet::new();
    for f in t
        .ids_of("ADVANCED_FACE")
        .into_iter()
        .chain(t.ids_of("FACE_SURFACE"))
    {
        if let Ok(a) = t.args(f, &["ADVANCED_FACE", "FACE_SURFACE"], 3) {
            if let Ok(s) = t.r(f, &a[2], "face_geometry") {
                used.insert(s);
            }
        }
    }
    // (surface, basis, [(boundary curve, outer, start point)])
    let mut todo = Vec::new();
    {
        let geo = super::geometry::Geo::with_scale(t, 1.0);
        for id in cbs {
            if used.contains(&id) {
                continue;
            }
            match boundaries(t, &geo, id) {
                Ok(b) => todo.push(b),
                Err(e) if other_faces => notes.push(format!(
                    "#{id} CURVE_BOUNDED_SURFACE: skipped, it cannot be read as a face: {}",
                    e.reason
                )),
                Err(e) => return Err(e),
            }
        }
    }
    if todo.is_empty() {
        return Ok(notes);
    }
    let next = t.ents.keys().max().copied().unwrap_or(0) + 1;
    let mut w = Writer { t, next };
    let mut faces = Vec::new();
    for (_id, basis, bounds) in todo {
        let mut fb = Vec::new();
        for (b, outer, p) in bounds {
            let cp = w.point(p);
            let v = w.add(simple(
                "VERTEX_POINT",
                vec![Parameter::String(String::new()), rf(cp)],
            ));
            let e = w.add(simple(
                "EDGE_CURVE",
                vec![
                    Parameter::String(String::new()),
                    rf(v),
                    rf(v),
                    rf(b),
                    enum_bool(true),
                ],
            ));
            let oe = w.add(simple(
                "ORIENTED_EDGE",
                vec![
                    Parameter::String(String::new()),
                    Parameter::NotProvided,
                    Parameter::NotProvided,
                    rf(e),
                    enum_bool(true),
                ],
            ));
            let lp = w.add(simple(
                "EDGE_LOOP",
                vec![
                    Parameter::String(String::new()),
                    Parameter::List(vec![rf(oe)]),
                ],
            ));
            fb.push(w.add(simple(
                if outer {
                    "FACE_OUTER_BOUND"
                } else {
                    "FACE_BOUND"
                },
                vec![Parameter::String(String::new()), rf(lp), enum_bool(true)],
            )));
        }
        faces.push(w.add(simple(
            "FACE_SURFACE",
            vec![
                Parameter::String(String::new()),
                Parameter::List(fb.into_iter().map(rf).collect()),
                rf(basis),
                enum_bool(true),
            ],
        )));
    }
    w.add(simple(
        "OPEN_SHELL",
        vec![
            Parameter::String(String::new()),
            Parameter::List(faces.into_iter().map(rf).collect()),
        ],
    ));
    Ok(notes)
}

/// A CURVE_BOUNDED_SURFACE's (id, basis surface, boundaries: curve, whether
/// outer, start point).
#[allow(clippy::type_complexity)]
fn boundaries(
    t: &Table,
    geo: &super::geometry::Geo,
    id: u64,
) -> Result<(u64, u64, Vec<(u64, bool, [f64; 3])>), StepError> {
    let a = t.args(id, &["CURVE_BOUNDED_SURFACE"], 4)?;
    let basis = t.r(id, &a[1], "basis_surface")?;
    let implicit = t.boolean(id, &a[3], "implicit_outer")?;
    if implicit {
        return Err(t.err(
            id,
            "implicit_outer (the basis surface's own edges as the outer boundary) \
             is not supported",
        ));
    }
    let mut bounds = Vec::new();
    for b in t.refs(id, &a[2], "boundaries")? {
        let outer = t.get(b)?.is("OUTER_BOUNDARY_CURVE");
        let c = match geo.curve(b)? {
            super::geometry::CurveGeom::General(c) => c,
            super::geometry::CurveGeom::Spline(n) => n,
            _ => return Err(t.err(b, "a boundary must be a bounded curve")),
        };
        let (lo, hi) = c.interval();
        let (p, q) = (c.point(lo), c.point(hi));
        let gap = (p - q).norm();
        if gap > 1e-4 * geo.extent.max(1e-300) && gap > 10.0 * geo.uncertainty {
            return Err(t.err(
                b,
                format!("a boundary curve that does not close (its ends {gap:.3e} apart)"),
            ));
        }
        bounds.push((b, outer, [p.x, p.y, p.z]));
    }
    if bounds.is_empty() {
        return Err(t.err(id, "no boundaries"));
    }
    // without an OUTER_BOUNDARY_CURVE the first boundary is the outer one
    if !bounds.iter().any(|b| b.1) {
        bounds[0].1 = true;
    }
    Ok((id, basis, bounds))
}
