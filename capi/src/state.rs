//! `bm_state`: the saved packing of a run (thesis §4.8), the state file of
//! the command line's `mesh --save-state` / `remesh STATE`
//! (docs/state-format.md), which a later run re-meshes from
//! (`bm_remesh_generate`, `bm_remesh_step_file` in [`crate::mesh`]).
//!
//! A mesh does not keep its model (the host's callbacks may be gone by
//! the time `bm_mesh_state` is called), so what the state needs beyond the
//! mesh's nodes is taken when the mesh is made, inside the meshing call
//! (`bubblemesh_core::remesh::Seed`): each entity's record and the spacing
//! at each node. `bm_mesh_state` then puts the nodes into the records.

use std::ffi::{c_char, c_void};
use std::path::Path;

use bubblemesh_core::remesh::State;

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
/// command line's `--save-state` (`bubblemesh-state` version 2,
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
