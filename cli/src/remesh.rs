//! `bubblemesh remesh STATE INPUT …` and `mesh … --save-state STATE`
//! (thesis §4.8): the state file read and matched to the input before
//! meshing, the new state and the re-meshing's summary after.
//!
//! `remesh` is `mesh` with a warm start: the same flags and the same
//! contract (outputs written whole or not at all, errors naming the file
//! and the reason), plus `--region` for a local re-meshing.

use std::path::PathBuf;
use std::sync::Arc;

use bubblemesh_core::remesh::{self, summary, Matching, Region, State, WarmStart};
use bubblemesh_core::{Mesh, Model, Options, Report, Spacing};

use crate::CliError;

/// What `remesh` adds to `mesh`'s arguments.
#[derive(Clone, Debug)]
pub(crate) struct RemeshSpec {
    /// The state file to start from.
    pub state: PathBuf,
    /// `--region`, as given.
    pub region: Option<String>,
}

/// A re-meshing under way: the old state and how it was matched.
pub(crate) struct Warm {
    state: State,
    matching: Matching,
    warm: Arc<WarmStart>,
    region: Option<Region>,
}

/// Reads the state of `spec`, matches it to `model` and puts the warm
/// start into `opts`. Every failure names the state file and the reason.
pub(crate) fn prepare(
    spec: &RemeshSpec,
    input: &std::path::Path,
    model: &Model,
    spacing: &dyn Spacing,
    opts: &mut Options,
) -> Result<Warm, CliError> {
    let name = spec.state.display();
    if opts.fast {
        return Err(CliError::Message(
            "remesh: --fast is not supported (a warm start is a short stage 2)".into(),
        ));
    }
    let region = spec
        .region
        .as_deref()
        .map(Region::parse)
        .transpose()
        .map_err(|e| CliError::Message(format!("--region {e}")))?;
    let bytes = std::fs::read(&spec.state)
        .map_err(|e| CliError::Message(format!("{name}: cannot read the state: {e}")))?;
    let state = State::from_bytes(&bytes)
        .map_err(|e| CliError::Message(format!("{name}: not a usable state: {e}")))?;
    let (warm, matching) = remesh::plan(&state, model, spacing, region.as_ref()).map_err(|e| {
        CliError::Message(format!(
            "{name}: cannot re-mesh {} from it: {e}",
            input.display()
        ))
    })?;
    let warm = Arc::new(warm);
    opts.warm = Some(warm.clone());
    Ok(Warm {
        state,
        matching,
        warm,
        region,
    })
}

impl Warm {
    /// The report's `remesh` section: what was matched, kept, moved,
    /// added and removed, and the stage-2 steps of each face.
    pub(crate) fn report(&self, mesh: &Mesh, report: &Report) -> serde_json::Value {
        let s = summary::section(
            &self.state,
            self.matching.clone(),
            &self.warm,
            mesh,
            self.region.as_ref(),
            report.stage2_steps_per_face(),
        );
        serde_json::to_value(s).unwrap_or_default()
    }

    /// One line for stderr.
    pub(crate) fn said(&self, mesh: &Mesh) -> String {
        let s = summary::summarise(
            &self.state,
            self.matching.clone(),
            &self.warm,
            mesh,
            self.region.as_ref(),
        );
        let far = match (s.far_from_region, s.far_kept) {
            (Some(f), Some(k)) => format!("; {k} of the {f} old nodes farther than 2 spacings from the region kept bit for bit"),
            _ => String::new(),
        };
        let tets = match (s.tets_old, s.tets_kept) {
            (Some(o), Some(k)) => format!("; tetrahedra kept {k} of {o}"),
            _ => String::new(),
        };
        format!(
            "re-meshed from {} matched entities ({} meshed anew): nodes kept {}, moved {}, added {}; old bubbles removed {}{far}{tets}",
            s.matching.matched.len(),
            s.matching.unmatched.len(),
            s.kept,
            s.moved,
            s.added,
            s.removed
        )
    }
}

/// The bytes of the state of a finished run.
pub(crate) fn state_bytes(
    model: &Model,
    mesh: &Mesh,
    spacing: &dyn Spacing,
    size_text: &str,
    input: &std::path::Path,
) -> Vec<u8> {
    remesh::state_of(
        model,
        mesh,
        spacing,
        size_text,
        &input.display().to_string(),
    )
    .to_bytes()
}
