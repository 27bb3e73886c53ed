//! Stage 2 on an edge (thesis §4.2–4.5): the chain of bubbles along the
//! curve relaxed with its ends fixed (see the module docs of `edge` for
//! why a chain has its own loop).

use crate::bubbles::{dynamics, force};
use crate::error::MeshError;
use crate::geom::{Curve, P3, V3};

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
pub(super) fn relax_chain(
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
