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
//! Where the radii spread over at most 16, a cell grid answers the same
//! queries faster (as it did before the tree), so the tree is only built
//! beyond that.
//!
//! Invariant: [`Balls::any`] calls its test for every ball whose box meets
//! the query's box (every ball within reach, and possibly some beyond:
//! callers test the true distance), and stops at the first `true`.

use crate::geom::P3;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{RTree, AABB};

type Entry = GeomWithData<Rectangle<[f64; 3]>, u32>;

/// Balls (centre, radius): in a cell grid where the radii spread over at
/// most [`MAX_SPREAD`](super::grid::MAX_SPREAD) (the usual case, where a
/// grid is faster), else in an R*-tree of their bounding boxes.
pub(crate) struct Balls {
    kind: Kind,
}

enum Kind {
    /// The centres in cells of four times the least radius; a query
    /// reaches its radius plus the largest (the callers' distance tests
    /// decide, so no box test is made here).
    Cells {
        grid: super::grid::Grid,
        rmax: f64,
    },
    Tree(RTree<Entry>),
}

/// The box of the ball (p, r); a radius that is not a finite non-negative
/// number gives the point alone (its distance test decides).
fn cube(p: &P3, r: f64) -> AABB<[f64; 3]> {
    let r = clean(r);
    AABB::from_corners([p.x - r, p.y - r, p.z - r], [p.x + r, p.y + r, p.z + r])
}

/// `r` if it is a finite non-negative number, else 0.
fn clean(r: f64) -> f64 {
    if r.is_finite() && r > 0.0 {
        r
    } else {
        0.0
    }
}

impl Balls {
    /// The balls (`centres[j]`, `radius(j)`).
    pub(crate) fn new(centres: &[P3], radius: impl Fn(usize) -> f64) -> Self {
        let radii: Vec<f64> = (0..centres.len()).map(|j| clean(radius(j))).collect();
        let rmin = radii.iter().cloned().fold(f64::INFINITY, f64::min);
        let rmax = radii.iter().cloned().fold(0.0f64, f64::max);
        if rmin > 0.0 && rmax <= super::grid::MAX_SPREAD * rmin {
            return Balls {
                kind: Kind::Cells {
                    grid: super::grid::Grid::new(centres, 4.0 * rmin),
                    rmax,
                },
            };
        }
        let entries: Vec<Entry> = centres
            .iter()
            .zip(&radii)
            .enumerate()
            .map(|(j, (p, &r))| {
                let b = cube(p, r);
                GeomWithData::new(Rectangle::from_corners(b.lower(), b.upper()), j as u32)
            })
            .collect();
        Balls {
            kind: Kind::Tree(RTree::bulk_load(entries)),
        }
    }

    /// Calls `f(j)` for every ball j whose box meets the box of the ball
    /// (p, r), and possibly for others, until `f` returns `true`; returns
    /// whether one did. The order depends only on the set.
    fn visit(&self, p: &P3, r: f64, mut f: impl FnMut(usize) -> bool) -> bool {
        match &self.kind {
            Kind::Cells { grid, rmax } => {
                let mut hit = false;
                grid.query(p, clean(r) + rmax, |j| {
                    if !hit {
                        hit = f(j as usize);
                    }
                });
                hit
            }
            Kind::Tree(t) => t
                .locate_in_envelope_intersecting(&cube(p, r))
                .any(|e| f(e.data as usize)),
        }
    }

    /// Whether `test(j)` holds for some ball j that may meet the ball
    /// (p, r): every ball whose box meets that ball's box is tried, in an
    /// order that depends only on the set, until one passes.
    pub(crate) fn any(&self, p: &P3, r: f64, test: impl FnMut(usize) -> bool) -> bool {
        self.visit(p, r, test)
    }

    /// Calls `f(j)` for every ball j whose box meets the box of the ball
    /// (p, r).
    pub(crate) fn each(&self, p: &P3, r: f64, mut f: impl FnMut(usize)) {
        self.visit(p, r, |j| {
            f(j);
            false
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Balls from d/64 to d (the tree) and from d/4 to d (the cells):
    /// every overlapping pair is found (against a brute-force scan), and
    /// nothing is reported for a query far away.
    #[test]
    fn finds_every_overlap_across_a_wide_spread_of_sizes() {
        for (octaves, tree) in [(6.0, true), (2.0, false)] {
            let mut pos = Vec::new();
            let mut rad = Vec::new();
            let mut rnd = crate::bubbles::testing::uniform(12345);
            for _ in 0..2000 {
                pos.push(P3::new(10.0 * rnd(), 10.0 * rnd(), 0.01 * rnd()));
                rad.push(0.5 * 2f64.powf(-octaves * rnd()));
            }
            let balls = Balls::new(&pos, |j| rad[j]);
            assert_eq!(matches!(balls.kind, Kind::Tree(_)), tree);
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
}
