//! Local refinement where the geometry needs more nodes than the requested
//! spacing gives: a face whose bubbles cannot be connected into a valid
//! triangulation (a fillet or small sphere sampled too coarsely, a sliver
//! face narrower than the spacing, boundary chords that cross in (u,v)) is
//! meshed again with a finer spacing inside it and on its boundary edges.
//!
//! Each failed attempt raises the face's *level* by one: its interior
//! spacing is d · 2^-level, and each of its edges gets spacing d · 2^-level
//! with at least level + 1 segments (so an edge far shorter than d is split
//! too). Neighbouring faces share the refined edges and are meshed again
//! with them. Levels stop at [`MAX_LEVEL`]; a face that still fails is an
//! error. Every refinement is listed in the report with its reason, since
//! there the mesh departs from the requested spacing.

use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};

/// The most refinement rounds of one model: each round meshes the whole
/// model again, so this bounds the time. Faces often fail one after
/// another as their neighbours' edges are refined: `as_0049` needs 9 rounds
/// and `as_0085` 7 at diag/25 (with 6, both were refused).
pub const MAX_ROUNDS: usize = 16;

/// The finest level: spacing d/16 and at least 5 segments per edge.
pub const MAX_LEVEL: u8 = 4;

/// Refinement levels of faces and edges (0: the requested spacing).
#[derive(Clone, Debug, Default)]
pub(crate) struct Refinement {
    face: Vec<u8>,
    edge: Vec<u8>,
    /// Why each face was refined (the last error it gave).
    reason: Vec<Option<String>>,
}

/// One refined face, for the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RefinedFace {
    /// The face's id.
    pub face: u32,
    /// The face's name in the model, if it has one.
    pub name: Option<String>,
    /// Interior and boundary spacing as a fraction of the requested one.
    pub spacing_factor: f64,
    /// The error the face gave at the coarser level.
    pub reason: String,
}

impl Refinement {
    /// No refinement: every face and edge at level 0.
    pub fn new(model: &Model) -> Self {
        Refinement {
            face: vec![0; model.faces.len()],
            edge: vec![0; model.edges.len()],
            reason: vec![None; model.faces.len()],
        }
    }

    /// Whether nothing is refined (the requested spacing everywhere).
    pub fn is_empty(&self) -> bool {
        self.face.iter().all(|&l| l == 0) && self.edge.iter().all(|&l| l == 0)
    }

    /// Refines `faces` and `edges` one level further (the faces' boundary
    /// edges with them). Returns `false` when none of them can be refined
    /// further.
    /// `reasons[k]` is why `faces[k]` failed; faces beyond it take `reason`.
    pub fn bump(
        &mut self,
        model: &Model,
        faces: &[u32],
        reasons: &[String],
        edges: &[u32],
        reason: &str,
    ) -> bool {
        let mut any = false;
        for (k, &f) in faces.iter().enumerate() {
            let reason = reasons.get(k).map_or(reason, |r| r.as_str());
            let Some(l) = self.face.get_mut(f as usize) else {
                continue;
            };
            if *l >= MAX_LEVEL {
                continue;
            }
            *l += 1;
            let level = *l;
            any = true;
            self.reason[f as usize] = Some(reason.to_string());
            for u in model.faces[f as usize]
                .loops
                .iter()
                .flat_map(|l| l.edges.iter())
            {
                let e = &mut self.edge[u.edge as usize];
                *e = (*e).max(level);
            }
            for &e in &model.faces[f as usize].embedded_edges {
                let e = &mut self.edge[e as usize];
                *e = (*e).max(level);
            }
        }
        for &e in edges {
            if let Some(l) = self.edge.get_mut(e as usize) {
                if *l < MAX_LEVEL {
                    *l += 1;
                    any = true;
                }
            }
        }
        any
    }

    /// The least number of segments of edge `e`.
    pub fn min_segments(&self, e: usize) -> usize {
        self.edge.get(e).map_or(1, |&l| l as usize + 1)
    }

    fn factor(&self, e: EntityRef) -> f64 {
        let level = match e.dim {
            1 => self.edge.get(e.id as usize).copied().unwrap_or(0),
            2 => self.face.get(e.id as usize).copied().unwrap_or(0),
            _ => 0,
        };
        0.5f64.powi(level as i32)
    }

    /// The refined faces, for the report.
    pub fn faces(&self, model: &Model) -> Vec<RefinedFace> {
        (0..self.face.len())
            .filter(|&f| self.face[f] > 0)
            .map(|f| RefinedFace {
                face: f as u32,
                name: model.faces[f].name.clone(),
                spacing_factor: 0.5f64.powi(self.face[f] as i32),
                reason: self.reason[f].clone().unwrap_or_default(),
            })
            .collect()
    }
}

/// The requested spacing with the refinement applied: d times the factor
/// of the entity the query is on (vertices and volumes keep d).
pub(crate) struct Refined<'a> {
    pub inner: &'a dyn Spacing,
    pub refinement: &'a Refinement,
}

impl Spacing for Refined<'_> {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.inner.spacing(q) * self.refinement.factor(q.entity)
    }
    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        self.inner.spacing_batch(qs, out);
        for (q, o) in qs.iter().zip(out.iter_mut()) {
            *o *= self.refinement.factor(q.entity);
        }
    }
    fn constant(&self) -> Option<f64> {
        if self.refinement.is_empty() {
            self.inner.constant()
        } else {
            None
        }
    }
}
