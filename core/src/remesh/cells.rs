//! A hash grid of points: which points lie within a distance of a point.

// Fx hashing (rustc-hash): cell keys of one run's points, and a query
// looks up 27 cells
use rustc_hash::FxHashMap as HashMap;

use crate::geom::P3;

/// A hash grid of points for searches within one cell size.
pub(crate) struct Cells {
    h: f64,
    map: HashMap<(i64, i64, i64), Vec<usize>>,
}

impl Cells {
    fn key(&self, p: &P3) -> (i64, i64, i64) {
        let f = |x: f64| (x / self.h).floor().clamp(-1e15, 1e15) as i64;
        (f(p.x), f(p.y), f(p.z))
    }

    pub(crate) fn new(pts: &[P3], h: f64) -> Cells {
        let mut c = Cells {
            h,
            map: HashMap::default(),
        };
        for (i, p) in pts.iter().enumerate() {
            let k = c.key(p);
            c.map.entry(k).or_default().push(i);
        }
        c
    }

    /// Whether some point of `pts` is within `r` (≤ h) of `p`.
    pub(crate) fn near(&self, pts: &[P3], p: &P3, r: f64) -> bool {
        let (a, b, c) = self.key(p);
        for i in a - 1..=a + 1 {
            for j in b - 1..=b + 1 {
                for k in c - 1..=c + 1 {
                    if let Some(v) = self.map.get(&(i, j, k)) {
                        if v.iter().any(|&q| (pts[q] - p).norm() <= r) {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}
