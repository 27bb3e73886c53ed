//! Neighbour search: a uniform cell grid in model space, rebuilt every step in
//! O(n) (counting sort into compressed rows).
//!
//! Written by hand rather than taken from a k-d tree crate because the engine
//! rebuilds it every time step and the counting sort is both simpler and
//! faster for that use than a tree rebuild.
//!
//! Where the spacings spread over more than [`MAX_SPREAD`] (a volume whose
//! boundary was refined to d/64 in places), cells of the least spacing make
//! a query of the largest walk (d_max/d_min)³ cells, nearly all empty (a
//! volume of `as_0082` at diag/15 spent minutes there);
//! [`Grid::for_spacings`] then builds an R*-tree (`rstar`) of the points,
//! whose queries cost O(log n + hits) at any spread. Stage 2's neighbour
//! lists, rebuilt often, take [`Levels`] there instead: a grid per spacing
//! class, each pair asked for from the side whose cells fit it.
//!
//! Invariant: `query(p, r, f)` calls `f` for every bubble whose position is
//! within distance `r` of `p` (and possibly for some farther ones; callers
//! test the distance).

use crate::geom::P3;
use rstar::primitives::GeomWithData;
use rstar::{RTree, AABB};

/// The largest ratio of the largest to the least spacing searched with
/// cells; beyond it [`Grid::for_spacings`] builds a tree.
pub const MAX_SPREAD: f64 = 16.0;

pub struct Grid {
    kind: Kind,
}

enum Kind {
    Cells(Cells),
    Tree(RTree<GeomWithData<[f64; 3], u32>>),
}

/// Uniform cells, their items in compressed rows.
struct Cells {
    lo: P3,
    inv_h: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    /// Builds a grid over `pos` with cells of side about `h`, enlarged when
    /// needed so that there are at most `max(8·n, 64)` cells.
    pub fn new(pos: &[P3], h: f64) -> Grid {
        Grid {
            kind: Kind::Cells(Cells::new(pos, h)),
        }
    }

    /// A search over bubbles at `pos` of spacings `d` whose queries reach
    /// at most `factor` times the querying bubble's spacing: cells of
    /// `factor` times the least spacing, or a tree where the spacings
    /// spread over more than [`MAX_SPREAD`].
    pub fn for_spacings(pos: &[P3], d: &[f64], factor: f64) -> Grid {
        let dmin = d.iter().cloned().fold(f64::INFINITY, f64::min);
        let dmax = d.iter().cloned().fold(0.0f64, f64::max);
        if dmax > MAX_SPREAD * dmin {
            let points = pos
                .iter()
                .enumerate()
                .map(|(j, p)| GeomWithData::new([p.x, p.y, p.z], j as u32))
                .collect();
            Grid {
                kind: Kind::Tree(RTree::bulk_load(points)),
            }
        } else {
            Grid::new(pos, factor * dmin)
        }
    }

    /// Where this is a tree, the same search over the bubbles from index
    /// `first` on alone (the free ones, when the fixed come first): the
    /// bubbles a fixed one must find, without the thousands of fixed ones
    /// in its reach beside a finely refined boundary. `None` with cells,
    /// whose queries are cheap at any rate (and whose visit order, which
    /// decides the forces' summation order, then stays the one it was).
    pub fn only_from(&self, pos: &[P3], first: usize) -> Option<Grid> {
        match &self.kind {
            Kind::Cells(_) => None,
            Kind::Tree(_) => Some(Grid {
                kind: Kind::Tree(RTree::bulk_load(
                    pos.iter()
                        .enumerate()
                        .skip(first)
                        .map(|(j, p)| GeomWithData::new([p.x, p.y, p.z], j as u32))
                        .collect(),
                )),
            }),
        }
    }

    /// Calls `f(j)` for the bubbles in the cells overlapping the ball (p, r)
    /// (in the tree: in the cube around it).
    #[inline]
    pub fn query(&self, p: &P3, r: f64, mut f: impl FnMut(u32)) {
        match &self.kind {
            Kind::Cells(c) => c.query(p, r, f),
            Kind::Tree(t) => {
                let cube =
                    AABB::from_corners([p.x - r, p.y - r, p.z - r], [p.x + r, p.y + r, p.z + r]);
                for e in t.locate_in_envelope(&cube) {
                    f(e.data);
                }
            }
        }
    }
}

impl Cells {
    fn new(pos: &[P3], h: f64) -> Cells {
        let mut lo = P3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = P3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in pos {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if pos.is_empty() {
            lo = P3::origin();
            hi = P3::origin();
        }
        let ext = hi - lo;
        let max_cells = (8 * pos.len()).max(64) as f64;
        let mut h = if h.is_finite() && h > 0.0 {
            h
        } else {
            ext.norm().max(1.0)
        };
        loop {
            let cells: f64 = (0..3).map(|k| (ext[k] / h).floor() + 1.0).product();
            if cells <= max_cells {
                break;
            }
            h *= 1.26;
        }
        let dims = [0, 1, 2].map(|k| (ext[k] / h).floor() as usize + 1);
        let ncell = dims[0] * dims[1] * dims[2];
        let inv_h = 1.0 / h;
        let mut start = vec![0u32; ncell + 1];
        let cell_of = |p: &P3| -> usize {
            let i = (((p.x - lo.x) * inv_h) as usize).min(dims[0] - 1);
            let j = (((p.y - lo.y) * inv_h) as usize).min(dims[1] - 1);
            let k = (((p.z - lo.z) * inv_h) as usize).min(dims[2] - 1);
            i + dims[0] * (j + dims[1] * k)
        };
        let cells: Vec<usize> = pos.iter().map(cell_of).collect();
        for &c in &cells {
            start[c + 1] += 1;
        }
        for c in 0..ncell {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; pos.len()];
        for (i, &c) in cells.iter().enumerate() {
            items[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        Cells {
            lo,
            inv_h,
            dims,
            start,
            items,
        }
    }

    #[inline]
    fn query(&self, p: &P3, r: f64, mut f: impl FnMut(u32)) {
        let mut a = [0usize; 3];
        let mut b = [0usize; 3];
        for k in 0..3 {
            let lo = ((p[k] - r - self.lo[k]) * self.inv_h).floor();
            let hi = ((p[k] + r - self.lo[k]) * self.inv_h).floor();
            if hi < 0.0 || lo > (self.dims[k] - 1) as f64 {
                return;
            }
            a[k] = lo.max(0.0) as usize;
            b[k] = (hi as usize).min(self.dims[k] - 1);
        }
        for k in a[2]..=b[2] {
            for j in a[1]..=b[1] {
                let row = self.dims[0] * (j + self.dims[1] * k);
                let s = self.start[row + a[0]] as usize;
                let e = self.start[row + b[0] + 1] as usize;
                for &it in &self.items[s..e] {
                    f(it);
                }
            }
        }
    }
}

/// Candidate pairs of bubbles of spread spacings: each bubble's spacing
/// class (d within a factor 2) in a cell grid of its own, with cells of
/// about the least reach in the class. A pair inside a class is asked for
/// by its larger bubble, within its own reach; a pair across classes by
/// its smaller bubble, in the classes above its own, within the reach of
/// the class's largest.
///
/// Why not [`Grid`]: a pair's reach, `reach·(d_i + d_j)/2`, is set by the
/// larger bubble, so one grid must either be searched from the larger
/// bubble through cells of the least spacing ((d_max/d_min)³ cells a
/// query, nearly all empty on a graded volume) or be a tree (an R*-tree
/// bulk-loaded at every rebuild; a quarter of a graded plate's time). Here
/// a query reaches at most 2.2 cells from its centre (six cells a side),
/// whatever the spread.
///
/// Invariant: [`Levels::candidates`] calls `f(i, j)` once for every
/// unordered pair within `reach·(d_i + d_j)/2` of each other (and for some
/// farther ones: callers test the distance), with `i` the larger bubble
/// (`d_j < d_i`, or equal spacings and `i < j`), never twice for a pair.
pub struct Levels {
    /// Per bubble, its class.
    class: Vec<u8>,
    classes: Vec<Class>,
}

/// One spacing class: its bubbles, their largest d, and their cells (the
/// cells' items index `ids`). Every d of a class is below every d of the
/// next.
struct Class {
    ids: Vec<u32>,
    dmax: f64,
    cells: Cells,
}

/// A class's cells, in units of the reach of its least spacing.
const CELL: f64 = 0.9;

/// Classes beyond this many doublings of the least spacing share the last
/// one (a spread of 2⁴⁰ is no mesh; the last class's queries then span more
/// cells, but stay correct).
const MAX_CLASSES: usize = 40;

impl Levels {
    /// Whether spacings `d` spread over more than [`MAX_SPREAD`]: there a
    /// single [`Grid`] would be a tree, and the classes are faster; below
    /// it the single grid's cells are (cases B and C, 4–5 %).
    pub fn needed(d: &[f64]) -> bool {
        let dmin = d.iter().cloned().fold(f64::INFINITY, f64::min);
        let dmax = d.iter().cloned().fold(0.0f64, f64::max);
        dmax > MAX_SPREAD * dmin
    }

    /// Classes of the bubbles at `pos` with spacings `d`, for pairs within
    /// `reach` times their mean spacing.
    pub fn new(pos: &[P3], d: &[f64], reach: f64) -> Levels {
        let dmin = d
            .iter()
            .cloned()
            .filter(|v| *v > 0.0)
            .fold(f64::INFINITY, f64::min);
        // class k holds d in [dmin·2^k, dmin·2^(k+1)); thresholds by
        // doubling (exact), so a larger d never takes a lower class
        let class: Vec<u8> = d
            .iter()
            .map(|&v| {
                let mut k = 0usize;
                let mut t = 2.0 * dmin;
                while k + 1 < MAX_CLASSES && v >= t {
                    k += 1;
                    t *= 2.0;
                }
                k as u8
            })
            .collect();
        let nclass = class.iter().map(|&k| k as usize + 1).max().unwrap_or(0);
        let mut ids: Vec<Vec<u32>> = vec![Vec::new(); nclass];
        for (i, &k) in class.iter().enumerate() {
            ids[k as usize].push(i as u32);
        }
        let classes = ids
            .into_iter()
            .map(|ids| {
                let dmax = ids.iter().map(|&i| d[i as usize]).fold(0.0f64, f64::max);
                let dlo = ids
                    .iter()
                    .map(|&i| d[i as usize])
                    .fold(f64::INFINITY, f64::min);
                let p: Vec<P3> = ids.iter().map(|&i| pos[i as usize]).collect();
                let cells = Cells::new(&p, CELL * reach * dlo);
                Class { ids, dmax, cells }
            })
            .collect();
        Levels { class, classes }
    }

    /// Calls `f(i, j)` for the candidate pairs (see the type's invariant).
    pub fn candidates(&self, pos: &[P3], d: &[f64], reach: f64, mut f: impl FnMut(usize, usize)) {
        for q in 0..pos.len() {
            let (pq, dq) = (pos[q], d[q]);
            let own = self.class[q] as usize;
            let c = &self.classes[own];
            c.cells.query(&pq, reach * dq, |local| {
                let j = c.ids[local as usize] as usize;
                let dj = d[j];
                if dj < dq || (dj == dq && j > q) {
                    f(q, j);
                }
            });
            for c in &self.classes[own + 1..] {
                c.cells.query(&pq, reach * 0.5 * (dq + c.dmax), |local| {
                    f(c.ids[local as usize] as usize, q);
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_every_point_within_radius() {
        let mut pts = Vec::new();
        let mut rnd = crate::bubbles::testing::uniform(12345);
        for _ in 0..2000 {
            pts.push(P3::new(rnd(), rnd() * 0.5, 0.0));
        }
        let g = Grid::new(&pts, 0.03);
        for q in pts.iter().take(200) {
            let r = 0.05;
            let mut found = Vec::new();
            g.query(q, r, |j| found.push(j));
            for (j, p) in pts.iter().enumerate() {
                if (p - q).norm() <= r {
                    assert!(found.contains(&(j as u32)));
                }
            }
        }
    }

    /// Spacings spreading over more than `MAX_SPREAD` take the tree, which
    /// finds every point within the radius as the cells do.
    #[test]
    fn a_wide_spread_of_spacings_finds_every_point_within_radius() {
        let mut pts = Vec::new();
        let mut d = Vec::new();
        let mut rnd = crate::bubbles::testing::uniform(99);
        for k in 0..3000 {
            pts.push(P3::new(rnd(), rnd(), 0.1 * rnd()));
            d.push(if k % 10 == 0 { 0.2 } else { 0.002 });
        }
        let g = Grid::for_spacings(&pts, &d, 1.5);
        assert!(matches!(g.kind, Kind::Tree(_)));
        for (q, &dq) in pts.iter().zip(&d).take(300) {
            let r = 1.5 * dq;
            let mut found = Vec::new();
            g.query(q, r, |j| found.push(j));
            for (j, p) in pts.iter().enumerate() {
                if (p - q).norm() <= r {
                    assert!(found.contains(&(j as u32)));
                }
            }
        }
    }

    /// Every pair within reach of its mean spacing is given once, by its
    /// larger bubble first, over spacings spread 200-fold, with ties (equal
    /// spacings at the class boundaries) and coincident points.
    #[test]
    fn levels_give_every_pair_within_reach_once_larger_first() {
        let mut pts = Vec::new();
        let mut d = Vec::new();
        let mut rnd = crate::bubbles::testing::uniform(7);
        for k in 0..2500 {
            pts.push(P3::new(rnd(), rnd(), 0.2 * rnd()));
            d.push(match k % 5 {
                0 => 0.2,
                1 => 0.004,
                2 => 0.008,
                _ => 0.001 + 0.05 * rnd(),
            });
        }
        pts.push(pts[10]);
        d.push(d[10]);
        let reach = 1.65;
        let lv = Levels::new(&pts, &d, reach);
        let n = pts.len();
        let mut seen = std::collections::HashSet::new();
        lv.candidates(&pts, &d, reach, |i, j| {
            assert!(d[j] < d[i] || (d[j] == d[i] && i < j), "{i} {j}");
            assert!(seen.insert((i, j)), "pair ({i}, {j}) given twice");
        });
        for i in 0..n {
            for j in 0..n {
                let larger = d[j] < d[i] || (d[j] == d[i] && i < j);
                if larger && (pts[i] - pts[j]).norm() < reach * 0.5 * (d[i] + d[j]) {
                    assert!(seen.contains(&(i, j)), "pair ({i}, {j}) missed");
                }
            }
        }
    }
}
