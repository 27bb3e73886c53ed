//! B-reps built in code with truck-modeling (a `Solid` or `Shell` of
//! truck-topology over truck-modeling's `Curve` and `Surface`) as bubblemesh
//! models.
//!
//! Geometry is converted, not wrapped: lines become segments between their
//! edge's vertices, B-spline and NURBS curves and surfaces become
//! bubblemesh-analytic [`Nurbs`] / [`NurbsSurface`] (exact second
//! derivatives, which truck-geometry 0.5 gets wrong for degree ≥ 3), planes
//! the core [`Plane`], and truck's revolved curves an analytic
//! [`Revolution`] of the converted, transformed profile. Intersection curves
//! are refused with an error naming the edge. Faces are built from their
//! boundary wires like STEP faces ([`crate::face_build`]); truck-modeling
//! splits closed sweeps into several faces, so there are no seam edges (an
//! edge used twice by one face is an error).
//!
//! Parameters: a curve's edge is trimmed to its vertices by closest-point
//! inversion (the same as for STEP B-spline edges).

use std::collections::HashMap;
use std::sync::Arc;

use bubblemesh_analytic::{Line, Nurbs, NurbsSurface, Revolution};
use bubblemesh_core::geom::{Curve, Plane, Surface, P3, V3};
use bubblemesh_core::model::{Edge, EdgeUse, Loop, Model, Vertex, Volume};
use truck_modeling::base::{Matrix4, Point3, Transform, Vector4};
use truck_modeling::topology::{EdgeID, VertexID};
use truck_modeling::{Curve as TCurve, Shell, Solid, Surface as TSurface};

use crate::curve_tools::closest_parameter;

/// Why a truck-modeling B-rep could not be converted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("truck B-rep: {what}: {reason}")]
pub struct TruckError {
    /// The entity at fault ("edge 3", "face 2", …; numbered in the order
    /// the model lists them).
    pub what: String,
    /// What is wrong with it (an unsupported curve type such as an
    /// intersection curve, an empty boundary wire or one using an edge
    /// twice, vertices off their curve, invalid NURBS data, ...).
    pub reason: String,
}

fn err(what: impl Into<String>, reason: impl Into<String>) -> TruckError {
    TruckError {
        what: what.into(),
        reason: reason.into(),
    }
}

/// A solid: one model volume bounded by all the faces of its shells
/// (truck-topology's boundary shells: the first outer, the others voids).
pub fn from_truck_solid(solid: &Solid) -> Result<Model, TruckError> {
    let mut b = Builder::default();
    let mut faces = Vec::new();
    for shell in solid.boundaries() {
        faces.extend(b.shell(shell)?);
    }
    b.model.volumes.push(Volume {
        faces,
        geometry: None,
        name: Some("truck solid".into()),
    });
    Ok(b.model)
}

/// A shell on its own: its faces, no volume (a closed shell meshes into a
/// closed surface, an open one into a sheet).
pub fn from_truck_shell(shell: &Shell) -> Result<Model, TruckError> {
    let mut b = Builder::default();
    b.shell(shell)?;
    Ok(b.model)
}

#[derive(Default)]
struct Builder {
    model: Model,
    vmap: HashMap<VertexID, u32>,
    emap: HashMap<EdgeID, u32>,
    /// Per model face, whether truck's face orientation agrees with its
    /// surface's normal (kept for the record; the engine orients closed
    /// shells outward itself).
    same_sense: Vec<bool>,
}

fn p3(p: Point3) -> P3 {
    P3::new(p.x, p.y, p.z)
}

impl Builder {
    fn extent(&self) -> f64 {
        let mut lo = V3::repeat(f64::INFINITY);
        let mut hi = V3::repeat(f64::NEG_INFINITY);
        for v in &self.model.vertices {
            lo = lo.inf(&v.point.coords);
            hi = hi.sup(&v.point.coords);
        }
        (hi - lo).norm().max(1.0)
    }

    fn vertex(&mut self, v: &truck_modeling::Vertex) -> u32 {
        let n = self.model.vertices.len() as u32;
        *self.vmap.entry(v.id()).or_insert_with(|| {
            self.model.vertices.push(Vertex {
                point: p3(v.point()),
                name: Some(format!("vertex {n}")),
            });
            n
        })
    }

    fn shell(&mut self, shell: &Shell) -> Result<Vec<u32>, TruckError> {
        // vertices first, so the extent is known for the edges' checks
        for face in shell.face_iter() {
            for v in face.vertex_iter() {
                self.vertex(&v);
            }
        }
        let mut out = Vec::new();
        for face in shell.face_iter() {
            let fi = self.model.faces.len();
            let what = format!("face {fi}");
            let mut loops = Vec::new();
            for wire in face.absolute_boundaries() {
                let mut uses = Vec::new();
                for e in wire.edge_iter() {
                    let m = self.edge(e)?;
                    uses.push(EdgeUse {
                        edge: m,
                        forward: e.orientation(),
                    });
                }
                if uses.is_empty() {
                    return Err(err(&what, "an empty boundary wire"));
                }
                let mut seen = std::collections::HashSet::new();
                if !uses.iter().all(|u| seen.insert(u.edge)) {
                    return Err(err(
                        &what,
                        "a boundary wire uses an edge twice (seam edges are not supported)",
                    ));
                }
                loops.push(Loop { edges: uses });
            }
            let (surface, planar) = convert_surface(&face.surface()).map_err(|r| err(&what, r))?;
            let f = crate::face_build::face_from_loops(
                surface,
                planar,
                true,
                loops,
                Vec::new(),
                &self.model,
                self.extent(),
                what.clone(),
            )
            .map_err(|r| err(&what, r))?;
            self.model.faces.push(f);
            self.same_sense.push(face.orientation());
            out.push(fi as u32);
        }
        Ok(out)
    }

    fn edge(&mut self, e: &truck_modeling::Edge) -> Result<u32, TruckError> {
        if let Some(&m) = self.emap.get(&e.id()) {
            return Ok(m);
        }
        let n = self.model.edges.len();
        let what = format!("edge {n}");
        let start = self.vertex(e.absolute_front());
        let end = self.vertex(e.absolute_back());
        let (a, b) = (
            self.model.vertices[start as usize].point,
            self.model.vertices[end as usize].point,
        );
        let tol = 1e-6 * self.extent();
        let (curve, t0, t1): (Arc<dyn Curve>, f64, f64) = match e.curve() {
            TCurve::Line(_) => {
                let l = Line::new(a, b).map_err(|g| err(&what, g.to_string()))?;
                (Arc::new(l), 0.0, 1.0)
            }
            TCurve::IntersectionCurve(_) => {
                return Err(err(&what, "intersection curves are not supported"))
            }
            c => {
                let n = convert_curve(&c).map_err(|r| err(&what, r))?;
                let (lo, hi) = n.interval();
                let samples = (16 * n.span_count()).clamp(32, 4000);
                let (ta, da) = closest_parameter(&n, &a, lo, hi, samples);
                let (mut tb, db) = closest_parameter(&n, &b, lo, hi, samples);
                if da > 1e3 * tol || db > 1e3 * tol {
                    return Err(err(
                        &what,
                        format!("its vertices lie {da:.3e} and {db:.3e} from its curve"),
                    ));
                }
                if start == end || tb <= ta {
                    // a closed curve from its start round to its end
                    if (n.point(lo) - n.point(hi)).norm() <= tol && start == end {
                        tb = hi;
                    } else {
                        return Err(err(&what, "its vertices are out of order along its curve"));
                    }
                }
                (Arc::new(n) as Arc<dyn Curve>, ta, tb)
            }
        };
        self.model.edges.push(Edge {
            curve,
            t0,
            t1,
            start,
            end,
            name: Some(what),
        });
        self.emap.insert(e.id(), n as u32);
        Ok(n as u32)
    }
}

/// A B-spline or NURBS curve of truck as a bubblemesh NURBS curve.
fn convert_curve(c: &TCurve) -> Result<Nurbs, String> {
    let bad = |g: bubblemesh_analytic::GeometryError| g.to_string();
    match c {
        TCurve::BSplineCurve(b) => Nurbs::new(
            b.degree(),
            b.control_points().iter().map(|p| p3(*p)).collect(),
            None,
            b.knot_vec().to_vec(),
        )
        .map_err(bad),
        TCurve::NurbsCurve(n) => {
            let (pts, w) = dehomogenize(n.control_points());
            Nurbs::new(n.degree(), pts, Some(w), n.knot_vec().to_vec()).map_err(bad)
        }
        TCurve::Line(l) => {
            Nurbs::new(1, vec![p3(l.0), p3(l.1)], None, vec![0.0, 0.0, 1.0, 1.0]).map_err(bad)
        }
        TCurve::IntersectionCurve(_) => Err("intersection curves are not supported".into()),
    }
}

fn dehomogenize(h: &[Vector4]) -> (Vec<P3>, Vec<f64>) {
    h.iter()
        .map(|v| (P3::new(v.x / v.w, v.y / v.w, v.z / v.w), v.w))
        .unzip()
}

/// A truck-modeling surface: (surface, whether planar).
fn convert_surface(s: &TSurface) -> Result<(Arc<dyn Surface>, bool), String> {
    let bad = |g: bubblemesh_analytic::SurfaceError| g.to_string();
    Ok(match s {
        TSurface::Plane(p) => {
            let o = p3(p.origin());
            // the core plane wants an orthonormal basis (its inverse
            // projects on it): truck's axes orthonormalised, same normal
            let (a, b) = (p.u_axis(), p.v_axis());
            let (a, b) = (V3::new(a.x, a.y, a.z), V3::new(b.x, b.y, b.z));
            let n = a
                .cross(&b)
                .try_normalize(0.0)
                .ok_or("a plane with parallel axes")?;
            let e1 = a.normalize();
            let e2 = n.cross(&e1);
            (Arc::new(Plane { origin: o, e1, e2 }), true)
        }
        TSurface::BSplineSurface(b) => {
            let net = b
                .control_points()
                .iter()
                .map(|r| r.iter().map(|p| p3(*p)).collect())
                .collect();
            let (ku, kv) = b.knot_vecs();
            let (p, q) = b.degrees();
            let s = NurbsSurface::new(p, q, net, None, ku.to_vec(), kv.to_vec()).map_err(bad)?;
            (Arc::new(s), false)
        }
        TSurface::NurbsSurface(n) => {
            let mut net = Vec::new();
            let mut w = Vec::new();
            for row in n.control_points() {
                let (p, ww) = dehomogenize(row);
                net.push(p);
                w.push(ww);
            }
            let (ku, kv) = n.knot_vecs();
            let (p, q) = n.degrees();
            let s = NurbsSurface::new(p, q, net, Some(w), ku.to_vec(), kv.to_vec()).map_err(bad)?;
            (Arc::new(s), false)
        }
        TSurface::RevolutedCurve(proc_) => {
            let rc = proc_.entity();
            let m: Matrix4 = *proc_.transform();
            let profile = transformed(rc.entity_curve(), &m)?;
            let o = m.transform_point(rc.origin());
            let z = m.transform_vector(rc.axis());
            let r =
                Revolution::new(Arc::new(profile), p3(o), V3::new(z.x, z.y, z.z)).map_err(bad)?;
            (Arc::new(r), false)
        }
    })
}

/// A profile curve moved by the surface's transform (B-spline and NURBS
/// control points transform as points: the transform is affine).
fn transformed(c: &TCurve, m: &Matrix4) -> Result<Nurbs, String> {
    let n = convert_curve(c)?;
    let pts: Vec<P3> = (0..n.control_points().len())
        .map(|i| {
            let p = n.control_points()[i];
            p3(m.transform_point(Point3::new(p.x, p.y, p.z)))
        })
        .collect();
    Nurbs::new(
        n.degree(),
        pts,
        Some(n.weights().to_vec()),
        n.knots().to_vec(),
    )
    .map_err(|g| g.to_string())
}
