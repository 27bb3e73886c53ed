//! Re-meshing (thesis §4.8): a run that starts from the bubbles of an
//! earlier one.
//!
//! - [`state`]: the saved packing, a versioned file (docs/state-format.md);
//! - [`fingerprint`]: which entities of a changed model are the old ones;
//! - [`region`]: where a local re-meshing (§4.8.1) may move bubbles;
//! - [`warm`]: the per-entity start ([`WarmStart`]) a run consumes
//!   through [`crate::Options::warm`]: continuous re-meshing (§4.8.2)
//!   starts matched entities from their old bubbles carried over by
//!   parameters, population control and a short stage 2 settle them; a
//!   local one keeps the bubbles outside the region fixed, bit for bit;
//! - [`summary`]: what a re-meshing kept, moved, added and removed.

mod cells;
pub mod fingerprint;
pub mod region;
pub mod state;
pub mod summary;
pub mod warm;

pub use region::Region;
pub use state::{State, StateError};
pub use warm::{plan, Matching, PlanError, WarmStart};

use crate::mesh::Mesh;
use crate::model::Model;
use crate::spacing::{Spacing, SpacingQuery};
use state::{Bubble, EntityState};

/// The state of a finished run: every edge, face and volume of `model`
/// with the nodes `mesh` put on it (the bubbles after stage 2, connection
/// and improvement), each with the spacing there as its diameter.
/// `spacing_text` and `source` are recorded as given.
pub fn state_of(
    model: &Model,
    mesh: &Mesh,
    spacing: &dyn Spacing,
    spacing_text: &str,
    source: &str,
) -> State {
    let ents = fingerprint::entities(model);
    let index: std::collections::HashMap<_, _> =
        ents.iter().enumerate().map(|(k, e)| (*e, k)).collect();
    let mut entities: Vec<EntityState> = ents
        .iter()
        .map(|&e| EntityState {
            entity: e,
            name: fingerprint::name_of(model, e),
            fingerprint: fingerprint::fingerprint(model, e),
            range: if e.dim == 1 {
                let x = &model.edges[e.id as usize];
                [x.t0, x.t1]
            } else {
                [0.0, 0.0]
            },
            bubbles: Vec::new(),
        })
        .collect();
    for n in &mesh.nodes {
        if let Some(&k) = index.get(&n.entity) {
            let d = spacing.spacing(&SpacingQuery {
                point: n.pos,
                entity: n.entity,
                params: n.params,
            });
            entities[k].bubbles.push(Bubble {
                params: n.params,
                pos: n.pos,
                d: if d.is_finite() && d > 0.0 {
                    d
                } else {
                    f64::MIN_POSITIVE
                },
            });
        }
    }
    State {
        spacing: spacing_text.to_string(),
        source: source.to_string(),
        dim: mesh.dim().max(1),
        entities,
    }
}
