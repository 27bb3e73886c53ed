//! A warm-started edge (thesis §4.8): the chain starts from the old
//! bubbles, carried over by their parameter relative to the edge's range.
//!
//! The edge's fixed points are its end vertices and, in a local
//! re-meshing, the kept bubbles; between two fixed points the free old
//! bubbles are the start when their count is eq. 4.7.1's for that piece
//! (population control on a chain: the count is all there is to control),
//! else the piece is placed afresh by equidistribution; either way the
//! piece's chain is then relaxed with its ends fixed. A piece with no free
//! bubble between two kept ones is left as it was.

use crate::error::MeshError;
use crate::geom::{Curve, P3};
use crate::remesh::warm::EntityStart;

use super::chain;
use super::placement;

/// The interior parameters of a warm-started edge on `[t0, t1]`, sorted,
/// each with its old coordinates when it is a kept bubble (to be written
/// back bit for bit). `d_ends` are the spacings at the end vertices.
pub(super) fn place(
    curve: &dyn Curve,
    t0: f64,
    t1: f64,
    closed: bool,
    start: &EntityStart,
    d_ends: (f64, f64),
    d_at: &mut dyn FnMut(f64, &P3) -> Result<f64, MeshError>,
) -> Result<Vec<(f64, Option<P3>)>, MeshError> {
    let [r0, r1] = start.range;
    let carry = |t: f64| {
        if r1 != r0 {
            t0 + (t - r0) / (r1 - r0) * (t1 - t0)
        } else {
            t
        }
    };
    // fixed points along the edge: (t, d, kept position)
    let mut fixed: Vec<(f64, f64, Option<P3>)> = vec![(t0, d_ends.0, None)];
    let mut kept: Vec<_> = start
        .kept
        .iter()
        .filter(|b| b.params[0] > t0 && b.params[0] < t1)
        .map(|b| (b.params[0], b.d, Some(b.pos)))
        .collect();
    kept.sort_by(|a, b| a.0.total_cmp(&b.0));
    fixed.extend(kept);
    fixed.push((t1, d_ends.1, None));
    let mut free: Vec<f64> = start.free.iter().map(|b| carry(b.params[0])).collect();
    free.sort_by(|a, b| a.total_cmp(b));
    let whole = start.kept.is_empty();
    let mut out = Vec::new();
    for w in fixed.windows(2) {
        let ((a, da, _), (b, db, _)) = (w[0], w[1]);
        let mut ts: Vec<f64> = free.iter().copied().filter(|&t| t > a && t < b).collect();
        if whole || !ts.is_empty() {
            let want = placement::equidistribute_edge(curve, a, b, d_at, closed && whole)?;
            if want.len() != ts.len() {
                ts = want;
            }
            chain::relax_chain(curve, a, b, da, db, &mut ts, d_at)?;
        }
        out.extend(ts.into_iter().map(|t| (t, None)));
        if w[1].2.is_some() {
            out.push((w[1].0, w[1].2));
        }
    }
    Ok(out)
}
