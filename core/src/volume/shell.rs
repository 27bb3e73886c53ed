//! The closed triangulated boundary of a volume (its faces' meshes) and
//! the two questions the volume stage asks of it: which way is out, and is a
//! point inside.
//!
//! Inside/outside is the parity of the crossings of the ray from the point
//! in the +x direction with the shell's triangles, decided with exact
//! predicates (`robust::orient2d` in the (y,z) projection, `orient3d` for
//! the side of the plane). A ray through a shared edge or vertex is counted
//! once by the *top-left rule* on the projected triangles (each point of a
//! planar subdivision belongs to exactly one triangle), so lattice points
//! aligned with mesh edges, which stage 1 produces on boxes all the time,
//! are classified correctly. This is written here rather than taken from a
//! crate because no maintained crate offers an exact point-in-mesh test;
//! the generalised winding number would do but costs O(triangles) per query.
//!
//! Invariant: `inside` is exact for points not on the shell; points on the
//! shell may go either way.

pub use crate::error::ShellError;
use std::collections::HashMap;

use robust::Coord;

use crate::geom::{P3, V3};

/// A closed triangle shell with a (y,z) bin index for ray queries.
pub struct Shell {
    pts: Vec<P3>,
    /// Triangles (indices into `pts`) whose (y,z) projection is not
    /// degenerate, ordered counter-clockwise in (y,z).
    tris: Vec<[u32; 3]>,
    /// The largest x of each triangle of `tris`. Each bin's items are
    /// sorted by it, decreasing, so a ray query stops at the first
    /// triangle wholly behind the point (x < p.x), which the +x ray cannot
    /// meet: half a column's triangles on average.
    xmax: Vec<f64>,
    lo: [f64; 2],
    inv_h: f64,
    dims: [usize; 2],
    start: Vec<u32>,
    items: Vec<u32>,
    /// A coarse voxel classification (see [`Voxels`]) answering most
    /// queries without a ray.
    voxels: Option<Voxels>,
}

/// Voxels of the shell's bounding box marked `BOUNDARY` when a triangle's
/// bounding box touches them, else `INSIDE` or `OUTSIDE` by a flood fill
/// from the box's border: a point in a non-boundary voxel is classified
/// without a ray (the flood cannot cross the surface, whose triangles all
/// lie in boundary voxels).
struct Voxels {
    lo: P3,
    inv_h: f64,
    dims: [usize; 3],
    state: Vec<u8>,
}

const OUTSIDE: u8 = 0;
const INSIDE: u8 = 1;
const BOUNDARY: u8 = 2;
const UNKNOWN: u8 = 3;

impl Voxels {
    fn new(pts: &[P3], tris: &[[u32; 3]]) -> Option<Voxels> {
        if tris.is_empty() {
            return None;
        }
        let mut lo = P3::new(f64::MAX, f64::MAX, f64::MAX);
        let mut hi = P3::new(f64::MIN, f64::MIN, f64::MIN);
        let mut edge = 0.0;
        for t in tris {
            for &k in t {
                let p = pts[k as usize];
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
            edge += (pts[t[1] as usize] - pts[t[0] as usize]).norm();
        }
        let ext = hi - lo;
        // voxels about half an edge wide, at most 64 per triangle and 8M in
        // all: the bubbles nearest the boundary stand about half a spacing
        // from it, so most of them are outside the boundary voxels and need
        // no ray (with voxels an edge wide the rays were 7 % of block_holes'
        // tetrahedra at 0.8, now 1.3 %)
        let mut h = 0.5 * edge / tris.len() as f64;
        let cap = ((64 * tris.len()).max(64) as f64).min(8e6);
        if h.is_nan() || h <= 0.0 {
            return None;
        }
        // one voxel of margin on every side so the border is outside
        lo -= V3::repeat(h);
        while (0..3)
            .map(|a| ((ext[a] + 2.0 * h) / h).ceil() + 1.0)
            .product::<f64>()
            > cap
        {
            h *= 1.25;
        }
        let lo = lo;
        let dims = [0, 1, 2].map(|a| ((ext[a] + 2.0 * h) / h).ceil() as usize + 1);
        let inv_h = 1.0 / h;
        let idx = |i: usize, j: usize, k: usize| i + dims[0] * (j + dims[1] * k);
        let mut state = vec![UNKNOWN; dims[0] * dims[1] * dims[2]];
        let cell = |x: f64, a: usize| (((x - lo[a]) * inv_h).max(0.0) as usize).min(dims[a] - 1);
        for t in tris {
            let ps = t.map(|k| pts[k as usize]);
            let r: Vec<(usize, usize)> = (0..3)
                .map(|a| {
                    let mn = ps.iter().map(|p| p[a]).fold(f64::MAX, f64::min);
                    let mx = ps.iter().map(|p| p[a]).fold(f64::MIN, f64::max);
                    // a hair wider than the triangle, so rounding at a voxel
                    // face cannot leave a touched voxel unmarked
                    let eps = 1e-6 * h;
                    (cell(mn - eps, a), cell(mx + eps, a))
                })
                .collect();
            for k in r[2].0..=r[2].1 {
                for j in r[1].0..=r[1].1 {
                    for i in r[0].0..=r[0].1 {
                        state[idx(i, j, k)] = BOUNDARY;
                    }
                }
            }
        }
        // flood the outside from the corner (always outside: margin)
        let mut stack = vec![(0usize, 0usize, 0usize)];
        state[0] = OUTSIDE;
        while let Some((i, j, k)) = stack.pop() {
            let mut visit = |i: usize, j: usize, k: usize, st: &mut Vec<u8>| {
                let c = idx(i, j, k);
                if st[c] == UNKNOWN {
                    st[c] = OUTSIDE;
                    stack.push((i, j, k));
                }
            };
            if i > 0 {
                visit(i - 1, j, k, &mut state);
            }
            if i + 1 < dims[0] {
                visit(i + 1, j, k, &mut state);
            }
            if j > 0 {
                visit(i, j - 1, k, &mut state);
            }
            if j + 1 < dims[1] {
                visit(i, j + 1, k, &mut state);
            }
            if k > 0 {
                visit(i, j, k - 1, &mut state);
            }
            if k + 1 < dims[2] {
                visit(i, j, k + 1, &mut state);
            }
        }
        // what the outside flood did not reach is inside or a void's
        // outside; those are told apart per region by one ray test each,
        // done lazily in `Shell::new`
        Some(Voxels {
            lo,
            inv_h,
            dims,
            state,
        })
    }

    fn at(&self, p: &P3) -> Option<usize> {
        let mut c = [0usize; 3];
        for a in 0..3 {
            let x = (p[a] - self.lo[a]) * self.inv_h;
            if x.is_nan() || x < 0.0 || x as usize >= self.dims[a] {
                return None;
            }
            c[a] = x as usize;
        }
        Some(c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2]))
    }
}

fn c2(p: &P3) -> Coord<f64> {
    Coord { x: p.y, y: p.z }
}

/// Whether the directed edge a→b of a counter-clockwise triangle owns the
/// points on it (top-left rule in (y,z) coordinates).
fn owns(a: &P3, b: &P3) -> bool {
    let (dy, dz) = (b.y - a.y, b.z - a.z);
    dz < 0.0 || (dz == 0.0 && dy < 0.0)
}

impl Shell {
    /// A shell over the points `pts` and triangles `tris`. The triangles
    /// need not be oriented.
    pub fn new(pts: Vec<P3>, tris: &[[u32; 3]]) -> Shell {
        let mut kept: Vec<[u32; 3]> = Vec::with_capacity(tris.len());
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let mut size = 0.0;
        for t in tris {
            let [a, b, c] = t.map(|k| pts[k as usize]);
            let o = robust::orient2d(c2(&a), c2(&b), c2(&c));
            if o == 0.0 {
                continue;
            }
            kept.push(if o > 0.0 { *t } else { [t[0], t[2], t[1]] });
            for p in [a, b, c] {
                lo[0] = lo[0].min(p.y);
                lo[1] = lo[1].min(p.z);
                hi[0] = hi[0].max(p.y);
                hi[1] = hi[1].max(p.z);
            }
            size += (b - a).norm();
        }
        if kept.is_empty() {
            return Shell {
                pts,
                tris: kept,
                xmax: vec![],
                lo: [0.0; 2],
                inv_h: 1.0,
                dims: [1, 1],
                start: vec![0, 0],
                items: vec![],
                voxels: None,
            };
        }
        // cells about twice the mean edge length, at most ~4 per triangle
        let mut h = 2.0 * size / kept.len() as f64;
        let ext = [hi[0] - lo[0], hi[1] - lo[1]];
        let max_cells = (4 * kept.len()).max(16) as f64;
        if h.is_nan() || h <= 0.0 {
            h = ext[0].max(ext[1]).max(1e-300);
        }
        while ((ext[0] / h).floor() + 1.0) * ((ext[1] / h).floor() + 1.0) > max_cells {
            h *= 1.3;
        }
        let dims = [(ext[0] / h) as usize + 1, (ext[1] / h) as usize + 1];
        let inv_h = 1.0 / h;
        let cell = |x: f64, k: usize| (((x - lo[k]) * inv_h) as usize).min(dims[k] - 1);
        let mut count = vec![0u32; dims[0] * dims[1] + 1];
        let mut ranges = Vec::with_capacity(kept.len());
        for t in &kept {
            let ps = t.map(|k| pts[k as usize]);
            let (mut y0, mut y1, mut z0, mut z1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            for p in ps {
                y0 = y0.min(p.y);
                y1 = y1.max(p.y);
                z0 = z0.min(p.z);
                z1 = z1.max(p.z);
            }
            let r = [cell(y0, 0), cell(y1, 0), cell(z0, 1), cell(z1, 1)];
            for j in r[2]..=r[3] {
                for i in r[0]..=r[1] {
                    count[i + dims[0] * j + 1] += 1;
                }
            }
            ranges.push(r);
        }
        for k in 0..dims[0] * dims[1] {
            count[k + 1] += count[k];
        }
        let mut fill = count.clone();
        let mut items = vec![0u32; count[dims[0] * dims[1]] as usize];
        for (ti, r) in ranges.iter().enumerate() {
            for j in r[2]..=r[3] {
                for i in r[0]..=r[1] {
                    let c = i + dims[0] * j;
                    items[fill[c] as usize] = ti as u32;
                    fill[c] += 1;
                }
            }
        }
        let xmax = sort_columns_by_xmax(&pts, &kept, &count, &mut items);
        let mut shell = Shell {
            pts,
            tris: kept,
            xmax,
            lo,
            inv_h,
            dims,
            start: count,
            items,
            voxels: None,
        };
        if let Some(mut vx) = Voxels::new(&shell.pts, tris) {
            // classify the unreached regions: flood each from one voxel
            // whose centre is ray-tested
            let n = vx.state.len();
            let d = vx.dims;
            for seed in 0..n {
                if vx.state[seed] != UNKNOWN {
                    continue;
                }
                let (i, j, k) = (seed % d[0], (seed / d[0]) % d[1], seed / (d[0] * d[1]));
                let h = 1.0 / vx.inv_h;
                let centre = P3::new(
                    vx.lo.x + (i as f64 + 0.5) * h,
                    vx.lo.y + (j as f64 + 0.5) * h,
                    vx.lo.z + (k as f64 + 0.5) * h,
                );
                let st = if shell.ray_inside(&centre) {
                    INSIDE
                } else {
                    OUTSIDE
                };
                let mut stack = vec![seed];
                vx.state[seed] = st;
                while let Some(c) = stack.pop() {
                    let (i, j, k) = (c % d[0], (c / d[0]) % d[1], c / (d[0] * d[1]));
                    let mut nb = [usize::MAX; 6];
                    if i > 0 {
                        nb[0] = c - 1;
                    }
                    if i + 1 < d[0] {
                        nb[1] = c + 1;
                    }
                    if j > 0 {
                        nb[2] = c - d[0];
                    }
                    if j + 1 < d[1] {
                        nb[3] = c + d[0];
                    }
                    if k > 0 {
                        nb[4] = c - d[0] * d[1];
                    }
                    if k + 1 < d[2] {
                        nb[5] = c + d[0] * d[1];
                    }
                    for o in nb {
                        if o != usize::MAX && vx.state[o] == UNKNOWN {
                            vx.state[o] = st;
                            stack.push(o);
                        }
                    }
                }
            }
            shell.voxels = Some(vx);
        }
        shell
    }

    /// Whether `p` is inside the shell (odd number of crossings of the ray
    /// from `p` towards +x; answered from the voxels away from the shell).
    pub fn inside(&self, p: &P3) -> bool {
        if let Some(vx) = &self.voxels {
            match vx.at(p).map(|c| vx.state[c]) {
                None => return false,
                Some(INSIDE) => return true,
                Some(OUTSIDE) => return false,
                _ => {}
            }
        }
        self.ray_inside(p)
    }

    /// The exact ray-parity test.
    fn ray_inside(&self, p: &P3) -> bool {
        let i = (p.y - self.lo[0]) * self.inv_h;
        let j = (p.z - self.lo[1]) * self.inv_h;
        if !(i >= 0.0 && j >= 0.0) || i as usize >= self.dims[0] || j as usize >= self.dims[1] {
            // outside the projected extent; the bins clamp, so test the
            // border cell only when the point is on its edge
            if !(i >= -1e-9 && j >= -1e-9) {
                return false;
            }
        }
        let (i, j) = (
            (i.max(0.0) as usize).min(self.dims[0] - 1),
            (j.max(0.0) as usize).min(self.dims[1] - 1),
        );
        let c = i + self.dims[0] * j;
        let q = c2(p);
        let mut odd = false;
        for &t in &self.items[self.start[c] as usize..self.start[c + 1] as usize] {
            if self.xmax[t as usize] < p.x {
                break;
            }
            let [a, b, cc] = self.tris[t as usize].map(|k| self.pts[k as usize]);
            let mut hit = true;
            for (e0, e1) in [(&a, &b), (&b, &cc), (&cc, &a)] {
                let s = robust::orient2d(c2(e0), c2(e1), q);
                if s < 0.0 || (s == 0.0 && !owns(e0, e1)) {
                    hit = false;
                    break;
                }
            }
            // behind the plane: the triangle's normal has +x component
            if hit && crate::measure::orient3d(&a, &b, &cc, p) > 0.0 {
                odd = !odd;
            }
        }
        odd
    }
}

/// The largest x of each triangle, and each (y,z) column's items sorted by
/// it, decreasing (see [`Shell::xmax`]); `start` holds the columns' offsets
/// into `items`.
fn sort_columns_by_xmax(
    pts: &[P3],
    tris: &[[u32; 3]],
    start: &[u32],
    items: &mut [u32],
) -> Vec<f64> {
    let xmax: Vec<f64> = tris
        .iter()
        .map(|t| {
            t.iter()
                .map(|&k| pts[k as usize].x)
                .fold(f64::MIN, f64::max)
        })
        .collect();
    for w in start.windows(2) {
        items[w[0] as usize..w[1] as usize].sort_unstable_by(|&a, &b| {
            xmax[b as usize]
                .total_cmp(&xmax[a as usize])
                .then(a.cmp(&b))
        });
    }
    xmax
}

/// Orients the triangles of a set of closed shells so that every normal
/// (right-hand rule) points out of the region they bound: consistently
/// across shared edges within each connected component, then each
/// component outward (a component nested inside an odd number of others,
/// a void, points into itself).
///
/// Returns an error naming an edge used by other than two triangles
/// (the shell is open or non-manifold there).
pub fn orient_outward(pts: &[P3], tris: &mut [[u32; 3]]) -> Result<(), ShellError> {
    let key = |a: u32, b: u32| if a < b { (a, b) } else { (b, a) };
    let mut by_edge: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            by_edge
                .entry(key(t[k], t[(k + 1) % 3]))
                .or_default()
                .push(ti as u32);
        }
    }
    // the first such edge in vertex order, so the message is the same on
    // every run (a HashMap's iteration order is not)
    if let Some((e, ts)) = by_edge
        .iter()
        .filter(|(_, v)| v.len() != 2)
        .min_by_key(|(e, _)| **e)
    {
        let (a, b) = (pts[e.0 as usize], pts[e.1 as usize]);
        return Err(ShellError::NotClosed {
            a,
            b,
            triangles: ts.len(),
        });
    }
    let n = tris.len();
    let mut comp = vec![u32::MAX; n];
    let mut ncomp = 0u32;
    let mut stack = Vec::new();
    for seed in 0..n {
        if comp[seed] != u32::MAX {
            continue;
        }
        comp[seed] = ncomp;
        stack.push(seed as u32);
        while let Some(t) = stack.pop() {
            let tt = tris[t as usize];
            for k in 0..3 {
                let (a, b) = (tt[k], tt[(k + 1) % 3]);
                for &o in &by_edge[&key(a, b)] {
                    if o == t || comp[o as usize] != u32::MAX {
                        continue;
                    }
                    // the neighbour must run the shared edge b→a
                    let ot = tris[o as usize];
                    let same = (0..3).any(|m| ot[m] == a && ot[(m + 1) % 3] == b);
                    if same {
                        tris[o as usize].swap(1, 2);
                    }
                    comp[o as usize] = ncomp;
                    stack.push(o);
                }
            }
        }
        ncomp += 1;
    }
    // signed volume per component
    let mut vol = vec![0.0f64; ncomp as usize];
    for (ti, t) in tris.iter().enumerate() {
        let [a, b, c] = t.map(|k| pts[k as usize].coords);
        vol[comp[ti] as usize] += a.dot(&b.cross(&c)) / 6.0;
    }
    for (ti, t) in tris.iter_mut().enumerate() {
        if vol[comp[ti] as usize] < 0.0 {
            t.swap(1, 2);
        }
    }
    if ncomp > 1 {
        // nesting: a component inside an odd number of others is a void
        let comps: Vec<Vec<[u32; 3]>> = (0..ncomp)
            .map(|c| {
                tris.iter()
                    .enumerate()
                    .filter(|(ti, _)| comp[*ti] == c)
                    .map(|(_, t)| *t)
                    .collect()
            })
            .collect();
        let shells: Vec<Shell> = comps
            .iter()
            .map(|ts| Shell::new(pts.to_vec(), ts))
            .collect();
        for c in 0..ncomp as usize {
            let probe = pts[comps[c][0][0] as usize];
            let depth = (0..ncomp as usize)
                .filter(|&o| o != c && shells[o].inside(&probe))
                .count();
            if depth % 2 == 1 {
                for (ti, t) in tris.iter_mut().enumerate() {
                    if comp[ti] as usize == c {
                        t.swap(1, 2);
                    }
                }
            }
        }
    }
    Ok(())
}

/// Volume enclosed by outward-oriented closed shells (divergence theorem).
#[cfg(test)]
fn enclosed_volume(pts: &[P3], tris: &[[u32; 3]]) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| pts[k as usize].coords);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The unit cube's surface split into 2 triangles per side, corners at
    /// integer points: rays through lattice points hit edges and vertices.
    pub(crate) fn cube() -> (Vec<P3>, Vec<[u32; 3]>) {
        let mut pts = Vec::new();
        for k in 0..8 {
            pts.push(P3::new(
                (k & 1) as f64,
                (k >> 1 & 1) as f64,
                (k >> 2 & 1) as f64,
            ));
        }
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let mut tris = Vec::new();
        for q in quads {
            tris.push([q[0], q[1], q[2]]);
            tris.push([q[0], q[2], q[3]]);
        }
        (pts, tris)
    }

    #[test]
    fn points_on_edge_and_vertex_rays_are_classified_once() {
        let (pts, tris) = cube();
        let s = Shell::new(pts, &tris);
        // rays through the cube's face diagonals and corners
        for p in [
            P3::new(0.5, 0.5, 0.5),
            P3::new(-0.5, 0.5, 0.5),
            P3::new(0.5, 0.0, 0.0),
            P3::new(0.25, 0.25, 0.25),
            P3::new(0.5, 1.0, 1.0),
            P3::new(0.3, 0.7, 0.7),
        ] {
            let inside_box = (0..3).all(|k| p[k] > 0.0 && p[k] < 1.0);
            if (0..3).all(|k| p[k] > 0.0 && p[k] < 1.0) || p.x < 0.0 {
                assert_eq!(s.inside(&p), inside_box, "{p:?}");
            }
        }
        // a dense lattice including points whose rays run along edges
        let mut inside = 0;
        for i in 0..=20 {
            for j in 0..=20 {
                for k in 0..=20 {
                    let p = P3::new(
                        i as f64 / 20.0 * 1.2 - 0.1,
                        j as f64 / 20.0,
                        k as f64 / 20.0,
                    );
                    let strictly = (0..3).all(|a| p[a] > 1e-12 && p[a] < 1.0 - 1e-12);
                    if strictly {
                        assert!(s.inside(&p), "{p:?} is inside");
                        inside += 1;
                    } else if p.x < 0.0 || p.x > 1.0 {
                        assert!(!s.inside(&p), "{p:?} is outside");
                    }
                }
            }
        }
        assert!(inside > 0);
    }

    /// The ray test stops at the first triangle of its column wholly
    /// behind the point (`Shell::xmax`): a cube with a cubic void, both
    /// split along diagonals, on a lattice whose x values include every
    /// triangle's largest x exactly (0.25, 0.75, 1), classified as the
    /// exact parity says.
    #[test]
    fn rays_stop_at_triangles_behind_the_point_without_changing_the_parity() {
        let (mut pts, mut tris) = cube();
        let (inner, inner_tris) = cube();
        pts.extend(
            inner
                .iter()
                .map(|p| P3::new(0.25 + 0.5 * p.x, 0.25 + 0.5 * p.y, 0.25 + 0.5 * p.z)),
        );
        tris.extend(inner_tris.iter().map(|t| t.map(|k| k + 8)));
        let s = Shell::new(pts, &tris);
        let on = |x: f64, lo: f64, hi: f64| x == lo || x == hi;
        let mut tested = [0; 2];
        for i in 0..=24 {
            for j in 0..=8 {
                for k in 0..=8 {
                    let p = P3::new((i as f64 - 2.0) / 20.0, j as f64 / 8.0, k as f64 / 8.0);
                    let in_box = |lo: f64, hi: f64| (0..3).all(|a| p[a] > lo && p[a] < hi);
                    let on_shell = |lo: f64, hi: f64| {
                        (0..3).any(|a| on(p[a], lo, hi)) && (0..3).all(|a| p[a] >= lo && p[a] <= hi)
                    };
                    if on_shell(0.0, 1.0) || on_shell(0.25, 0.75) {
                        continue;
                    }
                    let want = in_box(0.0, 1.0) && !in_box(0.25, 0.75);
                    assert_eq!(s.ray_inside(&p), want, "{p:?}");
                    tested[want as usize] += 1;
                }
            }
        }
        assert!(tested[0] > 100 && tested[1] > 100, "{tested:?}");
    }

    #[test]
    fn orientation_is_made_outward_and_voids_inward() {
        let (pts, mut tris) = cube();
        // scramble orientation
        for t in tris.iter_mut().step_by(3) {
            t.swap(0, 1);
        }
        // a void: a smaller cube inside
        let mut all = pts.clone();
        let (inner, itris) = cube();
        let off = all.len() as u32;
        all.extend(
            inner
                .iter()
                .map(|p| P3::new(0.25 + 0.5 * p.x, 0.25 + 0.5 * p.y, 0.25 + 0.5 * p.z)),
        );
        tris.extend(itris.iter().map(|t| t.map(|k| k + off)));
        orient_outward(&all, &mut tris).unwrap();
        let v = enclosed_volume(&all, &tris);
        assert!((v - (1.0 - 0.125)).abs() < 1e-12, "volume {v}");
    }

    #[test]
    fn an_open_shell_is_refused() {
        let (pts, mut tris) = cube();
        tris.pop();
        let err = orient_outward(&pts, &mut tris).unwrap_err().to_string();
        assert!(err.contains("not closed"), "{err}");
    }
}
