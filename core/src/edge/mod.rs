//! Edge meshing (thesis §4.1.1, §4.2–4.5): stage 1 by recursive bisection
//! of the edge's parameter range, stage 2 relaxes the chain of bubbles along
//! the curve to the force balance, with the end vertices fixed.
//!
//! The chain has its own Euler loop ([`chain::relax_chain`]) rather than the
//! bubble [`crate::bubbles::system::System`] with a curve carrier: a chain's
//! neighbours are known (the next bubbles along the curve), its bubbles
//! must keep their order, and it has no population control; the `System`
//! would find neighbours by a grid, let balanced bubbles sleep and stop at a
//! coarser tolerance, so the edges' nodes, and every mesh after them, would
//! change.

mod chain;
pub(crate) mod placement;
pub(crate) mod stagger;
mod warm;

use crate::error::{check_spacing, MeshError};
use crate::geom::{Curve, P3};
use crate::mesh::{Mesh, Node};
use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};

/// Meshes one edge; returns its node ids from start vertex to end vertex.
/// An open edge with `ghosts` (nodes of earlier edges across a narrow face,
/// [`stagger`]) places its nodes between them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn mesh_edge(
    model: &Model,
    ei: usize,
    spacing: &dyn Spacing,
    fast: bool,
    start: Option<&crate::remesh::warm::EntityStart>,
    ghosts: &[stagger::Ghost],
    mesh: &mut Mesh,
    node_d: &mut Vec<f64>,
) -> Result<Vec<u32>, MeshError> {
    let edge = &model.edges[ei];
    let e = EntityRef::new(1, ei as u32);
    let curve: &dyn Curve = edge.curve.as_ref();
    let (t0, t1) = (edge.t0, edge.t1);
    if !(t0.is_finite() && t1.is_finite()) || t0 == t1 {
        return Err(MeshError::Invalid(format!(
            "parameter range [{t0}, {t1}] is empty or not finite"
        )));
    }
    for k in 0..=8 {
        let t = t0 + (t1 - t0) * k as f64 / 8.0;
        let p = curve.point(t);
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(MeshError::Invalid(format!(
                "the curve is not finite at t = {t}"
            )));
        }
    }
    let closed = edge.start == edge.end;
    let mut d_at = |t: f64, p: &P3| -> Result<f64, MeshError> {
        let d = spacing.spacing(&SpacingQuery {
            point: *p,
            entity: e,
            params: [t, 0.0],
        });
        check_spacing(d, *p, e)
    };
    let (sd, ed) = (node_d[edge.start as usize], node_d[edge.end as usize]);
    // a warm start (§4.8) gives the parameters, and the old coordinates of
    // the bubbles a local re-meshing keeps
    let placed: Vec<(f64, Option<P3>)> = match start {
        Some(w) if !fast => warm::place(curve, t0, t1, closed, w, (sd, ed), &mut d_at)?,
        _ if !fast && !closed && !ghosts.is_empty() => {
            match stagger::place(curve, t0, t1, ghosts, &mut d_at)? {
                Some(ts) => ts,
                None => {
                    let mut ts = placement::equidistribute_edge(curve, t0, t1, &mut d_at, closed)?;
                    chain::relax_chain(curve, t0, t1, sd, ed, &mut ts, &mut d_at)?;
                    ts
                }
            }
            .into_iter()
            .map(|t| (t, None))
            .collect()
        }
        _ => {
            let mut ts = if fast {
                placement::bisect_edge(curve, t0, t1, &mut d_at, closed)?
            } else {
                placement::equidistribute_edge(curve, t0, t1, &mut d_at, closed)?
            };
            if !fast {
                chain::relax_chain(curve, t0, t1, sd, ed, &mut ts, &mut d_at)?;
            }
            ts.into_iter().map(|t| (t, None)).collect()
        }
    };
    let mut ids = Vec::with_capacity(placed.len() + 2);
    ids.push(edge.start);
    for (t, kept) in placed {
        let p = kept.unwrap_or_else(|| curve.point(t));
        let d = d_at(t, &p)?;
        ids.push(mesh.nodes.len() as u32);
        mesh.nodes.push(Node {
            pos: p,
            entity: e,
            params: [t, 0.0],
        });
        node_d.push(d);
    }
    ids.push(edge.end);
    Ok(ids)
}
