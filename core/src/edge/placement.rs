//! Stage 1 on edges (thesis §4.1.1): recursive bisection of the parameter
//! interval, and the equidistribution of the weighted length ∫ ds/d with the
//! bubble count of eq. 4.7.1.

use crate::bubbles::MAX_BUBBLES_PER_ENTITY;
use crate::error::MeshError;
use crate::geom::{Curve, P3};

/// Recursive bisection of `[t0, t1]` (§4.1.1): a sub-interval is split at
/// its parametric midpoint while the chord between its end bubbles is longer
/// than the sum of their radii. Returns the interior parameters, sorted.
pub fn bisect_edge(
    curve: &dyn Curve,
    t0: f64,
    t1: f64,
    d_at: &mut dyn FnMut(f64, &P3) -> Result<f64, MeshError>,
    closed: bool,
) -> Result<Vec<f64>, MeshError> {
    let mut out = Vec::new();
    // a closed curve starts from three pieces so its end bubbles are distinct
    let mut stack: Vec<(f64, f64, P3, P3, f64, f64)> = Vec::new();
    let seeds: Vec<f64> = if closed {
        (0..=3).map(|k| t0 + (t1 - t0) * k as f64 / 3.0).collect()
    } else {
        vec![t0, t1]
    };
    let pts: Vec<P3> = seeds.iter().map(|&t| curve.point(t)).collect();
    let mut ds = Vec::new();
    for (t, p) in seeds.iter().zip(&pts) {
        ds.push(d_at(*t, p)?);
    }
    out.extend_from_slice(&seeds[1..seeds.len() - 1]);
    for k in 0..seeds.len() - 1 {
        stack.push((seeds[k], seeds[k + 1], pts[k], pts[k + 1], ds[k], ds[k + 1]));
    }
    while let Some((a, b, pa, pb, da, db)) = stack.pop() {
        if (pa - pb).norm() <= 0.5 * (da + db) || (b - a) <= 1e-14 * (t1 - t0).abs() {
            continue;
        }
        let m = 0.5 * (a + b);
        let pm = curve.point(m);
        let dm = d_at(m, &pm)?;
        out.push(m);
        if out.len() > MAX_BUBBLES_PER_ENTITY {
            return Err(MeshError::TooManyBubbles {
                limit: MAX_BUBBLES_PER_ENTITY,
            });
        }
        stack.push((a, m, pa, pm, da, dm));
        stack.push((m, b, pm, pb, dm, db));
    }
    out.sort_by(|a, b| a.total_cmp(b));
    Ok(out)
}

/// Places bubbles on `[t0, t1]` so that every piece holds the same share of
/// the weighted length ∫ ds/d, with the number of pieces from eq. 4.7.1
/// (the weighted length, less the halves of the two end bubbles, gives the
/// interior bubbles; pieces = interior + 1 = round(∫ ds/d)).
/// Returns the interior parameters, sorted.
pub fn equidistribute_edge(
    curve: &dyn Curve,
    t0: f64,
    t1: f64,
    d_at: &mut dyn FnMut(f64, &P3) -> Result<f64, MeshError>,
    closed: bool,
) -> Result<Vec<f64>, MeshError> {
    // an open edge whose weighted length is clearly below 1.5 is one piece
    // and has no interior bubble: a first look at 32 samples tells, where
    // each sample step is a small fraction of the local spacing (most edges
    // of a part at the sizes engineers ask for are like this, and the
    // spacing is the costly part here)
    if !closed {
        const LOOK: usize = 32;
        let mut total = 0.0;
        let mut steepest: f64 = 0.0;
        let mut prev: Option<f64> = None;
        let dt = (t1 - t0) / LOOK as f64;
        for k in 0..=LOOK {
            let t = t0 + (t1 - t0) * k as f64 / LOOK as f64;
            let w = curve.d1(t).norm() / d_at(t, &curve.point(t))?;
            if let Some(p) = prev {
                let piece = 0.5 * (p + w) * dt;
                total += piece;
                steepest = steepest.max(piece);
            }
            prev = Some(w);
        }
        if total < 1.25 && steepest <= 1.0 / 16.0 {
            return Ok(Vec::new());
        }
    }
    let (ts, cum) = weighted_table(curve, t0, t1, d_at)?;
    let total = cum[cum.len() - 1];
    let min_pieces = if closed { 3 } else { 1 };
    let pieces = (total.round() as usize).max(min_pieces);
    let mut out = Vec::with_capacity(pieces.saturating_sub(1));
    let mut k = 0;
    for q in 1..pieces {
        let target = total * q as f64 / pieces as f64;
        while cum[k + 1] < target {
            k += 1;
        }
        let f = (target - cum[k]) / (cum[k + 1] - cum[k]).max(f64::MIN_POSITIVE);
        out.push(ts[k] + f * (ts[k + 1] - ts[k]));
    }
    Ok(out)
}

/// The weighted length ∫ ds/d along `[t0, t1]` as a table: parameters
/// `ts` (equal steps, at least 256 and at least 16 per unit of weighted
/// length) and the cumulative weighted length `cum` at each (`cum[0] = 0`,
/// non-decreasing, the last entry the whole edge's). The trapezoid rule on
/// this sampling is what the equidistribution and the staggering
/// ([`super::stagger`]) read positions from.
pub(crate) fn weighted_table(
    curve: &dyn Curve,
    t0: f64,
    t1: f64,
    d_at: &mut dyn FnMut(f64, &P3) -> Result<f64, MeshError>,
) -> Result<(Vec<f64>, Vec<f64>), MeshError> {
    let mut m = 256usize;
    loop {
        let ts: Vec<f64> = (0..=m)
            .map(|k| t0 + (t1 - t0) * k as f64 / m as f64)
            .collect();
        let mut w = Vec::with_capacity(m + 1);
        for &t in &ts {
            let p = curve.point(t);
            let d = d_at(t, &p)?;
            w.push(curve.d1(t).norm() / d);
        }
        let mut cum = vec![0.0; m + 1];
        for k in 0..m {
            cum[k + 1] = cum[k] + 0.5 * (w[k] + w[k + 1]) * (ts[k + 1] - ts[k]);
        }
        let total = cum[m];
        if !total.is_finite() {
            return Err(MeshError::Invalid(
                "weighted edge length is not finite".into(),
            ));
        }
        // refine until there are at least 16 samples per piece
        if (m as f64) < 16.0 * total && m < (1 << 26) {
            // compared as a float first: a spacing like 1e-300 makes the
            // count overflow usize, and the wrapped count looped forever
            if 16.0 * total > MAX_BUBBLES_PER_ENTITY as f64 {
                return Err(MeshError::TooManyBubbles {
                    limit: MAX_BUBBLES_PER_ENTITY,
                });
            }
            m = ((16.0 * total) as usize + 1).next_power_of_two();
            if m > MAX_BUBBLES_PER_ENTITY {
                return Err(MeshError::TooManyBubbles {
                    limit: MAX_BUBBLES_PER_ENTITY,
                });
            }
            continue;
        }
        return Ok((ts, cum));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::V3;

    /// The segment [0,1] of the x axis, C(t) = (t, 0, 0).
    #[derive(Debug)]
    struct Segment;

    impl Curve for Segment {
        fn interval(&self) -> (f64, f64) {
            (0.0, 1.0)
        }
        fn point(&self, t: f64) -> P3 {
            P3::new(t, 0.0, 0.0)
        }
        fn d1(&self, _t: f64) -> V3 {
            V3::x()
        }
        fn d2(&self, _t: f64) -> V3 {
            V3::zeros()
        }
    }

    fn graded(x: f64) -> f64 {
        0.05 + 0.1 * x
    }

    /// Bisection (§4.1.1) stops splitting when the chord is at most the sum
    /// of the end radii, and splits while it is longer: every segment is at
    /// most (d_a + d_b)/2 long and more than half that (its parent was
    /// split).
    #[test]
    fn bisection_gives_segments_near_the_spacing() {
        let mut d_at = |t: f64, _: &P3| Ok(graded(t));
        let ts = bisect_edge(&Segment, 0.0, 1.0, &mut d_at, false).unwrap();
        let all: Vec<f64> = std::iter::once(0.0)
            .chain(ts.iter().cloned())
            .chain(std::iter::once(1.0))
            .collect();
        for w in all.windows(2) {
            let (len, r0) = (w[1] - w[0], 0.5 * (graded(w[0]) + graded(w[1])));
            assert!(len <= r0 * (1.0 + 1e-12), "segment {w:?}: {len} > {r0}");
            assert!(len > 0.5 * r0 * 0.99, "segment {w:?}: {len} against {r0}");
        }
    }

    /// Equidistribution gives eq. 4.7.1's count: ∫ ds/d less the two end
    /// bubbles' halves; for d = 0.05 + 0.1 x on [0,1], ∫ ds/d = 10 ln 3 =
    /// 10.99, so 11 pieces and 10 interior bubbles, each piece holding the
    /// same weighted length.
    #[test]
    fn equidistribution_follows_the_population_estimate() {
        let mut d_at = |t: f64, _: &P3| Ok(graded(t));
        let ts = equidistribute_edge(&Segment, 0.0, 1.0, &mut d_at, false).unwrap();
        let total = 10.0 * 3f64.ln();
        assert_eq!(ts.len(), total.round() as usize - 1);
        let weighted = |a: f64, b: f64| 10.0 * (graded(b) / graded(a)).ln();
        let all: Vec<f64> = std::iter::once(0.0)
            .chain(ts.iter().cloned())
            .chain(std::iter::once(1.0))
            .collect();
        for w in all.windows(2) {
            let share = weighted(w[0], w[1]);
            assert!(
                (share - total / 11.0).abs() < 1e-3,
                "piece {w:?} holds {share}"
            );
        }
    }
}
