//! Fingerprints of a model's entities, and whether two match (thesis §4.8.2:
//! continuous re-meshing starts an entity from its old bubbles only if it
//! is the same entity, changed a little).
//!
//! An entity of the new model matches the state's entity of the same
//! dimension and id when the names agree (a volume's may differ: STEP
//! writers number the product a solid comes from per export, OpenCascade's
//! "Open CASCADE STEP translator 7.9 1" is "… 2" in the next file), the
//! geometry's type agrees, the
//! measure changed by at most [`MEASURE_TOL`] of the old and the centroid
//! moved by at most [`CENTROID_TOL`] of the entity's scale (its measure, or
//! the square root of an area).

use crate::geom::{length_between, P3};
use crate::model::{EntityRef, Model};
use crate::remesh::state::{EntityState, Fingerprint};

/// Largest relative change of the measure for a match.
pub const MEASURE_TOL: f64 = 0.25;
/// Largest move of the centroid for a match, as a fraction of the scale.
pub const CENTROID_TOL: f64 = 0.25;

/// Samples per edge for the centroid.
const EDGE_SAMPLES: usize = 32;

/// The type name of a geometry from its `Debug` text (`Line { .. }` →
/// `Line`).
fn kind_of(debug: &str) -> String {
    debug
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect()
}

/// Length and centroid of edge `ei`.
fn edge_samples(model: &Model, ei: usize) -> (f64, P3) {
    let e = &model.edges[ei];
    let len = length_between(e.curve.as_ref(), e.t0, e.t1);
    let mut c = P3::origin().coords;
    for k in 0..=EDGE_SAMPLES {
        let t = e.t0 + (e.t1 - e.t0) * k as f64 / EDGE_SAMPLES as f64;
        c += e.curve.point(t).coords;
    }
    (len, P3::from(c / (EDGE_SAMPLES + 1) as f64))
}

/// The fingerprint of an entity of `model` (dimension 1 to 3).
pub fn fingerprint(model: &Model, e: EntityRef) -> Fingerprint {
    let i = e.id as usize;
    match e.dim {
        1 => {
            let (measure, centroid) = edge_samples(model, i);
            Fingerprint {
                kind: kind_of(&format!("{:?}", model.edges[i].curve)),
                measure,
                centroid,
            }
        }
        2 => face_fingerprint(model, i),
        _ => {
            let v = &model.volumes[i];
            let fs: Vec<Fingerprint> = v
                .faces
                .iter()
                .map(|&f| face_fingerprint(model, f as usize))
                .collect();
            let measure: f64 = fs.iter().map(|f| f.measure).sum();
            let c = fs
                .iter()
                .map(|f| f.centroid.coords * f.measure)
                .fold(P3::origin().coords, |a, b| a + b)
                / measure.max(f64::MIN_POSITIVE);
            Fingerprint {
                kind: "Volume".into(),
                measure,
                centroid: P3::from(c),
            }
        }
    }
}

/// A face's fingerprint: its boundary's length and centroid; a face
/// without boundary (a whole sphere) its area and centroid, sampled on
/// its parameter box.
fn face_fingerprint(model: &Model, fi: usize) -> Fingerprint {
    let f = &model.faces[fi];
    let kind = kind_of(&format!("{:?}", f.surface));
    let edges: Vec<usize> = f
        .loops
        .iter()
        .flat_map(|l| l.edges.iter().map(|u| u.edge as usize))
        .filter(|&e| e < model.edges.len())
        .collect();
    if !edges.is_empty() {
        let mut len = 0.0;
        let mut c = P3::origin().coords;
        for e in edges {
            let (l, ce) = edge_samples(model, e);
            len += l;
            c += ce.coords * l;
        }
        return Fingerprint {
            kind,
            measure: len,
            centroid: P3::from(c / len.max(f64::MIN_POSITIVE)),
        };
    }
    let (u, v) = f.surface.domain();
    let n = 24;
    let (du, dv) = ((u[1] - u[0]) / n as f64, (v[1] - v[0]) / n as f64);
    let mut area = 0.0;
    let mut c = P3::origin().coords;
    if du.is_finite() && dv.is_finite() {
        for i in 0..n {
            for j in 0..n {
                let (a, b) = (u[0] + (i as f64 + 0.5) * du, v[0] + (j as f64 + 0.5) * dv);
                let d = f.surface.derivs(a, b);
                let w = d.su.cross(&d.sv).norm() * du * dv;
                if w.is_finite() {
                    area += w;
                    c += f.surface.point(a, b).coords * w;
                }
            }
        }
    }
    Fingerprint {
        kind,
        measure: area,
        centroid: P3::from(c / area.max(f64::MIN_POSITIVE)),
    }
}

/// The name of an entity of `model`.
pub fn name_of(model: &Model, e: EntityRef) -> Option<String> {
    let i = e.id as usize;
    match e.dim {
        1 => model.edges.get(i).and_then(|x| x.name.clone()),
        2 => model.faces.get(i).and_then(|x| x.name.clone()),
        3 => model.volumes.get(i).and_then(|x| x.name.clone()),
        _ => None,
    }
}

/// Why `old` does not match the entity `e` of `model` (`None`: it matches).
pub fn mismatch(model: &Model, e: EntityRef, old: &EntityState) -> Option<String> {
    if old.entity != e {
        return Some(format!("{} is not {e}", old.entity));
    }
    let name = name_of(model, e);
    if name != old.name && e.dim != 3 {
        return Some(format!("named {:?}, was {:?}", name, old.name));
    }
    let new = fingerprint(model, e);
    let was = &old.fingerprint;
    if new.kind != was.kind {
        return Some(format!("a {} now, was a {}", new.kind, was.kind));
    }
    let scale = if e.dim == 2 && model.faces[e.id as usize].loops.is_empty() {
        was.measure.sqrt()
    } else {
        was.measure
    };
    if (new.measure - was.measure).abs() > MEASURE_TOL * was.measure {
        return Some(format!(
            "measure {:.6} now, was {:.6}",
            new.measure, was.measure
        ));
    }
    let moved = (new.centroid - was.centroid).norm();
    if moved > CENTROID_TOL * scale {
        return Some(format!("centroid moved by {moved:.6}"));
    }
    None
}

/// Every edge, face and volume of `model`, in (dim, id) order.
pub fn entities(model: &Model) -> Vec<EntityRef> {
    let mut out = Vec::new();
    for (dim, n) in [
        (1u8, model.edges.len()),
        (2, model.faces.len()),
        (3, model.volumes.len()),
    ] {
        out.extend((0..n as u32).map(|i| EntityRef::new(dim, i)));
    }
    out
}
