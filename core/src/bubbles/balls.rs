//! Overlap queries among balls of very different sizes: "is some bubble j
//! closer to p than c·(d + d_j)/2?" where the spacings d_j of the set span
//! orders of magnitude (a face refined to d/64 in a place beside bubbles
//! of the requested spacing).
//!
//! Why not the neighbour grid ([`super::grid::Grid`]): its cells follow
//! the smallest spacing and a query must reach the largest, so one query
//! walks (d_max/d_min)³ cells, most of them empty; on `as_0082` at diag/15
//! the seed filter of the refined faces took 45 % of a run of minutes. An
//! R*-tree (`rstar`) over each ball's bounding box answers the same query
//! in O(log n + hits) whatever the spread.
//!
//! Invariant: [`Balls::any`] calls its test for every ball whose box meets
//! the query's box (every ball within reach, and possibly some beyond:
//! callers test the true distance), and stops at the first `true`.

use crate::geom::P3;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{RTree, AABB};

type Entry = GeomWithData<Rectangle<[f64; 3]>, u32>;

/// Balls (centre, radius) in an R*-tree of their bounding boxes.
pub(crate) struct Balls {
    tree: RTree<Entry>,
}

/// The box of the ball (p, r); a radius that is not a finite non-negative
/// number gives the point alone (its distance test decides).
fn cube(p: &P3, r: f64) -> AABB<[f64; 3]> {
    let r = if r.is_finite() && r > 0.0 { r } else { 0.0 };
    AABB::from_corners([p.x - r, p.y - r, p.z - r], [p.x + r, p.y + r, p.z + r])
}

impl Balls {
    /// The balls (`centres[j]`, `radius(j)`).
    pub(crate) fn new(centres: &[P3], radius: impl Fn(usize) -> f64) -> Self {
        let entries: Vec<Entry> = centres
            .iter()
            .enumerate()
            .map(|(j, p)| {
                let b = cube(p, radius(j));
                GeomWithData::new(Rectangle::from_corners(b.lower(), b.upper()), j as u32)
            })
            .collect();
        Balls {
            tree: RTree::bulk_load(entries),
        }
    }

    /// Whether `test(j)` holds for some ball j that may meet the ball
    /// (p, r): every ball whose box meets that ball's box is tried, in an
    /// order that depends only on the set, until one passes.
    pub(crate) fn any(&self, p: &P3, r: f64, mut test: impl FnMut(usize) -> bool) -> bool {
        self.tree
            .locate_in_envelope_intersecting(&cube(p, r))
            .any(|e| test(e.data as usize))
    }

    /// Calls `f(j)` for every ball j whose box meets the box of the ball
    /// (p, r).
    pub(crate) fn each(&self, p: &P3, r: f64, mut f: impl FnMut(usize)) {
        for e in self.tree.locate_in_envelope_intersecting(&cube(p, r)) {
            f(e.data as usize);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Balls from d/64 to d: every overlapping pair is found (against a
    /// brute-force scan), and nothing is reported for a query far away.
    #[test]
    fn finds_every_overlap_across_a_wide_spread_of_sizes() {
        let mut pos = Vec::new();
        let mut rad = Vec::new();
        let mut rnd = crate::bubbles::testing::uniform(12345);
        for _ in 0..2000 {
            pos.push(P3::new(10.0 * rnd(), 10.0 * rnd(), 0.01 * rnd()));
            rad.push(0.5 * 2f64.powf(-6.0 * rnd()));
        }
        let balls = Balls::new(&pos, |j| rad[j]);
        for q in 0..200 {
            let (p, r) = (pos[q * 7], rad[q * 7]);
            let mut found = Vec::new();
            balls.each(&p, r, |j| {
                if (pos[j] - p).norm() < r + rad[j] {
                    found.push(j);
                }
            });
            found.sort_unstable();
            let brute: Vec<usize> = (0..pos.len())
                .filter(|&j| (pos[j] - p).norm() < r + rad[j])
                .collect();
            assert_eq!(found, brute);
        }
        assert!(!balls.any(&P3::new(100.0, 0.0, 0.0), 1.0, |_| true));
        assert!(balls.any(&pos[0], 0.0, |j| j == 0));
    }
}
