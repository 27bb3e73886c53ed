//! A warm-started volume (thesis §4.8): stage 1 is the old packing, as for
//! a face ([`crate::face`]'s `warm`), in 3D.
//!
//! - Kept bubbles (the old interior nodes away from the footprint of the
//!   change, or outside a local re-meshing's region) become fixed bubbles
//!   after the boundary's, at their old coordinates, bit for bit; they stay
//!   fixed through stage 2, the ODT smoothing, the sliver pass and the
//!   polish, and become nodes of the volume unmoved, with the old
//!   tetrahedra among them ([`super::keep`]). The one exception, in a
//!   continuous re-meshing whose old tetrahedra cannot be kept (a version 1
//!   state, or [`super::keep`] gave up): a kept corner of a sliver whose
//!   corners are all fixed moves in the sliver pass (the Delaunay
//!   connection of the old nodes need not be the old mesh's; a Steiner
//!   point there costs a re-connection), and the report counts them
//!   (`warm_released`).
//! - Free old bubbles stay where they were (a volume's bubbles have no
//!   parameters to carry them by); those now outside the volume are
//!   dropped, and those crowding the boundary, a kept bubble or each other
//!   (closer than 0.75 of their mean spacing, as a face's) are removed.
//! - Where the change left room (a face moved out), the FCC seeds that
//!   crowd no bubble fill it.
//!
//! Stage 2 then runs short ([`STAGE2_STEPS`]) with population control,
//! the kept bubbles far from every free one set aside ([`crate::face`]'s
//! `split_far`: they cannot meet a free bubble in a short stage 2), and
//! the ODT smoothing runs [`ODT_ITERATIONS`] times over the free nodes and
//! the kept ones near them only.

use crate::bubbles::constraint::Carrier;
use crate::bubbles::system::{System, KEPT_ID};
use crate::error::MeshError;
use crate::face::placement::{uncrowded, Seed};
use crate::face::warm::{assemble, Far};
use crate::geom::P3;
use crate::remesh::warm::EntityStart;
use crate::spacing::{Spacing, SpacingQuery};

/// Stage-2 steps at most of a warm volume. The old bubbles are an
/// ODT-smoothed packing and the fill is FCC, both near a balance; the ODT
/// smoothing after stage 2 does the rest. Measured on case e of
/// `bench/run_remesh.py` (a cube face moved by 0.375 spacings, 736 of 2 442
/// old bubbles free): 100 steps (the cap from scratch) and 20 give the
/// same mean radius ratio (0.9148 / 0.9145, from scratch 0.9143), stage 2
/// 0.16 s → 0.03 s.
pub(super) const STAGE2_STEPS: usize = 20;

/// ODT iterations of a warm volume (from scratch: 20, which never stop
/// early on case e of `bench/run_remesh.py`). On case e 20, 8, 5 and 3
/// iterations gave mean radius ratios 0.9145–0.9149 and minima 0.55–0.57
/// (from scratch 0.9143, 0.551); 3 cost 0.02 s against 0.23 s for 20.
pub(super) const ODT_ITERATIONS: usize = 3;

/// A kept bubble closer than this many of its spacings to a boundary
/// bubble that is not an old node is dropped (a re-meshed boundary came
/// onto it).
const ON_TOP: f64 = 0.25;

/// What a warm stage 1 did, for the report: kept (fixed) old bubbles, free
/// old bubbles that start stage 2, and FCC seeds added where the old
/// packing left room.
pub(super) type WarmCounts = [usize; 3];

/// The volume's fixed bubbles (its boundary nodes): positions, diameters
/// and node ids.
pub(super) struct Fixed<'b> {
    pub pos: &'b [P3],
    pub d: &'b [f64],
    pub ids: &'b [u32],
}

/// Stage 1 of a volume from the old bubbles `start` (see the module docs),
/// after the boundary's `fixed` bubbles, in `carrier` (whose inside test is
/// `inside`). `fill(pos, d)` gives the FCC seeds clear of the bubbles at
/// `pos` with diameters `d`. Returns the system (boundary bubbles, then the
/// kept ones, fixed; then the free ones), the counts, and the kept bubbles
/// set aside for stage 2.
pub(super) fn stage1<'a, C: Carrier>(
    fixed: Fixed<'_>,
    spacing: &'a dyn Spacing,
    carrier: C,
    inside: impl Fn(&P3) -> bool,
    fill: impl FnOnce(&[P3], &[f64]) -> Result<Vec<(P3, f64)>, MeshError>,
    start: &EntityStart,
) -> Result<(System<'a, C>, WarmCounts, Far), MeshError> {
    let entity = carrier.entity();
    let d_at = |p: &P3| -> Result<f64, MeshError> {
        let d = spacing.spacing(&SpacingQuery {
            point: *p,
            entity,
            params: [0.0; 2],
        });
        crate::error::check_spacing(d, *p, entity)
    };
    let n_boundary = fixed.ids.len();
    let mut fixed_pos = fixed.pos.to_vec();
    let mut fixed_d = fixed.d.to_vec();
    let mut fixed_ids = fixed.ids.to_vec();
    let mut counts: WarmCounts = [0; 3];
    // kept bubbles: inside the new volume and not on top of a boundary
    // bubble. They lay beside the boundary bubbles near them in the old
    // mesh, which are kept too (the footprint's band is wider than a
    // bubble's reach), so only a re-meshed boundary can come that close.
    let bgrid = crate::bubbles::grid::Grid::new(
        fixed.pos,
        fixed.d.iter().cloned().fold(f64::MIN_POSITIVE, f64::max),
    );
    // the old mesh's nodes (corners of its tetrahedra, when the state has
    // them): a boundary node among them was there before, beside the kept
    // bubble, so it does not make it crowd (a Steiner point near the
    // boundary stays)
    let old: rustc_hash::FxHashSet<[u64; 3]> = start
        .tets
        .iter()
        .flatten()
        .map(crate::remesh::state::bits)
        .collect();
    for b in &start.kept {
        if !inside(&b.pos) {
            continue;
        }
        let d = d_at(&b.pos)?;
        let mut on_top = false;
        bgrid.query(&b.pos, ON_TOP * d, |j| {
            let q = fixed.pos[j as usize];
            on_top |=
                (q - b.pos).norm() < ON_TOP * d && !old.contains(&crate::remesh::state::bits(&q));
        });
        if !on_top {
            fixed_pos.push(b.pos);
            fixed_d.push(d);
            fixed_ids.push(KEPT_ID);
            counts[0] += 1;
        }
    }
    let carried: Vec<Seed> = start
        .free
        .iter()
        .filter(|b| inside(&b.pos))
        .map(|b| {
            Ok(Seed {
                pos: b.pos,
                params: [0.0; 2],
                d: d_at(&b.pos)?,
            })
        })
        .collect::<Result<_, MeshError>>()?;
    let carried = uncrowded(carried, &fixed_pos, &fixed_d, true);
    // FCC seeds only where no bubble is near
    let mut near_pos = fixed_pos.clone();
    let mut near_d = fixed_d.clone();
    near_pos.extend(carried.iter().map(|s| s.pos));
    near_d.extend(carried.iter().map(|s| s.d));
    let fill: Vec<Seed> = fill(&near_pos, &near_d)?
        .into_iter()
        .map(|(pos, d)| Seed {
            pos,
            params: [0.0; 2],
            d,
        })
        .collect();
    let filled = uncrowded(fill, &near_pos, &near_d, true);
    counts[1] = carried.len();
    counts[2] = filled.len();
    let seeds: Vec<Seed> = carried.into_iter().chain(filled).collect();
    let fixed = crate::face::warm::Fixed {
        uv: vec![[0.0; 2]; fixed_pos.len()],
        pos: fixed_pos,
        d: fixed_d,
        ids: fixed_ids,
    };
    let (sys, far) = assemble(carrier, spacing, 3, fixed, n_boundary, seeds);
    Ok((sys, counts, far))
}
