//! `[[surface]]` entries of the domain format: faces on curved surfaces.
//!
//! - `sphere`, `torus`: closed faces with no boundary loop;
//! - `cylinder`, `cone`: the lateral face between the circles at the ends of
//!   its range (a cone from its apex has only the base circle);
//! - `nurbs`: a NURBS patch, its outer loop the boundary of the parameter
//!   domain;
//! - `holes_uv`: polygons in the surface's (u,v) parameters cut out of any
//!   of them (each side a curve on the surface, C(t) = S(P(t))).
//!
//! Every surface is documented with its parametrization in
//! `docs/domain-format.md` and in [`crate::surfaces`].

use std::sync::Arc;

use bubblemesh_core::geom::{Curve, Surface, P3, V3};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex};
use serde::Deserialize;

use super::error::Invalid;
use super::spec::Pt;
use crate::curves::{CurveOnSurface, Line};
use crate::surfaces::{Cone, Cylinder, NurbsSurface, Sphere, Torus};

/// One `[[surface]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SurfaceSpec {
    pub name: Option<String>,
    pub sphere: Option<SphereSpec>,
    pub torus: Option<TorusSpec>,
    pub cylinder: Option<CylinderSpec>,
    pub cone: Option<ConeSpec>,
    pub nurbs: Option<NurbsSurfaceSpec>,
    /// Holes as polygons in (u,v).
    #[serde(default)]
    pub holes_uv: Vec<Vec<[f64; 2]>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SphereSpec {
    pub center: Pt,
    pub radius: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TorusSpec {
    pub center: Pt,
    pub axis: Option<Pt>,
    pub major: f64,
    pub minor: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CylinderSpec {
    pub origin: Pt,
    pub axis: Option<Pt>,
    pub radius: f64,
    pub height: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ConeSpec {
    pub apex: Pt,
    pub axis: Option<Pt>,
    /// Half angle in degrees.
    pub half_angle: f64,
    /// Slant distances from the apex bounding the face (`from` may be 0).
    pub from: f64,
    pub to: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct NurbsSurfaceSpec {
    pub degree: [usize; 2],
    /// `points[i][j]`, i along u.
    pub points: Vec<Vec<Pt>>,
    pub weights: Option<Vec<Vec<f64>>>,
    pub knots_u: Option<Vec<f64>>,
    pub knots_v: Option<Vec<f64>>,
}

fn p3(p: &Pt, entity: &str, what: &str) -> Result<P3, Invalid> {
    match p.as_slice() {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Ok(P3::new(*x, *y, *z)),
        [x, y] if x.is_finite() && y.is_finite() => Ok(P3::new(*x, *y, 0.0)),
        _ => Err(Invalid::new(
            entity,
            format!("{what} must be [x, y, z] of finite numbers"),
        )),
    }
}

fn axis(p: &Option<Pt>, entity: &str) -> Result<V3, Invalid> {
    match p {
        None => Ok(V3::z()),
        Some(a) => Ok(p3(a, entity, "the axis")?.coords),
    }
}

/// Adds the `[[surface]]` faces to `model`.
pub(crate) fn add_surfaces(specs: &[SurfaceSpec], model: &mut Model) -> Result<(), Invalid> {
    for (i, s) in specs.iter().enumerate() {
        let entity = match &s.name {
            Some(n) => format!("surface '{n}' (surface #{})", i + 1),
            None => format!("surface #{}", i + 1),
        };
        let kinds = [
            s.sphere.is_some(),
            s.torus.is_some(),
            s.cylinder.is_some(),
            s.cone.is_some(),
            s.nurbs.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if kinds != 1 {
            return Err(Invalid::new(
                &entity,
                format!(
                    "needs exactly one of sphere, torus, cylinder, cone, nurbs (found {kinds})"
                ),
            ));
        }
        let bad = |e: crate::surfaces::SurfaceError| Invalid::new(&entity, e.to_string());
        let tau = std::f64::consts::TAU;
        // (surface, boundary loops in (u,v) as (open pcurve polylines that
        // close through a period, or closed polygons))
        let (surface, mut loops): (Arc<dyn Surface>, Vec<Vec<[f64; 2]>>) = if let Some(sp) =
            &s.sphere
        {
            (
                Arc::new(
                    Sphere::new(p3(&sp.center, &entity, "the centre")?, sp.radius).map_err(bad)?,
                ),
                vec![],
            )
        } else if let Some(t) = &s.torus {
            let c = p3(&t.center, &entity, "the centre")?;
            (
                Arc::new(Torus::new(c, axis(&t.axis, &entity)?, t.major, t.minor).map_err(bad)?),
                vec![],
            )
        } else if let Some(c) = &s.cylinder {
            let o = p3(&c.origin, &entity, "the origin")?;
            if !(c.height > 0.0 && c.height.is_finite()) {
                return Err(Invalid::new(
                    &entity,
                    format!("height must be positive (got {})", c.height),
                ));
            }
            let cyl = Cylinder::bounded(o, axis(&c.axis, &entity)?, c.radius, 0.0, c.height)
                .map_err(bad)?;
            (
                Arc::new(cyl),
                vec![
                    vec![[0.0, 0.0], [tau, 0.0]],
                    vec![[tau, c.height], [0.0, c.height]],
                ],
            )
        } else if let Some(c) = &s.cone {
            let a = p3(&c.apex, &entity, "the apex")?;
            if !(c.from >= 0.0 && c.to > c.from && c.to.is_finite()) {
                return Err(Invalid::new(
                    &entity,
                    format!("needs 0 ≤ from < to (got from {}, to {})", c.from, c.to),
                ));
            }
            let half = c.half_angle.to_radians();
            let cone =
                Cone::bounded(a, axis(&c.axis, &entity)?, half, c.from, c.to).map_err(bad)?;
            let mut l = vec![vec![[tau, c.to], [0.0, c.to]]];
            if c.from > 0.0 {
                l.insert(0, vec![[0.0, c.from], [tau, c.from]]);
            }
            (Arc::new(cone), l)
        } else if let Some(n) = &s.nurbs {
            let net: Vec<Vec<P3>> = n
                .points
                .iter()
                .map(|row| {
                    row.iter()
                        .map(|p| p3(p, &entity, "a control point"))
                        .collect()
                })
                .collect::<Result<_, _>>()?;
            let surf = match (&n.knots_u, &n.knots_v) {
                (Some(ku), Some(kv)) => NurbsSurface::new(
                    n.degree[0],
                    n.degree[1],
                    net,
                    n.weights.clone(),
                    ku.clone(),
                    kv.clone(),
                ),
                (None, None) => {
                    NurbsSurface::clamped_uniform(n.degree[0], n.degree[1], net, n.weights.clone())
                }
                _ => {
                    return Err(Invalid::new(
                        &entity,
                        "give both knots_u and knots_v, or neither",
                    ))
                }
            }
            .map_err(bad)?;
            let (du, dv) = surf.domain();
            let outer = vec![
                [du[0], dv[0]],
                [du[1], dv[0]],
                [du[1], dv[1]],
                [du[0], dv[1]],
                [du[0], dv[0]],
            ];
            (Arc::new(surf), vec![outer])
        } else {
            unreachable!("exactly one kind was checked above")
        };
        let periods = surface.periods();
        // holes: closed polygons in (u,v), made clockwise
        for (k, h) in s.holes_uv.iter().enumerate() {
            if h.len() < 3 || h.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
                return Err(Invalid::new(
                    &entity,
                    format!("hole {} needs at least 3 finite (u,v) points", k + 1),
                ));
            }
            // a hole wholly beyond the parameter range along a
            // non-periodic direction cuts nothing: the connection would
            // fail later with misleading advice about the size
            let (du, dv) = surface.domain();
            for (c, (range, name)) in [(du, "u"), (dv, "v")].into_iter().enumerate() {
                if periods[c].is_some() {
                    continue;
                }
                let below = h.iter().all(|p| p[c] <= range[0]);
                let above = h.iter().all(|p| p[c] >= range[1]);
                if below || above {
                    return Err(Invalid::new(
                        &entity,
                        format!(
                            "hole {} lies outside the surface's parameter range \
                             ({name} in [{}, {}]); holes_uv are (u,v) points of the surface",
                            k + 1,
                            range[0],
                            range[1]
                        ),
                    ));
                }
            }
            let o = h[0];
            let area2: f64 = (0..h.len())
                .map(|i| {
                    let (a, b) = (h[i], h[(i + 1) % h.len()]);
                    let (a, b) = ([a[0] - o[0], a[1] - o[1]], [b[0] - o[0], b[1] - o[1]]);
                    a[0] * b[1] - b[0] * a[1]
                })
                .sum();
            let mut h = h.clone();
            if area2 > 0.0 {
                h.reverse();
            }
            let mut closed = h.clone();
            closed.push(h[0]);
            loops.push(closed);
        }
        let mut face_loops = Vec::new();
        for (li, pts) in loops.iter().enumerate() {
            // a loop given open ([a, b] across a period) closes through it;
            // a closed polygon repeats its first point
            let n_sides = pts.len() - 1;
            let mut vids = Vec::new();
            for p in &pts[..n_sides] {
                let q = surface.point(p[0], p[1]);
                vids.push(model.vertices.len() as u32);
                model.vertices.push(Vertex {
                    point: q,
                    name: None,
                });
            }
            let closes_through_period = (0..2).any(|c| {
                periods[c]
                    .is_some_and(|per| ((pts[n_sides][c] - pts[0][c]).abs() - per).abs() < 1e-12)
            });
            let mut lp = Loop::default();
            for k in 0..n_sides {
                let (a, b) = (pts[k], pts[k + 1]);
                let pcurve = Line::new(P3::new(a[0], a[1], 0.0), P3::new(b[0], b[1], 0.0))
                    .map_err(|e| Invalid::new(&entity, format!("loop {}: {e}", li + 1)))?;
                let pcurve: Arc<dyn Curve> = Arc::new(pcurve);
                let curve: Arc<dyn Curve> = Arc::new(CurveOnSurface {
                    surface: surface.clone(),
                    pcurve: pcurve.clone(),
                });
                let start = vids[k];
                let end = if k + 1 == n_sides {
                    if closes_through_period || pts[n_sides] == pts[0] {
                        vids[0]
                    } else {
                        return Err(Invalid::new(
                            &entity,
                            format!("loop {} is not closed", li + 1),
                        ));
                    }
                } else {
                    vids[k + 1]
                };
                model.edges.push(Edge {
                    curve,
                    t0: 0.0,
                    t1: 1.0,
                    start,
                    end,
                    name: None,
                });
                let edge = model.edges.len() as u32 - 1;
                model
                    .pcurves
                    .insert((model.faces.len() as u32, edge), pcurve);
                lp.edges.push(EdgeUse {
                    edge,
                    forward: true,
                });
            }
            face_loops.push(lp);
        }
        // a cone that reaches its apex has a vertex there: the sharp point
        // is a node of the mesh (thesis §3.2.3: vertex bubbles are fixed)
        let mut embedded_vertices = Vec::new();
        if let Some(c) = &s.cone {
            if c.from == 0.0 {
                embedded_vertices.push(model.vertices.len() as u32);
                model.vertices.push(Vertex {
                    point: p3(&c.apex, &entity, "the apex")?,
                    name: Some("apex".into()),
                });
            }
        }
        model.faces.push(Face {
            surface,
            loops: face_loops,
            embedded_edges: vec![],
            embedded_vertices,
            name: s.name.clone(),
        });
    }
    Ok(())
}
