//! `bm_state`: the saved packing of a run (thesis §4.8), the state file of
//! the command line's `mesh --save-state` / `remesh STATE`
//! (docs/state-format.md), which a later run re-meshes from
//! (`bm_remesh_generate`, `bm_remesh_step_file` in [`crate::mesh`]).
//!
//! A mesh does not keep its model (the host's callbacks may be gone by
//! the time `bm_mesh_state` is called), so what the state needs beyond the
//! mesh's nodes is taken when the mesh is made ([`Seed`]): each entity's
//! record (name, fingerprint, parameter range; the model's geometry is
//! evaluated for it there, inside the meshing call) and the spacing at each
//! node. `bm_mesh_state` then puts the nodes into the records.

use std::collections::HashMap;
use std::ffi::{c_char, c_void};
use std::path::Path;

use bubblemesh_core::model::EntityRef;
use bubblemesh_core::remesh::state::Bubble;
use bubblemesh_core::remesh::{self, State};
use bubblemesh_core::spacing::{Spacing, SpacingQuery};
use bubblemesh_core::{Mesh, Model};

use crate::error::{bm_result, guard, guard_void, Error, Result};
use crate::mesh::{bm_mesh, mesh_obj};
use crate::{free_handle, into_handle, need, object, put, utf8, Object};

/// A saved packing (opaque): the bubbles of every edge, face and volume of
/// a finished run, with what identifies each entity, so that a run on a
/// changed model (or with a changed spacing) can start from them. Get one
/// from a mesh with `bm_mesh_state` or from a file with `bm_state_load`;
/// free with `bm_state_free`. Independent of the mesh, the model and the
/// spacing it came from.
#[allow(non_camel_case_types)]
pub struct bm_state {
    _private: [u8; 0],
}

#[repr(C)]
pub(crate) struct StateObj {
    magic: u64,
    pub state: State,
    /// Where it came from, for messages: "loaded from 'PATH'" or "taken
    /// from a mesh".
    pub origin: String,
}

impl Object for StateObj {
    const MAGIC: u64 = 0x626d_5f73_7461_7465; // "bm_state"
    const KIND: &'static str = "bm_state";
}

pub(crate) unsafe fn state_obj<'a>(p: *const bm_state) -> Result<&'a StateObj> {
    unsafe { object::<StateObj>(p as *const c_void, "state") }
}

/// What a mesh keeps to give its state later without its model: the state
/// of the run without its bubbles, and the spacing at each node.
pub(crate) struct Seed {
    /// Every edge, face and volume's record, no bubbles yet.
    records: State,
    /// The spacing at each node of the mesh, in node order (unused for
    /// nodes on model vertices, which a state does not store).
    d: Vec<f64>,
}

impl Seed {
    /// The seed of a run that made `mesh` on `model` with `spacing`
    /// (what `remesh::state_of` needs from the model and the spacing).
    /// Evaluates the model's geometry and the spacing: call it inside the
    /// callback scope and the unwind guard of the meshing call.
    pub fn new(
        model: &Model,
        mesh: &Mesh,
        spacing: &dyn Spacing,
        spacing_text: &str,
        source: &str,
    ) -> Seed {
        // the records alone: `state_of` on a mesh without nodes
        let mut records = remesh::state_of(model, &Mesh::default(), spacing, spacing_text, source);
        records.dim = mesh.dim().max(1);
        let d = mesh
            .nodes
            .iter()
            .map(|n| {
                if n.entity.dim == 0 {
                    return 0.0;
                }
                let d = spacing.spacing(&SpacingQuery {
                    point: n.pos,
                    entity: n.entity,
                    params: n.params,
                });
                // as `state_of`: a diameter must be > 0
                if d.is_finite() && d > 0.0 {
                    d
                } else {
                    f64::MIN_POSITIVE
                }
            })
            .collect();
        Seed { records, d }
    }

    /// The state of the run that made `mesh`: what `remesh::state_of`
    /// gives for it (tested against it below).
    pub fn state(&self, mesh: &Mesh) -> State {
        let mut s = self.records.clone();
        let index: HashMap<EntityRef, usize> = s
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
        s
    }
}

/// The state of the run that made `mesh` (a `bm_mesh_generate`,
/// `bm_mesh_step_file` or `bm_remesh_*` call): every edge, face and
/// volume of its model with the mesh's nodes on it as bubbles, each with
/// the spacing there as its diameter. The new state goes to `*out`; it
/// does not depend on the mesh.
#[no_mangle]
pub unsafe extern "C" fn bm_mesh_state(mesh: *const bm_mesh, out: *mut *mut bm_state) -> bm_result {
    guard("bm_mesh_state", || unsafe {
        let m = mesh_obj(mesh)?;
        need(out, "out")?;
        let state = m.seed.state(&m.mesh);
        put(
            out,
            "out",
            into_handle(StateObj {
                magic: StateObj::MAGIC,
                state,
                origin: "taken from a mesh".into(),
            }),
        )
    })
}

/// Writes `state` to the file `path` (UTF-8) in the state format of the
/// command line's `--save-state` (`bubblemesh-state` version 1,
/// docs/state-format.md; `bubblemesh remesh` reads it). The file is
/// written whole or not at all: a temporary file in its directory renamed
/// over it once complete (an existing file is left untouched on error).
/// A file that cannot be written gives `BM_ERR_IO`, naming it.
#[no_mangle]
pub unsafe extern "C" fn bm_state_save(state: *const bm_state, path: *const c_char) -> bm_result {
    guard("bm_state_save", || unsafe {
        let s = state_obj(state)?;
        let path = utf8(path, "path")?;
        bubblemesh_io::output::write_file(Path::new(path), &s.state.to_bytes())
            .map_err(|e| Error::new(bm_result::BM_ERR_IO, e.to_string()))
    })
}

/// Reads the state file at `path` (written by `bm_state_save` or the
/// command line's `--save-state`); the new state goes to `*out`. A missing
/// or unreadable file gives `BM_ERR_IO`; a file that is not a state, of
/// another version of the format, truncated or corrupted (its checksum)
/// gives `BM_ERR_FORMAT`. Either message names the file and the reason.
#[no_mangle]
pub unsafe extern "C" fn bm_state_load(path: *const c_char, out: *mut *mut bm_state) -> bm_result {
    guard("bm_state_load", || unsafe {
        let path = utf8(path, "path")?;
        need(out, "out")?;
        let bytes = std::fs::read(path).map_err(|e| {
            Error::new(
                bm_result::BM_ERR_IO,
                format!("{path}: cannot read the state: {e}"),
            )
        })?;
        let state = State::from_bytes(&bytes).map_err(|e| {
            Error::new(
                bm_result::BM_ERR_FORMAT,
                format!("{path}: not a usable state: {e}"),
            )
        })?;
        put(
            out,
            "out",
            into_handle(StateObj {
                magic: StateObj::MAGIC,
                state,
                origin: format!("loaded from '{path}'"),
            }),
        )
    })
}

/// Frees a state (NULL: nothing).
#[no_mangle]
pub unsafe extern "C" fn bm_state_free(state: *mut bm_state) {
    guard_void("bm_state_free", || unsafe {
        free_handle::<StateObj>(state as *mut c_void)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Segment;
    use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Vertex};
    use bubblemesh_core::spacing::Expr;
    use bubblemesh_core::{mesh_model, Options, Plane, P3};
    use std::sync::Arc;

    /// The unit square in z = 0 as one plane face of four lines.
    fn square() -> Model {
        let mut m = Model::default();
        for p in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
            m.vertices.push(Vertex {
                point: P3::new(p[0], p[1], 0.0),
                name: None,
            });
        }
        let mut lp = Loop::default();
        for k in 0..4u32 {
            let (a, b) = (k, (k + 1) % 4);
            let (pa, pb) = (m.vertices[a as usize].point, m.vertices[b as usize].point);
            m.edges.push(Edge {
                curve: Arc::new(Segment(pa, pb)),
                t0: 0.0,
                t1: 1.0,
                start: a,
                end: b,
                name: None,
            });
            lp.edges.push(EdgeUse {
                edge: k,
                forward: true,
            });
        }
        m.faces.push(Face {
            surface: Arc::new(Plane::xy()),
            loops: vec![lp],
            embedded_edges: vec![],
            embedded_vertices: vec![],
            name: Some("square".into()),
        });
        m
    }

    /// The seed's state is the core's `state_of` of the same run, exactly
    /// (so the C ABI's states are the command line's).
    #[test]
    fn the_seed_gives_what_state_of_gives() {
        let model = square();
        let s = Expr::parse("0.05 + 0.05*x").unwrap();
        let (mesh, _) = mesh_model(&model, &s, &Options::default()).unwrap();
        let seed = Seed::new(&model, &mesh, &s, "0.05 + 0.05*x", "square");
        let ours = seed.state(&mesh);
        let core = remesh::state_of(&model, &mesh, &s, "0.05 + 0.05*x", "square");
        assert!(ours.entities.iter().map(|e| e.bubbles.len()).sum::<usize>() > 50);
        assert_eq!(ours, core);
        assert_eq!(ours.to_bytes(), core.to_bytes());
    }
}
