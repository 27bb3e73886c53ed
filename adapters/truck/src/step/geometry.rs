//! STEP geometry entities (ISO 10303-42) as bubblemesh-analytic curves and
//! surfaces.

use std::sync::Arc;

use bubblemesh_analytic::{
    Cone, Cylinder, Extrusion, Frame, Line, Nurbs, NurbsSurface, Revolution, Sphere, Torus,
    MAX_NURBS_DEGREE,
};
use bubblemesh_core::geom::{Curve, Plane, Surface, P3, V3};
use truck_stepio::r#in::ruststep::ast::Parameter;

use super::table::Table;
use super::StepError;

/// Most control points accepted in one curve or surface (guards memory
/// against hostile files; real parts stay far below).
pub const MAX_CONTROL_POINTS: usize = 1 << 20;

/// An orthonormal placement (origin; x, y, z).
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    pub o: P3,
    pub x: V3,
    pub y: V3,
    pub z: V3,
}

/// A rigid motion x ↦ rot·x + shift (`rot` a rotation: orthonormal, det
/// +1), placing a part's geometry in its assembly. Lengths in the file's
/// length unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    pub rot: nalgebra::Matrix3<f64>,
    pub shift: V3,
}

impl Rigid {
    pub fn identity() -> Self {
        Rigid {
            rot: nalgebra::Matrix3::identity(),
            shift: V3::zeros(),
        }
    }
    /// The motion taking the world frame onto `pl`: local coordinates
    /// (a, b, c) in `pl` ↦ o + a x + b y + c z.
    pub fn from_placement(pl: &Placement) -> Self {
        Rigid {
            rot: nalgebra::Matrix3::from_columns(&[pl.x, pl.y, pl.z]),
            shift: pl.o.coords,
        }
    }
    pub fn inverse(&self) -> Self {
        let rt = self.rot.transpose();
        Rigid {
            rot: rt,
            shift: -(rt * self.shift),
        }
    }
    /// `self ∘ other`: `other` first.
    pub fn then_after(&self, other: &Rigid) -> Self {
        Rigid {
            rot: self.rot * other.rot,
            shift: self.rot * other.shift + self.shift,
        }
    }
    pub fn point(&self, p: &P3) -> P3 {
        P3::from(self.rot * p.coords + self.shift)
    }
    pub fn vector(&self, v: &V3) -> V3 {
        self.rot * v
    }
    /// Whether this moves no point of a box of size `scale` by more than
    /// `1e-12 · scale`.
    pub fn is_identity(&self, scale: f64) -> bool {
        let e = (self.rot - nalgebra::Matrix3::identity()).abs().max() * scale.max(1.0)
            + self.shift.norm();
        e <= 1e-12 * scale.max(1.0)
    }
}

/// A 3D curve of the file, untrimmed.
#[derive(Clone, Debug)]
pub enum CurveGeom {
    Line {
        p: P3,
        d: V3,
    },
    Circle {
        pl: Placement,
        r: f64,
    },
    Ellipse {
        pl: Placement,
        a: f64,
        b: f64,
    },
    Hyperbola {
        pl: Placement,
        a: f64,
        b: f64,
    },
    /// C(t) = o + f (t² x + 2 t y).
    Parabola {
        pl: Placement,
        f: f64,
    },
    Spline(Arc<Nurbs>),
    /// Any other bounded curve, its parameter the file's (a composite
    /// curve, an offset curve without an exact form, a pcurve's image):
    /// edges are trimmed to their vertices by closest-point inversion.
    General(Arc<dyn Curve>),
}

/// Where a B-spline's knots come from: the multiplicities and knots
/// parameters of a `…_WITH_KNOTS` record, or its implicit form.
#[derive(Clone)]
enum Knots<'p> {
    Explicit(&'p Parameter, &'p Parameter),
    Uniform,
    QuasiUniform,
    Bezier,
}

/// A surface of the file.
pub struct SurfGeom {
    pub surface: Arc<dyn Surface>,
    pub planar: bool,
    /// Centre and radius when the surface is a sphere (a face that is the
    /// sphere minus holes is built on the sphere turned, see
    /// `face_build::face_from_loops_within`).
    pub sphere: Option<(P3, f64)>,
}

/// Converts geometry with the file's context: its angle unit and extent.
pub struct Geo<'a> {
    pub t: &'a Table,
    /// Radians per plane-angle unit of the file.
    pub angle: f64,
    /// Diagonal of the bounding box of all the file's cartesian points
    /// (sizes infinite lines used as profiles).
    pub extent: f64,
    /// Diagonal of the bounding box of the file's `VERTEX_POINT`s (the
    /// size of the parts themselves, without construction points far away).
    pub vertex_extent: f64,
    /// The largest `UNCERTAINTY_MEASURE_WITH_UNIT` of the file (its distance
    /// accuracy, in the file's length unit; 0 when none is given).
    pub uncertainty: f64,
    /// The motion applied to every point and direction read (a part's
    /// placement in its assembly; the identity otherwise). Everything built
    /// from points and directions — placements, vectors, control points —
    /// is moved with it.
    pub xf: Rigid,
    /// Output units per file length unit: every coordinate and length read
    /// (points, radii, magnitudes, offsets) is multiplied by it before `xf`
    /// is applied (1 unless a unit conversion was asked for).
    pub scale: f64,
    /// Reading the 2D geometry of a pcurve (ISO 10303-42 parameter space):
    /// points and directions have two coordinates, become (x, y, 0), and are
    /// neither scaled nor moved; AXIS2_PLACEMENT_2D is a placement.
    pub flat: bool,
}

impl<'a> Geo<'a> {
    #[cfg(test)]
    pub fn new(t: &'a Table) -> Self {
        Self::with_scale(t, 1.0)
    }

    /// The reader converting lengths by `scale` (output units per file unit).
    pub fn with_scale(t: &'a Table, scale: f64) -> Self {
        // plane angle unit: radians unless a conversion-based DEGREE is given
        let mut angle = 1.0;
        for e in t.ents.values() {
            if e.is("PLANE_ANGLE_UNIT") {
                if let Some(p) = e.part("CONVERSION_BASED_UNIT") {
                    if let Some(Parameter::String(s)) = p.first() {
                        if s.to_ascii_uppercase().contains("DEGREE") {
                            angle = std::f64::consts::PI / 180.0;
                        }
                    }
                }
            }
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for e in t.ents.values() {
            if let Some(p) = e.part("CARTESIAN_POINT") {
                if let Some(Parameter::List(c)) = p.get(1) {
                    for (k, x) in c.iter().take(3).enumerate() {
                        if let Parameter::Real(x) = x {
                            if x.abs() <= super::table::MAX_COORDINATE {
                                lo[k] = lo[k].min(*x);
                                hi[k] = hi[k].max(*x);
                            }
                        }
                    }
                }
            }
        }
        let extent = (0..3)
            .map(|k| (hi[k] - lo[k]).max(0.0))
            .map(|d| if d.is_finite() { d * d } else { 0.0 })
            .sum::<f64>()
            .sqrt()
            .max(1.0);
        let mut vlo = [f64::INFINITY; 3];
        let mut vhi = [f64::NEG_INFINITY; 3];
        let mut uncertainty: f64 = 0.0;
        for e in t.ents.values() {
            if let Some(p) = e.part("VERTEX_POINT") {
                let q = match p.get(1) {
                    Some(Parameter::Ref(truck_stepio::r#in::ruststep::ast::Name::Entity(q))) => *q,
                    _ => continue,
                };
                let Some(Parameter::List(c)) = t
                    .ents
                    .get(&q)
                    .and_then(|pe| pe.part("CARTESIAN_POINT"))
                    .and_then(|pp| pp.get(1))
                else {
                    continue;
                };
                for (k, x) in c.iter().take(3).enumerate() {
                    if let Parameter::Real(x) = x {
                        if x.is_finite() {
                            vlo[k] = vlo[k].min(*x);
                            vhi[k] = vhi[k].max(*x);
                        }
                    }
                }
            }
            if let Some(p) = e.part("UNCERTAINTY_MEASURE_WITH_UNIT") {
                if let Some(u) = p.first().and_then(|x| t.real(0, x, "value_component").ok()) {
                    if u > 0.0 {
                        uncertainty = uncertainty.max(u);
                    }
                }
            }
        }
        let vertex_extent = (0..3)
            .map(|k| (vhi[k] - vlo[k]).max(0.0))
            .map(|d| if d.is_finite() { d * d } else { 0.0 })
            .sum::<f64>()
            .sqrt()
            .min(extent);
        // an uncertainty a tenth of the parts' size or more is a mistake of
        // the writer (or a unit mix-up): ignored
        let uncertainty = if uncertainty < 0.1 * vertex_extent {
            uncertainty
        } else {
            0.0
        };
        Geo {
            t,
            angle,
            extent: extent * scale,
            vertex_extent: vertex_extent * scale,
            uncertainty: uncertainty * scale,
            xf: Rigid::identity(),
            scale,
            flat: false,
        }
    }

    /// The same reader with every point and direction moved by `xf`.
    pub fn moved(&self, xf: Rigid) -> Geo<'a> {
        Geo {
            t: self.t,
            angle: self.angle,
            extent: self.extent,
            vertex_extent: self.vertex_extent,
            uncertainty: self.uncertainty,
            xf,
            scale: self.scale,
            flat: self.flat,
        }
    }

    pub fn point(&self, id: u64) -> Result<P3, StepError> {
        let a = self.t.args(id, &["CARTESIAN_POINT"], 2)?;
        let c = self.t.coords(id, &a[1], "coordinates")?;
        if self.flat {
            return match c.as_slice() {
                [x, y] => Ok(P3::new(*x, *y, 0.0)),
                _ => Err(self.t.err(
                    id,
                    format!("has {} coordinates, a 2D point is needed", c.len()),
                )),
            };
        }
        match c.as_slice() {
            [x, y, z] => {
                Ok(self
                    .xf
                    .point(&P3::new(*x * self.scale, *y * self.scale, *z * self.scale)))
            }
            _ => Err(self.t.err(
                id,
                format!("has {} coordinates, a 3D point is needed", c.len()),
            )),
        }
    }

    pub fn direction(&self, id: u64) -> Result<V3, StepError> {
        let a = self.t.args(id, &["DIRECTION"], 2)?;
        let c = self.t.reals(id, &a[1], "direction ratios")?;
        let v = match c.as_slice() {
            [x, y] if self.flat => V3::new(*x, *y, 0.0),
            [x, y, z] if !self.flat => V3::new(*x, *y, *z),
            _ => {
                return Err(self.t.err(
                    id,
                    format!("has {} components, a 3D direction is needed", c.len()),
                ))
            }
        };
        v.try_normalize(0.0)
            .map(|v| if self.flat { v } else { self.xf.vector(&v) })
            .ok_or_else(|| self.t.err(id, "is the zero vector"))
    }

    pub(super) fn vector(&self, id: u64) -> Result<V3, StepError> {
        let a = self.t.args(id, &["VECTOR"], 3)?;
        let d = self.direction(self.t.r(id, &a[1], "orientation")?)?;
        let m = self.t.real(id, &a[2], "magnitude")? * self.len_scale();
        if !(m > 0.0) {
            return Err(self.t.err(id, format!("magnitude {m} is not positive")));
        }
        Ok(d * m)
    }

    /// The factor lengths read are multiplied by (1 in parameter space).
    pub(super) fn len_scale(&self) -> f64 {
        if self.flat {
            1.0
        } else {
            self.scale
        }
    }

    /// AXIS2_PLACEMENT_3D(name, location, axis?, ref_direction?); in
    /// parameter space also AXIS2_PLACEMENT_2D(name, location, ref_direction?).
    pub fn placement(&self, id: u64) -> Result<Placement, StepError> {
        if self.flat && self.t.get(id)?.is("AXIS2_PLACEMENT_2D") {
            let a = self.t.args(id, &["AXIS2_PLACEMENT_2D"], 2)?;
            let o = self.point(self.t.r(id, &a[1], "location")?)?;
            let x = match a.get(2) {
                None | Some(Parameter::NotProvided) | Some(Parameter::Omitted) => V3::x(),
                Some(p) => self.direction(self.t.r(id, p, "ref_direction")?)?,
            };
            return Ok(Placement {
                o,
                x,
                y: V3::new(-x.y, x.x, 0.0),
                z: V3::z(),
            });
        }
        let a = self.t.args(id, &["AXIS2_PLACEMENT_3D"], 2)?;
        let o = self.point(self.t.r(id, &a[1], "location")?)?;
        let opt = |k: usize, what: &str, dflt: V3| -> Result<V3, StepError> {
            match a.get(k) {
                None | Some(Parameter::NotProvided) | Some(Parameter::Omitted) => Ok(dflt),
                Some(p) => self.direction(self.t.r(id, p, what)?),
            }
        };
        let z = opt(2, "axis", V3::z())?;
        let r = opt(3, "ref_direction", V3::x())?;
        let x = (r - z * z.dot(&r)).try_normalize(1e-9).or_else(|| {
            // a reference along the axis: any perpendicular (ISO 10303-42 §4.4.4)
            let alt = if z.x.abs() < 0.9 { V3::x() } else { V3::y() };
            (alt - z * z.dot(&alt)).try_normalize(0.0)
        });
        let x = x.ok_or_else(|| self.t.err(id, "degenerate axes"))?;
        Ok(Placement {
            o,
            x,
            y: z.cross(&x),
            z,
        })
    }

    /// AXIS1_PLACEMENT(name, location, axis?).
    fn axis1(&self, id: u64) -> Result<(P3, V3), StepError> {
        let a = self.t.args(id, &["AXIS1_PLACEMENT"], 2)?;
        let o = self.point(self.t.r(id, &a[1], "location")?)?;
        let z = match a.get(2) {
            None | Some(Parameter::NotProvided) | Some(Parameter::Omitted) => V3::z(),
            Some(p) => self.direction(self.t.r(id, p, "axis")?)?,
        };
        Ok((o, z))
    }

    /// A positive length (converted by `scale`).
    pub(super) fn positive(&self, id: u64, p: &Parameter, what: &str) -> Result<f64, StepError> {
        let r = self.t.real(id, p, what)? * self.len_scale();
        if !(r > 0.0) {
            return Err(self.t.err(id, format!("{what} {r} is not positive")));
        }
        Ok(r)
    }

    /// A 3D curve (the 3D curve of a SURFACE_CURVE / SEAM_CURVE, the basis
    /// of a TRIMMED_CURVE: edges are trimmed to their vertices anyway).
    pub fn curve(&self, id: u64) -> Result<CurveGeom, StepError> {
        self.curve_depth(id, 0)
    }

    pub(super) fn curve_depth(&self, id: u64, depth: usize) -> Result<CurveGeom, StepError> {
        if depth > 8 {
            return Err(self.t.err(id, "curve references nest too deeply"));
        }
        let e = self.t.get(id)?;
        if e.is("LINE") {
            let a = self.t.args(id, &["LINE"], 3)?;
            let p = self.point(self.t.r(id, &a[1], "pnt")?)?;
            let d = self.vector(self.t.r(id, &a[2], "dir")?)?;
            return Ok(CurveGeom::Line { p, d });
        }
        if e.is("CIRCLE") {
            let a = self.t.args(id, &["CIRCLE"], 3)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let r = self.positive(id, &a[2], "radius")?;
            return Ok(CurveGeom::Circle { pl, r });
        }
        if e.is("ELLIPSE") {
            let a = self.t.args(id, &["ELLIPSE"], 4)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let s1 = self.positive(id, &a[2], "semi_axis_1")?;
            let s2 = self.positive(id, &a[3], "semi_axis_2")?;
            return Ok(CurveGeom::Ellipse { pl, a: s1, b: s2 });
        }
        if e.is("HYPERBOLA") {
            let a = self.t.args(id, &["HYPERBOLA"], 4)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let s1 = self.positive(id, &a[2], "semi_axis")?;
            let s2 = self.positive(id, &a[3], "semi_imag_axis")?;
            return Ok(CurveGeom::Hyperbola { pl, a: s1, b: s2 });
        }
        if e.is("SURFACE_CURVE") || e.is("SEAM_CURVE") {
            let a = self.t.args(id, &["SURFACE_CURVE", "SEAM_CURVE"], 2)?;
            let c3 = self.curve_depth(self.t.r(id, &a[1], "curve_3d")?, depth + 1);
            return match c3 {
                Ok(c) => Ok(c),
                // the 3D curve cannot be read: the pcurves can stand in
                Err(err) => self.via_pcurves(id, a.get(2), depth).ok_or(err),
            };
        }
        if e.is("PARABOLA") {
            let a = self.t.args(id, &["PARABOLA"], 3)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let f = self.positive(id, &a[2], "focal_dist")?;
            return Ok(CurveGeom::Parabola { pl, f });
        }
        if e.is("OFFSET_CURVE_3D") {
            return self.offset_curve(id, depth);
        }
        if e.is("COMPOSITE_CURVE") || e.is("BOUNDARY_CURVE") || e.is("OUTER_BOUNDARY_CURVE") {
            return Ok(CurveGeom::General(Arc::new(self.composite(id, depth)?)));
        }
        if e.is("PCURVE") && !self.flat {
            return Ok(CurveGeom::General(self.pcurve(id, depth)?));
        }
        if e.is("TRIMMED_CURVE") {
            let a = self.t.args(id, &["TRIMMED_CURVE"], 2)?;
            return self.curve_depth(self.t.r(id, &a[1], "basis_curve")?, depth + 1);
        }
        if [
            "B_SPLINE_CURVE_WITH_KNOTS",
            "B_SPLINE_CURVE",
            "UNIFORM_CURVE",
            "QUASI_UNIFORM_CURVE",
            "BEZIER_CURVE",
        ]
        .iter()
        .any(|n| e.is(n))
        {
            return Ok(CurveGeom::Spline(Arc::new(self.spline_curve(id)?)));
        }
        if e.is("POLYLINE") {
            // the points joined by segments: a degree-1 B-spline with a knot
            // per point
            let a = self.t.args(id, &["POLYLINE"], 2)?;
            let ids = self.t.refs(id, &a[1], "points")?;
            if ids.len() < 2 || ids.len() > MAX_CONTROL_POINTS {
                return Err(self.t.err(id, format!("{} points", ids.len())));
            }
            let points: Vec<P3> = ids
                .iter()
                .map(|&q| self.point(q))
                .collect::<Result<_, _>>()?;
            let n = points.len();
            let mut knots = vec![0.0];
            knots.extend((0..n).map(|i| i as f64));
            knots.push((n - 1) as f64);
            return Ok(CurveGeom::Spline(Arc::new(
                Nurbs::new(1, points, None, knots).map_err(|g| self.t.err(id, g.to_string()))?,
            )));
        }
        Err(self.t.err(
            id,
            "unsupported curve type (supported: LINE, CIRCLE, ELLIPSE, HYPERBOLA, PARABOLA, \
             POLYLINE, B_SPLINE_CURVE_WITH_KNOTS, UNIFORM_CURVE, QUASI_UNIFORM_CURVE, BEZIER_CURVE \
             and their rational forms, SURFACE_CURVE, SEAM_CURVE, TRIMMED_CURVE, OFFSET_CURVE_3D, \
             COMPOSITE_CURVE, PCURVE)",
        ))
    }

    /// Knots × multiplicities, checked against the degree and count.
    fn knots(
        &self,
        id: u64,
        mults: &Parameter,
        knots: &Parameter,
        p: usize,
        n: usize,
        dir: &str,
    ) -> Result<Vec<f64>, StepError> {
        let m: Vec<i64> = self
            .t
            .list(id, mults, "knot_multiplicities")?
            .iter()
            .map(|x| self.t.int(id, x, "knot multiplicity"))
            .collect::<Result<_, _>>()?;
        let k = self.t.reals(id, knots, "knots")?;
        if m.len() != k.len() {
            return Err(self.t.err(
                id,
                format!("{dir}{} knot multiplicities for {} knots", m.len(), k.len()),
            ));
        }
        if let Some(bad) = m.iter().find(|&&x| x < 1 || x as usize > p + 1) {
            return Err(self.t.err(
                id,
                format!(
                    "{dir}knot multiplicity {bad} outside 1..=degree+1 ({})",
                    p + 1
                ),
            ));
        }
        let total: usize = m.iter().map(|&x| x as usize).sum();
        if total != n + p + 1 {
            return Err(self.t.err(
                id,
                format!(
                    "{dir}{total} knots (with multiplicity), but degree {p} with {n} control points needs {}",
                    n + p + 1
                ),
            ));
        }
        let mut out = Vec::with_capacity(total);
        for (x, c) in k.iter().zip(&m) {
            out.extend(std::iter::repeat(*x).take(*c as usize));
        }
        Ok(out)
    }

    /// Which of the three implicit-knot forms entity `id` is.
    fn implicit_kind(&self, id: u64, names: [&str; 3]) -> Result<Knots<'static>, StepError> {
        let e = self.t.get(id)?;
        if e.is(names[0]) {
            Ok(Knots::Uniform)
        } else if e.is(names[1]) {
            Ok(Knots::QuasiUniform)
        } else if e.is(names[2]) {
            Ok(Knots::Bezier)
        } else {
            Err(self.t.err(
                id,
                format!("a B-spline without knots that is no {}", names.join(", ")),
            ))
        }
    }

    /// The knot vector (with multiplicities) of degree `p` over `n` control
    /// points: given, or implied by the form (ISO 10303-42 §4.3.5): uniform
    /// −p, −p+1, …, n (unclamped, spacing 1); quasi-uniform clamped with
    /// unit interior spacing; Bézier clamped with multiplicity p inside,
    /// one segment per p control points.
    fn knots_of(
        &self,
        id: u64,
        kind: &Knots,
        p: usize,
        n: usize,
        dir: &str,
    ) -> Result<Vec<f64>, StepError> {
        if n < p + 1 {
            return Err(self.t.err(
                id,
                format!("{dir}{n} control points are too few for degree {p}"),
            ));
        }
        Ok(match kind {
            Knots::Explicit(m, k) => return self.knots(id, m, k, p, n, dir),
            Knots::Uniform => (0..n + p + 1).map(|i| i as f64 - p as f64).collect(),
            Knots::QuasiUniform => {
                let last = (n - p) as f64;
                let mut v = vec![0.0; p + 1];
                v.extend((1..n - p).map(|i| i as f64));
                v.extend(std::iter::repeat(last).take(p + 1));
                v
            }
            Knots::Bezier => {
                if (n - 1) % p != 0 {
                    return Err(self.t.err(
                        id,
                        format!("{dir}a Bézier form of degree {p} needs 1 + k·{p} control points, not {n}"),
                    ));
                }
                let segs = (n - 1) / p;
                let mut v = vec![0.0; p + 1];
                for i in 1..segs {
                    v.extend(std::iter::repeat(i as f64).take(p));
                }
                v.extend(std::iter::repeat(segs as f64).take(p + 1));
                v
            }
        })
    }

    fn degree(&self, id: u64, p: &Parameter, what: &str) -> Result<usize, StepError> {
        let d = self.t.int(id, p, what)?;
        if d < 1 || d as usize > MAX_NURBS_DEGREE {
            return Err(self.t.err(
                id,
                format!("{what} {d} outside the supported 1..={MAX_NURBS_DEGREE}"),
            ));
        }
        Ok(d as usize)
    }

    /// B_SPLINE_CURVE_WITH_KNOTS, simple or in a complex instance with
    /// B_SPLINE_CURVE and RATIONAL_B_SPLINE_CURVE.
    fn spline_curve(&self, id: u64) -> Result<Nurbs, StepError> {
        let e = self.t.get(id)?;
        let (deg, pts, kinds) = if let Some(b) = e.part("B_SPLINE_CURVE") {
            if b.len() < 2 {
                return Err(self.t.err(id, "too few B-spline parameters"));
            }
            let kinds = match e.part("B_SPLINE_CURVE_WITH_KNOTS") {
                Some(k) if k.len() >= 2 => Knots::Explicit(&k[0], &k[1]),
                Some(_) => return Err(self.t.err(id, "too few B-spline parameters")),
                None => self
                    .implicit_kind(id, ["UNIFORM_CURVE", "QUASI_UNIFORM_CURVE", "BEZIER_CURVE"])?,
            };
            (&b[0], &b[1], kinds)
        } else if e.is("B_SPLINE_CURVE_WITH_KNOTS") {
            let a = self.t.args(id, &["B_SPLINE_CURVE_WITH_KNOTS"], 8)?;
            (&a[1], &a[2], Knots::Explicit(&a[6], &a[7]))
        } else {
            let names = ["UNIFORM_CURVE", "QUASI_UNIFORM_CURVE", "BEZIER_CURVE"];
            let a = self.t.args(id, &names, 3)?;
            (&a[1], &a[2], self.implicit_kind(id, names)?)
        };
        let p = self.degree(id, deg, "degree")?;
        let ids = self.t.refs(id, pts, "control_points_list")?;
        if ids.len() > MAX_CONTROL_POINTS {
            return Err(self.t.err(
                id,
                format!("{} control points (limit {MAX_CONTROL_POINTS})", ids.len()),
            ));
        }
        let points: Vec<P3> = ids
            .iter()
            .map(|&q| self.point(q))
            .collect::<Result<_, _>>()?;
        let knots = self.knots_of(id, &kinds, p, points.len(), "")?;
        let weights = match e.part("RATIONAL_B_SPLINE_CURVE") {
            Some(w) if !w.is_empty() => Some(self.t.reals(id, &w[0], "weights_data")?),
            _ => None,
        };
        Nurbs::new(p, points, weights, knots).map_err(|g| self.t.err(id, g.to_string()))
    }

    fn spline_surface(&self, id: u64) -> Result<NurbsSurface, StepError> {
        let e = self.t.get(id)?;
        let names = ["UNIFORM_SURFACE", "QUASI_UNIFORM_SURFACE", "BEZIER_SURFACE"];
        let (du, dv, pts, ku_kind, kv_kind) = if let Some(b) = e.part("B_SPLINE_SURFACE") {
            if b.len() < 3 {
                return Err(self.t.err(id, "too few B-spline surface parameters"));
            }
            let (ku, kv) = match e.part("B_SPLINE_SURFACE_WITH_KNOTS") {
                Some(k) if k.len() >= 4 => {
                    (Knots::Explicit(&k[0], &k[2]), Knots::Explicit(&k[1], &k[3]))
                }
                Some(_) => return Err(self.t.err(id, "too few B-spline surface parameters")),
                None => {
                    let k = self.implicit_kind(id, names)?;
                    (k.clone(), k)
                }
            };
            (&b[0], &b[1], &b[2], ku, kv)
        } else if e.is("B_SPLINE_SURFACE_WITH_KNOTS") {
            let a = self.t.args(id, &["B_SPLINE_SURFACE_WITH_KNOTS"], 12)?;
            (
                &a[1],
                &a[2],
                &a[3],
                Knots::Explicit(&a[8], &a[10]),
                Knots::Explicit(&a[9], &a[11]),
            )
        } else {
            let a = self.t.args(id, &names, 4)?;
            let k = self.implicit_kind(id, names)?;
            (&a[1], &a[2], &a[3], k.clone(), k)
        };
        let p = self.degree(id, du, "u_degree")?;
        let q = self.degree(id, dv, "v_degree")?;
        let rows = self.t.list(id, pts, "control_points_list")?;
        let mut count = 0usize;
        let mut net = Vec::with_capacity(rows.len());
        for row in rows {
            let ids = self.t.refs(id, row, "control point row")?;
            count += ids.len();
            if count > MAX_CONTROL_POINTS {
                return Err(self
                    .t
                    .err(id, format!("more than {MAX_CONTROL_POINTS} control points")));
            }
            net.push(
                ids.iter()
                    .map(|&x| self.point(x))
                    .collect::<Result<Vec<_>, _>>()?,
            );
        }
        let nu = net.len();
        let nv = net.first().map_or(0, |r| r.len());
        let ku = self.knots_of(id, &ku_kind, p, nu, "u: ")?;
        let kv = self.knots_of(id, &kv_kind, q, nv, "v: ")?;
        let weights = match e.part("RATIONAL_B_SPLINE_SURFACE") {
            Some(w) if !w.is_empty() => Some(
                self.t
                    .list(id, &w[0], "weights_data")?
                    .iter()
                    .map(|r| self.t.reals(id, r, "weights row"))
                    .collect::<Result<Vec<_>, _>>()?,
            ),
            _ => None,
        };
        NurbsSurface::new(p, q, net, weights, ku, kv).map_err(|g| self.t.err(id, g.to_string()))
    }

    /// A profile curve over a finite interval (a line becomes a segment of
    /// ±4 file extents around its point).
    fn profile(&self, id: u64) -> Result<Arc<dyn Curve>, StepError> {
        let c = self.curve(id)?;
        let bad = |g: bubblemesh_analytic::GeometryError| self.t.err(id, g.to_string());
        Ok(match c {
            CurveGeom::Line { p, d } => {
                let l = 4.0 * self.extent / d.norm();
                Arc::new(Line::new(p - d * l, p + d * l).map_err(bad)?)
            }
            CurveGeom::Circle { pl, r } => Arc::new(
                bubblemesh_analytic::CircleArc::with_basis(
                    pl.o,
                    pl.x,
                    pl.y,
                    r,
                    0.0,
                    std::f64::consts::TAU,
                )
                .map_err(bad)?,
            ),
            CurveGeom::Ellipse { pl, a, b } => Arc::new(
                bubblemesh_analytic::EllipseArc::new(
                    pl.o,
                    pl.x,
                    pl.y,
                    a,
                    b,
                    0.0,
                    std::f64::consts::TAU,
                )
                .map_err(bad)?,
            ),
            CurveGeom::Spline(n) => n,
            // over ±4 file extents, like a line
            g @ (CurveGeom::Hyperbola { .. }
            | CurveGeom::Parabola { .. }
            | CurveGeom::General(_)) => self.finite(id, &g)?,
        })
    }

    /// The elementary surface `id` (PLANE, CYLINDRICAL_SURFACE,
    /// CONICAL_SURFACE, SPHERICAL_SURFACE, TOROIDAL_SURFACE) offset by `d`
    /// along its normal; `None` for another type.
    fn elementary(&self, id: u64, d: f64) -> Result<Option<SurfGeom>, StepError> {
        let e = self.t.get(id)?;
        let bad = |g: bubblemesh_analytic::SurfaceError| self.t.err(id, g.to_string());
        let frame = |pl: &Placement| {
            Frame::with_reference(pl.o, pl.z, pl.x).map_err(|g| self.t.err(id, g.to_string()))
        };
        let curved = |s: Arc<dyn Surface>| {
            Ok(Some(SurfGeom {
                surface: s,
                planar: false,
                sphere: None,
            }))
        };
        let grown = |r: f64, what: &str| -> Result<f64, StepError> {
            let r2 = r + d;
            if r2 > 0.0 {
                Ok(r2)
            } else {
                Err(self
                    .t
                    .err(id, format!("offset by {d}, its {what} {r} becomes {r2}")))
            }
        };
        if e.is("PLANE") {
            let a = self.t.args(id, &["PLANE"], 2)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            return Ok(Some(SurfGeom {
                surface: Arc::new(Plane {
                    origin: pl.o + pl.z * d,
                    e1: pl.x,
                    e2: pl.y,
                }),
                planar: true,
                sphere: None,
            }));
        }
        if e.is("CYLINDRICAL_SURFACE") {
            let a = self.t.args(id, &["CYLINDRICAL_SURFACE"], 3)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let r = grown(self.positive(id, &a[2], "radius")?, "radius")?;
            let c = Cylinder::with_frame(frame(&pl)?, r, [f64::NEG_INFINITY, f64::INFINITY])
                .map_err(bad)?;
            return curved(Arc::new(c));
        }
        if e.is("CONICAL_SURFACE") {
            let a = self.t.args(id, &["CONICAL_SURFACE"], 4)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let r = self.t.real(id, &a[2], "radius")? * self.scale;
            let alpha = self.t.real(id, &a[3], "semi_angle")? * self.angle;
            if !(r >= 0.0 && alpha > 0.0 && alpha < std::f64::consts::FRAC_PI_2) {
                return Err(self.t.err(
                    id,
                    format!("radius {r} or semi-angle {alpha} rad out of range"),
                ));
            }
            // S = C + (R + h tan α)(cos u x + sin u y) + h z: apex at h = −R / tan α;
            // offset by d along the normal (cos α radial − sin α axial) it
            // is the cone of radius R + d / cos α
            let r = r + d / alpha.cos();
            let apex = pl.o - pl.z * (r / alpha.tan());
            let f = Frame::with_reference(apex, pl.z, pl.x)
                .map_err(|g| self.t.err(id, g.to_string()))?;
            let c = Cone::with_frame(f, alpha, [0.0, f64::INFINITY]).map_err(bad)?;
            return curved(Arc::new(c));
        }
        if e.is("SPHERICAL_SURFACE") {
            let a = self.t.args(id, &["SPHERICAL_SURFACE"], 3)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let r = grown(self.positive(id, &a[2], "radius")?, "radius")?;
            return Ok(Some(SurfGeom {
                surface: Arc::new(Sphere::with_frame(frame(&pl)?, r).map_err(bad)?),
                planar: false,
                sphere: Some((pl.o, r)),
            }));
        }
        if e.is("TOROIDAL_SURFACE") {
            let a = self.t.args(id, &["TOROIDAL_SURFACE"], 4)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let big = self.positive(id, &a[2], "major_radius")?;
            let small = grown(self.positive(id, &a[3], "minor_radius")?, "minor_radius")?;
            if big > small {
                return curved(Arc::new(
                    Torus::with_frame(frame(&pl)?, big, small).map_err(bad)?,
                ));
            }
            // a horn or spindle torus (a fillet whose radius reaches the
            // axis): the tube circle revolved about the axis
            let tube = bubblemesh_analytic::CircleArc::with_basis(
                pl.o + pl.x * big,
                pl.x,
                pl.z,
                small,
                0.0,
                std::f64::consts::TAU,
            )
            .map_err(|g| self.t.err(id, g.to_string()))?;
            return curved(Arc::new(
                Revolution::new(Arc::new(tube), pl.o, pl.z).map_err(bad)?,
            ));
        }
        Ok(None)
    }

    /// A surface.
    pub fn surface(&self, id: u64) -> Result<SurfGeom, StepError> {
        self.surface_depth(id, 0)
    }

    fn surface_depth(&self, id: u64, depth: usize) -> Result<SurfGeom, StepError> {
        if depth > 8 {
            return Err(self.t.err(id, "surface references nest too deeply"));
        }
        let e = self.t.get(id)?;
        let bad = |g: bubblemesh_analytic::SurfaceError| self.t.err(id, g.to_string());
        let curved = |s: Arc<dyn Surface>| {
            Ok(SurfGeom {
                surface: s,
                planar: false,
                sphere: None,
            })
        };
        if let Some(sg) = self.elementary(id, 0.0)? {
            return Ok(sg);
        }
        if e.is("OFFSET_SURFACE") {
            // an elementary surface offset along its normal (ISO 10303-42:
            // a plane's axis, outward from a cylinder's or cone's axis, a
            // sphere's centre, a torus's tube) is the same kind of surface
            let a = self.t.args(id, &["OFFSET_SURFACE"], 3)?;
            let basis = self.t.r(id, &a[1], "basis_surface")?;
            let d = self.t.real(id, &a[2], "distance")? * self.scale;
            if let Some(sg) = self.elementary(basis, d)? {
                return Ok(sg);
            }
            return Err(self.t.err(
                id,
                format!(
                    "unsupported: the offset of a {} (supported: offsets of PLANE, \
                     CYLINDRICAL_SURFACE, CONICAL_SURFACE, SPHERICAL_SURFACE, TOROIDAL_SURFACE)",
                    self.t.type_name(basis)
                ),
            ));
        }
        if e.is("DEGENERATE_TOROIDAL_SURFACE") {
            // a spindle torus (minor radius ≥ major): the outer "apple" or
            // the inner "lemon" part, as select_outer says; the tube circle
            // crosses the axis where R + r cos θ = 0, θ = ±θ₀, and the
            // part is that circle's arc on the chosen side, revolved
            let a = self.t.args(id, &["DEGENERATE_TOROIDAL_SURFACE"], 5)?;
            let pl = self.placement(self.t.r(id, &a[1], "position")?)?;
            let big = self.t.real(id, &a[2], "major_radius")? * self.scale;
            let small = self.positive(id, &a[3], "minor_radius")?;
            let outer = self.t.boolean(id, &a[4], "select_outer")?;
            if !(big >= 0.0) {
                return Err(self.t.err(id, format!("major_radius {big} is negative")));
            }
            let (t0, t1) = if big >= small {
                // not degenerate after all: the whole tube
                (0.0, std::f64::consts::TAU)
            } else {
                let th = (-big / small).acos();
                if outer {
                    (-th, th)
                } else {
                    (th, std::f64::consts::TAU - th)
                }
            };
            let tube = bubblemesh_analytic::CircleArc::with_basis(
                pl.o + pl.x * big,
                pl.x,
                pl.z,
                small,
                t0,
                t1,
            )
            .map_err(|g| self.t.err(id, g.to_string()))?;
            return curved(Arc::new(
                Revolution::new(Arc::new(tube), pl.o, pl.z).map_err(bad)?,
            ));
        }
        if [
            "B_SPLINE_SURFACE_WITH_KNOTS",
            "B_SPLINE_SURFACE",
            "UNIFORM_SURFACE",
            "QUASI_UNIFORM_SURFACE",
            "BEZIER_SURFACE",
        ]
        .iter()
        .any(|n| e.is(n))
        {
            return curved(Arc::new(self.spline_surface(id)?));
        }
        if e.is("SURFACE_OF_REVOLUTION") {
            let a = self.t.args(id, &["SURFACE_OF_REVOLUTION"], 3)?;
            let prof = self.profile(self.t.r(id, &a[1], "swept_curve")?)?;
            let (o, z) = self.axis1(self.t.r(id, &a[2], "axis_position")?)?;
            return curved(Arc::new(Revolution::new(prof, o, z).map_err(bad)?));
        }
        if e.is("SURFACE_OF_LINEAR_EXTRUSION") {
            let a = self.t.args(id, &["SURFACE_OF_LINEAR_EXTRUSION"], 3)?;
            let prof = self.profile(self.t.r(id, &a[1], "swept_curve")?)?;
            let d = self.vector(self.t.r(id, &a[2], "extrusion_axis")?)?;
            let l = 4.0 * self.extent / d.norm();
            return curved(Arc::new(
                Extrusion::with_range(prof, d, [-l, l]).map_err(bad)?,
            ));
        }
        if e.is("CURVE_BOUNDED_SURFACE") {
            // as a face's geometry: the face's loops bound it
            let a = self.t.args(id, &["CURVE_BOUNDED_SURFACE"], 2)?;
            return self.surface_depth(self.t.r(id, &a[1], "basis_surface")?, depth + 1);
        }
        if e.is("RECTANGULAR_TRIMMED_SURFACE") {
            // the face's loops trim it anyway
            let a = self.t.args(id, &["RECTANGULAR_TRIMMED_SURFACE"], 2)?;
            return self.surface_depth(self.t.r(id, &a[1], "basis_surface")?, depth + 1);
        }
        Err(self.t.err(
            id,
            "unsupported surface type (supported: PLANE, CYLINDRICAL_SURFACE, CONICAL_SURFACE, \
             SPHERICAL_SURFACE, TOROIDAL_SURFACE, DEGENERATE_TOROIDAL_SURFACE, \
             OFFSET_SURFACE of those, B_SPLINE_SURFACE_WITH_KNOTS, UNIFORM_SURFACE, \
             QUASI_UNIFORM_SURFACE, BEZIER_SURFACE and its rational \
             form, SURFACE_OF_REVOLUTION, SURFACE_OF_LINEAR_EXTRUSION, RECTANGULAR_TRIMMED_SURFACE, \
             CURVE_BOUNDED_SURFACE)",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table of a DATA section body.
    fn table(body: &str) -> Table {
        let text = format!(
            "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('','',(''),(''),'','','');\nFILE_SCHEMA(('X'));\nENDSEC;\nDATA;\n{body}ENDSEC;\nEND-ISO-10303-21;\n"
        );
        let ex = truck_stepio::r#in::ruststep::parser::parse(&text).unwrap();
        let inst: Vec<_> = ex.data.into_iter().flat_map(|d| d.entities).collect();
        Table::new("test", inst).unwrap()
    }

    /// Largest and smallest distance from the z axis over a grid of the
    /// surface, and the largest residual of `(ρ ∓ R)² + z² = r²`.
    fn spindle_samples(s: &dyn Surface, big: f64, small: f64, inner: bool) -> (f64, f64, f64) {
        let (u, v) = s.domain();
        let (mut lo, mut hi, mut res) = (f64::INFINITY, 0.0f64, 0.0f64);
        for i in 0..=20 {
            for j in 0..=20 {
                let p = s.point(
                    u[0] + (u[1] - u[0]) * i as f64 / 20.0,
                    v[0] + (v[1] - v[0]) * j as f64 / 20.0,
                );
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                let c = if inner { rho + big } else { rho - big };
                res = res.max((c * c + p.z * p.z - small * small).abs());
                lo = lo.min(rho);
                hi = hi.max(rho);
            }
        }
        (lo, hi, res)
    }

    /// DEGENERATE_TOROIDAL_SURFACE is the outer (apple) part of a spindle
    /// torus with select_outer, the inner (lemon) part without.
    #[test]
    fn degenerate_torus_is_the_selected_part_of_a_spindle_torus() {
        for (flag, inner) in [(".T.", false), (".F.", true)] {
            let t = table(&format!(
                "#1 = DEGENERATE_TOROIDAL_SURFACE('',#2,1.,2.,{flag});\n\
                 #2 = AXIS2_PLACEMENT_3D('',#3,$,$);\n\
                 #3 = CARTESIAN_POINT('',(0.,0.,0.));\n"
            ));
            let g = Geo::new(&t);
            let s = g.surface(1).unwrap();
            let (lo, hi, res) = spindle_samples(s.surface.as_ref(), 1.0, 2.0, inner);
            assert!(res < 1e-9, "{flag}: off the torus by {res}");
            assert!(lo < 1e-9, "{flag}: reaches the axis");
            let want = if inner { 1.0 } else { 3.0 };
            assert!(
                (hi - want).abs() < 1e-2,
                "{flag}: widest {hi}, expected {want}"
            );
        }
    }

    /// Sample points of a surface over its domain (infinite ranges cut to
    /// a unit length from their finite end, or to [−1, 1]).
    fn samples(s: &dyn Surface) -> Vec<P3> {
        let (u, v) = s.domain();
        let cut = |r: [f64; 2]| match (r[0].is_finite(), r[1].is_finite()) {
            (true, true) => r,
            (true, false) => [r[0], r[0] + 1.0],
            (false, true) => [r[1] - 1.0, r[1]],
            (false, false) => [-1.0, 1.0],
        };
        let (u, v) = (cut(u), cut(v));
        let mut out = Vec::new();
        for i in 0..=10 {
            for j in 0..=10 {
                out.push(s.point(
                    u[0] + (u[1] - u[0]) * i as f64 / 10.0,
                    v[0] + (v[1] - v[0]) * j as f64 / 10.0,
                ));
            }
        }
        out
    }

    /// OFFSET_SURFACE of a plane, cylinder, cone, sphere or torus is that
    /// surface moved along its normal by the distance, exactly: every
    /// sample of the offset lies at the distance from the basis.
    #[test]
    fn offsets_of_elementary_surfaces_are_exact() {
        let place = "#2 = AXIS2_PLACEMENT_3D('',#3,$,$);\n#3 = CARTESIAN_POINT('',(0.,0.,0.));\n";
        let quarter = std::f64::consts::FRAC_PI_4;
        // (basis, offset, distance of p from the basis surface)
        type Dist = fn(&P3) -> f64;
        let cases: [(String, f64, Dist); 5] = [
            ("PLANE('',#2)".into(), 0.5, |p| p.z),
            ("CYLINDRICAL_SURFACE('',#2,2.)".into(), 0.5, |p| {
                p.coords.xy().norm() - 2.0
            }),
            ("SPHERICAL_SURFACE('',#2,2.)".into(), -0.5, |p| {
                p.coords.norm() - 2.0
            }),
            ("TOROIDAL_SURFACE('',#2,3.,1.)".into(), 0.5, |p| {
                (p.coords.xy().norm() - 3.0).hypot(p.z) - 1.0
            }),
            (format!("CONICAL_SURFACE('',#2,1.,{quarter:?})"), 0.5, |p| {
                // signed distance from the cone ρ = 1 + z (α = 45°)
                (p.coords.xy().norm() - 1.0 - p.z) * std::f64::consts::FRAC_1_SQRT_2
            }),
        ];
        for (basis, d, dist) in cases {
            let t = table(&format!(
                "#1 = OFFSET_SURFACE('',#4,{d:?},.F.);\n#4 = {basis};\n{place}"
            ));
            let g = Geo::new(&t);
            let s = g.surface(1).unwrap_or_else(|e| panic!("{basis}: {e}"));
            for p in samples(s.surface.as_ref()) {
                let got = dist(&p);
                assert!(
                    (got - d).abs() < 1e-9,
                    "{basis}: {p:?} is {got} off, expected {d}"
                );
            }
        }
        // an offset through a radius is refused
        let t = table(&format!(
            "#1 = OFFSET_SURFACE('',#4,-3.,.F.);\n#4 = SPHERICAL_SURFACE('',#2,2.);\n{place}"
        ));
        assert!(Geo::new(&t).surface(1).is_err());
    }

    /// A PARABOLA revolved about its axis is the paraboloid 4 f z = ρ², a
    /// HYPERBOLA the hyperboloid of one sheet ρ²/a² − z²/b² = 1; their
    /// derivatives agree with finite differences.
    #[test]
    fn revolved_parabola_and_hyperbola_are_quadrics() {
        // the conics in the xz plane: their x axis along z (parabola) or x
        // (hyperbola), revolved about z
        // (conic entity, its extra directions, the quadric it revolves to)
        type Case = (&'static str, &'static str, fn(&P3) -> f64);
        let cases: [Case; 2] = [
            (
                "PARABOLA('',#4,0.5)",
                "#6 = DIRECTION('',(0.,1.,0.));\n#7 = DIRECTION('',(0.,0.,1.));\n",
                |p| 2.0 * p.z - (p.x * p.x + p.y * p.y),
            ),
            (
                "HYPERBOLA('',#4,1.,2.)",
                "#6 = DIRECTION('',(0.,-1.,0.));\n#7 = DIRECTION('',(1.,0.,0.));\n",
                |p| (p.x * p.x + p.y * p.y) - p.z * p.z / 4.0 - 1.0,
            ),
        ];
        for (conic, dirs, residual) in cases {
            let t = table(&format!(
                "#1 = SURFACE_OF_REVOLUTION('',#2,#3);\n#2 = {conic};\n\
                 #3 = AXIS1_PLACEMENT('',#5,#8);\n#4 = AXIS2_PLACEMENT_3D('',#5,#6,#7);\n\
                 #5 = CARTESIAN_POINT('',(0.,0.,0.));\n{dirs}#8 = DIRECTION('',(0.,0.,1.));\n\
                 #9 = CARTESIAN_POINT('',(3.,3.,3.));\n"
            ));
            let s = Geo::new(&t)
                .surface(1)
                .unwrap_or_else(|e| panic!("{conic}: {e}"));
            let s = s.surface.as_ref();
            let (u, v) = s.domain();
            for i in 1..10 {
                for j in 1..10 {
                    let (a, b) = (
                        u[0] + (u[1] - u[0]) * i as f64 / 10.0,
                        v[0] + (v[1] - v[0]) * j as f64 / 10.0,
                    );
                    let p = s.point(a, b);
                    let r = residual(&p);
                    assert!(
                        r.abs() < 1e-6 * (1.0 + p.coords.norm_squared()),
                        "{conic}: {p:?} off by {r}"
                    );
                    let d = s.derivs(a, b);
                    let h = 1e-6;
                    let su = (s.point(a + h, b) - s.point(a - h, b)) / (2.0 * h);
                    let sv = (s.point(a, b + h) - s.point(a, b - h)) / (2.0 * h);
                    let scale = 1.0 + d.su.norm() + d.sv.norm();
                    assert!((su - d.su).norm() < 1e-5 * scale, "{conic}: S_u");
                    assert!((sv - d.sv).norm() < 1e-5 * scale, "{conic}: S_v");
                    let suu = (s.derivs(a + h, b).su - s.derivs(a - h, b).su) / (2.0 * h);
                    let svv = (s.derivs(a, b + h).sv - s.derivs(a, b - h).sv) / (2.0 * h);
                    let suv = (s.derivs(a, b + h).su - s.derivs(a, b - h).su) / (2.0 * h);
                    let s2 = scale + d.suu.norm() + d.svv.norm();
                    assert!((suu - d.suu).norm() < 1e-4 * s2, "{conic}: S_uu");
                    assert!((svv - d.svv).norm() < 1e-4 * s2, "{conic}: S_vv");
                    assert!((suv - d.suv).norm() < 1e-4 * s2, "{conic}: S_uv");
                }
            }
        }
    }

    /// POLYLINE and the B-spline forms with implicit knots evaluate as their
    /// knots say: a polyline through its points, a uniform curve over its
    /// middle span, a Bézier curve by Bernstein weights.
    #[test]
    fn polyline_and_implicit_knot_curves_evaluate_as_specified() {
        let pts = "#2 = CARTESIAN_POINT('',(0.,0.,0.));\n#3 = CARTESIAN_POINT('',(1.,0.,0.));\n#4 = CARTESIAN_POINT('',(1.,1.,0.));\n";
        let curve = |def: &str| {
            let t = table(&format!("#1 = {def};\n{pts}"));
            match Geo::new(&t)
                .curve(1)
                .unwrap_or_else(|e| panic!("{def}: {e}"))
            {
                CurveGeom::Spline(n) => n,
                other => panic!("{def}: {other:?}"),
            }
        };
        let close = |a: P3, b: [f64; 3]| (a - P3::new(b[0], b[1], b[2])).norm() < 1e-12;
        let n = curve("POLYLINE('',(#2,#3,#4))");
        let (lo, hi) = n.interval();
        assert!(close(n.point(lo), [0.0, 0.0, 0.0]) && close(n.point(hi), [1.0, 1.0, 0.0]));
        assert!(close(n.point(0.5 * (lo + hi)), [1.0, 0.0, 0.0]));
        let n = curve("QUASI_UNIFORM_CURVE('',1,(#2,#3,#4),.POLYLINE_FORM.,.F.,.F.)");
        let (lo, hi) = n.interval();
        assert!(close(n.point(0.5 * (lo + hi)), [1.0, 0.0, 0.0]));
        let n = curve("UNIFORM_CURVE('',1,(#2,#3,#4),.POLYLINE_FORM.,.F.,.F.)");
        let (lo, hi) = n.interval();
        assert!(close(n.point(lo), [0.0, 0.0, 0.0]) && close(n.point(hi), [1.0, 1.0, 0.0]));
        let n = curve("BEZIER_CURVE('',2,(#2,#3,#4),.UNSPECIFIED.,.F.,.F.)");
        let (lo, hi) = n.interval();
        // ¼ P0 + ½ P1 + ¼ P2
        assert!(close(n.point(0.5 * (lo + hi)), [0.75, 0.25, 0.0]));
    }
}
