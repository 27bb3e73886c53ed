//! In/out classification of parameter points against a face's discrete
//! boundary (the polygon through its edge bubbles, in (u,v)).
//!
//! The engine classifies against the *discrete* boundary because that is the
//! boundary the triangulation will have: a face bubble must lie strictly
//! inside the polygon joining the boundary bubbles or the constrained
//! triangulation could not contain it.
//!
//! Queries use the even–odd rule with a horizontal ray; segments are bucketed
//! into horizontal bands so a query touches only the segments of one band
//! (O(1) on typical faces instead of O(boundary)).
//! Written by hand: no maintained crate offers an indexed point-in-polygon
//! test over many loops.

pub struct Region {
    segs: Vec<[[f64; 2]; 2]>,
    v0: f64,
    inv_band: f64,
    bands: Vec<Vec<u32>>,
    lo: [f64; 2],
    hi: [f64; 2],
}

impl Region {
    /// `loops`: closed polygons in (u,v) (the last point joins the first).
    pub fn new(loops: &[Vec<[f64; 2]>]) -> Region {
        let mut segs = Vec::new();
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for l in loops {
            for k in 0..l.len() {
                let a = l[k];
                let b = l[(k + 1) % l.len()];
                for c in 0..2 {
                    lo[c] = lo[c].min(a[c]);
                    hi[c] = hi[c].max(a[c]);
                }
                if a[1] != b[1] {
                    segs.push([a, b]);
                }
            }
        }
        let nb = segs.len().clamp(1, 1 << 16);
        let height = (hi[1] - lo[1]).max(f64::MIN_POSITIVE);
        let inv_band = nb as f64 / height;
        let mut bands = vec![Vec::new(); nb];
        for (i, s) in segs.iter().enumerate() {
            let (a, b) = (s[0][1].min(s[1][1]), s[0][1].max(s[1][1]));
            let ia = (((a - lo[1]) * inv_band) as usize).min(nb - 1);
            let ib = (((b - lo[1]) * inv_band) as usize).min(nb - 1);
            for band in &mut bands[ia..=ib] {
                band.push(i as u32);
            }
        }
        Region {
            segs,
            v0: lo[1],
            inv_band,
            bands,
            lo,
            hi,
        }
    }

    /// Whether (u,v) is inside (even–odd rule over all loops).
    pub fn contains(&self, u: f64, v: f64) -> bool {
        if !(u >= self.lo[0] && u <= self.hi[0] && v >= self.lo[1] && v <= self.hi[1]) {
            return false;
        }
        let band = (((v - self.v0) * self.inv_band) as usize).min(self.bands.len() - 1);
        let mut inside = false;
        for &i in &self.bands[band] {
            let [a, b] = self.segs[i as usize];
            // half-open rule: a segment counts when v is in [min, max)
            if (a[1] <= v) != (b[1] <= v) {
                let t = (v - a[1]) / (b[1] - a[1]);
                let x = a[0] + t * (b[0] - a[0]);
                if x > u {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// The (u,v) bounding box of the boundary.
    pub fn bbox(&self) -> ([f64; 2], [f64; 2]) {
        (self.lo, self.hi)
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
}
