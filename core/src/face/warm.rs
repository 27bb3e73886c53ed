//! A warm-started face (thesis §4.8): stage 1 is the old packing.
//!
//! - The free old bubbles are carried over by their (u,v) and re-projected
//!   onto the new surface (its point at that (u,v)); those now outside the
//!   face are dropped, and those crowding the new boundary or each other
//!   (closer than 0.75·r0, as stage 1's seeds) are removed.
//! - Kept bubbles (a local re-meshing, §4.8.1) become fixed bubbles at
//!   their old coordinates, bit for bit, after the boundary's; the mesh
//!   gets them as nodes when the face is emitted ([`KEPT`]).
//! - Where the change left room (a hole moved away, a spacing refined),
//!   the oblique quadtree's seeds that crowd no bubble fill it.
//!
//! Stage 2 then runs short ([`crate::remesh::warm::WARM_MAX_STEPS`]), with
//! population control, and stops on the usual small-move tolerance.

use crate::bubbles::constraint::Carrier;
use crate::bubbles::grid;
use crate::bubbles::system::{self, System};
use crate::error::MeshError;
use crate::geom::{P3, V3};
use crate::remesh::warm::EntityStart;
use crate::spacing::Spacing;

use super::carrier::OnFace;
use super::placement::{self, uncrowded};

/// The fixed-bubble id of a kept bubble: not yet a mesh node (see
/// `FaceJob::emit`).
pub(super) const KEPT: u32 = system::KEPT_ID;

/// What a warm stage 1 did, for the report.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct WarmCounts {
    /// Kept (fixed) old bubbles.
    pub kept: usize,
    /// Free old bubbles that start stage 2.
    pub carried: usize,
    /// Quadtree seeds added where the old packing left room.
    pub filled: usize,
}

/// The fixed bubbles of a face (its boundary): positions, diameters,
/// (u,v) and node ids.
pub(crate) struct Fixed {
    pub pos: Vec<P3>,
    pub d: Vec<f64>,
    pub uv: Vec<[f64; 2]>,
    pub ids: Vec<u32>,
}

/// Stage 1 from the old bubbles `start` on the face `carrier` holds
/// bubbles on, after the boundary's `fixed` bubbles (see the module docs),
/// with the boundary layer's seeds `apex` (empty where the spacing varies)
/// first where the face changed.
pub(super) fn stage1<'a>(
    carrier: OnFace<'a>,
    spacing: &'a dyn Spacing,
    fixed: Fixed,
    apex: Vec<placement::Seed>,
    start: &EntityStart,
) -> Result<(System<'a, OnFace<'a>>, WarmCounts, Far), MeshError> {
    let fe = carrier.entity();
    let mut d_at = placement::spacing_on(spacing, fe);
    let n_boundary = fixed.ids.len();
    let Fixed {
        pos: mut fixed_pos,
        d: mut fixed_d,
        uv: mut fixed_uv,
        ids: mut fixed_ids,
    } = fixed;
    let mut counts = WarmCounts::default();
    for b in &start.kept {
        let uv = carrier.region.wrap(b.params);
        if carrier.contains(uv) {
            fixed_d.push(d_at(&b.pos, uv)?);
            fixed_pos.push(b.pos);
            fixed_uv.push(uv);
            fixed_ids.push(KEPT);
            counts.kept += 1;
        }
    }
    let mut carried = Vec::new();
    for b in &start.free {
        let uv = carrier.region.wrap(b.params);
        if carrier.contains(uv) {
            let p = carrier.point(uv);
            carried.push(placement::Seed {
                pos: p,
                params: uv,
                d: d_at(&p, uv)?,
            });
        }
    }
    // the boundary layer's seeds (a uniform spacing) come first where the
    // face changed: where the old bubbles are kept, so is their layer
    let old_free: Vec<P3> = start.free.iter().map(|b| b.pos).collect();
    let apex = among_free(apex, &fixed_pos[n_boundary..], &old_free);
    let carried = uncrowded(
        apex.into_iter().chain(carried).collect(),
        &fixed_pos,
        &fixed_d,
        true,
    );
    // the quadtree's seeds survive only where no bubble is near
    let (lo, hi) = carrier.region.bbox();
    let d_outside = fixed_d
        .iter()
        .chain(carried.iter().map(|s| &s.d))
        .fold([f64::INFINITY, 0.0], |[lo, hi], &d| [lo.min(d), hi.max(d)]);
    // nothing fixed or carried: outside corners never split a cell
    let d_outside = if d_outside[1] >= d_outside[0] {
        d_outside
    } else {
        [f64::INFINITY; 2]
    };
    let quad = placement::oblique_quadtree(&carrier, lo, hi, None, d_outside, &mut d_at)?;
    let mut near_pos = fixed_pos.clone();
    let mut near_d = fixed_d.clone();
    near_pos.extend(carried.iter().map(|s| s.pos));
    near_d.extend(carried.iter().map(|s| s.d));
    let filled = uncrowded(quad, &near_pos, &near_d, true);
    let carried_pos: Vec<P3> = carried.iter().map(|s| s.pos).collect();
    let filled = among_free(filled, &fixed_pos[n_boundary..], &carried_pos);
    counts.carried = carried.len();
    counts.filled = filled.len();
    let seeds: Vec<placement::Seed> = carried.into_iter().chain(filled).collect();
    let fixed = Fixed {
        pos: fixed_pos,
        d: fixed_d,
        uv: fixed_uv,
        ids: fixed_ids,
    };
    let (sys, far) = assemble(carrier, spacing, 2, fixed, n_boundary, seeds);
    Ok((sys, counts, far))
}

/// The seeds whose nearest old bubble is a free one, or that have none
/// within 2⁹ of their spacings: in a local re-meshing the quadtree fills
/// only the free part of the face. Among the kept bubbles, a finer
/// spacing leaves room that `uncrowded` does not refuse, and a seed there
/// sat between two boundary nodes that stay, on their segment
/// (examples/two_faces.toml, `--region faces:1` from 0.1 to 0.06, with the
/// boundary's apex layer). Without kept bubbles every seed stays.
fn among_free(seeds: Vec<placement::Seed>, kept: &[P3], free: &[P3]) -> Vec<placement::Seed> {
    if kept.is_empty() || seeds.is_empty() {
        return seeds;
    }
    let all: Vec<P3> = kept.iter().chain(free.iter()).copied().collect();
    let reach = 2.0 * seeds.iter().map(|s| s.d).fold(0.0f64, f64::max);
    let g = grid::Grid::new(&all, reach.max(f64::MIN_POSITIVE));
    seeds
        .into_iter()
        .filter(|s| {
            // the nearest old bubble, looked for in balls growing from two
            // spacings (the old packing may be much coarser than s.d)
            let mut radius = 2.0 * s.d;
            for _ in 0..8 {
                let mut best = (radius, None);
                g.query(&s.pos, radius, |j| {
                    let r = (all[j as usize] - s.pos).norm();
                    if r < best.0 {
                        best = (r, Some(j as usize));
                    }
                });
                if let Some(j) = best.1 {
                    return j >= kept.len();
                }
                radius *= 2.0;
            }
            true
        })
        .collect()
}

/// The stage-2 system of a warm start: the fixed bubbles (the boundary's,
/// its first `n_boundary`, then the kept ones), then the free `seeds`.
/// Kept bubbles far from every seed cannot meet a free bubble in a short
/// stage 2: they wait outside the system, returned apart (see `restore`).
pub(crate) fn assemble<'a, C: Carrier>(
    carrier: C,
    spacing: &'a dyn Spacing,
    dim: u8,
    fixed: Fixed,
    n_boundary: usize,
    seeds: Vec<placement::Seed>,
) -> (System<'a, C>, Far) {
    let Fixed {
        mut pos,
        mut d,
        mut uv,
        mut ids,
    } = fixed;
    let far = split_far(&mut pos, &mut uv, &mut d, &mut ids, n_boundary, &seeds);
    let mut sys = System::with_fixed(carrier, spacing, dim, pos, uv, d, ids);
    for s in seeds {
        sys.push_free(s.pos, s.params, s.d);
    }
    (sys, far)
}

/// Kept bubbles set aside during stage 2 (positions, parameters,
/// diameters).
pub(crate) type Far = (Vec<P3>, Vec<[f64; 2]>, Vec<f64>);

/// A kept bubble joins stage 2 only if it lies within this many of its
/// spacings of a seed: the force reaches 1.5 spacings, and a short stage 2
/// moves a free bubble a fraction of one.
const NEAR: f64 = 4.0;
/// Kept bubbles within this many spacings of a boundary bubble stay in
/// stage 2 as well (see `split_far`).
const WALL: f64 = 2.5;

/// Takes the kept bubbles (fixed bubbles from `first` on) farther than
/// [`NEAR`] spacings from every seed and [`WALL`] spacings from every
/// boundary bubble out of the fixed arrays.
fn split_far(
    pos: &mut Vec<P3>,
    uv: &mut Vec<[f64; 2]>,
    d: &mut Vec<f64>,
    ids: &mut Vec<u32>,
    first: usize,
    seeds: &[placement::Seed],
) -> Far {
    let spos: Vec<P3> = seeds.iter().map(|s| s.pos).collect();
    let dmax = d
        .iter()
        .chain(seeds.iter().map(|s| &s.d))
        .cloned()
        .fold(0.0f64, f64::max);
    let g = grid::Grid::new(&spos, (NEAR * dmax).max(f64::MIN_POSITIVE));
    let bpos: Vec<P3> = pos[..first].to_vec();
    let bg = grid::Grid::new(&bpos, (WALL * dmax).max(f64::MIN_POSITIVE));
    let mut far: Far = (Vec::new(), Vec::new(), Vec::new());
    let mut k = first;
    for i in first..pos.len() {
        let mut near = false;
        g.query(&pos[i], NEAR * dmax, |j| {
            near |= (spos[j as usize] - pos[i]).norm() <= NEAR * d[i].max(seeds[j as usize].d);
        });
        // the kept bubbles along the boundary stay too: population control
        // looks for room next to a boundary bubble, and they fill it
        bg.query(&pos[i], WALL * dmax, |j| {
            near |= (bpos[j as usize] - pos[i]).norm() <= WALL * d[i].max(d[j as usize]);
        });
        if near {
            pos[k] = pos[i];
            uv[k] = uv[i];
            d[k] = d[i];
            ids[k] = ids[i];
            k += 1;
        } else {
            far.0.push(pos[i]);
            far.1.push(uv[i]);
            far.2.push(d[i]);
        }
    }
    pos.truncate(k);
    uv.truncate(k);
    d.truncate(k);
    ids.truncate(k);
    far
}

/// Puts the kept bubbles set aside back among the fixed ones (after the
/// others, before the free ones), for the connection.
pub(crate) fn restore<C: Carrier>(sys: &mut System<'_, C>, far: Far) {
    let nf = sys.n_fixed;
    let m = far.0.len();
    sys.pos.splice(nf..nf, far.0);
    sys.params.splice(nf..nf, far.1);
    sys.d.splice(nf..nf, far.2);
    sys.vel.splice(nf..nf, std::iter::repeat_n(V3::zeros(), m));
    sys.fixed_ids.extend(std::iter::repeat_n(KEPT, m));
    sys.n_fixed += m;
}
