//! NURBS knot spans in power (monomial) form, for the point and first
//! derivatives that stage 2 asks once per bubble and step: a surface's
//! patches ([`PowerPatches`]) and a curve's segments ([`PowerSegments`],
//! for the profiles of extrusions and surfaces of revolution).
//!
//! On one knot span [u_k, u_k+1) the p + 1 basis functions that do not
//! vanish are polynomials of degree p in the local parameter
//! s = (u − u_k)/(u_k+1 − u_k) ∈ [0, 1]. Their coefficients come from the
//! Cox–de Boor recursion (The NURBS Book A2.2) carried out on polynomials
//! instead of numbers: each step multiplies by the linear polynomials
//! (u − u_i) and (u_i+k+1 − u) and divides by knot differences. Contracting
//! them with the homogeneous control net (w·P, w) gives, per pair of spans,
//! a (p + 1) × (q + 1) table of coefficients of s^a t^b, evaluated with
//! nested Horner schemes: O(p·q) multiply-adds for the point and both
//! partials, where A2.3's basis functions and derivatives cost O(p² + q²)
//! divisions and products before the same O(p·q) sum.
//!
//! Why by hand: no maintained crate evaluates rational tensor-product
//! patches with their partials (truck's `BSplineSurface` runs the
//! de Boor recursion per call). Measured on fixtures/step/pipe_sweep.step
//! (rational, degrees 6 × 11): A2.3's basis functions were 45 % of the
//! surface mesh's time.
//!
//! Accuracy: the coefficients are taken relative to the patch's first
//! control point, so rounding scales with the patch, not with its distance
//! from the origin. In monomial form a degree-n basis function's
//! coefficients grow like C(n, n/2)·2^(n/2) with alternating signs: for
//! degree 5 and less the point and partials equal A2.3's to about 1e-12
//! relative; for degree 11 (pipe_sweep's) points to about 1e-10 of the
//! net's size and partials to about 3e-9 relative (tests in
//! `surfaces/nurbs.rs` and `curves/nurbs.rs`),
//! far below anything meshing resolves. Consecutive spans meet to that
//! precision, not bit for bit. Second partials (curvature) stay with A2.3.

use crate::curves::MAXP;

/// Coefficient budget (f64 values) up to which a surface or curve keeps
/// its power form; larger nets evaluate with A2.3 only. 2²⁰ values are 8 MB: a
/// bicubic net of about 250 × 250 control points.
pub(crate) const MAX_COEFFICIENTS: usize = 1 << 20;

/// The power-form patches of a NURBS surface (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PowerPatches {
    degree: [usize; 2],
    /// Per span index k of a direction (p ≤ k < n), its slot among the
    /// non-empty spans, `usize::MAX` for an empty one.
    slot_u: Vec<usize>,
    slot_v: Vec<usize>,
    /// Per slot, 1 / (u_k+1 − u_k).
    inv_h_u: Vec<f64>,
    inv_h_v: Vec<f64>,
    /// Per (slot u, slot v), (p + 1)(q + 1) coefficients [x, y, z, w] of
    /// s^a t^b at index a·(q + 1) + b, of the net taken relative to the
    /// patch's `origin`.
    coef: Vec<[f64; 4]>,
    /// Per (slot u, slot v), the patch's first control point: the
    /// coefficients sum w·(P − origin), so that their rounding scales with
    /// the patch's extent, not with its distance from the model's origin.
    origin: Vec<[f64; 3]>,
    n_slots_v: usize,
}

/// The homogeneous point (w·P, w) as (w·(P − O), w).
fn relative(hw: &[f64; 4], o: &[f64; 3]) -> [f64; 4] {
    [
        hw[0] - hw[3] * o[0],
        hw[1] - hw[3] * o[1],
        hw[2] - hw[3] * o[2],
        hw[3],
    ]
}

/// The coefficients of s^m (m ≤ p) of the p + 1 basis functions
/// N_{k−p+j,p} on span k of `knots`, s = (u − u_k)/(u_k+1 − u_k): A2.2 on
/// polynomials. `out[j][m]`.
fn span_polynomials(knots: &[f64], k: usize, p: usize) -> [[f64; MAXP]; MAXP] {
    let a = knots[k];
    let h = knots[k + 1] - a;
    let mut n = [[0.0f64; MAXP]; MAXP];
    n[0][0] = 1.0;
    // left[j] = u − u_{k+1−j} = (a − u_{k+1−j}) + h·s, right[j] = u_{k+j} − u
    let mut left = [[0.0f64; 2]; MAXP];
    let mut right = [[0.0f64; 2]; MAXP];
    // multiply polynomial `poly` (degree < deg) by the linear `lin`
    let times = |poly: &[f64; MAXP], lin: &[f64; 2], deg: usize| {
        let mut out = [0.0f64; MAXP];
        for m in 0..deg {
            out[m] += poly[m] * lin[0];
            out[m + 1] += poly[m] * lin[1];
        }
        out
    };
    for j in 1..=p {
        left[j] = [a - knots[k + 1 - j], h];
        right[j] = [knots[k + j] - a, -h];
        let mut saved = [0.0f64; MAXP];
        for r in 0..j {
            // right[r+1] + left[j−r] = u_{k+r+1} − u_{k+1−j+r}, a constant
            let den = knots[k + r + 1] - knots[k + 1 - j + r];
            let mut temp = n[r];
            for c in temp.iter_mut().take(j) {
                *c /= den;
            }
            let t = times(&temp, &right[r + 1], j);
            for m in 0..=j {
                n[r][m] = saved[m] + t[m];
            }
            saved = times(&temp, &left[j - r], j);
        }
        n[j] = saved;
    }
    n
}

impl PowerPatches {
    /// The patches of a surface of degrees `degree`, net size `n`, knot
    /// vectors `knots_u`, `knots_v` and homogeneous net `hw` (row-major,
    /// i·nv + j), or `None` above [`MAX_COEFFICIENTS`].
    #[allow(clippy::needless_range_loop)] // i indexes the net's rows and the u polynomials
    pub(crate) fn new(
        degree: [usize; 2],
        n: [usize; 2],
        knots_u: &[f64],
        knots_v: &[f64],
        hw: &[[f64; 4]],
    ) -> Option<PowerPatches> {
        let [p, q] = degree;
        let [nu, nv] = n;
        let slots = |knots: &[f64], deg: usize, cnt: usize| {
            let mut slot = vec![usize::MAX; cnt];
            let mut inv_h = Vec::new();
            for (k, s) in slot.iter_mut().enumerate().take(cnt).skip(deg) {
                if knots[k + 1] > knots[k] {
                    *s = inv_h.len();
                    inv_h.push(1.0 / (knots[k + 1] - knots[k]));
                }
            }
            (slot, inv_h)
        };
        let (slot_u, inv_h_u) = slots(knots_u, p, nu);
        let (slot_v, inv_h_v) = slots(knots_v, q, nv);
        let per = (p + 1) * (q + 1);
        if inv_h_u.len() * inv_h_v.len() * per * 4 > MAX_COEFFICIENTS {
            return None;
        }
        let mut coef = vec![[0.0f64; 4]; inv_h_u.len() * inv_h_v.len() * per];
        let mut origin = vec![[0.0f64; 3]; inv_h_u.len() * inv_h_v.len()];
        let polys_v: Vec<(usize, [[f64; MAXP]; MAXP])> = (q..nv)
            .filter(|&k| slot_v[k] != usize::MAX)
            .map(|k| (k, span_polynomials(knots_v, k, q)))
            .collect();
        for ku in (p..nu).filter(|&k| slot_u[k] != usize::MAX) {
            let pu = span_polynomials(knots_u, ku, p);
            for (kv, pv) in &polys_v {
                let patch = slot_u[ku] * inv_h_v.len() + slot_v[*kv];
                let first = hw[(ku - p) * nv + kv - q];
                let o = [0, 1, 2].map(|m| first[m] / first[3]);
                origin[patch] = o;
                let out = &mut coef[patch * per..(patch + 1) * per];
                for i in 0..=p {
                    // row i of the net's sub-block, contracted along v
                    let row = (ku - p + i) * nv + kv - q;
                    let mut t = [[0.0f64; 4]; MAXP];
                    for j in 0..=q {
                        let h = relative(&hw[row + j], &o);
                        for (b, tb) in t.iter_mut().enumerate().take(q + 1) {
                            let c = pv[j][b];
                            for m in 0..4 {
                                tb[m] += c * h[m];
                            }
                        }
                    }
                    for a in 0..=p {
                        let c = pu[i][a];
                        for b in 0..=q {
                            for m in 0..4 {
                                out[a * (q + 1) + b][m] += c * t[b][m];
                            }
                        }
                    }
                }
            }
        }
        Some(PowerPatches {
            degree,
            slot_u,
            slot_v,
            inv_h_u,
            inv_h_v,
            coef,
            origin,
            n_slots_v: polys_v.len(),
        })
    }

    /// The patch's origin O and the homogeneous point A = Σ N M (w(P − O), w)
    /// with its partials A_u, A_v at (u, v) on spans (`ku`, `kv`) whose left
    /// knots are `u0`, `v0`; `None` where a span is empty (the caller then
    /// uses A2.3).
    pub(crate) fn eval(
        &self,
        (ku, u0, u): (usize, f64, f64),
        (kv, v0, v): (usize, f64, f64),
    ) -> Option<([f64; 3], [[f64; 4]; 3])> {
        let [p, q] = self.degree;
        let (su, sv) = (*self.slot_u.get(ku)?, *self.slot_v.get(kv)?);
        if su == usize::MAX || sv == usize::MAX {
            return None;
        }
        let (hu, hv) = (self.inv_h_u[su], self.inv_h_v[sv]);
        let (s, t) = ((u - u0) * hu, (v - v0) * hv);
        let per = (p + 1) * (q + 1);
        let patch = su * self.n_slots_v + sv;
        let c = &self.coef[patch * per..(patch + 1) * per];
        // Horner over s of the rows' values and t-derivatives, each row
        // by Horner over t
        let (mut a, mut a_s, mut a_t) = ([0.0f64; 4], [0.0f64; 4], [0.0f64; 4]);
        for i in (0..=p).rev() {
            let row = &c[i * (q + 1)..(i + 1) * (q + 1)];
            let (mut r, mut r_t) = ([0.0f64; 4], [0.0f64; 4]);
            for cb in row.iter().rev() {
                for m in 0..4 {
                    r_t[m] = r_t[m] * t + r[m];
                    r[m] = r[m] * t + cb[m];
                }
            }
            for m in 0..4 {
                a_s[m] = a_s[m] * s + a[m];
                a[m] = a[m] * s + r[m];
                a_t[m] = a_t[m] * s + r_t[m];
            }
        }
        for m in 0..4 {
            a_s[m] *= hu;
            a_t[m] *= hv;
        }
        Some((self.origin[patch], [a, a_s, a_t]))
    }
}

/// The power-form segments of a NURBS curve (see the module docs): per
/// non-empty knot span, p + 1 coefficients [x, y, z, w] of s^a of the
/// homogeneous curve relative to the segment's first control point.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PowerSegments {
    degree: usize,
    /// Per span index k (p ≤ k < n), its slot, `usize::MAX` when empty.
    slot: Vec<usize>,
    inv_h: Vec<f64>,
    coef: Vec<[f64; 4]>,
    origin: Vec<[f64; 3]>,
}

impl PowerSegments {
    /// The segments of a curve of degree `p` with knots `knots` and
    /// homogeneous points `hw` (w·P, w), or `None` above
    /// [`MAX_COEFFICIENTS`].
    pub(crate) fn new(p: usize, knots: &[f64], hw: &[[f64; 4]]) -> Option<PowerSegments> {
        let n = hw.len();
        let mut slot = vec![usize::MAX; n];
        let mut inv_h = Vec::new();
        let mut coef = Vec::new();
        let mut origin = Vec::new();
        for k in p..n {
            if knots[k + 1] <= knots[k] {
                continue;
            }
            if (coef.len() + p + 1) * 4 > MAX_COEFFICIENTS {
                return None;
            }
            slot[k] = inv_h.len();
            inv_h.push(1.0 / (knots[k + 1] - knots[k]));
            let polys = span_polynomials(knots, k, p);
            let first = hw[k - p];
            let o = [0, 1, 2].map(|m| first[m] / first[3]);
            origin.push(o);
            let mut c = vec![[0.0f64; 4]; p + 1];
            for (i, poly) in polys.iter().enumerate().take(p + 1) {
                let h = relative(&hw[k - p + i], &o);
                for (ca, &pa) in c.iter_mut().zip(poly.iter()) {
                    for m in 0..4 {
                        ca[m] += pa * h[m];
                    }
                }
            }
            coef.extend(c);
        }
        Some(PowerSegments {
            degree: p,
            slot,
            inv_h,
            coef,
            origin,
        })
    }

    /// The segment's origin O and the homogeneous A = Σ N (w(P − O), w) and
    /// A' at t on span `k` whose left knot is `t0`; `None` for an empty
    /// span.
    pub(crate) fn eval(&self, k: usize, t0: f64, t: f64) -> Option<([f64; 3], [[f64; 4]; 2])> {
        let sl = *self.slot.get(k)?;
        if sl == usize::MAX {
            return None;
        }
        let p = self.degree;
        let h = self.inv_h[sl];
        let s = (t - t0) * h;
        let c = &self.coef[sl * (p + 1)..(sl + 1) * (p + 1)];
        let (mut a, mut a_s) = ([0.0f64; 4], [0.0f64; 4]);
        for ca in c.iter().rev() {
            for m in 0..4 {
                a_s[m] = a_s[m] * s + a[m];
                a[m] = a[m] * s + ca[m];
            }
        }
        for x in a_s.iter_mut() {
            *x *= h;
        }
        Some((self.origin[sl], [a, a_s]))
    }
}
