//! From the parsed schema to a [`Model`]: curve construction, vertex and
//! edge merging, loop orientation and the geometric validity checks.
//!
//! Two passes. Pass 1 turns every path of the file into oriented curve
//! pieces (checking numbers, radii, knot vectors) and measures the model's
//! bounding box, which fixes the tolerance. Pass 2 creates vertices and
//! edges (merging coincident ones), assembles loops, orients them and
//! checks the faces (closure, planarity, crossings, containment).

use std::collections::HashMap;
use std::f64::consts::TAU;
use std::sync::Arc;

use bubblemesh_core::geom::{Curve, Plane, Surface, P3, V3};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex};

use super::error::Invalid;
use super::planar::{
    collinear_overlap, dist, dist_to_segment, folds_back, inside, perimeter, segments_meet,
    signed_area, sweep_pairs, Seg, Xy,
};
use super::spec::{ArcSpec, DomainSpec, Geometry, NurbsSpec, PathSpec, Pt};
use crate::curves::{CircleArc, Line, Nurbs};

/// Default merge/gap tolerance relative to the model size (the diagonal of
/// the bounding box of all geometry).
pub const RELATIVE_TOLERANCE: f64 = 1e-9;

/// Number of chords per full turn used to sample arcs for validation.
const ARC_SAMPLES_PER_TURN: f64 = 128.0;
/// Upper bound on the samples of one NURBS edge.
const MAX_NURBS_SAMPLES: usize = 4096;

/// One oriented piece of a path: a whole curve, run from its parameter
/// start to its end (or backwards when `reversed`).
struct RawPiece {
    curve: Arc<dyn Curve>,
    reversed: bool,
    /// Chords used to sample the curve for validation.
    segments: usize,
    /// Where the piece sits in its path, e.g. `side 3`, `piece 2 (arc)`.
    label: String,
    /// The reason reported when the piece turns out degenerate.
    zero_msg: String,
    name: Option<String>,
}

impl RawPiece {
    fn start(&self) -> P3 {
        let (a, b) = self.curve.interval();
        self.curve.point(if self.reversed { b } else { a })
    }
    fn end(&self) -> P3 {
        let (a, b) = self.curve.interval();
        self.curve.point(if self.reversed { a } else { b })
    }
}

/// A path (loop, constraint or stand-alone curve) as a list of pieces
/// joined end to end.
struct RawPath {
    /// Full entity description, e.g. `face 'plate' (face #1), hole 2`.
    entity: String,
    pieces: Vec<RawPiece>,
}

struct RawFace {
    entity: String,
    name: Option<String>,
    outer: RawPath,
    holes: Vec<RawPath>,
    constraints: Vec<RawPath>,
    points: Vec<(P3, String)>,
}

/// Builds the model from a parsed file. `Err` carries the entity and the
/// reason; the caller attaches the file name.
pub(crate) fn build(spec: &DomainSpec) -> Result<Model, Invalid> {
    if let Some(t) = spec.tolerance {
        if !(t.is_finite() && t > 0.0) {
            return Err(Invalid::new(
                "key `tolerance`",
                format!("must be a positive finite number (got {t})"),
            ));
        }
    }
    if spec.face.is_empty()
        && spec.curve.is_empty()
        && spec.surface.is_empty()
        && spec.solid.is_empty()
    {
        return Err(Invalid::new(
            "",
            "the file defines nothing to mesh: add at least one [[face]], [[curve]], [[surface]] or [[solid]]",
        ));
    }

    // Pass 1: curves.
    let mut faces = Vec::with_capacity(spec.face.len());
    for (i, f) in spec.face.iter().enumerate() {
        let entity = match &f.name {
            Some(n) => format!("face '{n}' (face #{})", i + 1),
            None => format!("face #{}", i + 1),
        };
        let outer = raw_path(&f.outer, format!("{entity}, outer loop"))?;
        let holes = f
            .holes
            .iter()
            .enumerate()
            .map(|(k, h)| raw_path(h, format!("{entity}, hole {}", k + 1)))
            .collect::<Result<Vec<_>, _>>()?;
        let constraints = f
            .constraints
            .iter()
            .enumerate()
            .map(|(k, c)| raw_path(c, format!("{entity}, constraint {}", k + 1)))
            .collect::<Result<Vec<_>, _>>()?;
        let points = f
            .points
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let e = format!("{entity}, point {}", k + 1);
                to_p3(p, &e, "the point").map(|q| (q, e))
            })
            .collect::<Result<Vec<_>, _>>()?;
        faces.push(RawFace {
            entity,
            name: f.name.clone(),
            outer,
            holes,
            constraints,
            points,
        });
    }
    let mut curves = Vec::with_capacity(spec.curve.len());
    for (i, c) in spec.curve.iter().enumerate() {
        let entity = match &c.name {
            Some(n) => format!("curve '{n}' (curve #{})", i + 1),
            None => format!("curve #{}", i + 1),
        };
        curves.push(raw_path(c, entity)?);
    }

    // Tolerance from the bounding box of everything.
    let mut bb = BBox::default();
    for f in &faces {
        for p in std::iter::once(&f.outer)
            .chain(&f.holes)
            .chain(&f.constraints)
        {
            bb.add_path(p);
        }
        for (q, _) in &f.points {
            bb.add(q);
        }
    }
    for c in &curves {
        bb.add_path(c);
    }
    let size = bb.diagonal();
    if !size.is_finite() {
        return Err(Invalid::new(
            "",
            "coordinates are too large (the model size overflows a 64-bit float)",
        ));
    }
    let tol = match spec.tolerance {
        Some(t) => t,
        None if size > 0.0 => RELATIVE_TOLERANCE * size,
        None => RELATIVE_TOLERANCE,
    };

    // Pass 2: topology.
    let mut b = Builder::new(tol);
    let plane: Arc<dyn Surface> = Arc::new(Plane::xy());
    for f in &faces {
        let face = b.face(f, plane.clone())?;
        b.model.faces.push(face);
    }
    for c in &curves {
        b.path(c, false)?;
    }
    super::surface::add_surfaces(&spec.surface, &mut b.model)?;
    super::solid::add_solids(&spec.solid, &mut b.model)?;
    Ok(b.model)
}

// ---------------------------------------------------------------- pass 1

/// Converts `[x, y]` / `[x, y, z]` to a point, checking finiteness.
fn to_p3(pt: &Pt, entity: &str, what: &str) -> Result<P3, Invalid> {
    let p = match pt.as_slice() {
        [x, y] => P3::new(*x, *y, 0.0),
        [x, y, z] => P3::new(*x, *y, *z),
        _ => {
            return Err(Invalid::new(
                entity,
                format!(
                    "{what} must be [x, y] or [x, y, z] (got {} numbers)",
                    pt.len()
                ),
            ))
        }
    };
    if p.iter().any(|x| !x.is_finite()) {
        return Err(Invalid::new(
            entity,
            format!("{what} {pt:?} has a coordinate that is not a finite number"),
        ));
    }
    Ok(p)
}

fn to_points(pts: &[Pt], entity: &str) -> Result<Vec<P3>, Invalid> {
    pts.iter()
        .enumerate()
        .map(|(k, p)| to_p3(p, entity, &format!("point {}", k + 1)))
        .collect()
}

fn normal_of(n: &Option<Pt>, entity: &str) -> Result<V3, Invalid> {
    match n {
        None => Ok(V3::z()),
        Some(v) => match v.as_slice() {
            [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => {
                let n = V3::new(*x, *y, *z);
                if n.norm() > 0.0 {
                    Ok(n)
                } else {
                    Err(Invalid::new(entity, "the normal must not be [0, 0, 0]"))
                }
            }
            [_, _, _] => Err(Invalid::new(
                entity,
                format!("the normal {v:?} has a component that is not a finite number"),
            )),
            _ => Err(Invalid::new(
                entity,
                format!("the normal must be [nx, ny, nz] (got {} numbers)", v.len()),
            )),
        },
    }
}

fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e-3 && v.abs() < 1e9 {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".into()
        } else {
            s.into()
        }
    } else {
        format!("{v:.3e}")
    }
}

/// `(x, y)` or `(x, y, z)` for messages.
fn fmt_p(p: &P3) -> String {
    if p.z == 0.0 {
        format!("({}, {})", fmt_num(p.x), fmt_num(p.y))
    } else {
        format!("({}, {}, {})", fmt_num(p.x), fmt_num(p.y), fmt_num(p.z))
    }
}

fn fmt_xy(p: Xy) -> String {
    format!("({}, {})", fmt_num(p[0]), fmt_num(p[1]))
}

fn line_piece(
    a: P3,
    b: P3,
    label: String,
    zero_msg: String,
    name: Option<String>,
    entity: &str,
) -> Result<RawPiece, Invalid> {
    let l = Line::new(a, b).map_err(|e| Invalid::new(entity, e.to_string()))?;
    Ok(RawPiece {
        curve: Arc::new(l),
        reversed: false,
        segments: 1,
        label,
        zero_msg,
        name,
    })
}

fn arc_segments(a: &CircleArc) -> usize {
    ((a.sweep() / TAU * ARC_SAMPLES_PER_TURN).ceil() as usize).max(4)
}

fn arc_piece(a: &ArcSpec, entity: &str, name: Option<String>) -> Result<RawPiece, Invalid> {
    let c = to_p3(&a.center, entity, "the centre")?;
    let n = normal_of(&a.normal, entity)?;
    if !(a.radius.is_finite() && a.radius > 0.0) {
        return Err(Invalid::new(
            entity,
            format!("radius must be a positive finite number (got {})", a.radius),
        ));
    }
    if !(a.start.is_finite() && a.end.is_finite()) {
        return Err(Invalid::new(
            entity,
            "the start and end angles must be finite numbers",
        ));
    }
    let sweep = a.end - a.start;
    if sweep == 0.0 {
        return Err(Invalid::new(
            entity,
            format!(
                "start and end angles are equal ({} degrees), so the arc is empty",
                a.start
            ),
        ));
    }
    if sweep.abs() > 360.0 {
        return Err(Invalid::new(
            entity,
            format!(
                "an arc turns at most 360 degrees (start {}, end {}: {} degrees)",
                a.start, a.end, sweep
            ),
        ));
    }
    // Counter-clockwise when end > start; otherwise the same ccw arc run
    // backwards, so every arc curve turns positively about its normal.
    let (lo, hi, reversed) = if sweep > 0.0 {
        (a.start, a.end, false)
    } else {
        (a.end, a.start, true)
    };
    let arc = CircleArc::new(c, n, a.radius, lo.to_radians(), hi.to_radians())
        .map_err(|e| Invalid::new(entity, e.to_string()))?;
    Ok(RawPiece {
        segments: arc_segments(&arc),
        curve: Arc::new(arc),
        reversed,
        label: "arc".into(),
        zero_msg: "the arc is degenerate (radius within the tolerance)".into(),
        name,
    })
}

fn arc3_piece(pts: &[Pt], entity: &str, name: Option<String>) -> Result<RawPiece, Invalid> {
    if pts.len() != 3 {
        return Err(Invalid::new(
            entity,
            format!(
                "arc3 needs exactly 3 points: start, a point on the arc, end (got {})",
                pts.len()
            ),
        ));
    }
    let p = to_points(pts, entity)?;
    let arc =
        CircleArc::through(p[0], p[1], p[2]).map_err(|e| Invalid::new(entity, e.to_string()))?;
    // Keep arcs of the (x, y) plane turning counter-clockwise about +z: a
    // clockwise arc is stored as the reverse of its ccw twin.
    let (arc, reversed) = if arc.normal().z < 0.0 {
        (
            CircleArc::through(p[2], p[1], p[0])
                .map_err(|e| Invalid::new(entity, e.to_string()))?,
            true,
        )
    } else {
        (arc, false)
    };
    Ok(RawPiece {
        segments: arc_segments(&arc),
        curve: Arc::new(arc),
        reversed,
        label: "arc3".into(),
        zero_msg: "the arc is degenerate (its points coincide within the tolerance)".into(),
        name,
    })
}

fn nurbs_piece(n: &NurbsSpec, entity: &str, name: Option<String>) -> Result<RawPiece, Invalid> {
    let pts = to_points(&n.points, entity)?;
    let curve = match &n.knots {
        Some(k) => Nurbs::new(n.degree, pts, n.weights.clone(), k.clone()),
        None => Nurbs::clamped_uniform(n.degree, pts, n.weights.clone()),
    }
    .map_err(|e| Invalid::new(entity, e.to_string()))?;
    let segments = (curve.span_count() * (4 * curve.degree()).max(8)).clamp(8, MAX_NURBS_SAMPLES);
    Ok(RawPiece {
        curve: Arc::new(curve),
        reversed: false,
        segments,
        label: "nurbs".into(),
        zero_msg: "the NURBS curve has zero length".into(),
        name,
    })
}

/// The pieces of one geometry. `entity` already names the path (and the
/// chain piece, inside a chain).
fn pieces_of(
    g: &Geometry<'_>,
    entity: &str,
    name: Option<&String>,
) -> Result<Vec<RawPiece>, Invalid> {
    let name = name.cloned();
    match g {
        Geometry::Line(pts) => {
            if pts.len() != 2 {
                return Err(Invalid::new(
                    entity,
                    format!("a line needs exactly 2 points (got {})", pts.len()),
                ));
            }
            let p = to_points(pts, entity)?;
            Ok(vec![line_piece(
                p[0],
                p[1],
                "line".into(),
                format!(
                    "the line has zero length (both points are at {})",
                    fmt_p(&p[0])
                ),
                name,
                entity,
            )?])
        }
        Geometry::Polyline(pts) => {
            if pts.len() < 2 {
                return Err(Invalid::new(
                    entity,
                    format!("a polyline needs at least 2 points (got {})", pts.len()),
                ));
            }
            let p = to_points(pts, entity)?;
            (0..p.len() - 1)
                .map(|k| {
                    line_piece(
                        p[k],
                        p[k + 1],
                        format!("segment {}", k + 1),
                        format!(
                            "repeated consecutive points: points {} and {} are both at {}",
                            k + 1,
                            k + 2,
                            fmt_p(&p[k])
                        ),
                        name.clone(),
                        entity,
                    )
                })
                .collect()
        }
        Geometry::Polygon(pts) => {
            let mut p = to_points(pts, entity)?;
            // A closing copy of the first point is allowed and dropped.
            if p.len() > 3 && p.first() == p.last() {
                p.pop();
            }
            if p.len() < 3 {
                return Err(Invalid::new(
                    entity,
                    format!(
                        "a polygon needs at least 3 distinct corners (got {})",
                        p.len()
                    ),
                ));
            }
            let n = p.len();
            (0..n)
                .map(|k| {
                    let j = (k + 1) % n;
                    line_piece(
                        p[k],
                        p[j],
                        format!("side {}", k + 1),
                        format!(
                            "repeated consecutive points: points {} and {} are both at {}",
                            k + 1,
                            j + 1,
                            fmt_p(&p[k])
                        ),
                        name.clone(),
                        entity,
                    )
                })
                .collect()
        }
        Geometry::Circle(c) => {
            let center = to_p3(&c.center, entity, "the centre")?;
            let n = normal_of(&c.normal, entity)?;
            if !(c.radius.is_finite() && c.radius > 0.0) {
                return Err(Invalid::new(
                    entity,
                    format!("radius must be a positive finite number (got {})", c.radius),
                ));
            }
            let arc = CircleArc::new(center, n, c.radius, 0.0, TAU)
                .map_err(|e| Invalid::new(entity, e.to_string()))?;
            Ok(vec![RawPiece {
                segments: arc_segments(&arc),
                curve: Arc::new(arc),
                reversed: false,
                label: "circle".into(),
                zero_msg: "the circle is degenerate (radius within the tolerance)".into(),
                name,
            }])
        }
        Geometry::Arc(a) => Ok(vec![arc_piece(a, entity, name)?]),
        Geometry::Arc3(p) => Ok(vec![arc3_piece(p, entity, name)?]),
        Geometry::Nurbs(n) => Ok(vec![nurbs_piece(n, entity, name)?]),
        Geometry::Chain(pieces) => {
            if pieces.is_empty() {
                return Err(Invalid::new(entity, "a chain needs at least one piece"));
            }
            let mut out = Vec::new();
            for (k, pc) in pieces.iter().enumerate() {
                let g = pc
                    .geometry()
                    .map_err(|m| Invalid::new(format!("{entity}, piece {}", k + 1), m))?;
                let head = format!("piece {} ({})", k + 1, g.kind());
                let sub_entity = format!("{entity}, {head}");
                let subs = pieces_of(&g, &sub_entity, pc.name.as_ref().or(name.as_ref()))?;
                let single = subs.len() == 1;
                for mut s in subs {
                    s.label = if single {
                        head.clone()
                    } else {
                        format!("{head}, {}", s.label)
                    };
                    out.push(s);
                }
            }
            Ok(out)
        }
    }
}

fn raw_path(p: &PathSpec, entity: String) -> Result<RawPath, Invalid> {
    let g = p.geometry().map_err(|m| Invalid::new(entity.clone(), m))?;
    let pieces = pieces_of(&g, &entity, p.name.as_ref())?;
    Ok(RawPath { entity, pieces })
}

#[derive(Default)]
struct BBox {
    lo: Option<(P3, P3)>,
}

impl BBox {
    fn add(&mut self, p: &P3) {
        match &mut self.lo {
            None => self.lo = Some((*p, *p)),
            Some((lo, hi)) => {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
    }
    fn add_path(&mut self, path: &RawPath) {
        for pc in &path.pieces {
            let (a, b) = pc.curve.interval();
            for k in 0..=pc.segments {
                self.add(&pc.curve.point(a + (b - a) * k as f64 / pc.segments as f64));
            }
        }
    }
    fn diagonal(&self) -> f64 {
        self.lo.map(|(a, b)| (b - a).norm()).unwrap_or(0.0)
    }
}

// ---------------------------------------------------------------- pass 2

/// A sampled loop or constraint: points in traversal order (for a loop
/// the closing point is not repeated), each tagged with the model vertex it
/// is, if any.
struct Trace {
    xy: Vec<Xy>,
    tags: Vec<Option<u32>>,
    closed: bool,
}

impl Trace {
    /// The segments between consecutive points (and back to the first for
    /// a closed trace).
    fn segments(&self, owner: usize) -> Vec<Seg> {
        let n = self.xy.len();
        let m = if self.closed { n } else { n.saturating_sub(1) };
        (0..m)
            .map(|i| {
                let j = (i + 1) % n;
                Seg {
                    a: self.xy[i],
                    b: self.xy[j],
                    owner,
                    index: i,
                    va: self.tags[i],
                    vb: self.tags[j],
                }
            })
            .collect()
    }

    /// Whether segments `i` and `j` of this trace share an end point by
    /// construction.
    fn adjacent(&self, i: usize, j: usize) -> bool {
        let m = if self.closed {
            self.xy.len()
        } else {
            self.xy.len().saturating_sub(1)
        };
        let (i, j) = (i.min(j), i.max(j));
        j == i + 1 || (self.closed && i == 0 && j + 1 == m)
    }
}

/// A loop of a face being checked.
struct LoopData {
    uses: Vec<EdgeUse>,
    trace: Trace,
    /// `the outer loop`, `hole 2`.
    label: String,
    entity: String,
}

struct Builder {
    model: Model,
    tol: f64,
    /// Spatial hash of vertices, cells of size 2·tol.
    grid: HashMap<[i64; 3], Vec<u32>>,
    cell: f64,
    /// Edges by unordered vertex pair, for merging.
    edge_index: HashMap<(u32, u32), Vec<u32>>,
    /// Per edge: sample points in parameter order; the ends are exactly the
    /// edge's vertex points.
    samples: Vec<Vec<P3>>,
}

impl Builder {
    fn new(tol: f64) -> Self {
        Builder {
            model: Model::default(),
            tol,
            grid: HashMap::new(),
            cell: 2.0 * tol,
            edge_index: HashMap::new(),
            samples: Vec::new(),
        }
    }

    fn cell_of(&self, p: &P3) -> [i64; 3] {
        // `as` saturates, so huge ratios cannot overflow.
        [
            (p.x / self.cell).floor() as i64,
            (p.y / self.cell).floor() as i64,
            (p.z / self.cell).floor() as i64,
        ]
    }

    /// The vertex at `p`: an existing one within the tolerance (the
    /// nearest), or a new one.
    fn vertex(&mut self, p: P3) -> u32 {
        let c = self.cell_of(&p);
        let mut best: Option<(f64, u32)> = None;
        for dx in -1..=1i64 {
            for dy in -1..=1i64 {
                for dz in -1..=1i64 {
                    let key = [
                        c[0].saturating_add(dx),
                        c[1].saturating_add(dy),
                        c[2].saturating_add(dz),
                    ];
                    if let Some(ids) = self.grid.get(&key) {
                        for &id in ids {
                            let d = (self.model.vertices[id as usize].point - p).norm();
                            if d <= self.tol && best.map_or(true, |(bd, _)| d < bd) {
                                best = Some((d, id));
                            }
                        }
                    }
                }
            }
        }
        if let Some((_, id)) = best {
            return id;
        }
        let id = self.model.vertices.len() as u32;
        self.model.vertices.push(Vertex {
            point: p,
            name: None,
        });
        self.grid.entry(c).or_default().push(id);
        id
    }

    /// The edge for `pc` between vertex `a` (at the curve's parameter start)
    /// and `b` (at its end): an existing edge with the same end vertices and
    /// the same geometry, or a new one. The flag tells whether the returned
    /// edge runs from `a` to `b`.
    fn edge(&mut self, pc: &RawPiece, a: u32, b: u32) -> (u32, bool) {
        const FRACTIONS: [f64; 5] = [1.0 / 6.0, 2.0 / 6.0, 3.0 / 6.0, 4.0 / 6.0, 5.0 / 6.0];
        let (t0, t1) = pc.curve.interval();
        let q: Vec<P3> = FRACTIONS
            .iter()
            .map(|f| pc.curve.point(t0 + f * (t1 - t0)))
            .collect();
        let key = (a.min(b), a.max(b));
        let close = 100.0 * self.tol;
        if let Some(cands) = self.edge_index.get(&key) {
            for &id in cands {
                let e = &self.model.edges[id as usize];
                let at = |f: f64| e.curve.point(e.t0 + f * (e.t1 - e.t0));
                let same = |rev: bool| {
                    FRACTIONS
                        .iter()
                        .zip(&q)
                        .all(|(f, qi)| (at(if rev { 1.0 - f } else { *f }) - qi).norm() <= close)
                };
                let found = if e.start == a && e.end == b && same(false) {
                    Some(true)
                } else if e.start == b && e.end == a && same(true) {
                    Some(false)
                } else {
                    None
                };
                if let Some(dir) = found {
                    let e = &mut self.model.edges[id as usize];
                    if e.name.is_none() {
                        e.name = pc.name.clone();
                    }
                    return (id, dir);
                }
            }
        }
        let id = self.model.edges.len() as u32;
        let n = pc.segments.max(1);
        let mut s: Vec<P3> = (0..=n)
            .map(|k| pc.curve.point(t0 + (t1 - t0) * k as f64 / n as f64))
            .collect();
        s[0] = self.model.vertices[a as usize].point;
        s[n] = self.model.vertices[b as usize].point;
        self.samples.push(s);
        self.model.edges.push(Edge {
            curve: pc.curve.clone(),
            t0,
            t1,
            start: a,
            end: b,
            name: pc.name.clone(),
        });
        self.edge_index.entry(key).or_default().push(id);
        (id, true)
    }

    /// Creates the vertices and edges of a path and returns its edge uses in
    /// order. With `close`, the path must end where it starts.
    fn path(&mut self, path: &RawPath, close: bool) -> Result<Vec<EdgeUse>, Invalid> {
        let tol = self.tol;
        let n = path.pieces.len();
        let mut uses = Vec::with_capacity(n);
        let mut first: Option<(u32, P3)> = None;
        let mut prev: Option<(u32, P3, &str)> = None;
        for (k, pc) in path.pieces.iter().enumerate() {
            let (s, e) = (pc.start(), pc.end());
            let len = pc.curve.approx_length();
            if !(len > 10.0 * tol) {
                return Err(Invalid::new(
                    format!("{}, {}", path.entity, pc.label),
                    pc.zero_msg.clone(),
                ));
            }
            let sv = match prev {
                None => self.vertex(s),
                Some((v, pe, plabel)) => {
                    let gap = (pe - s).norm();
                    if gap > tol {
                        let hint = if (pe - e).norm() <= tol {
                            " (it seems reversed: its end is there; swap its start and end)"
                        } else {
                            ""
                        };
                        return Err(Invalid::new(
                            path.entity.clone(),
                            format!(
                                "the pieces do not connect: {} starts at {} but {} ends at {}, a gap of {}{hint}",
                                pc.label,
                                fmt_p(&s),
                                plabel,
                                fmt_p(&pe),
                                fmt_num(gap)
                            ),
                        ));
                    }
                    v
                }
            };
            let first_v = *first.get_or_insert((sv, s));
            let ev = if close && k + 1 == n {
                let gap = (e - first_v.1).norm();
                if gap > tol {
                    return Err(Invalid::new(
                        path.entity.clone(),
                        format!(
                            "the loop is not closed: it starts at {} but ends at {} ({}), a gap of {} (tolerance {})",
                            fmt_p(&first_v.1),
                            fmt_p(&e),
                            pc.label,
                            fmt_num(gap),
                            fmt_num(tol)
                        ),
                    ));
                }
                first_v.0
            } else {
                self.vertex(e)
            };
            let (a, b) = if pc.reversed { (ev, sv) } else { (sv, ev) };
            let (id, along) = self.edge(pc, a, b);
            uses.push(EdgeUse {
                edge: id,
                forward: along != pc.reversed,
            });
            prev = Some((ev, e, &pc.label));
        }
        Ok(uses)
    }

    /// The sampled points of `uses` in traversal order, each tagged with
    /// the vertex it is (at edge ends) or `None`. For a closed path the
    /// final point (equal to the first) is dropped.
    fn trace(&self, uses: &[EdgeUse], closed: bool) -> Vec<(P3, Option<u32>)> {
        let mut out: Vec<(P3, Option<u32>)> = Vec::new();
        for (k, u) in uses.iter().enumerate() {
            let e = &self.model.edges[u.edge as usize];
            let s = &self.samples[u.edge as usize];
            let m = s.len() - 1;
            let (sv, ev) = if u.forward {
                (e.start, e.end)
            } else {
                (e.end, e.start)
            };
            for i in 0..=m {
                if i == 0 && k > 0 {
                    continue; // same as the previous use's last point
                }
                let p = if u.forward { s[i] } else { s[m - i] };
                let tag = if i == 0 {
                    Some(sv)
                } else if i == m {
                    Some(ev)
                } else {
                    None
                };
                out.push((p, tag));
            }
        }
        if closed {
            out.pop();
        }
        out
    }

    /// Checks that every traced point lies in z = 0 and returns the
    /// trace in (x, y).
    fn planar_trace(&self, uses: &[EdgeUse], closed: bool, entity: &str) -> Result<Trace, Invalid> {
        let pts = self.trace(uses, closed);
        if let Some((p, _)) = pts.iter().find(|(p, _)| !(p.z.abs() <= self.tol)) {
            return Err(Invalid::new(
                entity,
                format!(
                    "faces must lie in the plane z = 0, but the point {} has z = {}",
                    fmt_p(p),
                    fmt_num(p.z)
                ),
            ));
        }
        Ok(Trace {
            xy: pts.iter().map(|(p, _)| [p.x, p.y]).collect(),
            tags: pts.iter().map(|(_, t)| *t).collect(),
            closed,
        })
    }

    fn vertex_xy(&self, v: u32) -> Xy {
        let p = self.model.vertices[v as usize].point;
        [p.x, p.y]
    }

    /// Builds, orients and checks one face.
    fn face(&mut self, f: &RawFace, surface: Arc<dyn Surface>) -> Result<Face, Invalid> {
        let mut loops = Vec::with_capacity(1 + f.holes.len());
        for (li, path) in std::iter::once(&f.outer).chain(&f.holes).enumerate() {
            let uses = self.path(path, true)?;
            let trace = self.planar_trace(&uses, true, &path.entity)?;
            loops.push(LoopData {
                uses,
                trace,
                label: if li == 0 {
                    "the outer loop".to_string()
                } else {
                    format!("hole {li}")
                },
                entity: path.entity.clone(),
            });
        }
        let segs: Vec<Seg> = loops
            .iter()
            .enumerate()
            .flat_map(|(li, l)| l.trace.segments(li))
            .collect();
        check_loops_disjoint(&loops, &segs).map_err(|r| Invalid::new(f.entity.clone(), r))?;
        orient_loops(&mut loops, self.tol)?;
        check_holes_inside(&loops)?;
        let region = Region {
            loops: &loops,
            segs: &segs,
        };

        // Constraint curves.
        let loop_edges: Vec<u32> = loops
            .iter()
            .flat_map(|l| l.uses.iter().map(|u| u.edge))
            .collect();
        let mut embedded_edges: Vec<u32> = Vec::new();
        let mut traces = Vec::with_capacity(f.constraints.len());
        for path in &f.constraints {
            let uses = self.path(path, false)?;
            if uses.iter().any(|u| loop_edges.contains(&u.edge)) {
                return Err(Invalid::new(
                    path.entity.clone(),
                    "the constraint coincides with an edge of the face boundary",
                ));
            }
            traces.push(self.planar_trace(&uses, false, &path.entity)?);
            for u in uses {
                if !embedded_edges.contains(&u.edge) {
                    embedded_edges.push(u.edge);
                }
            }
        }
        self.check_constraints(f, &region, &traces)?;

        // Constraint points.
        let mut embedded_vertices: Vec<u32> = Vec::new();
        for (p, entity) in &f.points {
            if !(p.z.abs() <= self.tol) {
                return Err(Invalid::new(
                    entity.clone(),
                    format!(
                        "faces must lie in the plane z = 0, but the point has z = {}",
                        fmt_num(p.z)
                    ),
                ));
            }
            let q = [p.x, p.y];
            if region.boundary_dist(q) <= self.tol {
                return Err(Invalid::new(
                    entity.clone(),
                    format!(
                        "the point {} lies on the face boundary; constraint points must be inside the face",
                        fmt_xy(q)
                    ),
                ));
            }
            if let Err(where_) = region.locate(q) {
                return Err(Invalid::new(
                    entity.clone(),
                    format!("the point {} lies outside the face ({where_})", fmt_xy(q)),
                ));
            }
            let v = self.vertex(*p);
            if !embedded_vertices.contains(&v) {
                embedded_vertices.push(v);
            }
        }

        Ok(Face {
            surface,
            loops: loops.into_iter().map(|l| Loop { edges: l.uses }).collect(),
            embedded_edges,
            embedded_vertices,
            name: f.name.clone(),
        })
    }

    /// Constraint curves must not cross or touch the boundary or one
    /// another except at common vertices, and must lie inside the face.
    fn check_constraints(
        &self,
        f: &RawFace,
        region: &Region<'_>,
        traces: &[Trace],
    ) -> Result<(), Invalid> {
        let tol = self.tol;
        let nl = region.loops.len();
        let mut all = region.segs.to_vec();
        for (ci, t) in traces.iter().enumerate() {
            all.extend(t.segments(nl + ci));
        }
        let hit = sweep_pairs(&all, |s, t| {
            if s.owner < nl && t.owner < nl {
                return None; // loop against loop: checked already
            }
            if s.owner == t.owner && traces[s.owner - nl].adjacent(s.index, t.index) {
                return None;
            }
            // The constraint to blame, and what it meets.
            let (c, o) = if s.owner >= t.owner { (s, t) } else { (t, s) };
            let other = if o.owner < nl {
                region.loops[o.owner].label.clone()
            } else if o.owner == c.owner {
                "itself".to_string()
            } else {
                format!("constraint {}", o.owner - nl + 1)
            };
            if collinear_overlap(s.a, s.b, t.a, t.b, tol) > tol
                || collinear_overlap(t.a, t.b, s.a, s.b, tol) > tol
            {
                let p = segments_meet(s.a, s.b, t.a, t.b, false).unwrap_or(s.a);
                return Some((
                    c.owner - nl,
                    format!("the constraint runs along {other} near {}", fmt_xy(p)),
                ));
            }
            let p = segments_meet(s.a, s.b, t.a, t.b, false)?;
            if let Some(v) = s.shared_vertex(t) {
                if dist(p, self.vertex_xy(v)) <= tol {
                    return None; // they meet at a common vertex
                }
            }
            let how = if o.owner < nl {
                " (a constraint may meet the boundary only at a vertex of it)"
            } else {
                " (split them at a common point)"
            };
            Some((
                c.owner - nl,
                format!(
                    "the constraint crosses or touches {other} near {}{how}",
                    fmt_xy(p)
                ),
            ))
        });
        if let Some((ci, reason)) = hit {
            return Err(Invalid::new(f.constraints[ci].entity.clone(), reason));
        }
        // No crossing: each constraint is inside or outside as a whole, up
        // to contact at boundary vertices; test all its samples anyway.
        let loop_vertices: Vec<u32> = region
            .loops
            .iter()
            .flat_map(|l| l.trace.tags.iter().flatten().copied())
            .collect();
        for (path, t) in f.constraints.iter().zip(traces) {
            for (q, tag) in t.xy.iter().zip(&t.tags) {
                if region.boundary_dist(*q) <= tol {
                    if tag.is_some_and(|v| loop_vertices.contains(&v)) {
                        continue;
                    }
                    return Err(Invalid::new(
                        path.entity.clone(),
                        format!(
                            "the constraint touches the face boundary at {} away from a boundary vertex \
                             (a constraint may meet the boundary only at a vertex of it)",
                            fmt_xy(*q)
                        ),
                    ));
                }
                if let Err(where_) = region.locate(*q) {
                    return Err(Invalid::new(
                        path.entity.clone(),
                        format!(
                            "the constraint leaves the face: its point {} is {where_}",
                            fmt_xy(*q)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// The loops of a face are simple and pairwise disjoint: no two segments
/// meet except consecutive ones of one loop at their common point (and
/// those must not fold back).
fn check_loops_disjoint(loops: &[LoopData], segs: &[Seg]) -> Result<(), String> {
    let hit = sweep_pairs(segs, |s, t| {
        if s.owner == t.owner {
            let l = &loops[s.owner];
            let n = l.trace.xy.len();
            if (s.index + 1) % n == t.index {
                return folds_back(s.a, s.b, t.b)
                    .then(|| format!("{} runs back over itself near {}", l.label, fmt_xy(s.b)));
            }
            if (t.index + 1) % n == s.index {
                return folds_back(t.a, t.b, s.b)
                    .then(|| format!("{} runs back over itself near {}", l.label, fmt_xy(t.b)));
            }
            segments_meet(s.a, s.b, t.a, t.b, false)
                .map(|p| format!("{} crosses or touches itself near {}", l.label, fmt_xy(p)))
        } else {
            let (x, y) = (s.owner.min(t.owner), s.owner.max(t.owner));
            segments_meet(s.a, s.b, t.a, t.b, false).map(|p| {
                format!(
                    "{} and {} cross or touch near {} (loops must be disjoint)",
                    loops[x].label,
                    loops[y].label,
                    fmt_xy(p)
                )
            })
        }
    });
    match hit {
        Some(reason) => Err(reason),
        None => Ok(()),
    }
}

/// Outer loop counter-clockwise, holes clockwise (by the signed area of the
/// sampled loop). A simple loop has non-zero area; the area test is a last
/// guard.
fn orient_loops(loops: &mut [LoopData], tol: f64) -> Result<(), Invalid> {
    for (li, l) in loops.iter_mut().enumerate() {
        let area = signed_area(&l.trace.xy);
        if !(area.abs() > tol * perimeter(&l.trace.xy)) {
            return Err(Invalid::new(
                l.entity.clone(),
                "the loop encloses no area (its points are collinear or it runs back over itself)",
            ));
        }
        if (area > 0.0) != (li == 0) {
            l.uses.reverse();
            for u in &mut l.uses {
                u.forward = !u.forward;
            }
            l.trace.xy.reverse();
            l.trace.tags.reverse();
        }
    }
    Ok(())
}

/// Holes lie inside the outer loop and not inside one another. The loops
/// are disjoint, so one point of each hole decides.
fn check_holes_inside(loops: &[LoopData]) -> Result<(), Invalid> {
    for (k, h) in loops.iter().enumerate().skip(1) {
        let p = h.trace.xy[0];
        if !inside(p, &loops[0].trace.xy) {
            return Err(Invalid::new(
                h.entity.clone(),
                format!(
                    "the hole lies outside the outer loop (its point {} is outside)",
                    fmt_xy(p)
                ),
            ));
        }
        for (j, o) in loops.iter().enumerate().skip(1) {
            if j != k && inside(p, &o.trace.xy) {
                return Err(Invalid::new(
                    h.entity.clone(),
                    format!("the hole lies inside {} (holes may not be nested)", o.label),
                ));
            }
        }
    }
    Ok(())
}

/// The checked, oriented loops of a face, for point location.
struct Region<'a> {
    loops: &'a [LoopData],
    segs: &'a [Seg],
}

impl Region<'_> {
    /// Distance from `p` to the nearest loop segment.
    fn boundary_dist(&self, p: Xy) -> f64 {
        self.segs
            .iter()
            .map(|s| dist_to_segment(p, s.a, s.b))
            .fold(f64::INFINITY, f64::min)
    }

    /// `Ok` inside the face; otherwise where the point is.
    fn locate(&self, p: Xy) -> Result<(), String> {
        if !inside(p, &self.loops[0].trace.xy) {
            return Err("outside the outer loop".into());
        }
        match self.loops.iter().skip(1).find(|l| inside(p, &l.trace.xy)) {
            Some(l) => Err(format!("inside {}", l.label)),
            None => Ok(()),
        }
    }
}
