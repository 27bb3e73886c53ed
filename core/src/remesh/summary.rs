//! What a re-meshing did, node by node (thesis §4.8): compares the old
//! bubbles of the matched entities with the new mesh's nodes.
//!
//! A new node is *kept* when an old bubble of its entity had exactly its
//! coordinates (bit for bit), *moved* when one lies within half a spacing
//! of it, else *added*; an old bubble is *removed* when no new node of its
//! entity lies within half a spacing of it. With a spatial region, the old
//! bubbles farther than [`region::BAND`] spacings from it must all be kept:
//! `far_from_region` counts them and `far_kept` those that were. A new
//! tetrahedron is kept when an old one of its volume had exactly its
//! corners (`tets_kept` of the state's `tets_old`).

// Fx hashing (rustc-hash): coordinate bits of one run, not chosen input
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use crate::geom::P3;
use crate::mesh::Mesh;
use crate::model::EntityRef;
use crate::remesh::cells::Cells;
use crate::remesh::region::{self, Region};
use crate::remesh::state::State;
use crate::remesh::warm::Matching;

/// The report's `remesh` section: the [`Summary`] and the stage-2 steps of
/// each face (and their largest and total).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Section {
    /// What was matched, kept, moved, added and removed.
    pub summary: Summary,
    /// Stage-2 steps of each face that ran one, in face order.
    pub stage2_steps_per_face: Vec<usize>,
    /// The most steps of one face.
    pub stage2_steps_max: usize,
    /// All faces' steps.
    pub stage2_steps_total: usize,
}

/// The report's `remesh` section of a run from `state` ([`summarise`]'s
/// arguments) whose faces took `steps` stage-2 steps each
/// ([`crate::Report::stage2_steps_per_face`]).
pub fn section(
    state: &State,
    matching: Matching,
    warm: &crate::remesh::WarmStart,
    mesh: &Mesh,
    region: Option<&Region>,
    steps: Vec<usize>,
) -> Section {
    Section {
        summary: summarise(state, matching, warm, mesh, region),
        stage2_steps_max: steps.iter().copied().max().unwrap_or(0),
        stage2_steps_total: steps.iter().sum(),
        stage2_steps_per_face: steps,
    }
}

/// The counts of a re-meshing.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Summary {
    /// The matching of entities and the split of the old bubbles.
    pub matching: Matching,
    /// New nodes at an old bubble's exact coordinates.
    pub kept: usize,
    /// New nodes within half a spacing of an old bubble (not exact).
    pub moved: usize,
    /// New nodes with no old bubble within half a spacing.
    pub added: usize,
    /// Old bubbles with no new node within half a spacing.
    pub removed: usize,
    /// Old bubbles farther than two spacings from a spatial region.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub far_from_region: Option<usize>,
    /// Of those, how many a new node has at exactly their coordinates.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub far_kept: Option<usize>,
    /// The state's tetrahedra of matched volumes (absent when it holds
    /// none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tets_old: Option<usize>,
    /// Of those, how many the new mesh has, corner for corner, bit for bit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tets_kept: Option<usize>,
}

/// Compares `state`'s bubbles on the matched entities with `mesh`.
pub fn summarise(
    state: &State,
    matching: Matching,
    warm: &crate::remesh::WarmStart,
    mesh: &Mesh,
    region: Option<&Region>,
) -> Summary {
    let mut s = Summary {
        matching,
        ..Default::default()
    };
    let mut new_by: HashMap<EntityRef, Vec<P3>> = HashMap::default();
    for n in &mesh.nodes {
        new_by.entry(n.entity).or_default().push(n.pos);
    }
    let bits = |p: &P3| (p.x.to_bits(), p.y.to_bits(), p.z.to_bits());
    let spatial = region.filter(|r| r.distance(&P3::origin()).is_some());
    let (mut far, mut far_kept) = (0usize, 0usize);
    for old in &state.entities {
        let matched = warm.of(old.entity).is_some();
        let new = new_by.remove(&old.entity).unwrap_or_default();
        let olds: Vec<P3> = old.bubbles.iter().map(|b| b.pos).collect();
        let dmax = old.bubbles.iter().map(|b| b.d).fold(0.0f64, f64::max);
        let h = (0.5 * dmax).max(f64::MIN_POSITIVE);
        let exact: HashSet<_> = olds.iter().map(bits).collect();
        let new_exact: HashSet<_> = new.iter().map(bits).collect();
        let old_cells = Cells::new(&olds, h);
        let new_cells = Cells::new(&new, h);
        for p in new.iter().filter(|_| matched) {
            if exact.contains(&bits(p)) {
                s.kept += 1;
            } else if old_cells.near(&olds, p, h) {
                s.moved += 1;
            } else {
                s.added += 1;
            }
        }
        for b in &old.bubbles {
            if matched && !new_cells.near(&new, &b.pos, 0.5 * b.d) {
                s.removed += 1;
            }
            if let Some(r) = spatial.and_then(|r| r.distance(&b.pos)) {
                if r > region::BAND * b.d {
                    far += 1;
                    far_kept += new_exact.contains(&bits(&b.pos)) as usize;
                }
            }
        }
    }
    if spatial.is_some() {
        s.far_from_region = Some(far);
        s.far_kept = Some(far_kept);
    }
    (s.tets_old, s.tets_kept) = tets_kept(state, warm, mesh);
    s
}

/// The state's tetrahedra of matched volumes, and how many of them `mesh`
/// has with the same corners bit for bit (`None`s when it holds none).
fn tets_kept(
    state: &State,
    warm: &crate::remesh::WarmStart,
    mesh: &Mesh,
) -> (Option<usize>, Option<usize>) {
    let key = |t: [P3; 4]| {
        let mut k = t.map(|p| crate::remesh::state::bits(&p));
        k.sort_unstable();
        k
    };
    let mut old: HashSet<(EntityRef, [[u64; 3]; 4])> = HashSet::default();
    for e in state
        .entities
        .iter()
        .filter(|e| warm.of(e.entity).is_some())
    {
        old.extend(e.tets.iter().map(|t| (e.entity, key(*t))));
    }
    if old.is_empty() {
        return (None, None);
    }
    let kept = mesh
        .tetrahedra
        .iter()
        .filter(|t| old.contains(&(t.entity, key(t.nodes.map(|v| mesh.nodes[v as usize].pos)))))
        .count();
    (Some(old.len()), Some(kept))
}
