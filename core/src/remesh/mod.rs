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
    Seed::new(model, mesh, spacing, spacing_text, source).state(mesh)
}

/// [`state_of`] in two steps, for a caller that keeps a mesh but not its
/// model and spacing (the C ABI, whose host callbacks may be gone when the
/// state is asked for): [`Seed::new`] evaluates the geometry and the
/// spacing while they are at hand, [`Seed::state`] puts the nodes in later.
#[derive(Clone, Debug)]
pub struct Seed {
    /// Every edge, face and volume's record, without bubbles.
    records: State,
    /// The diameter of each node of the mesh, in node order (0 for nodes
    /// on no recorded entity: model vertices).
    d: Vec<f64>,
}

impl Seed {
    /// The records of `model` and the spacing at each node of `mesh`, a
    /// diameter > 0 (a spacing that is not is recorded as the smallest
    /// positive number).
    pub fn new(
        model: &Model,
        mesh: &Mesh,
        spacing: &dyn Spacing,
        spacing_text: &str,
        source: &str,
    ) -> Seed {
        let entities: Vec<EntityState> = fingerprint::entities(model)
            .into_iter()
            .map(|e| EntityState {
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
                tets: Vec::new(),
            })
            .collect();
        let recorded: std::collections::HashSet<_> = entities.iter().map(|e| e.entity).collect();
        let d = mesh
            .nodes
            .iter()
            .map(|n| {
                if !recorded.contains(&n.entity) {
                    return 0.0;
                }
                let d = spacing.spacing(&SpacingQuery {
                    point: n.pos,
                    entity: n.entity,
                    params: n.params,
                });
                if d.is_finite() && d > 0.0 {
                    d
                } else {
                    f64::MIN_POSITIVE
                }
            })
            .collect();
        Seed {
            records: State {
                spacing: spacing_text.to_string(),
                source: source.to_string(),
                dim: mesh.dim().max(1),
                entities,
            },
            d,
        }
    }

    /// The state of the run that made `mesh` (the mesh [`Seed::new`] was
    /// given): the records with each node as a bubble of its entity, and
    /// each tetrahedron in its volume's record.
    pub fn state(&self, mesh: &Mesh) -> State {
        let mut s = self.records.clone();
        let index: std::collections::HashMap<_, _> = s
            .entities
            .iter()
            .enumerate()
            .map(|(k, e)| (e.entity, k))
            .collect();
        for (n, &d) in mesh.nodes.iter().zip(&self.d) {
            if let Some(&k) = index.get(&n.entity) {
                s.entities[k].bubbles.push(Bubble {
                    params: n.params,
                    pos: n.pos,
                    d,
                });
            }
        }
        for t in &mesh.tetrahedra {
            if let Some(&k) = index.get(&t.entity) {
                s.entities[k]
                    .tets
                    .push(t.nodes.map(|v| mesh.nodes[v as usize].pos));
            }
        }
        s
    }
}
