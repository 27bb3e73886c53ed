//! Non-uniform rational B-spline curves with exact derivatives.
//!
//! Written here rather than taken from a NURBS crate because the engine
//! needs exactly three things — C, C' and C'' at one parameter — and the
//! standard algorithms for them (The NURBS Book, Piegl & Tiller, 2nd ed.:
//! A2.1 span search, A2.3 basis function derivatives, A4.2 rational
//! derivatives) fit in a page with no further dependency, while the
//! available crates either lack rational second derivatives or bring a
//! large geometry kernel with its own point types.

use crate::power_form::PowerSegments;
use bubblemesh_core::geom::{Curve, P3, V3};

use super::{finite_point, GeometryError};

/// Highest accepted degree. Real data rarely exceeds 7; the cap keeps the
/// per-evaluation work ((p+1)² basis table) and memory bounded for any input.
pub const MAX_NURBS_DEGREE: usize = 15;

/// A NURBS curve of degree p with n control points P_i, weights w_i > 0 and
/// knot vector U = (u_0 … u_{n+p}):
///
/// C(t) = Σ N_{i,p}(t) w_i P_i / Σ N_{i,p}(t) w_i,  t ∈ [u_p, u_n].
///
/// Clamped (end knots of multiplicity p + 1, the curve then interpolates
/// its first and last control points) and unclamped knot vectors are both
/// accepted; the parameter interval is always [u_p, u_n].
///
/// Invariants (checked by [`Nurbs::new`]): 1 ≤ p ≤ [`MAX_NURBS_DEGREE`];
/// n ≥ p + 1; `knots.len() == n + p + 1`; knots finite and non-decreasing
/// with u_p < u_n; no knot strictly inside (u_p, u_n) repeated more than p
/// times (so the curve is continuous); weights finite and > 0; control
/// points finite.
#[derive(Clone, Debug, PartialEq)]
pub struct Nurbs {
    degree: usize,
    points: Vec<P3>,
    weights: Vec<f64>,
    knots: Vec<f64>,
    rational: bool,
    /// The knot spans in power form for [`Curve::tangent`] (`None` above
    /// their budget).
    power: Option<PowerSegments>,
}

impl Nurbs {
    /// A NURBS curve; `weights = None` gives a polynomial B-spline (all
    /// weights 1).
    pub fn new(
        degree: usize,
        points: Vec<P3>,
        weights: Option<Vec<f64>>,
        knots: Vec<f64>,
    ) -> Result<Self, GeometryError> {
        if degree == 0 || degree > MAX_NURBS_DEGREE {
            return Err(GeometryError::BadDegree {
                got: degree,
                max: MAX_NURBS_DEGREE,
            });
        }
        let n = points.len();
        if n < degree + 1 {
            return Err(GeometryError::TooFewControlPoints { degree, got: n });
        }
        for p in &points {
            finite_point(p, "NURBS control point")?;
        }
        let weights = match weights {
            None => vec![1.0; n],
            Some(w) => {
                if w.len() != n {
                    return Err(GeometryError::BadWeights(format!(
                        "{} weights for {} control points (need one weight per control point)",
                        w.len(),
                        n
                    )));
                }
                if let Some((i, x)) = w
                    .iter()
                    .enumerate()
                    .find(|(_, x)| !(x.is_finite() && **x > 0.0))
                {
                    return Err(GeometryError::BadWeights(format!(
                        "weight {} is {x}; weights must be finite and > 0",
                        i + 1
                    )));
                }
                w
            }
        };
        check_knots(&knots, degree, n)?;
        let rational = weights.iter().any(|&w| w != 1.0);
        let hw: Vec<[f64; 4]> = points
            .iter()
            .zip(&weights)
            .map(|(p, &w)| [p.x * w, p.y * w, p.z * w, w])
            .collect();
        let power = PowerSegments::new(degree, &knots, &hw);
        Ok(Nurbs {
            degree,
            points,
            weights,
            knots,
            rational,
            power,
        })
    }

    /// A NURBS curve with the clamped uniform knot vector on [0, 1]:
    /// p + 1 zeros, the interior knots i/(n − p) for i = 1 … n − p − 1, and
    /// p + 1 ones.
    pub fn clamped_uniform(
        degree: usize,
        points: Vec<P3>,
        weights: Option<Vec<f64>>,
    ) -> Result<Self, GeometryError> {
        let knots = clamped_uniform_knots(degree, points.len());
        Self::new(degree, points, weights, knots)
    }

    /// Degree p.
    pub fn degree(&self) -> usize {
        self.degree
    }
    /// Control points P_0 … P_{n−1}.
    pub fn control_points(&self) -> &[P3] {
        &self.points
    }
    /// Weights w_0 … w_{n−1} (all 1 for a polynomial B-spline).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
    /// Knot vector u_0 … u_{n+p}.
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }
    /// Whether some weight differs from 1.
    pub fn is_rational(&self) -> bool {
        self.rational
    }
    /// Number of non-empty knot spans in the parameter interval.
    pub fn span_count(&self) -> usize {
        let (p, n) = (self.degree, self.points.len());
        (p..n)
            .filter(|&k| self.knots[k] < self.knots[k + 1])
            .count()
    }

    /// The knot span index k ∈ [p, n−1] with u_k ≤ t < u_{k+1} and
    /// u_k < u_{k+1} (A2.1). Parameters outside the interval (and NaN) map to
    /// the first or last non-empty span, so the end polynomial pieces are
    /// extrapolated smoothly.
    fn find_span(&self, t: f64) -> usize {
        find_span(&self.knots, self.degree, self.points.len(), t)
    }

    /// C^(k)(t) for k = 0, 1, 2: the homogeneous sums A^(k) = Σ N^(k) w P
    /// and w^(k) = Σ N^(k) w, then the quotient rule (A4.2).
    #[allow(clippy::needless_range_loop)] // index form of the book's algorithm
    fn eval(&self, t: f64) -> [V3; 3] {
        let p = self.degree;
        let span = self.find_span(t);
        let ders = basis_derivs(&self.knots, span, t, p, 2);
        let mut a = [V3::zeros(); 3];
        let mut w = [0.0; 3];
        for j in 0..=p {
            let i = span - p + j;
            let wi = self.weights[i];
            let pi = self.points[i].coords;
            for k in 0..3 {
                a[k] += pi * (ders[k][j] * wi);
                w[k] += ders[k][j] * wi;
            }
        }
        if !self.rational {
            // Σ N = 1 and Σ N' = Σ N'' = 0 exactly in exact arithmetic.
            return a;
        }
        let c0 = a[0] / w[0];
        let c1 = (a[1] - c0 * w[1]) / w[0];
        let c2 = (a[2] - c1 * (2.0 * w[1]) - c0 * w[2]) / w[0];
        [c0, c1, c2]
    }
}

fn check_knots(u: &[f64], p: usize, n: usize) -> Result<(), GeometryError> {
    let bad = |m: String| Err(GeometryError::BadKnots(m));
    if u.len() != n + p + 1 {
        return bad(format!(
            "{} knots, but degree {p} with {n} control points needs n + p + 1 = {}",
            u.len(),
            n + p + 1
        ));
    }
    if let Some(i) = u.iter().position(|x| !x.is_finite()) {
        return bad(format!("knot {} is {}", i + 1, u[i]));
    }
    if let Some(i) = (1..u.len()).find(|&i| u[i] < u[i - 1]) {
        return bad(format!(
            "knots must be non-decreasing, but knot {} ({}) < knot {} ({})",
            i + 1,
            u[i],
            i,
            u[i - 1]
        ));
    }
    if !(u[p] < u[n]) {
        return bad(format!(
            "the parameter interval [u_p, u_n] = [{}, {}] is empty",
            u[p], u[n]
        ));
    }
    // Multiplicity of interior knots (strictly inside (u_p, u_n)).
    let mut i = 0;
    while i < u.len() {
        let mut j = i;
        while j + 1 < u.len() && u[j + 1] == u[i] {
            j += 1;
        }
        let mult = j - i + 1;
        if u[i] > u[p] && u[i] < u[n] && mult > p {
            return bad(format!(
                "interior knot {} has multiplicity {mult} > degree {p}, so the curve would be discontinuous",
                u[i]
            ));
        }
        i = j + 1;
    }
    Ok(())
}

impl Curve for Nurbs {
    fn interval(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.points.len()])
    }
    fn point(&self, t: f64) -> P3 {
        P3::from(self.eval(t)[0])
    }
    fn d1(&self, t: f64) -> V3 {
        self.eval(t)[1]
    }
    fn d2(&self, t: f64) -> V3 {
        self.eval(t)[2]
    }
    fn derivs(&self, t: f64) -> (P3, V3, V3) {
        let [c0, c1, c2] = self.eval(t);
        (P3::from(c0), c1, c2)
    }
    /// From the power-form segments ([`crate::power_form`]; equal to
    /// A2.3's to rounding), else A2.3.
    fn tangent(&self, t: f64) -> (P3, V3) {
        if let Some(d) = self.power_tangent(t) {
            return d;
        }
        let [c0, c1, _] = self.eval(t);
        (P3::from(c0), c1)
    }
}

impl Nurbs {
    /// C and C' from the power-form segments, where the curve has them.
    fn power_tangent(&self, t: f64) -> Option<(P3, V3)> {
        let pw = self.power.as_ref()?;
        let k = self.find_span(t);
        let (o, [a, a1]) = pw.eval(k, self.knots[k], t)?;
        let o = P3::new(o[0], o[1], o[2]);
        let vec = |h: &[f64; 4]| V3::new(h[0], h[1], h[2]);
        if !self.rational {
            return Some((o + vec(&a), vec(&a1)));
        }
        let c = vec(&a) / a[3];
        Some((o + c, (vec(&a1) - c * a1[3]) / a[3]))
    }
}

/// Size of the fixed basis arrays: degree ≤ [`MAX_NURBS_DEGREE`].
pub(crate) const MAXP: usize = MAX_NURBS_DEGREE + 1;

/// The clamped uniform knot vector on [0, 1] for `n` control points
/// (empty when the degree or count is invalid; [`Nurbs::new`] reports it).
pub(crate) fn clamped_uniform_knots(p: usize, n: usize) -> Vec<f64> {
    if p == 0 || n < p + 1 {
        return Vec::new();
    }
    let spans = n - p;
    let mut k = vec![0.0; p + 1];
    k.extend((1..spans).map(|i| i as f64 / spans as f64));
    k.extend(std::iter::repeat(1.0).take(p + 1));
    k
}

/// The knot span k ∈ [p, n−1] with u_k ≤ t < u_{k+1}, u_k < u_{k+1} (A2.1);
/// outside the domain (and NaN) the first or last non-empty span, as for
/// the curves.
pub(crate) fn find_span(knots: &[f64], p: usize, n: usize, t: f64) -> usize {
    let idx = knots[p..=n].partition_point(|&x| x <= t);
    let mut k = (p + idx).saturating_sub(1).clamp(p, n - 1);
    while k > p && knots[k] == knots[k + 1] {
        k -= 1;
    }
    while k < n - 1 && knots[k] == knots[k + 1] {
        k += 1;
    }
    k
}

/// Non-zero basis functions N_{span−p+j,p} and their derivatives up to
/// order `n` ≤ 2 at `t` (A2.3): `ders[k][j]`, the rows above `n` zero (the
/// rows computed are the same numbers whatever `n`). Precondition:
/// non-empty span.
pub(crate) fn basis_derivs(
    knots: &[f64],
    span: usize,
    t: f64,
    p: usize,
    n: usize,
) -> [[f64; MAXP]; 3] {
    // the triangle table sized to the degree: zeroing a 16 × 16 table for
    // a cubic was a tenth of a NURBS face's stage 2
    if p < 8 {
        basis_table::<8>(knots, span, t, p, n)
    } else {
        basis_table::<MAXP>(knots, span, t, p, n)
    }
}

/// [`basis_derivs`] with tables of `M` > p entries per side.
#[allow(clippy::needless_range_loop)] // index form of the book's algorithm
fn basis_table<const M: usize>(
    knots: &[f64],
    span: usize,
    t: f64,
    p: usize,
    n: usize,
) -> [[f64; MAXP]; 3] {
    let mut ndu = [[0.0f64; M]; M];
    let mut left = [0.0f64; M];
    let mut right = [0.0f64; M];
    ndu[0][0] = 1.0;
    for j in 1..=p {
        left[j] = t - knots[span + 1 - j];
        right[j] = knots[span + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    let mut ders = [[0.0f64; MAXP]; 3];
    for j in 0..=p {
        ders[0][j] = ndu[j][p];
    }
    let nd = p.min(n.min(2));
    let mut a = [[0.0f64; MAXP]; 2];
    for r in 0..=p {
        let (mut s1, mut s2) = (0, 1);
        a[0][0] = 1.0;
        for k in 1..=nd {
            let mut d = 0.0;
            let rk = r as isize - k as isize;
            let pk = p - k;
            if rk >= 0 {
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if r <= pk + 1 { k - 1 } else { p - r };
            for j in j1..=j2 {
                let c = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][c];
                d += a[s2][j] * ndu[c][pk];
            }
            if r <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
                d += a[s2][k] * ndu[r][pk];
            }
            ders[k][r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    // Multiply by p!/(p−k)!.
    let mut f = p as f64;
    for k in 1..=nd {
        for j in 0..=p {
            ders[k][j] *= f;
        }
        f *= (p - k) as f64;
    }
    ders
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_functions_sum_to_one_and_derivatives_to_zero() {
        let u = [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 5.0, 5.0, 5.0];
        // The NURBS Book Ex. 2.4: t = 5/2, p = 2, span 4.
        let d = basis_derivs(&u, 4, 2.5, 2, 2);
        assert!((d[0].iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!(d[1].iter().sum::<f64>().abs() < 1e-14);
        assert!(d[2].iter().sum::<f64>().abs() < 1e-14);
        assert!((d[0][0] - 1.0 / 8.0).abs() < 1e-14);
        assert!((d[0][1] - 6.0 / 8.0).abs() < 1e-14);
        assert!((d[0][2] - 1.0 / 8.0).abs() < 1e-14);
        // Derivatives from the book: N'_{2,2} = -0.5, N'_{3,2} = 0, N'_{4,2} = 0.5.
        assert!((d[1][0] + 0.5).abs() < 1e-14);
        assert!(d[1][1].abs() < 1e-14);
        assert!((d[1][2] - 0.5).abs() < 1e-14);
    }

    #[test]
    fn span_search_handles_ends_and_nan() {
        let pts: Vec<P3> = (0..6).map(|i| P3::new(i as f64, 0.0, 0.0)).collect();
        let c = Nurbs::new(
            2,
            pts,
            None,
            vec![0.0, 0.0, 0.0, 2.0, 1.0, 2.0, 3.0, 3.0, 3.0],
        )
        .unwrap_err();
        assert!(matches!(c, GeometryError::BadKnots(_)), "{c:?}");
        let pts: Vec<P3> = (0..5).map(|i| P3::new(i as f64, 0.0, 0.0)).collect();
        let c = Nurbs::new(2, pts, None, vec![0.0, 0.0, 0.0, 1.0, 2.0, 2.0, 3.0, 3.0]).unwrap();
        assert_eq!(c.find_span(0.0), 2);
        assert_eq!(c.find_span(0.5), 2);
        assert_eq!(c.find_span(1.0), 3);
        assert_eq!(c.find_span(2.0), 3);
        assert_eq!(c.find_span(3.0), 3);
        assert_eq!(c.find_span(7.0), 3);
        assert_eq!(c.find_span(-1.0), 2);
        assert_eq!(c.find_span(f64::NAN), 2);
        assert_eq!(c.span_count(), 2);
    }

    /// The power-form segments (`power_form`) give A2.3's point and first
    /// derivative to rounding: rational curves of degrees 1 to 11 with
    /// repeated interior knots (empty spans) far from the origin, at every
    /// knot and at random parameters.
    #[test]
    fn power_form_tangent_equals_the_book_algorithm() {
        let mut unit = crate::testing::unit(0x7a3e_11c5);
        for p in [1usize, 2, 3, 5, 7, 11] {
            let mut knots = vec![-3.0; p + 1];
            for (k, m) in [(1.0, 1), (1.5, p.min(3)), (4.0, p)] {
                knots.extend(std::iter::repeat_n(k, m));
            }
            knots.extend(vec![9.0; p + 1]);
            let n = knots.len() - p - 1;
            let pts: Vec<P3> = (0..n)
                .map(|i| P3::new(4e3 + i as f64 + unit(), -2e3 + unit(), unit()))
                .collect();
            let w: Vec<f64> = (0..n).map(|_| 1.0 + 0.9 * unit()).collect();
            let c = Nurbs::new(p, pts, Some(w), knots.clone()).unwrap();
            assert!(c.power.is_some());
            let (a, b) = c.interval();
            let ts: Vec<f64> = knots
                .iter()
                .copied()
                .filter(|&t| t >= a && t <= b)
                .chain((0..100).map(|_| a + (b - a) * (unit() + 0.5)))
                .collect();
            for t in ts {
                let (pt, d1) = c.power_tangent(t).expect("a non-empty span");
                let [c0, c1, _] = c.eval(t);
                assert!((pt.coords - c0).norm() <= 1e-9 * 20.0, "degree {p} at {t}");
                assert!((d1 - c1).norm() <= 1e-8 * c1.norm(), "degree {p} C' at {t}");
                if p <= 5 {
                    assert!((pt.coords - c0).norm() <= 1e-15 * c0.norm() + 1e-11);
                    assert!((d1 - c1).norm() <= 1e-10 * c1.norm());
                }
            }
        }
    }
}
