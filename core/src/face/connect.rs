//! Connection of bubble centres into elements (thesis §2.1.1, §3.2.3).
//!
//! Faces: a constrained Delaunay triangulation in the face's (u,v)
//! parameters with `spade` (exact orientation and in-circle predicates via
//! `robust`), constrained by the boundary and embedded edges; triangles
//! outside the face are removed by a topological flood from the oriented
//! boundary segments.
//!
//! Invariants of [`triangulate`]'s result: every input point is a vertex of
//! some triangle or lies outside the kept region; every constraint segment is
//! an edge of the triangulation; triangles are counter-clockwise in (u,v).

use crate::geom::P3;
use std::collections::{HashMap, HashSet};

use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

pub use crate::error::ConnectError;

/// Constrained Delaunay triangulation of `uv` with the constraint segments
/// `segments` (indices into `uv`).
///
/// `boundary` lists the directed boundary segments with the region on their
/// left (they must also be in `segments`). Triangles are classified
/// *topologically*: a triangle holding a boundary segment in its
/// counter-clockwise order is inside, one holding it reversed is outside,
/// and the classification floods across every edge that is not a boundary
/// segment. No geometric in/out test is involved, so slivers between nearly
/// collinear boundary nodes are classified exactly. `keep` decides only for
/// a part that touches no boundary segment (which a valid face does not
/// have). Returns counter-clockwise triangles of indices into `uv`.
pub fn triangulate(
    uv: &[[f64; 2]],
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
    keep: impl Fn([f64; 2]) -> bool,
) -> Result<Vec<[usize; 3]>, ConnectError> {
    // spade refuses coordinates of magnitude below 2^-142 (TooSmall): such
    // round-off residues of a zero (seen on parts placed by an assembly
    // transform) are zero
    let flush = |x: f64| if x.abs() < 1e-40 { 0.0 } else { x };
    let pts: Vec<Point2<f64>> = uv
        .iter()
        .map(|p| Point2::new(flush(p[0]), flush(p[1])))
        .collect();
    let mut conflict = None;
    let cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::try_bulk_load_cdt(
        pts,
        segments.to_vec(),
        |e| {
            conflict.get_or_insert(e);
        },
    )
    .map_err(|e| ConnectError::Insertion(format!("{e:?}")))?;
    if cdt.num_vertices() != uv.len() {
        // find one duplicate to name it
        let mut sorted: Vec<usize> = (0..uv.len()).collect();
        sorted.sort_by(|&a, &b| {
            uv[a][0]
                .total_cmp(&uv[b][0])
                .then(uv[a][1].total_cmp(&uv[b][1]))
        });
        let dup = sorted
            .windows(2)
            .find(|w| uv[w[0]] == uv[w[1]])
            .map(|w| uv[w[0]])
            .unwrap_or([f64::NAN, f64::NAN]);
        return Err(ConnectError::Duplicate(dup[0], dup[1]));
    }
    if let Some([a, _]) = conflict {
        return Err(ConnectError::Crossing(uv[a][0], uv[a][1]));
    }
    let bset: std::collections::HashSet<(usize, usize)> =
        boundary.iter().map(|s| (s[0], s[1])).collect();
    // most edges touch no boundary vertex: test a flag before hashing
    let mut on_b = vec![false; uv.len()];
    for s in boundary {
        on_b[s[0]] = true;
        on_b[s[1]] = true;
    }
    let is_seg = |a: usize, b: usize| on_b[a] && on_b[b] && bset.contains(&(a, b));
    let nf = cdt.num_all_faces();
    // per spade face index: vertices, neighbours across each edge, label
    let mut verts = vec![[usize::MAX; 3]; nf];
    let mut nbr = vec![[usize::MAX; 3]; nf];
    let mut label = vec![0i8; nf]; // 1 inside, -1 outside, 0 unknown
    let mut stack = Vec::new();
    for f in cdt.inner_faces() {
        let fi = f.fix().index();
        for (k, e) in f.adjacent_edges().iter().enumerate() {
            let (a, b) = (e.from().fix().index(), e.to().fix().index());
            verts[fi][k] = a;
            nbr[fi][k] = e
                .rev()
                .face()
                .as_inner()
                .map(|g| g.fix().index())
                .unwrap_or(usize::MAX);
            if is_seg(a, b) {
                label[fi] = 1;
            } else if label[fi] == 0 && is_seg(b, a) {
                label[fi] = -1;
            }
        }
        if label[fi] != 0 {
            stack.push(fi);
        }
    }
    while let Some(fi) = stack.pop() {
        for k in 0..3 {
            let g = nbr[fi][k];
            if g == usize::MAX || label[g] != 0 {
                continue;
            }
            let (a, b) = (verts[fi][k], verts[fi][(k + 1) % 3]);
            if is_seg(a, b) || is_seg(b, a) {
                continue;
            }
            label[g] = label[fi];
            stack.push(g);
        }
    }
    let mut tris = Vec::with_capacity(2 * uv.len());
    for f in cdt.inner_faces() {
        let fi = f.fix().index();
        let idx = verts[fi];
        let inside = match label[fi] {
            1 => true,
            -1 => false,
            _ => keep([
                (uv[idx[0]][0] + uv[idx[1]][0] + uv[idx[2]][0]) / 3.0,
                (uv[idx[0]][1] + uv[idx[1]][1] + uv[idx[2]][1]) / 3.0,
            ]),
        };
        if inside {
            tris.push(idx);
        }
    }
    Ok(tris)
}

/// What [`triangulate_surface`] needs to know about a curved face.
pub struct SurfacePoints<'a> {
    /// Parameters of every point, in the fundamental domain.
    pub uv: &'a [[f64; 2]],
    /// Model-space positions.
    pub pos: &'a [crate::geom::P3],
    /// Unit surface normals (S_u × S_v) at the points.
    pub normal: &'a [crate::geom::V3],
    /// Node spacing at the points.
    pub d: &'a [f64],
    /// Points near a singular point of the parametrization (a pole, an
    /// apex): left out of the (u,v) triangulation and connected in their
    /// tangent plane instead.
    pub singular: &'a [bool],
    pub periods: [Option<f64>; 2],
    /// Start of the fundamental domain.
    pub origin: [f64; 2],
    /// Typical lengths |S_u|, |S_v| of the parameter derivatives: (u,v) is
    /// triangulated as (u·scale₀, v·scale₁), so that the Delaunay
    /// triangulation in parameter space is close to the one on the surface
    /// (on a cylinder of radius r, u is in radians and v in model units:
    /// unscaled, the triangulation of a thick cylinder degenerates).
    pub scale: [f64; 2],
}

/// Triangulation of a curved, possibly periodic face.
///
/// - Periodic directions: points within a margin of the seam are copied one
///   period over, the padded set is triangulated in (u,v), and of every
///   triangle and its copies the one whose centroid lies in the fundamental
///   domain is kept, its vertices mapped back to the originals; so the seam
///   is crossed by ordinary triangles and no node is duplicated.
/// - Singular points: the points marked `singular` are triangulated with the
///   ring of mesh edges around them in the tangent plane of the ring (a cap).
///
/// Triangles are oriented along the surface normal. Constraint segments
/// and boundary classification work as in [`triangulate`].
pub fn triangulate_surface(
    pts: &SurfacePoints<'_>,
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
) -> Result<Vec<[usize; 3]>, ConnectError> {
    triangulate_surface_with(pts, segments, boundary, false)
}

/// [`triangulate_surface`] with the (u,v) triangles that are flat against
/// model space ([`FLAT_UV`]) filled in their tangent plane like the long
/// ones: the last fallback of a curved face's connection, for a face
/// whose boundary nodes lie on one (u,v) line (a dimple bounded by a
/// circle of latitude). An error when there are none.
pub fn triangulate_surface_filling_flat(
    pts: &SurfacePoints<'_>,
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
) -> Result<Vec<[usize; 3]>, ConnectError> {
    triangulate_surface_with(pts, segments, boundary, true)
}

/// [`triangulate_surface`], or with `fill_flat`
/// [`triangulate_surface_filling_flat`].
fn triangulate_surface_with(
    pts: &SurfacePoints<'_>,
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
    fill_flat: bool,
) -> Result<Vec<[usize; 3]>, ConnectError> {
    let sc = pts
        .scale
        .map(|x| if x.is_finite() && x > 0.0 { x } else { 1.0 });
    let scaled_uv: Vec<[f64; 2]> = pts
        .uv
        .iter()
        .map(|q| [q[0] * sc[0], q[1] * sc[1]])
        .collect();
    let scaled = SurfacePoints {
        uv: &scaled_uv,
        periods: [
            pts.periods[0].map(|p| p * sc[0]),
            pts.periods[1].map(|p| p * sc[1]),
        ],
        origin: [pts.origin[0] * sc[0], pts.origin[1] * sc[1]],
        scale: [1.0, 1.0],
        ..*pts
    };
    let pts = &scaled;
    let n = pts.uv.len();
    // --- padded copies of the regular points
    let shifts_of = |uv: [f64; 2]| -> Vec<[f64; 2]> {
        let mut out = vec![[0.0, 0.0]];
        for c in 0..2 {
            if let Some(p) = pts.periods[c] {
                let margin = 0.25 * p;
                let mut extra = Vec::new();
                for s in &out {
                    if uv[c] - pts.origin[c] < margin {
                        let mut t = *s;
                        t[c] = p;
                        extra.push(t);
                    }
                    if pts.origin[c] + p - uv[c] < margin {
                        let mut t = *s;
                        t[c] = -p;
                        extra.push(t);
                    }
                }
                out.extend(extra);
            }
        }
        out
    };
    let mut ext_uv: Vec<[f64; 2]> = Vec::new();
    let mut ext_of: Vec<usize> = Vec::new();
    let mut copies: Vec<Vec<(usize, [f64; 2])>> = vec![Vec::new(); n];
    for (i, copies_i) in copies.iter_mut().enumerate() {
        if pts.singular[i] {
            continue;
        }
        for s in shifts_of(pts.uv[i]) {
            copies_i.push((ext_uv.len(), s));
            ext_uv.push([pts.uv[i][0] + s[0], pts.uv[i][1] + s[1]]);
            ext_of.push(i);
        }
    }
    // segments between copies that are near each other in (u,v)
    let lift = |segs: &[[usize; 2]]| -> Vec<[usize; 2]> {
        let mut out = Vec::new();
        for &[a, b] in segs {
            for &(ea, _) in &copies[a] {
                for &(eb, _) in &copies[b] {
                    let (pa, pb) = (ext_uv[ea], ext_uv[eb]);
                    let near = (0..2).all(|c| match pts.periods[c] {
                        Some(p) => (pa[c] - pb[c]).abs() < 0.5 * p,
                        None => true,
                    });
                    if near {
                        out.push([ea, eb]);
                    }
                }
            }
        }
        out
    };
    let ext_segments = lift(segments);
    let ext_boundary = lift(boundary);
    let ext_tris = triangulate(&ext_uv, &ext_segments, &ext_boundary, |_| true)?;
    // keep the copy whose centroid is in the fundamental domain
    let in_domain = |c: [f64; 2]| {
        (0..2).all(|k| match pts.periods[k] {
            Some(p) => c[k] >= pts.origin[k] && c[k] < pts.origin[k] + p,
            None => true,
        })
    };
    let mut tris: Vec<[usize; 3]> = Vec::new();
    // with `fill_flat`, whether each of `tris` is flat in (u,v) against
    // model space (see FLAT_UV)
    let mut flat: Vec<bool> = Vec::new();
    for t in ext_tris {
        let c = [
            (ext_uv[t[0]][0] + ext_uv[t[1]][0] + ext_uv[t[2]][0]) / 3.0,
            (ext_uv[t[0]][1] + ext_uv[t[1]][1] + ext_uv[t[2]][1]) / 3.0,
        ];
        if in_domain(c) {
            let g = [ext_of[t[0]], ext_of[t[1]], ext_of[t[2]]];
            if fill_flat {
                flat.push(flat_in_uv(pts, t.map(|e| ext_uv[e]), g));
            }
            tris.push(g);
        }
    }
    // --- where the parametrization is poor (around a pole, a hull lid
    // over a left-out cap) the (u,v) triangles are long in model space:
    // drop them and fill the holes in their tangent plane
    if fill_flat {
        return fill_flat_triangles(pts, &tris, &flat, boundary);
    }
    let (mut short, dropped): (Vec<[usize; 3]>, Vec<[usize; 3]>) =
        tris.iter().partition(|t| short_edges(pts, t));
    let mut tris = match fill_caps(pts, &mut short, boundary, &dropped) {
        Ok(()) => short,
        // The long triangles were not a distortion but the face itself: a
        // band narrower than the spacing (the wall of a hole of radius
        // ~d/10), a strip between a fine and a coarse edge. Its hole does
        // not project onto one tangent plane (a tube seen from its side),
        // but the (u,v) triangulation covers the face exactly and, on a
        // regular parametrization, does not fold: keep it, capping only
        // the left-out singular points.
        Err(first) => {
            let mut all = tris;
            match fill_caps(pts, &mut all, boundary, &[]) {
                Ok(()) => all,
                Err(_) => return Err(first),
            }
        }
    };
    orient_along_normal(pts, &mut tris);
    Ok(tris)
}

/// A hull edge longer than this many spacings (of its ends, averaged)
/// refuses [`triangulate_hull`]: bubbles a spacing apart on a sphere give
/// edges of about one spacing; a dimple closed by a pyramid from its pole
/// had 1.9.
const HULL_LONG_EDGE: f64 = 1.5;

/// Triangulation of a convex face as the convex hull of its points (the
/// boundary of their 3D Delaunay tetrahedralization), less the hull's
/// triangles over its holes: a whole sphere, or a sphere less a small cap.
/// On a sphere the hull is the Delaunay triangulation on the surface
/// itself (a hull facet's circumcircle is where its plane cuts the sphere,
/// empty of points), so it needs no parametrization: the fallback of a
/// sphere so small against the spacing that every bubble lies in a pole's
/// cap and the (u,v) triangulation is empty (a spherical void of radius
/// d/4).
///
/// `segments` must be edges of the hull; `boundary` (directed with the
/// face on their left, seen along the normal) tells the face's triangles
/// from the holes' as [`triangulate`] does, by a flood from them. Refused
/// (an error) unless every point is a corner of a kept triangle, every
/// hull triangle faces the way of the surface normals at its corners (the
/// face is convex as sampled), and every boundary segment lies in exactly
/// one kept triangle. Triangles come out oriented along the normal.
pub fn triangulate_hull(
    pts: &SurfacePoints<'_>,
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
) -> Result<Vec<[usize; 3]>, ConnectError> {
    let n = pts.pos.len();
    let coords: Vec<[f64; 3]> = pts.pos.iter().map(|p| [p.x, p.y, p.z]).collect();
    let t = bubblemesh_delaunay::tetrahedralize(&coords)
        .map_err(|e| ConnectError::Coarse(format!("its points have no hull: {e}")))?;
    if !t.duplicates.is_empty() {
        return Err(ConnectError::Coarse("two of its points coincide".into()));
    }
    let mut tris = Vec::new();
    for (tet, nb) in t.tets.iter().zip(&t.neighbours) {
        for (i, &other) in nb.iter().enumerate() {
            if other == bubblemesh_delaunay::HULL {
                // the face opposite corner i: every hull face is oriented
                // alike (which way is decided below)
                let f = crate::measure::TET_FACES[i].map(|k| tet[k] as usize);
                tris.push(f);
            }
        }
    }
    if let Some(i) = corners(n, &tris).iter().position(|u| !u) {
        let p = pts.pos[i];
        return Err(ConnectError::Coarse(format!(
            "the face is not convex: its point ({}, {}, {}) is inside the hull of the others",
            p.x, p.y, p.z
        )));
    }
    // the sign of each triangle's normal against the surface normals at its
    // corners (a pole's normal may be unusable: it is not judged)
    let sides = |sign: f64| {
        tris.iter().all(|t| {
            let [a, b, c] = t.map(|k| pts.pos[k]);
            let nrm = (b - a).cross(&(c - a));
            t.iter().all(|&k| {
                let s = nrm.dot(&pts.normal[k]) * sign;
                !s.is_finite() || pts.normal[k].norm() < 0.5 || s > 0.0
            })
        })
    };
    let (outward, inward) = (sides(1.0), sides(-1.0));
    // a hull edge far longer than the spacing spans a part of the face
    // no bubble samples (a deep cap closed by a pyramid from its pole): a
    // finer spacing is the cure, not the hull
    if let Some(t) = tris.iter().find(|t| {
        (0..3).any(|k| {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            (pts.pos[a] - pts.pos[b]).norm() > HULL_LONG_EDGE * 0.5 * (pts.d[a] + pts.d[b])
        })
    }) {
        let p = pts.pos[t[0]];
        return Err(ConnectError::Coarse(format!(
            "its hull has an edge longer than {HULL_LONG_EDGE} spacings near ({}, {}, {})",
            p.x, p.y, p.z
        )));
    }
    let tris = match (outward, inward) {
        (true, _) => tris,
        (false, true) => tris.into_iter().map(|[a, b, c]| [a, c, b]).collect(),
        _ => {
            return Err(ConnectError::Coarse(
                "the hull of its points does not follow the surface (the face is not convex)"
                    .into(),
            ))
        }
    };
    if boundary.is_empty() && segments.is_empty() {
        return Ok(tris);
    }
    // the face's triangles: those holding a boundary segment in their
    // order, and those reached from them across other edges
    let key = |a: usize, b: usize| (a.min(b), a.max(b));
    let bset: HashSet<(usize, usize)> = boundary.iter().map(|s| (s[0], s[1])).collect();
    let cut: HashSet<(usize, usize)> = boundary.iter().map(|s| key(s[0], s[1])).collect();
    let mut by_edge: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    let mut label = vec![0i8; tris.len()];
    let mut stack = Vec::new();
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            by_edge.entry(key(a, b)).or_default().push(ti);
            if bset.contains(&(a, b)) {
                label[ti] = 1;
            } else if label[ti] == 0 && bset.contains(&(b, a)) {
                label[ti] = -1;
            }
        }
        if label[ti] != 0 {
            stack.push(ti);
        }
    }
    while let Some(ti) = stack.pop() {
        let t = tris[ti];
        for k in 0..3 {
            let e = key(t[k], t[(k + 1) % 3]);
            if cut.contains(&e) {
                continue;
            }
            for &o in &by_edge[&e] {
                if label[o] == 0 {
                    label[o] = label[ti];
                    stack.push(o);
                }
            }
        }
    }
    if label.contains(&0) {
        return Err(ConnectError::Coarse(
            "a part of its hull touches no boundary segment".into(),
        ));
    }
    let kept: Vec<[usize; 3]> = tris
        .iter()
        .zip(&label)
        .filter(|(_, &l)| l > 0)
        .map(|(t, _)| *t)
        .collect();
    if let Some(s) = first_unclosed(&kept, boundary) {
        let p = pts.pos[s[0]];
        return Err(ConnectError::Coarse(format!(
            "its boundary segment at ({}, {}, {}) is no edge of its hull",
            p.x, p.y, p.z
        )));
    }
    let edges: HashSet<(usize, usize)> = kept
        .iter()
        .flat_map(|t| (0..3).map(move |k| key(t[k], t[(k + 1) % 3])))
        .collect();
    if segments.iter().any(|s| !edges.contains(&key(s[0], s[1]))) {
        return Err(ConnectError::Coarse(
            "an embedded edge is no edge of its hull".into(),
        ));
    }
    if corners(n, &kept).contains(&false) {
        return Err(ConnectError::Coarse(
            "a point is left out of its hull's face triangles".into(),
        ));
    }
    Ok(kept)
}

/// The least cosine between a point's surface normal and the face's mean
/// normal for [`triangulate_projected`]: below it the projection onto one
/// plane squeezes the face too much to be trusted (the final checks would
/// catch a fold, but a near-edge-on projection gives needle triangles).
const PROJECT_MIN_COS: f64 = 0.2;

/// Triangulation of a whole curved face in one plane: the plane through
/// the points perpendicular to their mean normal. The fallback of a face
/// whose (u,v) triangulation cannot be made valid at this spacing — a half
/// cone with its apex on the boundary, a fillet or a small sphere sampled
/// by a handful of nodes, a face whose chords cross in (u,v) — where the
/// face is a graph over one plane (every normal within about 78° of the
/// mean). The triangles are the constrained Delaunay triangulation of the
/// projected points, so they join the face's nodes and only those.
///
/// Refused (an error) unless: every usable normal is within
/// [`PROJECT_MIN_COS`] of the mean, every boundary segment is an edge of
/// exactly one triangle, and every triangle is non-degenerate in model
/// space and faces the way of the surface normals at its corners (no
/// fold). Points with no finite normal (an apex) are projected but not
/// judged. Triangles come out oriented along the normal.
pub fn triangulate_projected(
    pts: &SurfacePoints<'_>,
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
) -> Result<Vec<[usize; 3]>, ConnectError> {
    use crate::geom::V3;
    let n = pts.pos.len();
    let usable = |v: &V3| v.iter().all(|x| x.is_finite()) && v.norm() > 0.5;
    let mean = pts
        .normal
        .iter()
        .filter(|v| usable(v))
        .fold(V3::zeros(), |a, v| a + v.normalize());
    if !(mean.norm() > 0.0) {
        return Err(ConnectError::Coarse("no usable surface normal".into()));
    }
    let nrm = mean.normalize();
    if let Some(i) = (0..n)
        .find(|&i| usable(&pts.normal[i]) && pts.normal[i].normalize().dot(&nrm) < PROJECT_MIN_COS)
    {
        let p = pts.pos[i];
        return Err(ConnectError::Coarse(format!(
            "the face is no graph over one plane (its normal turns away near ({}, {}, {}))",
            p.x, p.y, p.z
        )));
    }
    let e1 = if nrm.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let e1 = (e1 - nrm * nrm.dot(&e1)).normalize();
    let e2 = nrm.cross(&e1);
    // relative to the centroid, so that parts far from the origin keep
    // their digits
    let o = pts.pos.iter().fold(V3::zeros(), |a, p| a + p.coords) / n.max(1) as f64;
    let puv: Vec<[f64; 2]> = pts
        .pos
        .iter()
        .map(|p| {
            let d = p.coords - o;
            [d.dot(&e1), d.dot(&e2)]
        })
        .collect();
    // counter-clockwise in the plane, so facing `nrm`: (u,v) counter-
    // clockwise is counter-clockwise about S_u × S_v, and every normal has
    // a positive component along `nrm`, so `boundary` keeps the face on its
    // left
    let tris = triangulate(&puv, segments, boundary, |_| false)?;
    if let Some(s) = first_unclosed(&tris, boundary) {
        let p = pts.pos[s[0]];
        return Err(ConnectError::Coarse(format!(
            "its projection onto one plane does not close at ({}, {}, {})",
            p.x, p.y, p.z
        )));
    }
    for t in &tris {
        let (a, b, c) = (pts.pos[t[0]], pts.pos[t[1]], pts.pos[t[2]]);
        let cr = (b - a).cross(&(c - a));
        let l2 = (b - a)
            .norm_squared()
            .max((c - a).norm_squared())
            .max((c - b).norm_squared());
        let along = t
            .iter()
            .map(|&i| pts.normal[i])
            .filter(usable)
            .fold(V3::zeros(), |s, v| s + v.normalize());
        let along = if along.norm() > 0.0 { along } else { nrm };
        if !(cr.norm() > 1e-12 * l2) || cr.dot(&along) <= 0.0 {
            let p = (a.coords + b.coords + c.coords) / 3.0;
            return Err(ConnectError::Coarse(format!(
                "its projection onto one plane folds near ({}, {}, {})",
                p.x, p.y, p.z
            )));
        }
    }
    Ok(tris)
}

/// Turns every triangle to be counter-clockwise about the surface normal.
fn orient_along_normal(pts: &SurfacePoints<'_>, tris: &mut [[usize; 3]]) {
    for t in tris.iter_mut() {
        let (a, b, c) = (pts.pos[t[0]], pts.pos[t[1]], pts.pos[t[2]]);
        let nrm = pts.normal[t[0]] + pts.normal[t[1]] + pts.normal[t[2]];
        if (b - a).cross(&(c - a)).dot(&nrm) < 0.0 {
            t.swap(1, 2);
        }
    }
}

/// Whether triangle `g` (nodes) is short in model space: no edge longer
/// than [`LONG_EDGE`] spacings.
fn short_edges(pts: &SurfacePoints<'_>, g: &[usize; 3]) -> bool {
    (0..3).all(|k| {
        let (a, b) = (g[k], g[(k + 1) % 3]);
        (pts.pos[a] - pts.pos[b]).norm() <= LONG_EDGE * 0.5 * (pts.d[a] + pts.d[b])
    })
}

/// Whether triangle `g` (nodes), at `uv` in the surface-scaled (u,v), is
/// flat there against model space, or has a node twice ([`FLAT_UV`]).
fn flat_in_uv(pts: &SurfacePoints<'_>, uv: [[f64; 2]; 3], g: [usize; 3]) -> bool {
    let [a, b, q] = uv;
    let uv_area = 0.5 * ((b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])).abs();
    let [pa, pb, pc] = g.map(|i| pts.pos[i]);
    let repeated = g[0] == g[1] || g[1] == g[2] || g[0] == g[2];
    repeated || uv_area < FLAT_UV * crate::measure::triangle_area(&pa, &pb, &pc)
}

/// The (u,v) triangles `tris` less the long ones and the `flat` ones,
/// their holes filled in the tangent plane ([`fill_caps`]): a dimple whose
/// boundary nodes all lie on one (u,v) line is its tangent-plane fill
/// around the pole. An error where none is flat.
fn fill_flat_triangles(
    pts: &SurfacePoints<'_>,
    tris: &[[usize; 3]],
    flat: &[bool],
    boundary: &[[usize; 2]],
) -> Result<Vec<[usize; 3]>, ConnectError> {
    if !flat.iter().any(|&f| f) {
        return Err(ConnectError::Coarse(
            "no (u,v) triangle is flat against the surface".into(),
        ));
    }
    let (mut kept, mut dropped) = (Vec::new(), Vec::new());
    for (t, &f) in tris.iter().zip(flat) {
        if !f && short_edges(pts, t) {
            kept.push(*t);
        } else {
            dropped.push(*t);
        }
    }
    fill_caps(pts, &mut kept, boundary, &dropped)?;
    orient_along_normal(pts, &mut kept);
    Ok(kept)
}

/// A (u,v) triangle whose area in the surface-scaled (u,v) is below this
/// fraction of its model-space area, or that has a node twice (two
/// periodic copies of one node), marks a degenerate place of the
/// parametrization ([`triangulate_surface_filling_flat`], the last
/// fallback of a face's connection): a spherical dimple bounded by one
/// circle of latitude has every boundary node on one (u,v) line, and the
/// triangulation of those nodes (the pole is left out)
/// gave slivers in (u,v) that were chords across the dimple's mouth in
/// model space (rp_5_004's dimple at diag/25: refused with its circle
/// points, which were then dropped for the whole part). A regular
/// parametrization scaled to the surface keeps the two areas within a
/// small factor of each other; a pole's neighbourhood stretches (u,v),
/// never shrinks it.
const FLAT_UV: f64 = 1e-3;

/// An edge of a (u,v) triangle longer than this many spacings marks a
/// distorted place of the parametrization (see [`triangulate_surface`]).
const LONG_EDGE: f64 = 2.0;

/// Fills every hole of `tris` bounded by edges that are not boundary
/// segments, with the points that lost all their triangles (singular
/// points, points under a dropped lid) in it, in the hole's tangent plane.
///
/// `dropped` are the triangles taken out of `tris` (none for singular
/// points alone): the hole loops and points they join are one hole — the
/// ring of triangles dropped between a face's inner boundary loop around a
/// pole and the rest of the mesh is an annulus, filled with both loops as
/// its sides. Points no dropped triangle reaches (singular points) go to
/// the hole with the nearest vertex. Each point is in at most one cap.
fn fill_caps(
    pts: &SurfacePoints<'_>,
    tris: &mut Vec<[usize; 3]>,
    boundary: &[[usize; 2]],
    dropped: &[[usize; 3]],
) -> Result<(), ConnectError> {
    let n = pts.uv.len();
    // orient the (u,v) triangles along the normal so hole sides are known
    orient_along_normal(pts, tris);
    let hole = hole_edges(tris, boundary);
    let used = corners(n, tris);
    let orphans: Vec<usize> = (0..n).filter(|&i| !used[i]).collect();
    if hole.is_empty() {
        return if orphans.is_empty() {
            Ok(())
        } else {
            Err(ConnectError::Coarse(format!(
                "{} points lost their triangles but no hole was found",
                orphans.len()
            )))
        };
    }
    let links: Vec<[usize; 2]> = dropped
        .iter()
        .flat_map(|t| [[t[0], t[1]], [t[1], t[2]]])
        .collect();
    let comps = hole_components(&hole, &links);
    let mut in_comp = vec![false; n];
    for c in &comps {
        for &v in c {
            in_comp[v] = true;
        }
    }
    // the other orphans go to the component with the nearest vertex
    let mut inner: Vec<Vec<usize>> = vec![Vec::new(); comps.len()];
    for &o in orphans.iter().filter(|&&o| !in_comp[o]) {
        let mut best = (f64::INFINITY, 0);
        for (k, c) in comps.iter().enumerate() {
            for &v in c {
                let dd = (pts.pos[o] - pts.pos[v]).norm();
                if dd < best.0 {
                    best = (dd, k);
                }
            }
        }
        inner[best.1].push(o);
    }
    for (k, comp) in comps.iter().enumerate() {
        let local: Vec<usize> = comp.iter().chain(inner[k].iter()).cloned().collect();
        let cap = tangent_cap(pts, &local, &hole)?;
        for t in cap {
            tris.push([local[t[0]], local[t[1]], local[t[2]]]);
        }
    }
    Ok(())
}

/// The half-edges of the holes of `tris`, directed with the hole on their
/// left: edges used by one triangle that are not boundary segments, and
/// boundary segments no triangle uses.
fn hole_edges(tris: &[[usize; 3]], boundary: &[[usize; 2]]) -> Vec<[usize; 2]> {
    let bset: HashSet<(usize, usize)> = boundary
        .iter()
        .map(|s| (s[0].min(s[1]), s[0].max(s[1])))
        .collect();
    let mut uses: HashMap<(usize, usize), (usize, usize, u32)> = HashMap::new();
    for t in tris.iter() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let e = uses.entry((a.min(b), a.max(b))).or_insert((a, b, 0));
            e.2 += 1;
        }
    }
    // hole half-edges, directed with the hole on their left
    let mut hole: Vec<[usize; 2]> = uses
        .iter()
        .filter(|(k, v)| v.2 == 1 && !bset.contains(k))
        .map(|(_, v)| [v.1, v.0])
        .collect();
    // A boundary segment no triangle uses bounds the hole too: a singular
    // point next to the face's boundary took the triangles on that segment
    // with it (seen on the corner spheres of a filleted box, where the
    // whole face is within a few spacings of its pole). Each such segment
    // is turned so that the hole's edges close into loops: in-degree equals
    // out-degree at every vertex.
    let mut unused: Vec<[usize; 2]> = boundary
        .iter()
        .filter(|s| !uses.contains_key(&(s[0].min(s[1]), s[0].max(s[1]))))
        .cloned()
        .collect();
    if !unused.is_empty() {
        let mut excess: HashMap<usize, i32> = HashMap::new(); // out − in
        for &[a, b] in &hole {
            *excess.entry(a).or_default() += 1;
            *excess.entry(b).or_default() -= 1;
        }
        // a segment whose turn is forced by an open chain end goes first;
        // the rest keep their direction (a hole bounded by segments alone)
        for _ in 0..=unused.len() {
            let before = unused.len();
            unused.retain(|&[a, b]| {
                let (ea, eb) = (
                    excess.get(&a).copied().unwrap_or(0),
                    excess.get(&b).copied().unwrap_or(0),
                );
                let dir = if ea < 0 || eb > 0 {
                    [a, b]
                } else if eb < 0 || ea > 0 {
                    [b, a]
                } else {
                    return true;
                };
                *excess.entry(dir[0]).or_default() += 1;
                *excess.entry(dir[1]).or_default() -= 1;
                hole.push(dir);
                false
            });
            if unused.is_empty() || unused.len() == before {
                break;
            }
        }
        hole.extend(unused);
    }
    // in a fixed order: the first ones came out of a HashMap, whose order
    // changes from run to run, and the cap's triangles came out in another
    // order on some runs (rp_5_025's void as tetrahedra)
    hole.sort_unstable();
    hole
}

/// The vertices of each connected component of the hole edges joined also
/// by `links` (edges of dropped triangles), each sorted by vertex id;
/// components in the order of their smallest vertex. A dropped region's
/// sides are hole edges (kept triangles' edges or unused boundary
/// segments), so links join hole loops and never make a component alone.
fn hole_components(hole: &[[usize; 2]], links: &[[usize; 2]]) -> Vec<Vec<usize>> {
    // connected components of the hole edges and links (union-find)
    let mut parent: HashMap<usize, usize> = HashMap::new();
    fn find(p: &mut HashMap<usize, usize>, x: usize) -> usize {
        let mut r = x;
        while let Some(&q) = p.get(&r) {
            if q == r {
                break;
            }
            r = q;
        }
        p.insert(x, r);
        r
    }
    for &[a, b] in hole.iter().chain(links) {
        parent.entry(a).or_insert(a);
        parent.entry(b).or_insert(b);
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            parent.insert(ra, rb);
        }
    }
    let mut comp_of: HashMap<usize, usize> = HashMap::new();
    let mut comps: Vec<Vec<usize>> = Vec::new();
    let mut keys: Vec<usize> = parent.keys().cloned().collect();
    keys.sort_unstable();
    for v in keys {
        let r = find(&mut parent, v);
        let k = *comp_of.entry(r).or_insert_with(|| {
            comps.push(Vec::new());
            comps.len() - 1
        });
        comps[k].push(v);
    }
    comps
}

/// Triangles filling a hole in its tangent plane: `local` are its vertices
/// (the hole's and the orphans'), the result's indices are into `local`.
/// An error when the fill folds or does not close the hole.
fn tangent_cap(
    pts: &SurfacePoints<'_>,
    local: &[usize],
    hole: &[[usize; 2]],
) -> Result<Vec<[usize; 3]>, ConnectError> {
    let index: HashMap<usize, usize> = local.iter().enumerate().map(|(i, &g)| (g, i)).collect();
    let nrm = local
        .iter()
        .fold(crate::geom::V3::zeros(), |a, &i| a + pts.normal[i]);
    let nrm = if nrm.norm() > 0.0 {
        nrm.normalize()
    } else {
        crate::geom::V3::z()
    };
    let e1 = if nrm.x.abs() < 0.9 {
        crate::geom::V3::x()
    } else {
        crate::geom::V3::y()
    };
    let e1 = (e1 - nrm * nrm.dot(&e1)).normalize();
    let e2 = nrm.cross(&e1);
    let o = pts.pos[local[0]];
    let puv: Vec<[f64; 2]> = local
        .iter()
        .map(|&i| {
            let d = pts.pos[i] - o;
            [d.dot(&e1), d.dot(&e2)]
        })
        .collect();
    let segs: Vec<[usize; 2]> = hole
        .iter()
        .filter(|s| index.contains_key(&s[0]) && index.contains_key(&s[1]))
        .map(|s| [index[&s[0]], index[&s[1]]])
        .collect();
    let cap = triangulate(&puv, &segs, &segs, |_| false).map_err(|e| match e {
        ConnectError::Crossing(..) | ConnectError::Duplicate(..) => ConnectError::Coarse(format!(
            "a hole around a pole or a tight bend folds in its tangent plane: {e}"
        )),
        other => other,
    })?;
    // the cap must close the hole: every hole edge used by exactly one
    // of its triangles (otherwise the face would come out with a hole,
    // silently). An orphan the cap leaves out lies between a boundary
    // segment and its curve, outside the chord polygon: the caller
    // drops such bubbles.
    if let Some(s) = first_unclosed(&cap, &segs) {
        let p = pts.pos[local[s[0]]];
        return Err(ConnectError::Coarse(format!(
            "a hole around a pole or a tight bend near ({}, {}, {}) is not closed by its tangent-plane fill",
            p.x, p.y, p.z
        )));
    }
    Ok(cap)
}

/// Per point of `n`, whether it is a corner of one of `tris`.
pub(crate) fn corners(n: usize, tris: &[[usize; 3]]) -> Vec<bool> {
    let mut used = vec![false; n];
    for t in tris {
        for &v in t {
            used[v] = true;
        }
    }
    used
}

/// The first of `segments` that is not an edge of exactly one of `tris`
/// (a hole left open, or a segment covered twice).
fn first_unclosed<'s>(tris: &[[usize; 3]], segments: &'s [[usize; 2]]) -> Option<&'s [usize; 2]> {
    let mut uses: HashMap<(usize, usize), u32> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    segments
        .iter()
        .find(|s| uses.get(&(s[0].min(s[1]), s[0].max(s[1]))) != Some(&1))
}

/// The first edge of `tris` not in as many triangles as a closed cover of
/// the face needs: one per loop segment of `directed` along it (a seam's
/// two, one each way), two elsewhere (embedded edges too). A connection
/// that fails it has a gap or an overlap the final check would refuse.
pub(crate) fn first_gap(tris: &[[usize; 3]], directed: &[[usize; 2]]) -> Option<[usize; 2]> {
    let key = |a: usize, b: usize| (a.min(b), a.max(b));
    let mut needed: HashMap<(usize, usize), u32> = HashMap::new();
    for s in directed {
        *needed.entry(key(s[0], s[1])).or_default() += 1;
    }
    let mut uses: HashMap<(usize, usize), u32> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            *uses.entry(key(t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    // the least such edge, not the first of a hash map's order: the error
    // message is the same from run to run
    uses.iter()
        .filter(|(e, &n)| n != needed.get(e).copied().unwrap_or(2))
        .map(|(e, _)| [e.0, e.1])
        .min()
}

/// The first pair of points of `pos` closer than `tol` (model units) of
/// which at least one is at index `from` or later (the free bubbles of a
/// face, after its `from` fixed nodes), in index order. Two such nodes of
/// one face have distinct (u,v) (either side of a seam, or at a pole) and
/// the same point on the surface: their triangles fold over each other,
/// which a check of the connection's edges does not see.
pub(crate) fn first_coincident(pos: &[P3], from: usize, tol: f64) -> Option<[usize; 2]> {
    if !(tol > 0.0 && tol.is_finite()) {
        return None;
    }
    // a hash grid of cell `tol`: a pair within it lies in adjacent cells
    let cell = |p: &P3| [p.x, p.y, p.z].map(|c| (c / tol).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, p) in pos.iter().enumerate() {
        grid.entry(cell(p)).or_default().push(i);
    }
    let mut found: Option<[usize; 2]> = None;
    for (i, p) in pos.iter().enumerate().skip(from) {
        let c = cell(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(v) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    for &j in v {
                        if j != i && (pos[j] - p).norm() < tol {
                            let pair = [i.min(j), i.max(j)];
                            found = Some(found.map_or(pair, |f| f.min(pair)));
                        }
                    }
                }
            }
        }
    }
    found
}

/// Signed area of a triangle of `uv` (positive when counter-clockwise).
#[cfg(test)]
fn signed_area(uv: &[[f64; 2]], t: [usize; 3]) -> f64 {
    let (a, b, c) = (uv[t[0]], uv[t[1]], uv[t[2]]);
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two free nodes at one point (either side of a seam, or at a pole)
    /// are found; a free node on a fixed one too; two fixed ones (a
    /// degenerate edge's ends) are the edge meshes' business; points
    /// farther apart than the tolerance are not a pair.
    #[test]
    fn coincident_nodes_of_a_face_are_found() {
        let p = |x: f64, y: f64| P3::new(x, y, 1.0e3);
        let pts = [
            p(0.0, 0.0),
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(2.0, 0.5),
            p(2.0, 0.5),
        ];
        assert_eq!(first_coincident(&pts, 2, 1e-9), Some([3, 4]));
        assert_eq!(
            first_coincident(&pts[..4], 2, 1e-9),
            None,
            "fixed pair only"
        );
        let on_fixed = [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 0.0)];
        assert_eq!(first_coincident(&on_fixed, 2, 1e-9), Some([1, 2]));
        let near = [p(0.0, 0.0), p(0.0, 1e-6)];
        assert_eq!(first_coincident(&near, 0, 1e-9), None);
        assert_eq!(first_coincident(&near, 0, 1e-5), Some([0, 1]));
    }

    /// The wall of a hole far smaller than the spacing: two rings of five
    /// nodes 0.001 apart on a cylinder of radius 0.025, with a spacing
    /// below the rings' segments, so every (u,v) triangle is "long". Its
    /// hole is a tube that no tangent plane can take; the (u,v)
    /// triangulation is kept instead: ten triangles, each boundary segment
    /// in exactly one.
    #[test]
    fn band_narrower_than_the_spacing_keeps_its_uv_triangles() {
        let tau = std::f64::consts::TAU;
        let (r, h) = (0.025, 0.001);
        let mut uv = Vec::new();
        let mut pos = Vec::new();
        let mut normal = Vec::new();
        for (v, phase) in [(0.0, 0.0), (h, 0.5)] {
            for k in 0..5 {
                let u = (k as f64 + phase) * tau / 5.0;
                uv.push([u, v]);
                pos.push(crate::geom::P3::new(r * u.cos(), r * u.sin(), v));
                normal.push(crate::geom::V3::new(u.cos(), u.sin(), 0.0));
            }
        }
        // bottom ring: u increasing (band on its left); top: decreasing
        let mut directed: Vec<[usize; 2]> = (0..5).map(|k| [k, (k + 1) % 5]).collect();
        directed.extend((0..5).map(|k| [5 + (k + 1) % 5, 5 + k]));
        let d = vec![0.005; 10];
        let singular = vec![false; 10];
        let pts = SurfacePoints {
            uv: &uv,
            pos: &pos,
            normal: &normal,
            d: &d,
            singular: &singular,
            periods: [Some(tau), None],
            origin: [0.0, -1.0],
            scale: [r, 1.0],
        };
        let tris = triangulate_surface(&pts, &directed, &directed).unwrap();
        assert_eq!(tris.len(), 10);
        for s in &directed {
            let uses = tris
                .iter()
                .filter(|t| {
                    (0..3).any(|k| {
                        let e = [t[k], t[(k + 1) % 3]];
                        e == *s || e == [s[1], s[0]]
                    })
                })
                .count();
            assert_eq!(uses, 1, "segment {s:?}");
        }
    }

    /// Parameters, positions, normals and the directed boundary of a
    /// test face.
    type TestFace = (
        Vec<[f64; 2]>,
        Vec<crate::geom::P3>,
        Vec<crate::geom::V3>,
        Vec<[usize; 2]>,
    );

    /// A half cone of semi-angle 59° with its apex on the boundary (as
    /// face #6366 of `as_0083` in `../shared/realstep`, meshed at a spacing
    /// larger than the face): points on rings s = ½ and s = 1, the apex a
    /// boundary vertex with no usable normal. (u, v) = (θ, s).
    fn half_cone() -> TestFace {
        use crate::geom::{P3, V3};
        let a = 59f64.to_radians();
        let point =
            |th: f64, s: f64| P3::new(s * a.sin() * th.cos(), s * a.sin() * th.sin(), s * a.cos());
        let normal = |th: f64, s: f64| -> V3 {
            let su = V3::new(-th.sin(), th.cos(), 0.0) * (s * a.sin());
            let sv = V3::new(a.sin() * th.cos(), a.sin() * th.sin(), a.cos());
            let n = su.cross(&sv);
            if n.norm() > 0.0 {
                n.normalize()
            } else {
                V3::zeros()
            }
        };
        let pi = std::f64::consts::PI;
        // counter-clockwise in (θ, s): apex, up the side θ = π, back along
        // the rim s = 1, down the side θ = 0
        let mut uv = vec![[0.5 * pi, 0.0], [pi, 0.5]];
        for k in 0..=6 {
            uv.push([pi * (1.0 - k as f64 / 6.0), 1.0]);
        }
        uv.push([0.0, 0.5]);
        let nb = uv.len();
        let directed: Vec<[usize; 2]> = (0..nb).map(|k| [k, (k + 1) % nb]).collect();
        // free bubbles inside
        for k in 1..4 {
            uv.push([pi * k as f64 / 4.0, 0.6]);
        }
        let pos = uv.iter().map(|q| point(q[0], q[1])).collect();
        let nrm = uv.iter().map(|q| normal(q[0], q[1])).collect();
        (uv, pos, nrm, directed)
    }

    #[test]
    fn half_cone_with_its_apex_on_the_boundary_connects_in_one_plane() {
        let (uv, pos, normal, directed) = half_cone();
        let n = uv.len();
        let (d, singular) = (vec![2.0; n], vec![false; n]);
        let pts = SurfacePoints {
            uv: &uv,
            pos: &pos,
            normal: &normal,
            d: &d,
            singular: &singular,
            periods: [None, None],
            origin: [0.0, 0.0],
            scale: [1.0, 1.0],
        };
        let tris = triangulate_projected(&pts, &directed, &directed).unwrap();
        // Euler: a disc with n points, nb on its boundary has 2n − nb − 2
        // triangles, and every point is used
        assert_eq!(tris.len(), 2 * n - directed.len() - 2);
        let mut used = vec![false; n];
        for t in &tris {
            for &v in t {
                used[v] = true;
            }
            // faces the surface's normal (outward of the cone's axis)
            let (a, b, c) = (pos[t[0]], pos[t[1]], pos[t[2]]);
            let nrm = (b - a).cross(&(c - a));
            let along: crate::geom::V3 = t.iter().map(|&i| normal[i]).sum();
            assert!(nrm.dot(&along) > 0.0, "triangle {t:?} folds");
        }
        assert!(used.iter().all(|&u| u));
        for s in &directed {
            let uses = tris
                .iter()
                .filter(|t| (0..3).any(|k| [t[k], t[(k + 1) % 3]] == *s))
                .count();
            assert_eq!(uses, 1, "boundary segment {s:?} once and in its direction");
        }
    }

    #[test]
    fn a_face_that_is_no_graph_over_one_plane_is_not_projected() {
        use crate::geom::{P3, V3};
        // a hemisphere's rim and pole: normals from vertical to horizontal
        let tau = std::f64::consts::TAU;
        let mut uv = Vec::new();
        for k in 0..8 {
            uv.push([tau * k as f64 / 8.0, 0.0]);
        }
        uv.push([0.0, 0.5 * std::f64::consts::PI]);
        let pos: Vec<P3> = uv
            .iter()
            .map(|q| P3::new(q[1].cos() * q[0].cos(), q[1].cos() * q[0].sin(), q[1].sin()))
            .collect();
        let normal: Vec<V3> = pos.iter().map(|p| p.coords).collect();
        let directed: Vec<[usize; 2]> = (0..8).map(|k| [k, (k + 1) % 8]).collect();
        let (d, singular) = (vec![1.0; 9], vec![false; 9]);
        let pts = SurfacePoints {
            uv: &uv,
            pos: &pos,
            normal: &normal,
            d: &d,
            singular: &singular,
            periods: [Some(tau), None],
            origin: [0.0, -1.0],
            scale: [1.0, 1.0],
        };
        let e = triangulate_projected(&pts, &directed, &directed).unwrap_err();
        assert!(e.to_string().contains("no graph over one plane"), "{e}");
    }

    /// Co-circular points (a regular octagon plus centre) are the classic
    /// degenerate in-circle case; the result must still be a valid
    /// triangulation covering the octagon.
    #[test]
    fn cocircular_points_triangulate() {
        let mut uv: Vec<[f64; 2]> = (0..8)
            .map(|k| {
                let a = k as f64 * std::f64::consts::FRAC_PI_4;
                [a.cos(), a.sin()]
            })
            .collect();
        uv.push([0.0, 0.0]);
        let t = triangulate(&uv, &[], &[], |_| true).unwrap();
        assert_eq!(t.len(), 8);
        let area: f64 = t.iter().map(|t| signed_area(&uv, *t)).sum();
        assert!((area - 2.0 * 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn constraint_edge_is_kept_against_delaunay() {
        // the Delaunay edge would be 2-3; the constraint forces 0-1
        let uv = [[0.0, 0.0], [3.0, 0.0], [1.5, 0.2], [1.5, -0.2]];
        let t = triangulate(&uv, &[[0, 1]], &[], |_| true).unwrap();
        let has = t.iter().any(|t| {
            (0..3).any(|k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                (a, b) == (0, 1) || (a, b) == (1, 0)
            })
        });
        assert!(has);
    }

    #[test]
    fn duplicate_point_is_an_error() {
        let uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]];
        assert!(matches!(
            triangulate(&uv, &[], &[], |_| true),
            Err(ConnectError::Duplicate(..))
        ));
    }

    /// A coordinate that is a round-off residue of zero (below spade's
    /// smallest accepted magnitude) triangulates as zero.
    #[test]
    fn underflowing_coordinate_is_zero() {
        let uv = [[0.0, 0.0], [1.0, 1e-45], [0.0, 1.0]];
        let t = triangulate(&uv, &[], &[], |_| true).unwrap();
        assert_eq!(t.len(), 1);
    }

    #[test]
    fn crossing_constraints_are_an_error() {
        let uv = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(matches!(
            triangulate(&uv, &[[0, 1], [2, 3]], &[], |_| true),
            Err(ConnectError::Crossing(..))
        ));
    }
}

#[cfg(test)]
mod classification {
    use super::*;

    /// A boundary node pushed a hair inward makes a sliver outside the
    /// region; the topological classification drops it where a centroid
    /// test in floating point may not.
    #[test]
    fn sliver_outside_a_nearly_straight_side_is_dropped() {
        let uv = [
            [0.0, 0.0],
            [0.5, 1e-17],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.5, 0.5],
        ];
        let b = [[0, 1], [1, 2], [2, 3], [3, 4], [4, 0]];
        let t = triangulate(&uv, &b, &b, |_| true).unwrap();
        let area: f64 = t.iter().map(|t| signed_area(&uv, *t)).sum();
        assert!((area - 1.0).abs() < 1e-12, "area {area}");
        for tri in &t {
            assert!(signed_area(&uv, *tri) > 1e-6, "sliver kept: {tri:?}");
        }
    }

    #[test]
    fn hole_is_removed() {
        let uv = [
            [0.0, 0.0],
            [3.0, 0.0],
            [3.0, 3.0],
            [0.0, 3.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [2.0, 2.0],
            [2.0, 1.0], // hole, clockwise
        ];
        let b = [
            [0, 1],
            [1, 2],
            [2, 3],
            [3, 0],
            [4, 5],
            [5, 6],
            [6, 7],
            [7, 4],
        ];
        let t = triangulate(&uv, &b, &b, |_| true).unwrap();
        let area: f64 = t.iter().map(|t| signed_area(&uv, *t)).sum();
        assert!((area - 8.0).abs() < 1e-12, "area {area}");
    }

    /// [`triangulate_hull`] of points at `pos` with surface normals
    /// `normal`, a spacing of 1 (the (u,v) are not used by the hull), the
    /// directed `boundary` as its only segments.
    fn hull_of(
        pos: &[crate::geom::P3],
        normal: &[crate::geom::V3],
        boundary: &[[usize; 2]],
    ) -> Result<Vec<[usize; 3]>, ConnectError> {
        let n = pos.len();
        let (uv, d, singular) = (vec![[0.0, 0.0]; n], vec![1.0; n], vec![false; n]);
        let pts = SurfacePoints {
            uv: &uv,
            pos,
            normal,
            d: &d,
            singular: &singular,
            periods: [None, None],
            origin: [0.0, 0.0],
            scale: [1.0, 1.0],
        };
        triangulate_hull(&pts, boundary, boundary)
    }

    /// The hull of a closed face's points (none when refused).
    fn closed(pos: &[crate::geom::P3], normal: &[crate::geom::V3]) -> Vec<[usize; 3]> {
        hull_of(pos, normal, &[]).unwrap_or_default()
    }

    /// A sphere sampled by a dozen points (a void far below the spacing):
    /// its hull is a closed surface (every edge in two triangles, Euler
    /// characteristic 2) with every point a corner and every triangle
    /// facing out along the normal, here the outward one, then the inward
    /// one (a void's face turned the other way).
    #[test]
    fn a_small_sphere_is_connected_as_its_hull() {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let n = 12;
        let c = crate::geom::P3::new(1e3, -2e3, 5e2); // far from the origin
        let r = 0.3;
        let dirs: Vec<crate::geom::V3> = (0..n)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
                let s = (1.0 - z * z).sqrt();
                let a = golden * k as f64;
                crate::geom::V3::new(s * a.cos(), s * a.sin(), z)
            })
            .collect();
        let pos: Vec<crate::geom::P3> = dirs.iter().map(|u| c + u * r).collect();
        for sign in [1.0, -1.0] {
            let normal: Vec<crate::geom::V3> = dirs.iter().map(|u| u * sign).collect();
            let t = closed(&pos, &normal);
            assert_eq!(t.len(), 2 * n - 4, "sign {sign}");
            let mut uses: HashMap<(usize, usize), i32> = HashMap::new();
            for tri in &t {
                let nrm = (pos[tri[1]] - pos[tri[0]]).cross(&(pos[tri[2]] - pos[tri[0]]));
                for k in 0..3 {
                    assert!(nrm.dot(&normal[tri[k]]) > 0.0, "a triangle faces inwards");
                    *uses.entry((tri[k], tri[(k + 1) % 3])).or_default() += 1;
                }
            }
            // each directed edge once, and its reverse too: closed, oriented
            assert!(uses
                .iter()
                .all(|(&(a, b), &u)| u == 1 && uses.get(&(b, a)) == Some(&1)));
        }
    }

    /// Points that are not in convex position (one inside the hull of the
    /// others, a dent) are refused, not triangulated around.
    #[test]
    fn a_non_convex_closed_face_is_not_connected_as_a_hull() {
        let v = |x: f64, y: f64, z: f64| crate::geom::V3::new(x, y, z);
        let dirs = [
            v(1.0, 0.0, 0.0),
            v(-1.0, 0.0, 0.0),
            v(0.0, 1.0, 0.0),
            v(0.0, -1.0, 0.0),
            v(0.0, 0.0, 1.0),
            v(0.0, 0.0, -1.0),
        ];
        let mut pos: Vec<crate::geom::P3> =
            dirs.iter().map(|u| crate::geom::P3::origin() + u).collect();
        let mut normal: Vec<crate::geom::V3> = dirs.to_vec();
        // a dent: a point pushed in towards the centre
        pos.push(crate::geom::P3::new(0.2, 0.2, 0.2));
        normal.push(v(1.0, 1.0, 1.0).normalize());
        assert!(closed(&pos, &normal).is_empty());
    }

    /// A sphere less a cap (a void cut by a larger one), sampled coarsely:
    /// the hull's triangles over the hole (its lid, all corners on the
    /// rim) are left out, every rim segment lies in one kept triangle, and
    /// every point is a corner.
    #[test]
    fn a_sphere_less_a_cap_is_its_hull_less_the_lid() {
        let (r, m) = (1.0, 6);
        let rim_z: f64 = 0.6;
        let rho = (r * r - rim_z * rim_z).sqrt();
        let tau = std::f64::consts::TAU;
        let mut pos = Vec::new();
        // the rim, clockwise seen from +z (the face, below it, on its left
        // seen from outside)
        for k in 0..m {
            let a = -tau * k as f64 / m as f64;
            pos.push(crate::geom::P3::new(rho * a.cos(), rho * a.sin(), rim_z));
        }
        // two rings below and the south pole
        for (z, n) in [(0.0, 7), (-0.7, 5)] {
            let rr: f64 = (r * r - z * z).sqrt();
            for k in 0..n {
                let a = tau * (k as f64 + 0.3) / n as f64;
                pos.push(crate::geom::P3::new(rr * a.cos(), rr * a.sin(), z));
            }
        }
        pos.push(crate::geom::P3::new(0.0, 0.0, -r));
        let normal: Vec<crate::geom::V3> = pos.iter().map(|p| p.coords / r).collect();
        let boundary: Vec<[usize; 2]> = (0..m).map(|k| [k, (k + 1) % m]).collect();
        let n = pos.len();
        let t = hull_of(&pos, &normal, &boundary).expect("hull");
        assert!(
            t.iter().all(|t| !t.iter().all(|&v| v < m)),
            "a lid triangle was kept"
        );
        assert!(first_unclosed(&t, &boundary).is_none());
        let mut used = vec![false; n];
        t.iter().flatten().for_each(|&v| used[v] = true);
        assert!(used.iter().all(|&u| u));
        // Euler: a disc (V − E + F = 1)
        let mut edges = HashSet::new();
        for tri in &t {
            for k in 0..3 {
                edges.insert((tri[k].min(tri[(k + 1) % 3]), tri[k].max(tri[(k + 1) % 3])));
            }
        }
        assert_eq!(n as i64 - edges.len() as i64 + t.len() as i64, 1);
    }

    /// A square of four boundary nodes and a centre: four triangles cover
    /// it once; without one the centre's edges to its corners are in one
    /// triangle (a gap), and a fifth triangle over one makes an edge of
    /// three (an overlap). A seam segment used both ways needs two.
    #[test]
    fn a_gap_or_an_overlap_is_found_and_a_seam_is_not() {
        let directed = [[0, 1], [1, 2], [2, 3], [3, 0]];
        let fan = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        assert_eq!(first_gap(&fan, &directed), None);
        assert!(first_gap(&fan[..3], &directed).is_some(), "a gap");
        let mut over = fan.clone();
        over.push([0, 1, 2]);
        assert!(first_gap(&over, &directed).is_some(), "an overlap");
        // 0-1 a seam: the loop runs along it both ways, a triangle each side
        let seam = [[0, 1], [1, 2], [2, 0], [1, 0], [0, 3], [3, 1]];
        assert_eq!(first_gap(&[[0, 1, 2], [1, 0, 3]], &seam), None);
        assert!(
            first_gap(&[[0, 1, 2]], &seam).is_some(),
            "a seam in one triangle"
        );
    }
}
