//! Volume connection (thesis §2.1.1, §3.1.3 in 3D): the Delaunay
//! tetrahedralization of a volume's bubble centres, made to conform to the
//! boundary mesh, and the tetrahedra inside it.
//!
//! Boundary conformity: every boundary triangle must be a face of the
//! tetrahedralization. A triangle is a Delaunay face when some sphere
//! through its corners is empty; its *diametral* ball (centred on the
//! triangle's circumcentre, in its plane) is the smallest such sphere. The
//! bubbles of a well-packed volume stay about 0.8·d off the boundary, so
//! that ball is almost always empty; where it is not, the free bubbles
//! inside it are removed and the tetrahedralization rebuilt (a boundary
//! triangle is never changed, so the boundary mesh is exactly the faces'
//! meshes). If a boundary triangle is still missing when no free bubble
//! blocks it, the surface mesh itself is not Delaunay there and the volume
//! is refused with the triangle's position.
//!
//! Inside: tetrahedra are flooded from the inner side of every boundary
//! triangle without crossing the boundary; reaching the convex hull means
//! the boundary leaks, which is reported rather than meshed.
//!
//! Invariants of the result: every tetrahedron has positive volume
//! (`orient3d` exact), the tetrahedra's boundary faces are exactly the
//! boundary triangles, each used once.

use crate::measure::{sorted3, triangle_circumball as circumball, TET_FACES as FACE};
use std::collections::{HashMap, HashSet};

use crate::measure::c3;

use crate::geom::P3;

/// Rounds of "remove the bubbles blocking a boundary triangle, rebuild".
const RECOVERY_ROUNDS: usize = 6;

pub use crate::error::Connect3dError;

/// The most missing boundary triangles a [`Connect3dError::NotConforming`]
/// lists.
pub const MAX_REPORTED: usize = 10_000;

/// The tetrahedra of a volume.
#[derive(Debug, Default)]
pub struct VolumeConnection {
    /// Which input points the mesh uses (free points blocking the boundary
    /// are dropped).
    pub kept: Vec<bool>,
    /// Tetrahedra (input point indices), positively oriented.
    pub tets: Vec<[u32; 4]>,
    /// Free points removed for boundary recovery.
    pub removed: usize,
}

/// The boundary triangle (index into the boundary, looked up in `bset`)
/// that is face `f` of tetrahedron `t`, if any. Only a face of three
/// boundary nodes (indices below `n_fixed`) can be one: that test spares
/// the hash lookup for nearly every face (33 M lookups on case K).
fn boundary_face(
    bset: &HashMap<[u32; 3], usize>,
    n_fixed: usize,
    t: &[u32; 4],
    f: &[usize; 3],
) -> Option<usize> {
    if f.iter().all(|&i| (t[i] as usize) < n_fixed) {
        bset.get(&sorted3(f.map(|i| t[i]))).copied()
    } else {
        None
    }
}

/// `tets` in the order of their lowest node, ties in their given order: a
/// counting sort (O(n), where a comparison sort of case K's 2.75 M
/// tetrahedra took a tenth of a second).
fn by_lowest_node(n: usize, tets: Vec<[u32; 4]>) -> Vec<[u32; 4]> {
    let low = |t: &[u32; 4]| *t.iter().min().unwrap_or(&0) as usize;
    let mut start = vec![0usize; n + 1];
    for t in &tets {
        start[low(t) + 1] += 1;
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let mut out = vec![[0u32; 4]; tets.len()];
    for t in tets {
        let k = low(&t);
        out[start[k]] = t;
        start[k] += 1;
    }
    out
}

/// Connects the points `pts` of one volume: the first `n_fixed` are
/// boundary nodes, the rest free bubbles; `boundary` are the boundary
/// triangles (indices into `pts`), oriented with outward normals.
pub fn connect_volume(
    pts: &[P3],
    n_fixed: usize,
    boundary: &[[u32; 3]],
) -> Result<VolumeConnection, Connect3dError> {
    let n = pts.len();
    let mut kept = vec![true; n];
    let bset: HashMap<[u32; 3], usize> = boundary
        .iter()
        .enumerate()
        .map(|(k, t)| (sorted3(*t), k))
        .collect();
    let mut removed = 0;
    for round in 0..=RECOVERY_ROUNDS {
        let active: Vec<u32> = (0..n as u32).filter(|&i| kept[i as usize]).collect();
        let coords: Vec<[f64; 3]> = active
            .iter()
            .map(|&i| {
                let p = pts[i as usize];
                [p.x, p.y, p.z]
            })
            .collect();
        let dt = bubblemesh_delaunay::tetrahedralize(&coords)
            .map_err(|e| Connect3dError::Delaunay(e.to_string()))?;
        // a duplicate free point is dropped; duplicate boundary nodes are an
        // error
        let mut dup_free = false;
        for &(a, b) in &dt.duplicates {
            let (ga, gb) = (active[a as usize], active[b as usize]);
            let free = if ga as usize >= n_fixed {
                Some(ga)
            } else if gb as usize >= n_fixed {
                Some(gb)
            } else {
                None
            };
            match free {
                Some(f) => {
                    kept[f as usize] = false;
                    removed += 1;
                    dup_free = true;
                }
                None => {
                    let p = pts[ga as usize];
                    return Err(Connect3dError::Duplicate {
                        x: p.x,
                        y: p.y,
                        z: p.z,
                    });
                }
            }
        }
        if dup_free {
            continue;
        }
        let tets: Vec<[u32; 4]> = dt
            .tets
            .iter()
            .map(|t| t.map(|k| active[k as usize]))
            .collect();
        // which boundary triangles are tet faces
        let mut found = vec![false; boundary.len()];
        for t in &tets {
            for f in &FACE {
                if let Some(k) = boundary_face(&bset, n_fixed, t, f) {
                    found[k] = true;
                }
            }
        }
        let missing: Vec<usize> = (0..boundary.len()).filter(|&k| !found[k]).collect();
        if !missing.is_empty() {
            if round == RECOVERY_ROUNDS {
                return Err(not_conforming(pts, boundary, &missing));
            }
            let before = removed;
            remove_blockers(pts, n_fixed, boundary, &missing, &mut kept, &mut removed);
            if removed == before {
                remove_sphere_blockers(pts, n_fixed, boundary, &missing, &mut kept, &mut removed);
            }
            if removed == before {
                return Err(not_conforming(pts, boundary, &missing));
            }
            continue;
        }
        let inside = flood_inside(pts, n_fixed, &tets, &dt.neighbours, boundary, &bset)?;
        // the kernel's tetrahedra are positive in our convention already
        // (det(b−a, c−a, d−a) > 0, its documented invariant, checked
        // exactly there), so they are kept as they are
        let out: Vec<[u32; 4]> = tets
            .iter()
            .zip(&inside)
            .filter(|(_, &ins)| ins)
            .map(|(t, _)| *t)
            .collect();
        debug_assert!(out.iter().all(|t| {
            let [a, b, c, d] = t.map(|k| c3(&pts[k as usize]));
            robust::orient3d(a, b, c, d) < 0.0
        }));
        // in the order of their lowest node: the kernel leaves them in the
        // order its cavities freed slots, and every later pass (node ->
        // tetrahedra tables, stars, flips) walks them by node; sorted, those
        // walks stay in cache (case K: each of 13 node tables 0.17 s -> 0.065 s, and the
        // whole run 19.5 s -> 15.8 s)
        let out = by_lowest_node(n, out);
        return Ok(VolumeConnection {
            kept,
            tets: out,
            removed,
        });
    }
    unreachable!("the last round returns")
}

/// Removes the free points inside the diametral balls of the missing
/// boundary triangles.
fn remove_blockers(
    pts: &[P3],
    n_fixed: usize,
    boundary: &[[u32; 3]],
    missing: &[usize],
    kept: &mut [bool],
    removed: &mut usize,
) {
    // balls, then a grid over them
    let balls: Vec<(P3, f64)> = missing
        .iter()
        .map(|&k| {
            let [a, b, c] = boundary[k].map(|i| pts[i as usize]);
            circumball(&a, &b, &c)
        })
        .collect();
    let rmax = balls.iter().map(|b| b.1).fold(0.0f64, f64::max);
    let centres: Vec<P3> = balls.iter().map(|b| b.0).collect();
    let grid = crate::bubbles::grid::Grid::new(&centres, rmax.max(f64::MIN_POSITIVE));
    for i in n_fixed..pts.len() {
        if !kept[i] {
            continue;
        }
        let p = pts[i];
        let mut hit = false;
        grid.query(&p, rmax * 1.01, |k| {
            let (c, r) = balls[k as usize];
            if (p - c).norm() <= r * 1.01 {
                hit = true;
            }
        });
        if hit {
            kept[i] = false;
            *removed += 1;
        }
    }
}

/// Removes, for each missing boundary triangle, the free points inside
/// the sphere through its corners that is empty of boundary points and
/// bulges farthest outward (the free points lie inside the volume, so
/// that sphere holds the fewest of them). The spheres through a triangle
/// are centred at c + t·n (c its circumcentre, n its outward unit normal,
/// radius² = R² + t²); a point p is inside when |p − c|² − R² < 2t·n·(p − c),
/// so the boundary points bound t to an interval [lo, hi], empty when the
/// triangle is no face of the Delaunay tetrahedralization of the boundary
/// points (nothing free blocks it then; it is left). The sphere taken is
/// t just inside hi. Once it is empty of free points the triangle is
/// Delaunay: the exact cure where the diametral ball holds boundary points
/// and so is no witness (a boundary split to Delaunay by [`super::split`]
/// needs it).
fn remove_sphere_blockers(
    pts: &[P3],
    n_fixed: usize,
    boundary: &[[u32; 3]],
    missing: &[usize],
    kept: &mut [bool],
    removed: &mut usize,
) {
    let free: Vec<usize> = (n_fixed..pts.len()).filter(|&i| kept[i]).collect();
    let mut drop: HashSet<usize> = HashSet::new();
    for &k in missing {
        let tri = boundary[k];
        let [a, b, c] = tri.map(|i| pts[i as usize]);
        let (cc, r) = circumball(&a, &b, &c);
        let n = (b - a).cross(&(c - a));
        if !(n.norm() > 0.0 && r.is_finite()) {
            continue;
        }
        let n = n.normalize();
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for (i, p) in pts[..n_fixed].iter().enumerate() {
            if tri.contains(&(i as u32)) {
                continue;
            }
            let v = p - cc;
            let (h, q) = (n.dot(&v), v.norm_squared() - r * r);
            if h > 0.0 {
                hi = hi.min(q / (2.0 * h));
            } else if h < 0.0 {
                lo = lo.max(q / (2.0 * h));
            } else if q < 0.0 {
                lo = f64::INFINITY;
            }
        }
        if !(lo < hi) {
            continue;
        }
        let t = if hi.is_finite() && lo.is_finite() {
            hi - 0.01 * (hi - lo)
        } else if hi.is_finite() {
            hi - 0.01 * (hi.abs() + r)
        } else {
            lo.max(0.0) + 10.0 * r
        };
        let centre = cc + n * t;
        let r2 = r * r + t * t;
        drop.extend(
            free.iter()
                .copied()
                .filter(|&i| (pts[i] - centre).norm_squared() <= r2 * (1.0 + 1e-9)),
        );
    }
    for i in drop {
        if kept[i] {
            kept[i] = false;
            *removed += 1;
        }
    }
}

/// Marks the tetrahedra inside the boundary: flood from the inner side of
/// each boundary triangle without crossing boundary triangles. The boundary
/// triangles' corners are the points below `n_fixed`.
fn flood_inside(
    pts: &[P3],
    n_fixed: usize,
    tets: &[[u32; 4]],
    neighbours: &[[u32; 4]],
    boundary: &[[u32; 3]],
    bset: &HashMap<[u32; 3], usize>,
) -> Result<Vec<bool>, Connect3dError> {
    let mut inside = vec![false; tets.len()];
    let mut stack = Vec::new();
    let mut used = HashSet::new();
    for (ti, t) in tets.iter().enumerate() {
        for (k, f) in FACE.iter().enumerate() {
            if let Some(bk) = boundary_face(bset, n_fixed, t, f) {
                let [a, b, c] = boundary[bk].map(|i| pts[i as usize]);
                let d = pts[t[k] as usize];
                // the fourth corner below the outward-oriented triangle:
                // this tet is on the inner side
                if robust::orient3d(c3(&a), c3(&b), c3(&c), c3(&d)) > 0.0 && !inside[ti] {
                    inside[ti] = true;
                    stack.push(ti);
                }
                if robust::orient3d(c3(&a), c3(&b), c3(&c), c3(&d)) > 0.0 {
                    used.insert(bk);
                }
            }
        }
    }
    while let Some(ti) = stack.pop() {
        let t = tets[ti];
        for (k, f) in FACE.iter().enumerate() {
            if boundary_face(bset, n_fixed, &t, f).is_some() {
                continue;
            }
            let nb = neighbours[ti][k];
            if nb == u32::MAX {
                let p = pts[t[f[0]] as usize];
                return Err(Connect3dError::Leak {
                    x: p.x,
                    y: p.y,
                    z: p.z,
                });
            }
            if !inside[nb as usize] {
                inside[nb as usize] = true;
                stack.push(nb as usize);
            }
        }
    }
    if used.len() != boundary.len() {
        let missing: Vec<usize> = (0..boundary.len()).filter(|k| !used.contains(k)).collect();
        return Err(not_conforming(pts, boundary, &missing));
    }
    Ok(inside)
}

/// The error for boundary triangles `missing` (indices into `boundary`)
/// that are not faces of the tetrahedralization: how many, a point of the
/// first, and at most [`MAX_REPORTED`] of them for refinement.
fn not_conforming(pts: &[P3], boundary: &[[u32; 3]], missing: &[usize]) -> Connect3dError {
    let p = pts[boundary[missing[0]][0] as usize];
    Connect3dError::NotConforming {
        missing: missing.len(),
        x: p.x,
        y: p.y,
        z: p.z,
        triangles: missing
            .iter()
            .take(MAX_REPORTED)
            .map(|&k| k as u32)
            .collect(),
    }
}
