//! Edge meshing (thesis §4.1.1, §4.2–4.5): stage 1 by recursive bisection
//! of the edge's parameter range, stage 2 relaxes the chain of bubbles along
//! the curve to the force balance, with the end vertices fixed.
//!
//! The chain has its own Euler loop ([`relax_chain`]) rather than the
//! bubble [`crate::bubbles::system::System`] with a curve carrier: a chain's
//! neighbours are known (the next bubbles along the curve), its bubbles
//! must keep their order, and it has no population control; the `System`
//! would find neighbours by a grid, let balanced bubbles sleep and stop at a
//! coarser tolerance, so the edges' nodes, and every mesh after them, would
//! change.

pub(crate) mod placement;
mod warm;

use crate::bubbles::{dynamics, force};
use crate::error::{check_spacing, MeshError};
use crate::geom::{Curve, P3, V3};
use crate::mesh::{Mesh, Node};
use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};

/// Meshes one edge; returns its node ids from start vertex to end vertex.
pub(crate) fn mesh_edge(
    model: &Model,
    ei: usize,
    spacing: &dyn Spacing,
    fast: bool,
    start: Option<&crate::remesh::warm::EntityStart>,
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
        _ => {
            let mut ts = if fast {
                placement::bisect_edge(curve, t0, t1, &mut d_at, closed)?
            } else {
                placement::equidistribute_edge(curve, t0, t1, &mut d_at, closed)?
            };
            if !fast {
                relax_chain(curve, t0, t1, sd, ed, &mut ts, &mut d_at)?;
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

/// Settings of the edge chain's relaxation ([`relax_chain`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ChainParams {
    /// Euler steps at most: a cap for a chain that does not settle, not a
    /// tuned value (a chain settles long before).
    pub max_steps: usize,
    /// The chain has settled when no bubble moved more than this fraction
    /// of its diameter in a step.
    pub tol: f64,
    /// A bubble stays this fraction of the edge's parameter range away from
    /// its neighbours' parameters, so the chain keeps its order.
    pub order_gap: f64,
}

impl Default for ChainParams {
    fn default() -> Self {
        ChainParams {
            max_steps: 2000,
            tol: 1e-6,
            order_gap: 1e-9,
        }
    }
}

/// Stage 2 on a curve: damped dynamics of the chain of edge bubbles with the
/// end bubbles fixed, each bubble kept on the curve by eq. 4.5.1
/// (Δt = Δx·C'/|C'|²). Bubbles keep their order along the curve. Forces are
/// taken at the start of a step (eq. 4.4.6) from the two neighbours along
/// the chain; the bubbles then move in order along the curve.
fn relax_chain(
    curve: &dyn Curve,
    t0: f64,
    t1: f64,
    d_start: f64,
    d_end: f64,
    ts: &mut [f64],
    d_at: &mut dyn FnMut(f64, &P3) -> Result<f64, MeshError>,
) -> Result<(), MeshError> {
    let n = ts.len();
    if n == 0 {
        return Ok(());
    }
    let h = dynamics::time_step(1);
    let c = dynamics::damping(1);
    let mut t: Vec<f64> = std::iter::once(t0)
        .chain(ts.iter().cloned())
        .chain(std::iter::once(t1))
        .collect();
    let mut p: Vec<P3> = t.iter().map(|&s| curve.point(s)).collect();
    let mut d = vec![0.0; n + 2];
    d[0] = d_start;
    d[n + 1] = d_end;
    for k in 1..=n {
        d[k] = d_at(t[k], &p[k])?;
    }
    let prm = ChainParams::default();
    let mut v = vec![V3::zeros(); n + 2];
    for _step in 0..prm.max_steps {
        let mut max_move: f64 = 0.0;
        let mut f = vec![V3::zeros(); n + 2];
        for k in 0..=n {
            let delta = p[k + 1] - p[k];
            let r = delta.norm();
            let r0 = 0.5 * (d[k] + d[k + 1]);
            if r > 0.0 {
                let fm = force::magnitude(r, r0, dynamics::K0) * (delta / r);
                f[k] -= fm;
                f[k + 1] += fm;
            }
        }
        for k in 1..=n {
            let tan = curve.d1(t[k]);
            let tt = tan.norm_squared();
            if tt <= 0.0 {
                continue;
            }
            let a = (f[k] - v[k] * c) / dynamics::MASS;
            let dx = v[k] * h;
            v[k] += a * h;
            // keep the velocity tangent
            v[k] = tan * (v[k].dot(&tan) / tt);
            let dt = dx.dot(&tan) / tt; // eq. 4.5.1
            let lo = t[k - 1] + prm.order_gap * (t1 - t0);
            let hi = t[k + 1] - prm.order_gap * (t1 - t0);
            let nt = (t[k] + dt).clamp(lo.min(hi), hi.max(lo));
            let np = curve.point(nt);
            max_move = max_move.max((np - p[k]).norm() / d[k]);
            t[k] = nt;
            p[k] = np;
            d[k] = d_at(nt, &np)?;
        }
        if max_move < prm.tol {
            break;
        }
    }
    ts.copy_from_slice(&t[1..=n]);
    Ok(())
}
