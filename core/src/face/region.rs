//! In/out classification of parameter points against a face's discrete
//! boundary (the polygon through its edge bubbles, in (u,v)).
//!
//! The engine classifies against the *discrete* boundary because that is the
//! boundary the triangulation will have: a face bubble must lie strictly
//! inside the polygon joining the boundary bubbles or the constrained
//! triangulation could not contain it.
//!
//! Queries use the even–odd rule with a ray along one parameter axis;
//! segments are bucketed into bands across that axis so a query touches only
//! the segments of one band (O(1) on typical faces instead of O(boundary)).
//!
//! On a surface periodic in u (a cylinder, a sphere) loops may run across
//! the seam and close only through the period (a circle around a
//! cylinder): segments are unwrapped, copied one period left and right, and
//! the ray runs along v, which crosses a loop around the surface once. A
//! face with no loops is the whole parameter domain (a sphere, a torus).
//! Written by hand: no maintained crate offers an indexed point-in-polygon
//! test over many loops, let alone a periodic one.

pub struct Region {
    /// Segments as (along, across) pairs: `along` is the ray's axis.
    segs: Vec<[[f64; 2]; 2]>,
    /// 0: the ray runs along +u (bands in v); 1: along +v (bands in u).
    axis: usize,
    band0: f64,
    inv_band: f64,
    bands: Vec<Vec<u32>>,
    /// Parameter bounds a point must be within (non-periodic directions).
    lo: [f64; 2],
    hi: [f64; 2],
    periods: [Option<f64>; 2],
    /// Start of the fundamental domain in each direction.
    origin: [f64; 2],
}

impl Region {
    /// `loops`: closed polygons in (u,v) (the last point joins the first),
    /// on a non-periodic parametrization.
    pub fn new(loops: &[Vec<[f64; 2]>]) -> Region {
        Region::build(
            loops,
            [None, None],
            ([f64::NEG_INFINITY; 2], [f64::INFINITY; 2]),
        )
    }

    /// Loops on a surface with the given periods and parameter domain
    /// `(lo, hi)`. With no loops the region is the whole domain. Loops on a
    /// surface periodic in both directions are not supported (the caller
    /// reports it).
    pub fn periodic(
        loops: &[Vec<[f64; 2]>],
        periods: [Option<f64>; 2],
        domain: ([f64; 2], [f64; 2]),
    ) -> Region {
        Region::build(loops, periods, domain)
    }

    fn build(
        loops: &[Vec<[f64; 2]>],
        periods: [Option<f64>; 2],
        domain: ([f64; 2], [f64; 2]),
    ) -> Region {
        // ray along u unless u is periodic (then along v)
        let axis = if periods[0].is_some() { 1 } else { 0 };
        let across = 1 - axis;
        let origin = [domain.0[0], domain.0[1]];
        let wrap = |x: f64, k: usize| crate::geom::wrap_coordinate(x, periods[k], origin[k]);
        let mut segs = Vec::new();
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for l in loops {
            for k in 0..l.len() {
                let mut a = l[k];
                let mut b = l[(k + 1) % l.len()];
                // unwrap: b nearest to a across periodic directions
                for c in 0..2 {
                    if let Some(p) = periods[c] {
                        let delta = b[c] - a[c];
                        a[c] = wrap(a[c], c);
                        b[c] = a[c] + crate::geom::nearest_turn(delta, p);
                    }
                }
                for c in 0..2 {
                    lo[c] = lo[c].min(a[c].min(b[c]));
                    hi[c] = hi[c].max(a[c].max(b[c]));
                }
                if a[across] == b[across] {
                    continue;
                }
                let shifts: Vec<f64> = match periods[across] {
                    Some(p) => vec![-p, 0.0, p],
                    None => vec![0.0],
                };
                for s in shifts {
                    let mut a2 = a;
                    let mut b2 = b;
                    a2[across] += s;
                    b2[across] += s;
                    segs.push([[a2[axis], a2[across]], [b2[axis], b2[across]]]);
                }
            }
        }
        // bounds: the loops' box on a plane, the domain where periodic or
        // where there are no loops
        // on a periodic surface a face may reach a singular edge of the
        // domain that is no loop (a cone down to its apex)
        if periods.iter().any(|p| p.is_some()) || loops.is_empty() {
            lo = domain.0;
            hi = domain.1;
        }
        let nb = segs.len().clamp(1, 1 << 16);
        let (b0, b1) = if segs.is_empty() {
            (0.0, 1.0)
        } else {
            let mut b0 = f64::INFINITY;
            let mut b1 = f64::NEG_INFINITY;
            for s in &segs {
                b0 = b0.min(s[0][1].min(s[1][1]));
                b1 = b1.max(s[0][1].max(s[1][1]));
            }
            (b0, b1)
        };
        let inv_band = nb as f64 / (b1 - b0).max(f64::MIN_POSITIVE);
        let mut bands = vec![Vec::new(); nb];
        for (i, s) in segs.iter().enumerate() {
            let (a, b) = (s[0][1].min(s[1][1]), s[0][1].max(s[1][1]));
            let ia = (((a - b0) * inv_band).max(0.0) as usize).min(nb - 1);
            let ib = (((b - b0) * inv_band).max(0.0) as usize).min(nb - 1);
            for band in &mut bands[ia..=ib] {
                band.push(i as u32);
            }
        }
        Region {
            segs,
            axis,
            band0: b0,
            inv_band,
            bands,
            lo,
            hi,
            periods,
            origin,
        }
    }

    /// `(u,v)` moved into the fundamental domain of the periodic directions.
    pub fn wrap(&self, uv: [f64; 2]) -> [f64; 2] {
        crate::geom::wrap_periodic(uv, self.periods, self.origin)
    }

    /// Whether (u,v) is inside (even–odd rule over all loops).
    pub fn contains(&self, u: f64, v: f64) -> bool {
        let uv = self.wrap([u, v]);
        for (c, period) in self.periods.iter().enumerate() {
            if period.is_none() && !(uv[c] >= self.lo[c] && uv[c] <= self.hi[c]) {
                return false;
            }
        }
        if self.segs.is_empty() {
            return true;
        }
        let (along, across) = (uv[self.axis], uv[1 - self.axis]);
        let band =
            ((((across - self.band0) * self.inv_band).max(0.0)) as usize).min(self.bands.len() - 1);
        let mut inside = false;
        for &i in &self.bands[band] {
            let [a, b] = self.segs[i as usize];
            // half-open rule: a segment counts when `across` is in [min, max)
            if (a[1] <= across) != (b[1] <= across) {
                let t = (across - a[1]) / (b[1] - a[1]);
                let x = a[0] + t * (b[0] - a[0]);
                if x > along {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// The (u,v) bounding box of the region (the fundamental domain in
    /// periodic directions).
    pub fn bbox(&self) -> ([f64; 2], [f64; 2]) {
        let mut lo = self.lo;
        let mut hi = self.hi;
        for c in 0..2 {
            if let Some(p) = self.periods[c] {
                lo[c] = self.origin[c];
                hi[c] = self.origin[c] + p;
            }
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_with_hole() {
        let outer = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
        let hole: Vec<[f64; 2]> = (0..32)
            .map(|k| {
                let a = k as f64 / 32.0 * std::f64::consts::TAU;
                [0.5 + 0.2 * a.cos(), 0.5 + 0.2 * a.sin()]
            })
            .collect();
        let r = Region::new(&[outer, hole]);
        assert!(r.contains(1.5, 0.5));
        assert!(!r.contains(0.5, 0.5));
        assert!(!r.contains(2.5, 0.5));
        assert!(!r.contains(1.0, -0.1));
        assert!(r.contains(0.05, 0.95));
    }

    /// A cylinder strip between two circles: each circle is a loop that
    /// closes only through the period.
    #[test]
    fn cylinder_strip_between_two_circles() {
        let tau = std::f64::consts::TAU;
        let circle = |v: f64, n: usize| -> Vec<[f64; 2]> {
            (0..n).map(|k| [k as f64 / n as f64 * tau, v]).collect()
        };
        let r = Region::periodic(
            &[circle(0.0, 12), circle(2.0, 12)],
            [Some(tau), None],
            ([0.0, -10.0], [tau, 10.0]),
        );
        for u in [0.0, 0.1, 3.0, 6.2, -0.3, 7.0] {
            assert!(r.contains(u, 1.0), "u = {u}");
            assert!(!r.contains(u, 2.5));
            assert!(!r.contains(u, -0.5));
        }
    }

    /// A hole that straddles the seam of a cylinder.
    #[test]
    fn hole_across_the_seam() {
        let tau = std::f64::consts::TAU;
        let circle =
            |v: f64| -> Vec<[f64; 2]> { (0..16).map(|k| [k as f64 / 16.0 * tau, v]).collect() };
        let hole: Vec<[f64; 2]> = (0..16)
            .map(|k| {
                let a = -(k as f64) / 16.0 * tau;
                [(0.3 * a.cos()).rem_euclid(tau), 1.0 + 0.3 * a.sin()]
            })
            .collect();
        let r = Region::periodic(
            &[circle(0.0), circle(2.0), hole],
            [Some(tau), None],
            ([0.0, -10.0], [tau, 10.0]),
        );
        assert!(!r.contains(0.0, 1.0));
        assert!(!r.contains(tau - 0.1, 1.0));
        assert!(!r.contains(0.1, 1.0));
        assert!(r.contains(3.0, 1.0));
        assert!(r.contains(0.0, 1.5));
    }

    #[test]
    fn closed_surface_is_everything_in_its_domain() {
        let tau = std::f64::consts::TAU;
        let h = std::f64::consts::FRAC_PI_2;
        let r = Region::periodic(&[], [Some(tau), None], ([0.0, -h], [tau, h]));
        assert!(r.contains(-1.0, 0.3));
        assert!(r.contains(10.0, h));
        assert!(!r.contains(1.0, h + 0.01));
    }
}
