//! Reading the curves of [`super::curves`]: `OFFSET_CURVE_3D`,
//! `COMPOSITE_CURVE` (and its `BOUNDARY_CURVE` / `OUTER_BOUNDARY_CURVE`
//! subtypes), `TRIMMED_CURVE` trims where a segment needs them, and
//! `PCURVE` / `DEFINITIONAL_REPRESENTATION` (a 2D curve evaluated on its
//! surface).

use std::f64::consts::TAU;
use std::sync::Arc;

use bubblemesh_analytic::curves::CurveOnSurface;
use bubblemesh_analytic::{CircleArc, EllipseArc, HyperbolaArc, Line};
use bubblemesh_core::geom::Curve;
use truck_stepio::r#in::ruststep::ast::Parameter;

use super::build::MAX_CONTROL_POINTS;
use super::curves::{Composite, Moved, OffsetCurve, Parabola, ParamScaled, Ranged, Segment};
use super::geometry::{CurveGeom, Geo, Rigid};
use super::StepError;
use crate::curve_tools::closest_parameter;

/// A bounded piece of a curve: the curve, `[a, b]` of its parameter,
/// whether it runs from b to a, and the curve's parameter per file
/// parameter (the angle unit for conics, else 1).
type Piece = (Arc<dyn Curve>, f64, f64, bool, f64);

impl<'a> Geo<'a> {
    /// The reader of a pcurve's parameter-space geometry (2D, unscaled,
    /// unmoved).
    fn flat_reader(&self) -> Geo<'a> {
        let g = self.unplaced();
        Geo {
            flat: true,
            // unbounded 2D lines span the part, and a full turn of an
            // angle parameter (in the file's angle unit) when that is more
            extent: g.extent.max(TAU / self.angle),
            ..g
        }
    }

    /// The reader of the file's geometry as written (unscaled, unmoved).
    fn unplaced(&self) -> Geo<'a> {
        Geo {
            t: self.t,
            angle: self.angle,
            extent: self.extent / self.scale,
            vertex_extent: self.vertex_extent / self.scale,
            uncertainty: self.uncertainty / self.scale,
            xf: Rigid::identity(),
            scale: 1.0,
            flat: false,
        }
    }

    /// Curve `g` (entity `id`) over a finite interval, its parameter the
    /// file's except for conics (radians): unbounded lines, parabolas and
    /// hyperbolas over ±4 file extents.
    pub(super) fn finite(&self, id: u64, g: &CurveGeom) -> Result<Arc<dyn Curve>, StepError> {
        let bad = |e: bubblemesh_analytic::GeometryError| self.t.err(id, e.to_string());
        let ext = 4.0 * self.extent;
        Ok(match g {
            CurveGeom::Line { p, d } => {
                let l = ext / d.norm();
                Arc::new(Ranged {
                    inner: Arc::new(Line::new(*p, p + d).map_err(bad)?),
                    t0: -l,
                    t1: l,
                })
            }
            CurveGeom::Circle { pl, r } => {
                Arc::new(CircleArc::with_basis(pl.o, pl.x, pl.y, *r, 0.0, TAU).map_err(bad)?)
            }
            CurveGeom::Ellipse { pl, a, b } => {
                Arc::new(EllipseArc::new(pl.o, pl.x, pl.y, *a, *b, 0.0, TAU).map_err(bad)?)
            }
            CurveGeom::Hyperbola { pl, a, b } => {
                let t = (ext / b).asinh().max(1.0);
                Arc::new(HyperbolaArc::new(pl.o, pl.x, pl.y, *a, *b, -t, t).map_err(bad)?)
            }
            CurveGeom::Parabola { pl, f } => {
                let t = (0.5 * ext / f).max((ext / f).sqrt());
                Arc::new(Parabola {
                    o: pl.o,
                    x: pl.x,
                    y: pl.y,
                    f: *f,
                    t0: -t,
                    t1: t,
                })
            }
            CurveGeom::Spline(n) => n.clone(),
            CurveGeom::General(c) => c.clone(),
        })
    }

    /// OFFSET_CURVE_3D(name, basis_curve, distance, self_intersect,
    /// ref_direction): a line or a circle (offset in its plane) exactly,
    /// any other basis evaluated as an [`OffsetCurve`].
    pub(super) fn offset_curve(&self, id: u64, depth: usize) -> Result<CurveGeom, StepError> {
        let a = self.t.args(id, &["OFFSET_CURVE_3D"], 5)?;
        let basis = self.t.r(id, &a[1], "basis_curve")?;
        let d = self.t.real(id, &a[2], "distance")? * self.len_scale();
        let v = self.direction(self.t.r(id, &a[4], "ref_direction")?)?;
        let g = self.curve_depth(basis, depth + 1)?;
        match g {
            CurveGeom::Line { p, d: dl } => {
                let n = v
                    .cross(&dl)
                    .try_normalize(1e-12)
                    .ok_or_else(|| self.t.err(id, "its LINE runs along its ref_direction"))?;
                Ok(CurveGeom::Line {
                    p: p + n * d,
                    d: dl,
                })
            }
            CurveGeom::Circle { pl, r } if pl.z.cross(&v).norm() <= 1e-12 => {
                // z × C' points to the centre of a counter-clockwise circle
                let r2 = r - d * pl.z.dot(&v).signum();
                if !(r2 > 0.0) {
                    return Err(self.t.err(
                        id,
                        format!("offset by {d}, its circle of radius {r} becomes {r2}"),
                    ));
                }
                Ok(CurveGeom::Circle { pl, r: r2 })
            }
            g => {
                let c = self.finite(basis, &g)?;
                let (lo, hi) = c.interval();
                let t = 0.5 * (lo + hi);
                if v.cross(&c.d1(t)).norm() <= 1e-12 * c.d1(t).norm() {
                    return Err(self.t.err(id, "its basis runs along its ref_direction"));
                }
                Ok(CurveGeom::General(Arc::new(OffsetCurve { basis: c, d, v })))
            }
        }
    }

    /// COMPOSITE_CURVE(name, segments, self_intersect) (also BOUNDARY_CURVE,
    /// OUTER_BOUNDARY_CURVE): its segments (COMPOSITE_CURVE_SEGMENT(
    /// transition, same_sense, parent_curve)) joined.
    pub(super) fn composite(&self, id: u64, depth: usize) -> Result<Composite, StepError> {
        if depth > 8 {
            return Err(self.t.err(id, "curve references nest too deeply"));
        }
        let names = ["COMPOSITE_CURVE", "BOUNDARY_CURVE", "OUTER_BOUNDARY_CURVE"];
        let a = self.t.args(id, &names, 2)?;
        let segs = self.t.refs(id, &a[1], "segments")?;
        if segs.is_empty() || segs.len() > MAX_CONTROL_POINTS {
            return Err(self.t.err(id, format!("{} segments", segs.len())));
        }
        let mut out = Vec::with_capacity(segs.len());
        for s in segs {
            let sa = self.t.args(
                s,
                &[
                    "COMPOSITE_CURVE_SEGMENT",
                    "REPARAMETRISED_COMPOSITE_CURVE_SEGMENT",
                ],
                3,
            )?;
            let same = self.t.boolean(s, &sa[1], "same_sense")?;
            let (curve, lo, hi, rev, k) =
                self.piece(self.t.r(s, &sa[2], "parent_curve")?, depth + 1)?;
            // a reparametrised segment has the parameter length it states
            let k = match sa.get(3) {
                Some(p) if self.t.get(s)?.is("REPARAMETRISED_COMPOSITE_CURVE_SEGMENT") => {
                    let l = self.t.real(s, p, "param_length")?;
                    if !(l > 0.0) {
                        return Err(self.t.err(s, format!("param_length {l} is not positive")));
                    }
                    (hi - lo) / l
                }
                _ => k,
            };
            out.push(Segment {
                curve,
                a: lo,
                b: hi,
                // run backwards when exactly one of the trim and the
                // segment's same_sense says so
                reversed: rev == same,
                k,
            });
        }
        let c = Composite::new(out).ok_or_else(|| self.t.err(id, "an empty segment"))?;
        if !self.flat {
            // consecutive segments must meet
            let tol = (1e-4 * self.extent).max(10.0 * self.uncertainty);
            let n = c.segments().len();
            for k in 1..n {
                let g0 = &c.segments()[k - 1];
                let g1 = &c.segments()[k];
                let e0 = g0.curve.point(if g0.reversed { g0.a } else { g0.b });
                let s1 = g1.curve.point(if g1.reversed { g1.b } else { g1.a });
                let gap = (e0 - s1).norm();
                if gap > tol {
                    return Err(self.t.err(
                        id,
                        format!(
                            "segment {} ends {gap:.3e} away from where segment {} starts",
                            k,
                            k + 1
                        ),
                    ));
                }
            }
        }
        Ok(c)
    }

    /// A bounded curve as a piece: a TRIMMED_CURVE by its trims, a
    /// composite, a B-spline or another bounded curve over its interval, a
    /// circle or ellipse whole.
    fn piece(&self, id: u64, depth: usize) -> Result<Piece, StepError> {
        let e = self.t.get(id)?;
        if e.is("TRIMMED_CURVE") {
            return self.trimmed(id, depth);
        }
        let g = self.curve_depth(id, depth)?;
        match g {
            CurveGeom::Line { .. } | CurveGeom::Hyperbola { .. } | CurveGeom::Parabola { .. } => {
                Err(self.t.err(id, "an unbounded curve as a segment"))
            }
            g => {
                let conic = matches!(g, CurveGeom::Circle { .. } | CurveGeom::Ellipse { .. });
                let c = self.finite(id, &g)?;
                let (lo, hi) = c.interval();
                Ok((c, lo, hi, false, if conic { self.angle } else { 1.0 }))
            }
        }
    }

    /// TRIMMED_CURVE(name, basis_curve, trim_1, trim_2, sense_agreement,
    /// master_representation): trims by PARAMETER_VALUE (angles in the
    /// file's angle unit on conics) or by CARTESIAN_POINT, the one the
    /// master representation names first.
    fn trimmed(&self, id: u64, depth: usize) -> Result<Piece, StepError> {
        let a = self.t.args(id, &["TRIMMED_CURVE"], 5)?;
        let basis = self.t.r(id, &a[1], "basis_curve")?;
        let g = self.curve_depth(basis, depth + 1)?;
        let conic = matches!(g, CurveGeom::Circle { .. } | CurveGeom::Ellipse { .. });
        let c = self.finite(basis, &g)?;
        let (lo, hi) = c.interval();
        let points_first = matches!(a.get(5), Some(Parameter::Enumeration(s)) if s == "CARTESIAN");
        let trim = |p: &Parameter, what: &str| -> Result<f64, StepError> {
            let mut by_value = None;
            let mut by_point = None;
            for x in self.t.list(id, p, what)? {
                match x {
                    Parameter::Typed { keyword, parameter } if keyword == "PARAMETER_VALUE" => {
                        let v = self.t.real(id, parameter, what)?;
                        by_value = Some(if conic { v * self.angle } else { v });
                    }
                    Parameter::Ref(_) => {
                        let q = self.point(self.t.r(id, x, what)?)?;
                        by_point = Some(match &g {
                            CurveGeom::Line { p, d } => (q - p).dot(d) / d.norm_squared(),
                            _ => closest_parameter(c.as_ref(), &q, lo, hi, 512).0,
                        });
                    }
                    _ => {}
                }
            }
            let t = if points_first {
                by_point.or(by_value)
            } else {
                by_value.or(by_point)
            };
            t.ok_or_else(|| {
                self.t
                    .err(id, format!("{what} gives no parameter value or point"))
            })
        };
        let t1 = trim(&a[2], "trim_1")?;
        let mut t2 = trim(&a[3], "trim_2")?;
        let sense = self.t.boolean(id, &a[4], "sense_agreement")?;
        let clamp = |t: f64| {
            if conic || matches!(g, CurveGeom::Line { .. }) {
                t
            } else {
                t.clamp(lo, hi)
            }
        };
        let (t1, t2v) = (clamp(t1), clamp(t2));
        t2 = t2v;
        if conic {
            if sense {
                t2 = t1 + (t2 - t1).rem_euclid(TAU);
                if t2 - t1 <= 1e-12 {
                    t2 = t1 + TAU;
                }
            } else {
                t2 = t1 - (t1 - t2).rem_euclid(TAU);
                if t1 - t2 <= 1e-12 {
                    t2 = t1 - TAU;
                }
            }
        }
        let k = if conic { self.angle } else { 1.0 };
        match sense {
            true if t2 > t1 => Ok((c, t1, t2, false, k)),
            false if t1 > t2 => Ok((c, t2, t1, true, k)),
            _ => Err(self.t.err(
                id,
                format!("its trims (t = {t1} then {t2}) do not run along sense_agreement {sense}"),
            )),
        }
    }

    /// The 3D image of a PCURVE(name, basis_surface, reference_to_curve):
    /// the first curve of its DEFINITIONAL_REPRESENTATION, read in the
    /// surface's parameter space, evaluated on the surface as the file
    /// writes it, then scaled and placed like the rest of the geometry.
    pub(super) fn pcurve(&self, id: u64, depth: usize) -> Result<Arc<dyn Curve>, StepError> {
        if depth > 8 {
            return Err(self.t.err(id, "curve references nest too deeply"));
        }
        let a = self.t.args(id, &["PCURVE"], 3)?;
        let surf = self.t.r(id, &a[1], "basis_surface")?;
        let rep = self.t.r(id, &a[2], "reference_to_curve")?;
        let ra = self
            .t
            .args(rep, &["DEFINITIONAL_REPRESENTATION", "REPRESENTATION"], 2)?;
        let items = self.t.refs(rep, &ra[1], "items")?;
        let flat = self.flat_reader();
        let first = *items
            .first()
            .ok_or_else(|| self.t.err(rep, "has no curve"))?;
        let g = flat.curve_depth(first, depth + 1)?;
        let c2 = flat.finite(first, &g)?;
        // surfaces whose parameters the file's are (angles in its unit)
        let mut base = surf;
        for _ in 0..8 {
            if !self.t.get(base)?.is("RECTANGULAR_TRIMMED_SURFACE") {
                break;
            }
            let b = self.t.args(base, &["RECTANGULAR_TRIMMED_SURFACE"], 2)?;
            base = self.t.r(base, &b[1], "basis_surface")?;
        }
        let be = self.t.get(base)?;
        let (su, sv, ov) = if be.is("PLANE")
            || [
                "B_SPLINE_SURFACE_WITH_KNOTS",
                "B_SPLINE_SURFACE",
                "UNIFORM_SURFACE",
                "QUASI_UNIFORM_SURFACE",
                "BEZIER_SURFACE",
            ]
            .iter()
            .any(|n| be.is(n))
        {
            (1.0, 1.0, 0.0)
        } else if be.is("CYLINDRICAL_SURFACE") {
            (self.angle, 1.0, 0.0)
        } else if be.is("SPHERICAL_SURFACE") || (be.is("TOROIDAL_SURFACE") && self.ring_torus(base))
        {
            (self.angle, self.angle, 0.0)
        } else if be.is("CONICAL_SURFACE") {
            // the file's v is the height above the placement, the cone's
            // the slant distance from its apex (at height −R / tan α)
            let a = self.t.args(base, &["CONICAL_SURFACE"], 4)?;
            let r = self.t.real(base, &a[2], "radius")?;
            let alpha = self.t.real(base, &a[3], "semi_angle")? * self.angle;
            (self.angle, 1.0 / alpha.cos(), r / alpha.sin())
        } else {
            return Err(self.t.err(
                id,
                format!(
                    "a PCURVE on a {} is not supported (supported: PLANE, CYLINDRICAL_SURFACE, \
                     CONICAL_SURFACE, SPHERICAL_SURFACE, TOROIDAL_SURFACE with major radius > \
                     minor, B-spline surfaces)",
                    self.t.type_name(base)
                ),
            ));
        };
        let surface = self.unplaced().surface(base)?.surface;
        let pcurve: Arc<dyn Curve> = if su == 1.0 && sv == 1.0 && ov == 0.0 {
            c2
        } else {
            Arc::new(ParamScaled {
                inner: c2,
                su,
                sv,
                ov,
            })
        };
        Ok(Arc::new(Moved {
            inner: Arc::new(CurveOnSurface { surface, pcurve }),
            scale: self.scale,
            xf: self.xf,
        }))
    }

    /// Whether TOROIDAL_SURFACE `id` is a ring torus (major radius > minor:
    /// read as a [`bubblemesh_analytic::Torus`], parametrized as the file's).
    fn ring_torus(&self, id: u64) -> bool {
        let Ok(a) = self.t.args(id, &["TOROIDAL_SURFACE"], 4) else {
            return false;
        };
        match (
            self.t.real(id, &a[2], "major_radius"),
            self.t.real(id, &a[3], "minor_radius"),
        ) {
            (Ok(big), Ok(small)) => big > small && small > 0.0,
            _ => false,
        }
    }

    /// The first of a SURFACE_CURVE's associated PCURVEs that reads, as its
    /// 3D curve.
    pub(super) fn via_pcurves(
        &self,
        id: u64,
        assoc: Option<&Parameter>,
        depth: usize,
    ) -> Option<CurveGeom> {
        let refs = self.t.refs(id, assoc?, "associated_geometry").ok()?;
        refs.into_iter().find_map(|p| {
            let e = self.t.get(p).ok()?;
            if !e.is("PCURVE") {
                return None;
            }
            self.pcurve(p, depth + 1).ok().map(CurveGeom::General)
        })
    }
}
