//! Tensor-product NURBS surfaces with exact first and second partials.
//!
//! The algorithms are those of The NURBS Book (Piegl & Tiller, 2nd ed.):
//! A2.1 span search, A2.3 basis-function derivatives, and the rational
//! quotient rule of A4.4 applied to the homogeneous sums. Unlike
//! truck-geometry 0.5 (whose second derivatives are off by a factor p − 1
//! for degree ≥ 3) S_uu, S_vv and S_uv are exact; the tests compare them
//! with finite differences on bicubic patches.

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3, V3};

use super::{
    area_singular, area_singular_of, newton_inverse, typical_partials, wrap, ParamBox, SurfaceError,
};
use crate::curves::{basis_derivs, clamped_uniform_knots, find_span, GeometryError, Nurbs};
use crate::power_form::PowerPatches;

/// A NURBS surface of degrees (p, q) with an nu × nv control net P_ij,
/// weights w_ij > 0 and knot vectors U = (u_0 … u_{nu+p}),
/// V = (v_0 … v_{nv+q}):
///
/// S(u,v) = Σ_ij N_{i,p}(u) M_{j,q}(v) w_ij P_ij / Σ_ij N_{i,p}(u) M_{j,q}(v) w_ij
///
/// on the domain u ∈ [u_p, u_nu], v ∈ [v_q, v_nv] (dimensionless knot
/// parameters). Index i runs along u, j along v: `net[i][j]`.
///
/// Each direction is validated exactly like a [`Nurbs`] curve (degree
/// 1 ..= [`MAX_NURBS_DEGREE`], at least degree + 1 points, knot count,
/// non-decreasing finite knots with a non-empty domain, interior knot
/// multiplicity ≤ degree); the net and weight net must be rectangular,
/// finite, with weights > 0.
///
/// A direction is *periodic* when the surface is closed in it: S(u_p, v) =
/// S(u_nu, v) (to 1e-10 × the net's size) at 9 sample values of v (and
/// likewise for v). Evaluation then takes that parameter modulo the domain
/// width, and [`Surface::periods`] reports it.
///
/// Singular points (collapsed edges, e.g. the pole of a sphere patch) use
/// the generic test |S_u × S_v| ≤ [`SINGULAR_REL`](super::SINGULAR_REL) × typical |S_u| ×
/// typical |S_v|. [`Surface::singular_points`] reports the *poles*: the
/// boundary isocurves (u = u_p, u = u_nu, v = v_q, v = v_nv) that collapse
/// to a point. At a clamped end (end knot of multiplicity degree + 1) the
/// isocurve is the NURBS curve of the boundary row (or column) of the net,
/// which is constant exactly when all of that row's control points coincide
/// (the basis functions are linearly independent and the weights positive);
/// at an unclamped end the isocurve is evaluated at 4 points per knot span.
/// Coincide means: within 1e-9 × the net's bounding-box diagonal.
#[derive(Clone, Debug, PartialEq)]
pub struct NurbsSurface {
    degree: [usize; 2],
    n: [usize; 2],
    /// Control points, row-major (index i·nv + j).
    points: Vec<P3>,
    weights: Vec<f64>,
    /// (w P, w) per control point.
    hw: Vec<[f64; 4]>,
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    rational: bool,
    period: [Option<f64>; 2],
    size: f64,
    scale: [f64; 2],
    /// Points where a boundary isocurve collapses (see the type's doc).
    poles: Vec<P3>,
    /// The knot-span patches in power form for [`Surface::tangents`]
    /// (`None` for a net above their budget).
    power: Option<PowerPatches>,
}

/// Relative tolerance (× the net's size) within which a boundary isocurve
/// counts as collapsed to a pole. STEP files print 15 significant digits,
/// so a pole written by a CAD kernel coincides to about 1e-15.
const POLE_REL: f64 = 1e-9;

impl NurbsSurface {
    /// A NURBS surface; `net[i][j]` is P_ij (i along u), `weights` (same
    /// shape) `None` for a polynomial B-spline surface (all weights 1).
    pub fn new(
        degree_u: usize,
        degree_v: usize,
        net: Vec<Vec<P3>>,
        weights: Option<Vec<Vec<f64>>>,
        knots_u: Vec<f64>,
        knots_v: Vec<f64>,
    ) -> Result<Self, SurfaceError> {
        let nu = net.len();
        let nv = net.first().map_or(0, |r| r.len());
        if let Some((i, r)) = net.iter().enumerate().find(|(_, r)| r.len() != nv) {
            return Err(SurfaceError::BadNet(format!(
                "row {} has {} points but row 1 has {nv} (the net must be rectangular)",
                i + 1,
                r.len()
            )));
        }
        // Each direction validated as a curve with that many points.
        let check = |dir: &'static str, p: usize, n: usize, knots: &Vec<f64>| {
            Nurbs::new(p, vec![P3::origin(); n], None, knots.clone())
                .map(|_| ())
                .map_err(|source| SurfaceError::NurbsDirection { dir, source })
        };
        check("u", degree_u, nu, &knots_u)?;
        check("v", degree_v, nv, &knots_v)?;
        let points: Vec<P3> = net.into_iter().flatten().collect();
        if !points.iter().all(|p| p.iter().all(|x| x.is_finite())) {
            return Err(GeometryError::NotFinite("NURBS control point").into());
        }
        let weights: Vec<f64> = match weights {
            None => vec![1.0; nu * nv],
            Some(w) => {
                if w.len() != nu || w.iter().any(|r| r.len() != nv) {
                    return Err(SurfaceError::BadNet(format!(
                        "the weight net must be {nu} × {nv} like the control net"
                    )));
                }
                let w: Vec<f64> = w.into_iter().flatten().collect();
                if let Some((k, x)) = w
                    .iter()
                    .enumerate()
                    .find(|(_, x)| !(x.is_finite() && **x > 0.0))
                {
                    return Err(GeometryError::BadWeights(format!(
                        "weight ({}, {}) is {x}; weights must be finite and > 0",
                        k / nv + 1,
                        k % nv + 1
                    ))
                    .into());
                }
                w
            }
        };
        let hw: Vec<[f64; 4]> = points
            .iter()
            .zip(&weights)
            .map(|(p, &w)| [p.x * w, p.y * w, p.z * w, w])
            .collect();
        let (mut lo, mut hi) = (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY));
        for p in &points {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        let power = PowerPatches::new([degree_u, degree_v], [nu, nv], &knots_u, &knots_v, &hw);
        let mut s = NurbsSurface {
            power,
            degree: [degree_u, degree_v],
            n: [nu, nv],
            rational: weights.iter().any(|&w| w != 1.0),
            points,
            weights,
            hw,
            knots_u,
            knots_v,
            period: [None, None],
            size: (hi - lo).norm().max(f64::MIN_POSITIVE),
            scale: [1.0, 1.0],
            poles: Vec::new(),
        };
        s.period = s.detect_periods();
        s.scale = typical_partials(&s);
        s.poles = s.detect_poles();
        Ok(s)
    }

    /// A NURBS surface with clamped uniform knot vectors on [0, 1] in both
    /// directions (p + 1 zeros, interior knots i/(n − p), p + 1 ones).
    pub fn clamped_uniform(
        degree_u: usize,
        degree_v: usize,
        net: Vec<Vec<P3>>,
        weights: Option<Vec<Vec<f64>>>,
    ) -> Result<Self, SurfaceError> {
        let nu = net.len();
        let nv = net.first().map_or(0, |r| r.len());
        let ku = clamped_uniform_knots(degree_u, nu);
        let kv = clamped_uniform_knots(degree_v, nv);
        Self::new(degree_u, degree_v, net, weights, ku, kv)
    }

    /// Degrees (p, q).
    pub fn degrees(&self) -> [usize; 2] {
        self.degree
    }
    /// Net size (nu, nv).
    pub fn net_size(&self) -> [usize; 2] {
        self.n
    }
    /// Control point P_ij.
    pub fn control_point(&self, i: usize, j: usize) -> P3 {
        self.points[i * self.n[1] + j]
    }
    /// Weight w_ij.
    pub fn weight(&self, i: usize, j: usize) -> f64 {
        self.weights[i * self.n[1] + j]
    }
    /// Knot vector U.
    pub fn knots_u(&self) -> &[f64] {
        &self.knots_u
    }
    /// Knot vector V.
    pub fn knots_v(&self) -> &[f64] {
        &self.knots_v
    }
    /// Whether some weight differs from 1.
    pub fn is_rational(&self) -> bool {
        self.rational
    }
    /// Control-net bounding-box diagonal (model units); the surface lies in
    /// the box (convex hull property). Used by the inverse's distance check.
    pub fn size(&self) -> f64 {
        self.size
    }

    fn detect_periods(&self) -> [Option<f64>; 2] {
        let (du, dv) = self.domain();
        let tol = 1e-10 * self.size;
        let closed = |f: &dyn Fn(f64) -> (P3, P3)| {
            (0..9).all(|k| {
                let (a, b) = f(k as f64 / 8.0);
                (a - b).norm() <= tol
            })
        };
        let cu = closed(&|t| {
            let v = dv[0] + t * (dv[1] - dv[0]);
            (self.eval(du[0], v).p, self.eval(du[1], v).p)
        });
        let cv = closed(&|t| {
            let u = du[0] + t * (du[1] - du[0]);
            (self.eval(u, dv[0]).p, self.eval(u, dv[1]).p)
        });
        [cu.then_some(du[1] - du[0]), cv.then_some(dv[1] - dv[0])]
    }

    /// The collapsed boundary isocurves' points (type documentation),
    /// without duplicates (a sphere patch whose two v-ends are poles gives
    /// two points; a cone patch one).
    fn detect_poles(&self) -> Vec<P3> {
        let tol = POLE_REL * self.size;
        let [nu, nv] = self.n;
        let (du, dv) = self.domain();
        let mut out: Vec<P3> = Vec::new();
        // (direction of the isocurve's own parameter, fixed end)
        for (fixed_dir, end) in [(0usize, 0usize), (0, 1), (1, 0), (1, 1)] {
            let (p, knots, n) = if fixed_dir == 0 {
                (self.degree[0], &self.knots_u, nu)
            } else {
                (self.degree[1], &self.knots_v, nv)
            };
            let clamped = if end == 0 {
                knots[..=p].iter().all(|&k| k == knots[0])
            } else {
                knots[n..].iter().all(|&k| k == knots[n])
            };
            let pts: Vec<P3> = if clamped {
                // the boundary row (fixed u index) or column (fixed v index)
                let idx = if end == 0 { 0 } else { n - 1 };
                if fixed_dir == 0 {
                    (0..nv).map(|j| self.control_point(idx, j)).collect()
                } else {
                    (0..nu).map(|i| self.control_point(i, idx)).collect()
                }
            } else {
                let other = 1 - fixed_dir;
                let m = 4 * self.span_count(other).max(1);
                let (fu, fv) = (du[end], dv[end]);
                (0..=m)
                    .map(|k| {
                        let t = k as f64 / m as f64;
                        if fixed_dir == 0 {
                            self.eval(fu, dv[0] + t * (dv[1] - dv[0])).p
                        } else {
                            self.eval(du[0] + t * (du[1] - du[0]), fv).p
                        }
                    })
                    .collect()
            };
            let first = pts[0];
            if pts.iter().all(|q| (q - first).norm() <= tol) {
                let pole = if clamped {
                    // the surface's corner point (exactly on it)
                    let (u, v) = if fixed_dir == 0 {
                        (du[end], dv[0])
                    } else {
                        (du[0], dv[end])
                    };
                    self.eval(u, v).p
                } else {
                    first
                };
                if !out.iter().any(|q| (q - pole).norm() <= tol) {
                    out.push(pole);
                }
            }
        }
        out
    }

    /// S and its partials up to order 2 (no wrapping).
    fn eval(&self, u: f64, v: f64) -> SurfaceDerivs {
        self.eval_upto(u, v, 2)
    }

    /// S and its partials up to order `order` ≤ 2 (no wrapping); the
    /// partials of higher order are left zero, the others are the numbers
    /// of the full evaluation (the same sums in the same order).
    #[allow(clippy::needless_range_loop)] // index form of the book's algorithm
    fn eval_upto(&self, u: f64, v: f64, order: usize) -> SurfaceDerivs {
        let [p, q] = self.degree;
        let [nu, nv] = self.n;
        let ku = find_span(&self.knots_u, p, nu, u);
        let kv = find_span(&self.knots_v, q, nv, v);
        let bu = basis_derivs(&self.knots_u, ku, u, p, order);
        let bv = basis_derivs(&self.knots_v, kv, v, q, order);
        let rows = order.min(2) + 1;
        // Homogeneous sums A^{(k,l)}: order 00, 10, 01, 20, 11, 02.
        let mut a = [[0.0f64; 4]; 6];
        for i in 0..=p {
            let row = (ku - p + i) * nv + kv - q;
            let mut t = [[0.0f64; 4]; 3];
            for j in 0..=q {
                let h = &self.hw[row + j];
                for l in 0..rows {
                    let c = bv[l][j];
                    for m in 0..4 {
                        t[l][m] += c * h[m];
                    }
                }
            }
            let (n0, n1, n2) = (bu[0][i], bu[1][i], bu[2][i]);
            for m in 0..4 {
                a[0][m] += n0 * t[0][m];
            }
            if rows > 1 {
                for m in 0..4 {
                    a[1][m] += n1 * t[0][m];
                    a[2][m] += n0 * t[1][m];
                }
            }
            if rows > 2 {
                for m in 0..4 {
                    a[3][m] += n2 * t[0][m];
                    a[4][m] += n1 * t[1][m];
                    a[5][m] += n0 * t[2][m];
                }
            }
        }
        let vec = |h: &[f64; 4]| V3::new(h[0], h[1], h[2]);
        if !self.rational {
            // Σ N M = 1 and its derivatives vanish in exact arithmetic.
            return SurfaceDerivs {
                p: P3::from(vec(&a[0])),
                su: vec(&a[1]),
                sv: vec(&a[2]),
                suu: vec(&a[3]),
                suv: vec(&a[4]),
                svv: vec(&a[5]),
            };
        }
        // Quotient rule (A4.4): A^{(k,l)} = Σ C(k,i) C(l,j) w^{(i,j)} S^{(k−i,l−j)}.
        let w = [a[0][3], a[1][3], a[2][3], a[3][3], a[4][3], a[5][3]];
        let s = vec(&a[0]) / w[0];
        let su = (vec(&a[1]) - s * w[1]) / w[0];
        let sv = (vec(&a[2]) - s * w[2]) / w[0];
        let suu = (vec(&a[3]) - su * (2.0 * w[1]) - s * w[3]) / w[0];
        let suv = (vec(&a[4]) - su * w[2] - sv * w[1] - s * w[4]) / w[0];
        let svv = (vec(&a[5]) - sv * (2.0 * w[2]) - s * w[5]) / w[0];
        SurfaceDerivs {
            p: P3::from(s),
            su,
            sv,
            suu,
            suv,
            svv,
        }
    }

    /// S, S_u and S_v from the power-form patches (no wrapping), where
    /// the surface has them.
    fn power_tangents(&self, u: f64, v: f64) -> Option<(P3, V3, V3)> {
        let pp = self.power.as_ref()?;
        let ([p, q], [nu, nv]) = (self.degree, self.n);
        let ku = find_span(&self.knots_u, p, nu, u);
        let kv = find_span(&self.knots_v, q, nv, v);
        let (o, [a, a_u, a_v]) = pp.eval((ku, self.knots_u[ku], u), (kv, self.knots_v[kv], v))?;
        let o = P3::new(o[0], o[1], o[2]);
        let vec = |h: &[f64; 4]| V3::new(h[0], h[1], h[2]);
        if !self.rational {
            return Some((o + vec(&a), vec(&a_u), vec(&a_v)));
        }
        // the quotient rule, as in eval_upto, on S − O
        let s = vec(&a) / a[3];
        let su = (vec(&a_u) - s * a_u[3]) / a[3];
        let sv = (vec(&a_v) - s * a_v[3]) / a[3];
        Some((o + s, su, sv))
    }

    fn wrap_params(&self, u: f64, v: f64) -> (f64, f64) {
        let (du, dv) = self.domain();
        (
            self.period[0].map_or(u, |t| wrap(u, du[0], t)),
            self.period[1].map_or(v, |t| wrap(v, dv[0], t)),
        )
    }

    fn span_count(&self, dir: usize) -> usize {
        let (p, n) = (self.degree[dir], self.n[dir]);
        let k = if dir == 0 {
            &self.knots_u
        } else {
            &self.knots_v
        };
        (p..n).filter(|&i| k[i] < k[i + 1]).count()
    }
}

impl Surface for NurbsSurface {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        let ([p, q], [nu, nv]) = (self.degree, self.n);
        (
            [self.knots_u[p], self.knots_u[nu]],
            [self.knots_v[q], self.knots_v[nv]],
        )
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let (u, v) = self.wrap_params(u, v);
        self.eval_upto(u, v, 0).p
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        let (u, v) = self.wrap_params(u, v);
        self.eval(u, v)
    }
    /// From the power-form patches where the surface has them
    /// ([`crate::power_form`]; equal to A2.3's to rounding), else A2.3.
    fn tangents(&self, u: f64, v: f64) -> (P3, V3, V3) {
        let (u, v) = self.wrap_params(u, v);
        if let Some(d) = self.power_tangents(u, v) {
            return d;
        }
        let d = self.eval_upto(u, v, 1);
        (d.p, d.su, d.sv)
    }
    /// Newton on the closest-point problem (module documentation). Without
    /// a hint the start is the best point of an n_u × n_v grid, n = 3 ×
    /// (number of knot spans) clamped to [16, 48].
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        newton_inverse(self, p, hint, self.size, || {
            let b = ParamBox::of(self);
            let us = b.samples(0, (3 * self.span_count(0)).clamp(16, 48));
            let vs = b.samples(1, (3 * self.span_count(1)).clamp(16, 48));
            us.iter()
                .flat_map(|&u| vs.iter().map(move |&v| [u, v]))
                .collect()
        })
    }
    fn periods(&self) -> [Option<f64>; 2] {
        self.period
    }
    fn is_singular(&self, u: f64, v: f64) -> bool {
        let (u, v) = self.wrap_params(u, v);
        area_singular(&self.eval_upto(u, v, 1), self.scale)
    }
    fn is_singular_with(&self, _u: f64, _v: f64, su: &V3, sv: &V3) -> bool {
        area_singular_of(su, sv, self.scale)
    }
    /// The poles: points to which a boundary isocurve collapses (type
    /// documentation). Empty for a surface without collapsed edges.
    fn singular_points(&self) -> Vec<P3> {
        self.poles.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_matches_the_book_example() {
        // The NURBS Book Ex. 2.4: t = 5/2, p = 2, span 4.
        let u = [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 5.0, 5.0, 5.0];
        let d = basis_derivs(&u, 4, 2.5, 2, 2);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-14;
        assert!(close(d[0][0], 1.0 / 8.0) && close(d[0][1], 6.0 / 8.0));
        assert!(close(d[0][2], 1.0 / 8.0));
        assert!(close(d[1][0], -0.5) && close(d[1][1], 0.0) && close(d[1][2], 0.5));
        // N'' of the three quadratics on a uniform span: 1, −2, 1.
        assert!(close(d[2][0], 1.0) && close(d[2][1], -2.0) && close(d[2][2], 1.0));
        assert_eq!(find_span(&u, 2, 8, 2.5), 4);
        assert_eq!(find_span(&u, 2, 8, 5.0), 7);
    }

    #[test]
    fn cubic_basis_second_derivatives_against_differences() {
        let u = [0.0, 0.0, 0.0, 0.0, 0.3, 0.45, 1.0, 1.0, 1.0, 1.0];
        for &t in &[0.1, 0.37, 0.7] {
            let span = find_span(&u, 3, 6, t);
            let h = 1e-5;
            let (a, b, c) = (
                basis_derivs(&u, span, t - h, 3, 2),
                basis_derivs(&u, span, t, 3, 2),
                basis_derivs(&u, span, t + h, 3, 2),
            );
            for j in 0..4 {
                let fd1 = (c[0][j] - a[0][j]) / (2.0 * h);
                let fd2 = (c[1][j] - a[1][j]) / (2.0 * h);
                assert!((fd1 - b[1][j]).abs() < 1e-7, "N' {j} at {t}");
                assert!((fd2 - b[2][j]).abs() < 1e-5, "N'' {j} at {t}");
            }
        }
    }

    /// A quarter cone as a bilinear patch collapsed at u = 0 (the apex)
    /// reports its apex; the same patch without the collapse reports
    /// nothing; a sphere-like patch collapsed at both v-ends reports both
    /// poles, also with unclamped knots.
    #[test]
    fn collapsed_boundary_rows_are_poles() {
        let apex = P3::new(0.0, 0.0, 2.0);
        let cone = NurbsSurface::clamped_uniform(
            1,
            1,
            vec![
                vec![apex, apex],
                vec![P3::new(1.0, 0.0, 0.0), P3::new(0.0, 1.0, 0.0)],
            ],
            None,
        )
        .unwrap();
        let poles = cone.singular_points();
        assert_eq!(poles.len(), 1);
        assert!((poles[0] - apex).norm() < 1e-12);
        assert!(cone.is_singular(0.0, 0.5));
        let flat = NurbsSurface::clamped_uniform(
            1,
            1,
            vec![
                vec![P3::new(0.0, 0.0, 0.0), P3::new(0.0, 1.0, 0.0)],
                vec![P3::new(1.0, 0.0, 0.0), P3::new(1.0, 1.0, 0.0)],
            ],
            None,
        )
        .unwrap();
        assert!(flat.singular_points().is_empty());
        // a spindle: u around (4 columns, degree 1), v pole to pole
        let (s, n) = (P3::new(0.0, 0.0, -1.0), P3::new(0.0, 0.0, 1.0));
        let ring = |a: f64| P3::new(a.cos(), a.sin(), 0.0);
        let net: Vec<Vec<P3>> = (0..5).map(|k| vec![s, ring(k as f64), n]).collect();
        let clamped = NurbsSurface::clamped_uniform(1, 2, net.clone(), None).unwrap();
        assert_eq!(clamped.singular_points().len(), 2);
        // unclamped in v: the ends are no longer the boundary rows, and the
        // surface does not reach the poles: nothing is reported
        let ku = clamped.knots_u().to_vec();
        let open =
            NurbsSurface::new(1, 2, net, None, ku, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
        assert!(open.singular_points().is_empty());
    }

    /// The power-form patches (`power_form`) give A2.3's point and first
    /// partials to rounding on rational nets of degrees 1 to 11, with
    /// repeated interior knots (empty spans), uneven spans far from the
    /// origin, and at span ends; where the net is over the budget the
    /// surface has no patches and A2.3 answers.
    #[test]
    fn power_form_tangents_equal_the_book_algorithm() {
        let mut unit = crate::testing::unit(0x51ed_2701);
        let cases: [(usize, usize, Vec<f64>, Vec<f64>); 4] = [
            (
                1,
                1,
                vec![0.0, 0.0, 1.0, 2.0, 2.0],
                vec![0.0, 0.0, 3.0, 3.0],
            ),
            (
                3,
                2,
                vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.3, 0.45, 1.0, 1.0, 1.0, 1.0],
                vec![-2.0, -2.0, -2.0, 0.5, 4.0, 4.0, 4.0],
            ),
            // pipe_sweep.step's surface: rational, degrees 6 × 11, interior
            // v knots of multiplicity 9
            (
                6,
                11,
                {
                    let tau = std::f64::consts::TAU;
                    [
                        vec![-tau; 1],
                        vec![0.0; 6],
                        vec![tau; 6],
                        vec![2.0 * tau; 1],
                    ]
                    .concat()
                },
                [
                    vec![0.0; 12],
                    vec![22.36; 9],
                    vec![30.23; 9],
                    vec![45.35; 9],
                    vec![75.58; 12],
                ]
                .concat(),
            ),
            (5, 4, (0..14).map(|k| 1e3 + k as f64).collect(), {
                let mut v = vec![0.0; 5];
                v.extend([0.1, 0.2, 0.2, 0.7]);
                v.extend(vec![1.0; 5]);
                v
            }),
        ];
        for (p, q, ku, kv) in cases {
            let (nu, nv) = (ku.len() - p - 1, kv.len() - q - 1);
            let net: Vec<Vec<P3>> = (0..nu)
                .map(|i| {
                    (0..nv)
                        .map(|j| {
                            P3::new(
                                5e3 + i as f64 + unit(),
                                -7e3 + j as f64 + unit(),
                                3.0 * unit(),
                            )
                        })
                        .collect()
                })
                .collect();
            let w: Vec<Vec<f64>> = (0..nu)
                .map(|_| (0..nv).map(|_| 1.0 + 0.9 * unit()).collect())
                .collect();
            let s = NurbsSurface::new(p, q, net, Some(w), ku.clone(), kv.clone()).unwrap();
            assert!(s.power.is_some(), "degrees {p} × {q}");
            let (du, dv) = s.domain();
            // every span end, and random points
            let mut uvs: Vec<[f64; 2]> = Vec::new();
            for &u in ku.iter().filter(|&&u| u >= du[0] && u <= du[1]) {
                for &v in kv.iter().filter(|&&v| v >= dv[0] && v <= dv[1]) {
                    uvs.push([u, v]);
                }
            }
            for _ in 0..200 {
                uvs.push([
                    du[0] + (du[1] - du[0]) * (unit() + 0.5),
                    dv[0] + (dv[1] - dv[0]) * (unit() + 0.5),
                ]);
            }
            for [u, v] in uvs {
                let (pt, su, sv) = s.power_tangents(u, v).expect("a non-empty span");
                let d = s.eval_upto(u, v, 1);
                // points to 1e-9 of the net's size, partials to 1e-8
                // relative (degree 11 loses about 1e-10 and 3e-9 to the
                // monomial form's cancellation; degree 5 and less 1e-12)
                assert!((pt - d.p).norm() <= 1e-9 * s.size(), "{p}×{q} at {u},{v}");
                let tol = |x: &V3| 1e-8 * x.norm().max(1e-300);
                assert!((su - d.su).norm() <= tol(&d.su), "{p}×{q} S_u at {u},{v}");
                assert!((sv - d.sv).norm() <= tol(&d.sv), "{p}×{q} S_v at {u},{v}");
                if p <= 5 {
                    assert!((pt - d.p).norm() <= 1e-15 * d.p.coords.norm() + 1e-12 * s.size());
                    assert!((su - d.su).norm() <= 1e-10 * d.su.norm());
                }
                assert_eq!(s.tangents(u, v).0, pt);
            }
        }
        // over the budget: a bicubic net of 600 × 600 points
        let k = clamped_uniform_knots(3, 600);
        let net = vec![vec![P3::origin(); 600]; 600];
        let big = NurbsSurface::new(3, 3, net, None, k.clone(), k).unwrap();
        assert!(big.power.is_none());
        let d = big.eval_upto(0.3, 0.6, 1);
        assert_eq!(big.tangents(0.3, 0.6), (d.p, d.su, d.sv));
    }
}
