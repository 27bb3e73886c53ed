//! The warm start of a run (thesis §4.8): for each entity of the new model
//! matched to the state's, the old bubbles it starts from — the free ones,
//! which stage 2 moves, and, in a local re-meshing (§4.8.1), the kept ones,
//! fixed where they were, bit for bit.
//!
//! Built by [`plan`] from a [`State`], the new model and an optional
//! [`Region`]; consumed where edges, faces and volumes place their stage-1
//! bubbles. An entity without a start is meshed from scratch.

use std::collections::HashMap;

use crate::geom::P3;
use crate::model::{EntityRef, Model};
use crate::remesh::cells::Cells;
use crate::remesh::fingerprint;
use crate::remesh::region::Region;
use crate::remesh::state::{Bubble, EntityState, State};
use crate::spacing::{Spacing, SpacingQuery};

/// Steps at most of the short stage 2 after a warm start: the old bubbles
/// are near a balance, so the run usually stops on [`WARM_TOL`] before;
/// this caps the slow creep of a packing that changed a lot.
pub const WARM_MAX_STEPS: usize = 300;

/// A warm stage 2 has settled when no free bubble moved more than this
/// fraction of its diameter in a step (stage 2 from scratch: 1e-3; a warm
/// start only has to settle the footprint of a change).
pub const WARM_TOL: f64 = 3e-3;

/// Where one entity starts.
#[derive(Clone, Debug, Default)]
pub struct EntityStart {
    /// Old bubbles that stage 2 moves (carried over by their parameters).
    pub free: Vec<Bubble>,
    /// Old bubbles kept exactly (local re-meshing: outside the region and
    /// its band); fixed, and written back with their old coordinates.
    pub kept: Vec<Bubble>,
    /// The old parameter range of an edge (`[t0, t1]`), to carry its
    /// bubbles' parameters over to the new range.
    pub range: [f64; 2],
    /// A volume's old tetrahedra (corner positions): those whose corners
    /// are all kept nodes and that nothing new enters are kept
    /// ([`crate::volume`]'s `keep`).
    pub tets: Vec<[P3; 4]>,
}

/// The warm start of every matched entity.
#[derive(Clone, Debug, Default)]
pub struct WarmStart {
    starts: HashMap<EntityRef, EntityStart>,
    /// A local re-meshing (some bubbles kept).
    pub local: bool,
}

impl WarmStart {
    /// The start of entity `e`, if it was matched.
    pub fn of(&self, e: EntityRef) -> Option<&EntityStart> {
        self.starts.get(&e)
    }
}

/// What [`plan`] found.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Matching {
    /// Entities started from their old bubbles.
    pub matched: Vec<String>,
    /// Entities meshed from scratch, each with why.
    pub unmatched: Vec<String>,
    /// Old bubbles left free (they move).
    pub free_bubbles: usize,
    /// Old bubbles kept exactly.
    pub kept_bubbles: usize,
}

/// Why a state cannot warm-start a model.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PlanError {
    /// Fewer than half the state's entities match: it is of another model.
    #[error("the state was saved from another model: {matched} of its {entities} entities match the input (fewer than half; first mismatch: {example})")]
    AnotherModel {
        /// Entities that matched.
        matched: usize,
        /// Entities in the state.
        entities: usize,
        /// Why the first did not match.
        example: String,
    },
    /// The region frees no bubble.
    #[error("the region {0} selects nothing: no bubble of a matched entity lies in it or within {band} spacings of it", band = crate::remesh::region::BAND)]
    EmptyRegion(String),
    /// A local re-meshing whose region leaves out a change of the
    /// geometry: a bubble it would keep is no longer on its edge or face.
    #[error("the region {region} leaves out a change of the geometry: {entity} moved by {moved:e} at ({x}, {y}, {z}), outside the region and its band; give a region that covers every change, or re-mesh without --region")]
    ChangedOutside {
        /// The region as written.
        region: String,
        /// The edge or face, described.
        entity: String,
        /// How far the kept bubble's point moved, model units.
        moved: f64,
        /// The old bubble.
        x: f64,
        /// See `x`.
        y: f64,
        /// See `x`.
        z: f64,
    },
    /// A listed face does not exist.
    #[error("the region names face {face}, but the model has {faces} faces (ids 0 to {last})", last = faces.saturating_sub(1))]
    NoSuchFace {
        /// The face id.
        face: u32,
        /// Faces in the model.
        faces: usize,
    },
}

/// Width of the band around the footprint of a change whose bubbles are
/// free in a continuous re-meshing, in spacings.
pub const FOOTPRINT_BAND: f64 = 3.0;

/// A local re-meshing refuses a kept bubble of an edge or face whose
/// carried-over position moved by more than this fraction of its diameter
/// (the region leaves out a change of the geometry; looser than
/// [`DISTURBED`], so that a re-export's rounding of the same geometry is
/// not taken for a change).
pub const OUTSIDE_TOL: f64 = 1e-6;

/// A bubble is disturbed by a change when its carried-over position moved,
/// or its spacing changed, by more than this fraction of its diameter.
pub const DISTURBED: f64 = 1e-9;

/// Matches the entities of `model` to those of `state` and splits each
/// matched entity's old bubbles into free and kept.
///
/// With a `region` (local re-meshing, §4.8.1) the bubbles in it or in its
/// band are free. Without one (continuous re-meshing, §4.8.2) the free
/// bubbles are the footprint of the change: every old bubble that the new
/// geometry or spacing displaces (carried over by its parameters onto the
/// new edge or face, its position or its spacing `spacing` changed by more
/// than [`DISTURBED`] of its diameter), every old bubble of an entity that
/// no longer matches, points along new edges, and every bubble within
/// [`FOOTPRINT_BAND`] spacings of those. The others are kept where they
/// were: where nothing changed, nothing moves (a model that deforms
/// everywhere frees every bubble).
pub fn plan(
    state: &State,
    model: &Model,
    spacing: &dyn Spacing,
    region: Option<&Region>,
) -> Result<(WarmStart, Matching), PlanError> {
    if let Some(Region::Faces(ids)) = region {
        if let Some(&face) = ids.iter().find(|&&f| f as usize >= model.faces.len()) {
            return Err(PlanError::NoSuchFace {
                face,
                faces: model.faces.len(),
            });
        }
    }
    let by_ref: HashMap<EntityRef, usize> = state
        .entities
        .iter()
        .enumerate()
        .map(|(k, e)| (e.entity, k))
        .collect();
    let mut m = Matching::default();
    let mut first_reason = None;
    let mut matched: Vec<(EntityRef, &EntityState)> = Vec::new();
    for e in fingerprint::entities(model) {
        let why = match by_ref.get(&e) {
            None => Some("not in the state".to_string()),
            Some(&k) => fingerprint::mismatch(model, e, &state.entities[k]),
        };
        match why {
            Some(why) => {
                first_reason.get_or_insert_with(|| format!("{}: {why}", model.describe(e)));
                m.unmatched.push(format!("{}: {why}", model.describe(e)));
            }
            None => {
                m.matched.push(model.describe(e));
                matched.push((e, &state.entities[by_ref[&e]]));
            }
        }
    }
    // a state whose entities mostly do not match is of another model (a
    // change of a design matches all but the few entities it touched)
    if matched.is_empty() || 2 * matched.len() < state.entities.len() {
        return Err(PlanError::AnotherModel {
            matched: matched.len(),
            entities: state.entities.len(),
            example: first_reason.unwrap_or_else(|| "the input has no entities".into()),
        });
    }
    let faces_of_edge = |edge: u32| -> Vec<u32> {
        (0..model.faces.len() as u32)
            .filter(|&f| {
                let face = &model.faces[f as usize];
                face.loops
                    .iter()
                    .any(|l| l.edges.iter().any(|u| u.edge == edge))
                    || face.embedded_edges.contains(&edge)
            })
            .collect()
    };
    let footprint = match region {
        Some(_) => None,
        None => Some(Footprint::of(state, model, spacing, &matched)),
    };
    let mut warm = WarmStart {
        starts: HashMap::new(),
        local: region.is_some(),
    };
    // the first kept bubble a local re-meshing finds off its geometry
    let mut outside = None;
    for (e, old) in matched {
        // an edge's bubbles get their parameters on the new edge (and its
        // range), a kept one keeping its old coordinates
        let range = match e.dim {
            1 => {
                let x = &model.edges[e.id as usize];
                [x.t0, x.t1]
            }
            _ => old.range,
        };
        let mut start = EntityStart {
            range,
            ..Default::default()
        };
        for b in &old.bubbles {
            let free = match (region, &footprint) {
                (Some(r), _) => r.frees(e, &b.pos, b.d, &faces_of_edge),
                (None, Some(f)) => f.frees(b),
                (None, None) => true,
            };
            let (at, params) = carried(model, e, old.range, b);
            if let (Some(r), false) = (region, free) {
                // a kept node must still be on its edge or face
                let moved = (at - b.pos).norm();
                if e.dim < 3 && moved > OUTSIDE_TOL * b.d && outside.is_none() {
                    outside = Some(PlanError::ChangedOutside {
                        region: describe_region(r),
                        entity: model.describe(e),
                        moved,
                        x: b.pos.x,
                        y: b.pos.y,
                        z: b.pos.z,
                    });
                }
            }
            let b = match e.dim {
                1 => Bubble { params, ..*b },
                _ => *b,
            };
            if free {
                start.free.push(b);
            } else {
                start.kept.push(b);
            }
        }
        start.tets = old.tets.clone();
        m.free_bubbles += start.free.len();
        m.kept_bubbles += start.kept.len();
        warm.starts.insert(e, start);
    }
    if let Some(r) = region {
        if m.free_bubbles == 0 && !matches!(r, Region::Faces(_)) {
            return Err(PlanError::EmptyRegion(describe_region(r)));
        }
    }
    if let Some(e) = outside {
        return Err(e);
    }
    Ok((warm, m))
}

/// Where a change touched the old packing: points with the spacing there.
struct Footprint {
    pts: Vec<P3>,
    cells: Cells,
}

impl Footprint {
    /// The disturbed points of a continuous re-meshing (see [`plan`]).
    fn of(
        state: &State,
        model: &Model,
        spacing: &dyn Spacing,
        matched: &[(EntityRef, &EntityState)],
    ) -> Footprint {
        let mut pts: Vec<P3> = Vec::new();
        let mut dmax: f64 = 0.0;
        let is_matched: std::collections::HashSet<EntityRef> =
            matched.iter().map(|(e, _)| *e).collect();
        for (e, old) in matched {
            for b in &old.bubbles {
                dmax = dmax.max(b.d);
                let (p, params) = carried(model, *e, old.range, b);
                let d = spacing.spacing(&SpacingQuery {
                    point: p,
                    entity: *e,
                    params,
                });
                let tol = DISTURBED * b.d;
                if !((p - b.pos).norm() <= tol && (d - b.d).abs() <= tol) {
                    pts.push(b.pos);
                    pts.push(p);
                }
            }
        }
        // entities that no longer match: their old bubbles, and points
        // along their new geometry (edges)
        for old in &state.entities {
            if !is_matched.contains(&old.entity) {
                pts.extend(old.bubbles.iter().map(|b| b.pos));
                dmax = old.bubbles.iter().map(|b| b.d).fold(dmax, f64::max);
            }
        }
        for (ei, edge) in model.edges.iter().enumerate() {
            if !is_matched.contains(&EntityRef::new(1, ei as u32)) {
                let n = 64;
                for k in 0..=n {
                    let t = edge.t0 + (edge.t1 - edge.t0) * k as f64 / n as f64;
                    pts.push(edge.curve.point(t));
                }
            }
        }
        let h = (FOOTPRINT_BAND * dmax).max(f64::MIN_POSITIVE);
        let cells = Cells::new(&pts, h);
        Footprint { pts, cells }
    }

    /// Whether old bubble `b` is within the band of the footprint.
    fn frees(&self, b: &Bubble) -> bool {
        self.cells.near(&self.pts, &b.pos, FOOTPRINT_BAND * b.d)
    }
}

/// An old bubble carried over to the new geometry of `e` by its
/// parameters: its new position and parameters (an edge's relative to its
/// old range `range`, or, where the old point still lies on the new edge,
/// that point's parameter — a line made longer keeps its nodes; a
/// volume's bubbles stay where they were).
fn carried(model: &Model, e: EntityRef, range: [f64; 2], b: &Bubble) -> (P3, [f64; 2]) {
    match e.dim {
        1 => {
            let edge = &model.edges[e.id as usize];
            let [r0, r1] = range;
            let t = if r1 != r0 {
                edge.t0 + (b.params[0] - r0) / (r1 - r0) * (edge.t1 - edge.t0)
            } else {
                b.params[0]
            };
            if let Some(s) = on_curve(&*edge.curve, edge.t0, edge.t1, t, &b.pos, DISTURBED * b.d) {
                return (b.pos, [s, 0.0]);
            }
            (edge.curve.point(t), [t, 0.0])
        }
        2 => {
            let s = &model.faces[e.id as usize].surface;
            (s.point(b.params[0], b.params[1]), b.params)
        }
        _ => (b.pos, b.params),
    }
}

/// The parameter in `[t0, t1]` of the point of `curve` within `tol` of
/// `p`, by Newton's method on (C(t) − p)·C′(t) = 0 from `guess`; `None`
/// when `p` is farther from the curve (or the iteration leaves the range).
fn on_curve(
    curve: &dyn crate::geom::Curve,
    t0: f64,
    t1: f64,
    guess: f64,
    p: &P3,
    tol: f64,
) -> Option<f64> {
    let mut t = guess.clamp(t0, t1);
    for _ in 0..16 {
        let r = curve.point(t) - p;
        if r.norm() <= tol {
            return Some(t);
        }
        let (c1, c2) = (curve.d1(t), curve.d2(t));
        let (f, df) = (r.dot(&c1), c1.norm_squared() + r.dot(&c2));
        if !(df > 0.0) {
            return None;
        }
        t = (t - f / df).clamp(t0, t1);
    }
    ((curve.point(t) - p).norm() <= tol).then_some(t)
}

/// A region as the user wrote it.
fn describe_region(r: &Region) -> String {
    match r {
        Region::Box { lo, hi } => {
            format!("box:{},{},{},{},{},{}", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z)
        }
        Region::Sphere { center, radius } => {
            format!("sphere:{},{},{},{radius}", center.x, center.y, center.z)
        }
        Region::Faces(ids) => format!(
            "faces:{}",
            ids.iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(",")
        ),
    }
}
