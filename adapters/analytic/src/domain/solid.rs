//! `[[solid]]` entries of the domain format: closed volumes for 3D meshing.
//!
//! - `box = { min = [x, y, z], max = [x, y, z] }`: an axis-aligned box, 8
//!   vertices, 12 line edges, 6 planar faces;
//! - `ball = { center = [x, y, z], radius = r }`: one closed sphere face.
//!
//! Each solid becomes one [`Volume`] listing its faces. The volume geometry
//! answers inside/outside exactly, so the engine needs no winding number for
//! these primitives.

use std::sync::Arc;

use bubblemesh_core::geom::{Plane, VolumeGeometry, P3, V3};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex, Volume};
use serde::Deserialize;

use super::error::Invalid;
use super::spec::Pt;
use crate::curves::Line;
use crate::surfaces::Sphere;

/// One `[[solid]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SolidSpec {
    pub name: Option<String>,
    #[serde(rename = "box")]
    pub box_: Option<BoxSpec>,
    pub ball: Option<BallSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BoxSpec {
    pub min: Pt,
    pub max: Pt,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BallSpec {
    pub center: Pt,
    pub radius: f64,
}

/// Exact inside test of an axis-aligned box.
#[derive(Debug)]
struct BoxVolume {
    lo: P3,
    hi: P3,
}

impl VolumeGeometry for BoxVolume {
    fn contains(&self, p: &P3) -> Option<bool> {
        Some((0..3).all(|k| p[k] >= self.lo[k] && p[k] <= self.hi[k]))
    }
}

/// Exact inside test of a ball.
#[derive(Debug)]
struct BallVolume {
    center: P3,
    radius: f64,
}

impl VolumeGeometry for BallVolume {
    fn contains(&self, p: &P3) -> Option<bool> {
        Some((p - self.center).norm() <= self.radius)
    }
}

fn p3(p: &Pt, entity: &str, what: &str) -> Result<P3, Invalid> {
    match p.as_slice() {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Ok(P3::new(*x, *y, *z)),
        _ => Err(Invalid::new(
            entity,
            format!("{what} must be [x, y, z] of finite numbers"),
        )),
    }
}

/// Adds the `[[solid]]` volumes (and their faces, edges, vertices) to
/// `model`.
pub(crate) fn add_solids(specs: &[SolidSpec], model: &mut Model) -> Result<(), Invalid> {
    for (i, s) in specs.iter().enumerate() {
        let entity = match &s.name {
            Some(n) => format!("solid '{n}' (solid #{})", i + 1),
            None => format!("solid #{}", i + 1),
        };
        match (&s.box_, &s.ball) {
            (Some(b), None) => add_box(b, &entity, s.name.clone(), model)?,
            (None, Some(b)) => add_ball(b, &entity, s.name.clone(), model)?,
            (a, b) => {
                return Err(Invalid::new(
                    &entity,
                    format!(
                        "needs exactly one of `box`, `ball` (found {})",
                        a.is_some() as u8 + b.is_some() as u8
                    ),
                ))
            }
        }
    }
    Ok(())
}

fn add_box(
    b: &BoxSpec,
    entity: &str,
    name: Option<String>,
    model: &mut Model,
) -> Result<(), Invalid> {
    let lo = p3(&b.min, entity, "`min`")?;
    let hi = p3(&b.max, entity, "`max`")?;
    if (0..3).any(|k| hi[k] <= lo[k]) {
        return Err(Invalid::new(
            entity,
            format!("`max` must exceed `min` in x, y and z (got min {lo:?}, max {hi:?})"),
        ));
    }
    // corner k has x = bit 0, y = bit 1, z = bit 2
    let v0 = model.vertices.len() as u32;
    for k in 0..8u32 {
        let c = |bit: u32, a: usize| if k >> bit & 1 == 1 { hi[a] } else { lo[a] };
        model.vertices.push(Vertex {
            point: P3::new(c(0, 0), c(1, 1), c(2, 2)),
            name: None,
        });
    }
    // the 12 edges: pairs of corners differing in one bit
    let mut edge_of = std::collections::HashMap::new();
    for a in 0..8u32 {
        for bit in 0..3 {
            let b2 = a | (1 << bit);
            if b2 == a {
                continue;
            }
            let (pa, pb) = (
                model.vertices[(v0 + a) as usize].point,
                model.vertices[(v0 + b2) as usize].point,
            );
            let line = Line::new(pa, pb).map_err(|e| Invalid::new(entity, e.to_string()))?;
            edge_of.insert((a, b2), model.edges.len() as u32);
            model.edges.push(Edge {
                curve: Arc::new(line),
                t0: 0.0,
                t1: 1.0,
                start: v0 + a,
                end: v0 + b2,
                name: None,
            });
        }
    }
    // faces: fixed axis `ax` at side `s` (0 = min, 1 = max); (u,v) along the
    // two other axes, right-handed with the outward normal
    let mut faces = Vec::new();
    for ax in 0..3usize {
        for side in 0..2u32 {
            let (a1, a2) = ((ax + 1) % 3, (ax + 2) % 3);
            let (mut e1, mut e2) = (V3::zeros(), V3::zeros());
            e1[a1] = 1.0;
            e2[a2] = 1.0;
            if side == 0 {
                std::mem::swap(&mut e1, &mut e2);
            }
            let mut origin = lo;
            origin[ax] = if side == 1 { hi[ax] } else { lo[ax] };
            // corners of the face in counter-clockwise order in (u,v)
            let corner = |b1: u32, b2: u32| -> u32 {
                let (ia, ib) = if side == 0 { (a2, a1) } else { (a1, a2) };
                (side << ax) | (b1 << ia) | (b2 << ib)
            };
            let ring = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
            let mut uses = Vec::new();
            for k in 0..4 {
                let (p, q) = (ring[k], ring[(k + 1) % 4]);
                let (e, forward) = match edge_of.get(&(p, q)) {
                    Some(&e) => (e, true),
                    None => (edge_of[&(q, p)], false),
                };
                uses.push(EdgeUse { edge: e, forward });
            }
            let label = ["x", "y", "z"][ax];
            faces.push(model.faces.len() as u32);
            model.faces.push(Face {
                surface: Arc::new(Plane { origin, e1, e2 }),
                loops: vec![Loop { edges: uses }],
                embedded_edges: vec![],
                embedded_vertices: vec![],
                name: Some(format!(
                    "{}{label}{}",
                    name.as_deref().map(|n| format!("{n}:")).unwrap_or_default(),
                    if side == 0 { "min" } else { "max" }
                )),
            });
        }
    }
    model.volumes.push(Volume {
        faces,
        geometry: Some(Arc::new(BoxVolume { lo, hi })),
        name,
    });
    Ok(())
}

fn add_ball(
    b: &BallSpec,
    entity: &str,
    name: Option<String>,
    model: &mut Model,
) -> Result<(), Invalid> {
    let center = p3(&b.center, entity, "`center`")?;
    let sphere = Sphere::new(center, b.radius).map_err(|e| Invalid::new(entity, e.to_string()))?;
    let f = model.faces.len() as u32;
    model.faces.push(Face {
        surface: Arc::new(sphere),
        loops: vec![],
        embedded_edges: vec![],
        embedded_vertices: vec![],
        name: name.clone(),
    });
    model.volumes.push(Volume {
        faces: vec![f],
        geometry: Some(Arc::new(BallVolume {
            center,
            radius: b.radius,
        })),
        name,
    });
    Ok(())
}
