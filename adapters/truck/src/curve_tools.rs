//! Curve helpers shared by the STEP and truck paths: the closest parameter
//! of a point on a curve, and a wrapper that evaluates a closed curve with
//! its parameter taken modulo the period (an edge that runs across the
//! start of a closed B-spline).

use std::sync::Arc;

use bubblemesh_core::geom::{Curve, P3, V3};

/// A closed curve whose parameter is taken modulo its period before
/// evaluation: C̃(t) = C(t₀ + (t − t₀) mod T) with [t₀, t₀ + T] the inner
/// curve's interval. The interval reported is `[t0, t0 + 2T]`, so that an
/// edge `[a, b]` with t₀ ≤ a < t₀ + T and a < b ≤ a + T lies inside it.
///
/// Invariant: the inner curve is closed (C(t₀) = C(t₀ + T)) and at least
/// C¹ across its ends where edges cross them (true of STEP periodic
/// B-splines and of circles).
#[derive(Debug, Clone)]
pub struct WrappedCurve {
    pub inner: Arc<dyn Curve>,
    t0: f64,
    period: f64,
}

impl WrappedCurve {
    pub fn new(inner: Arc<dyn Curve>) -> Self {
        let (a, b) = inner.interval();
        WrappedCurve {
            inner,
            t0: a,
            period: b - a,
        }
    }
    fn wrap(&self, t: f64) -> f64 {
        let y = self.t0 + (t - self.t0).rem_euclid(self.period);
        if y >= self.t0 + self.period {
            self.t0
        } else {
            y
        }
    }
}

impl Curve for WrappedCurve {
    fn interval(&self) -> (f64, f64) {
        (self.t0, self.t0 + 2.0 * self.period)
    }
    fn point(&self, t: f64) -> P3 {
        self.inner.point(self.wrap(t))
    }
    fn d1(&self, t: f64) -> V3 {
        self.inner.d1(self.wrap(t))
    }
    fn d2(&self, t: f64) -> V3 {
        self.inner.d2(self.wrap(t))
    }
    fn derivs(&self, t: f64) -> (P3, V3, V3) {
        self.inner.derivs(self.wrap(t))
    }
    fn tangent(&self, t: f64) -> (P3, V3) {
        self.inner.tangent(self.wrap(t))
    }
}

/// The parameter in `[a, b]` of the point of `c` nearest to `p`: the best
/// of `samples + 1` equally spaced parameters, refined by Newton on
/// (C(t) − p)·C'(t) = 0 kept inside `[a, b]`. Returns (t, distance).
///
/// Written here (not truck's `SearchNearestParameter`) because it runs on
/// bubblemesh curves and must never leave the curve's valid interval
/// (evaluating an unclamped spline outside it is what makes truck diverge).
pub fn closest_parameter(c: &dyn Curve, p: &P3, a: f64, b: f64, samples: usize) -> (f64, f64) {
    let n = samples.max(2);
    let mut best = (a, f64::INFINITY);
    for k in 0..=n {
        let t = a + (b - a) * k as f64 / n as f64;
        let d = (c.point(t) - p).norm_squared();
        if d < best.1 {
            best = (t, d);
        }
    }
    let mut t = best.0;
    let h = (b - a) / n as f64;
    let (lo, hi) = ((t - h).max(a), (t + h).min(b));
    for _ in 0..50 {
        let r = c.point(t) - p;
        let d1 = c.d1(t);
        let f = r.dot(&d1);
        let fp = d1.norm_squared() + r.dot(&c.d2(t));
        if !(fp > 0.0) || !f.is_finite() {
            break;
        }
        let tn = (t - f / fp).clamp(lo, hi);
        let step = (tn - t).abs();
        t = tn;
        if step <= 1e-15 * (b - a).abs().max(1.0) {
            break;
        }
    }
    let d = (c.point(t) - p).norm();
    if d.is_finite() && d * d <= best.1 {
        (t, d)
    } else {
        (best.0, best.1.sqrt())
    }
}
