//! The pictures of the bubbles settling (`--frames`, `--animate`), recorded
//! from the engine's events during the one run that writes the mesh.
//!
//! A [`Recorder`] observes the run: the bubbles each face and volume had
//! after stage 1, after stage-2 steps 1, 2, 4, 8, ... and after its last
//! step. [`settle_frames`] turns them into pictures: the edges' final
//! segments with the recorded bubbles, then the mesh written.

use std::collections::BTreeMap;

use bubblemesh_core::engine::Event;
use bubblemesh_core::mesh::{Element, Node};
use bubblemesh_core::{EntityRef, Mesh, Report, Spacing, P3};
use bubblemesh_viz::geometry::node_spacing;

/// The free bubbles of one entity at one moment.
#[derive(Clone, Default)]
struct Bubbles {
    pos: Vec<P3>,
    d: Vec<f64>,
}

impl Bubbles {
    /// Copies the bubbles after the first `fixed` into `self`, reusing its
    /// buffers.
    fn copy_from(&mut self, fixed: usize, pos: &[P3], d: &[f64]) {
        let fixed = fixed.min(pos.len()).min(d.len());
        self.pos.clear();
        self.pos.extend_from_slice(&pos[fixed..]);
        self.d.clear();
        self.d.extend_from_slice(&d[fixed..]);
    }
}

/// What was recorded of one face or volume.
#[derive(Default)]
struct Track {
    stage1: Bubbles,
    /// After steps 1, 2, 4, 8, ...
    steps: Vec<(usize, Bubbles)>,
    /// After the latest step (its number, 0 before stage 2).
    last: (usize, Bubbles),
}

impl Track {
    /// The bubbles after step `k` (the last ones if stage 2 stopped
    /// earlier; stage 1's if there was none).
    fn at(&self, k: usize) -> &Bubbles {
        if let Some((_, b)) = self.steps.iter().find(|(s, _)| *s == k) {
            return b;
        }
        if self.last.0 > 0 {
            &self.last.1
        } else {
            &self.stage1
        }
    }
}

/// Records the bubbles of each face and volume from the engine's events.
/// A second stage 1 of an entity (a retry, a refinement round) starts its
/// record again, so what is left is the run that made the mesh.
#[derive(Default)]
pub(crate) struct Recorder {
    tracks: BTreeMap<(u8, u32), Track>,
}

impl Recorder {
    /// Takes note of one event of the run.
    pub(crate) fn observe(&mut self, event: &Event<'_>) {
        let key = |e: EntityRef| (e.dim, e.id);
        match *event {
            Event::Stage1 {
                entity,
                fixed,
                positions,
                diameters,
            } => {
                let mut t = Track::default();
                t.stage1.copy_from(fixed, positions, diameters);
                self.tracks.insert(key(entity), t);
            }
            Event::Step {
                entity,
                step,
                fixed,
                positions,
                diameters,
                ..
            } => {
                let t = self.tracks.entry(key(entity)).or_default();
                if step.is_power_of_two() {
                    let mut b = Bubbles::default();
                    b.copy_from(fixed, positions, diameters);
                    t.steps.push((step, b));
                }
                t.last.0 = step;
                t.last.1.copy_from(fixed, positions, diameters);
            }
            Event::Pass { .. } | Event::Done { .. } => {}
        }
    }
}

/// One picture of the settling simulation.
pub(crate) struct SettleFrame {
    pub(crate) label: String,
    pub(crate) mesh: Mesh,
    /// The diameter of the bubble at each node of `mesh`.
    pub(crate) bubbles: Vec<f64>,
}

/// The vertices and edge segments of `full` (final from the face stage
/// on): the background of every frame before the last.
fn edges_of(full: &Mesh) -> Mesh {
    let mut new_id = vec![u32::MAX; full.nodes.len()];
    let mut base = Mesh {
        entities: full.entities.clone(),
        ..Default::default()
    };
    for (i, n) in full.nodes.iter().enumerate() {
        if n.entity.dim <= 1 {
            new_id[i] = base.nodes.len() as u32;
            base.nodes.push(*n);
        }
    }
    for l in &full.lines {
        let nodes = l.nodes.map(|i| new_id[i as usize]);
        if nodes.iter().all(|&i| i != u32::MAX) {
            base.lines.push(Element {
                nodes,
                entity: l.entity,
            });
        }
    }
    base
}

/// The frames of the settling simulation: stage 1, stage 2 after 1, 2, 4,
/// 8, ... steps (until every entity has stopped), then the mesh written.
/// With `--fast` (no stage 2) the one frame is the mesh written.
pub(crate) fn settle_frames(
    recorded: &Recorder,
    spacing: &dyn Spacing,
    full: &Mesh,
    full_report: &Report,
    max_steps: usize,
) -> Vec<SettleFrame> {
    if full_report.fast {
        return vec![SettleFrame {
            label: format!("stage 1 only (--fast): {} bubbles", full_report.nodes),
            mesh: full.clone(),
            bubbles: node_spacing(full, spacing),
        }];
    }
    let base = edges_of(full);
    let base_d = node_spacing(&base, spacing);
    let frame = |label: &dyn Fn(usize) -> String, pick: &dyn Fn(&Track) -> &Bubbles| {
        let mut mesh = base.clone();
        let mut bubbles = base_d.clone();
        for (&(dim, id), t) in &recorded.tracks {
            let b = pick(t);
            mesh.nodes.extend(b.pos.iter().map(|&pos| Node {
                pos,
                entity: EntityRef::new(dim, id),
                params: [0.0; 2],
            }));
            bubbles.extend_from_slice(&b.d);
        }
        SettleFrame {
            label: label(mesh.nodes.len()),
            mesh,
            bubbles,
        }
    };
    let mut out = vec![frame(
        &|n| format!("stage 1 (hierarchical placement): {n} bubbles"),
        &|t| &t.stage1,
    )];
    let mut k = 1;
    while k < max_steps {
        if !recorded.tracks.values().any(|t| t.last.0 >= k) {
            break;
        }
        out.push(frame(
            &|n| format!("stage 2 after {k} steps: {n} bubbles"),
            &|t| t.at(k),
        ));
        k *= 2;
    }
    let steps = full_report
        .faces
        .iter()
        .filter_map(|f| f.relax.as_ref().map(|x| x.steps))
        .max()
        .unwrap_or(0);
    out.push(SettleFrame {
        label: format!(
            "final: stage 2 ended after {steps} steps: {} bubbles",
            full_report.nodes
        ),
        mesh: full.clone(),
        bubbles: node_spacing(full, spacing),
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_recorder_keeps_stage_1_the_powers_of_two_and_the_last_step() {
        let e = EntityRef::new(2, 0);
        let pos = [P3::new(0.0, 0.0, 0.0), P3::new(1.0, 0.0, 0.0)];
        let d = [0.5, 0.25];
        let mut r = Recorder::default();
        r.observe(&Event::Stage1 {
            entity: e,
            fixed: 1,
            positions: &pos,
            diameters: &d,
        });
        for step in 1..=5 {
            r.observe(&Event::Step {
                entity: e,
                step,
                max_steps: 10,
                fixed: 1,
                positions: &pos,
                diameters: &d,
            });
        }
        let t = &r.tracks[&(2, 0)];
        // the fixed bubble is left out
        assert_eq!(t.stage1.d, [0.25]);
        let kept: Vec<usize> = t.steps.iter().map(|s| s.0).collect();
        assert_eq!(kept, [1, 2, 4]);
        assert_eq!(t.last.0, 5);
        // after its last step an entity stays as it ended
        assert_eq!(t.at(8).pos, t.last.1.pos);
        // a second stage 1 (a retry) starts again
        r.observe(&Event::Stage1 {
            entity: e,
            fixed: 0,
            positions: &pos,
            diameters: &d,
        });
        assert!(r.tracks[&(2, 0)].steps.is_empty());
    }
}
