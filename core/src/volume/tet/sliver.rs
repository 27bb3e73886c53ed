//! Sliver removal after the volume connection (not in the thesis; its
//! §5.1.4 tetrahedra come straight from Delaunay).
//!
//! A Delaunay tetrahedralization of well-packed bubbles still holds
//! *slivers*: four nearly cospherical, nearly coplanar points make a flat
//! tetrahedron with a good circumsphere but a tiny volume. They are removed
//! here by flips that raise the worst tetrahedron they touch
//! ([`super::flip::raise_worst`]), then by moving the free corners of
//! what the flips leave: a pattern search over small moves
//! (at most [`SliverParams::max_move`]·d in total) that raises the worst radius ratio of
//! the node's star, accepted only when every tetrahedron of the star stays
//! positively oriented (exact `orient3d`). Neither touches a boundary
//! triangle, so the boundary stays exactly the faces' meshes, and no node
//! leaves its volume (a node inside a valid star cannot cross the star's
//! outer faces).

use super::mesh::TetMesh;
use super::star::{node_tets, objective_of, Star, TARGET_Q};
use crate::geom::{P3, V3};

/// The sliver pass's tuning.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SliverParams {
    /// Tetrahedra whose objective is below this are worked on
    /// ([`TARGET_Q`]; a higher one asks for more where the mesh is small).
    pub target: f64,
    /// Rounds of the pattern search per smoothing pass.
    pub rounds: usize,
    /// Rounds of flips and pattern search in [`remove_slivers`].
    pub flip_smooth_rounds: usize,
    /// Largest move of a node per smoothing pass, in units of its spacing.
    pub max_move: f64,
    /// The flips between the searches.
    pub flips: super::flip::FlipParams,
}

impl Default for SliverParams {
    fn default() -> Self {
        SliverParams {
            target: TARGET_Q,
            rounds: 4,
            flip_smooth_rounds: 3,
            max_move: 0.35,
            flips: Default::default(),
        }
    }
}

/// What sliver removal did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SliverStats {
    /// Tetrahedra below the pass's target (`TARGET_Q` by default) before
    /// and after, and the worst objective.
    pub bad_before: usize,
    /// Tetrahedra below the target after.
    pub bad_after: usize,
    /// The worst objective before.
    pub min_q_before: f64,
    /// The worst objective after.
    pub min_q_after: f64,
    /// Node moves.
    pub moves: usize,
    /// Edge removals and 2-3 flips.
    pub flips: usize,
}

/// The sliver pass: flips and moves of free nodes (`mesh.movable`) that
/// raise the worst [`objective`](super::star::objective) of the
/// tetrahedra below `params.target` ([`TARGET_Q`] by default). Tetrahedra must be positively oriented
/// and stay so; boundary faces and fixed nodes are never touched.
pub(crate) fn remove_slivers(mesh: &mut TetMesh, params: &SliverParams) -> SliverStats {
    let qs = mesh.objectives();
    remove_slivers_given(mesh, params, qs)
}

/// [`remove_slivers`] given every tetrahedron's
/// [`objective`](super::star::objective) (`qs[i]` of `mesh.tets[i]`), for
/// a caller that has just computed them.
pub(crate) fn remove_slivers_given(
    mesh: &mut TetMesh,
    params: &SliverParams,
    // every tetrahedron's objective, kept current through the passes and
    // flips (one evaluation of the mesh instead of one per pass and sweep)
    mut qs: Vec<f64>,
) -> SliverStats {
    debug_assert_eq!(qs.len(), mesh.tets.len());
    let mut stats = SliverStats {
        bad_before: qs.iter().filter(|&&q| q < params.target).count(),
        min_q_before: qs.iter().cloned().fold(1.0, f64::min),
        ..Default::default()
    };
    // flips first, then the node search on what they leave: a flip round
    // costs a table of the mesh, a node search some fifty star evaluations
    // per node. Measured on case K (BCC, one thread): the flips take 25,296
    // bad tetrahedra to 3,707 in 1.0 s and the pass takes 2.6 s instead of
    // 3.0 s (smoothing first: 1.8 s for the first search alone), with
    // min radius ratio 0.550 instead of 0.533 and no tetrahedron left
    // below the target (10 before); cases H, I, J: the same worst
    // tetrahedra or better, means within 0.0004.
    stats.bad_after = stats.bad_before;
    stats.min_q_after = stats.min_q_before;
    for _ in 0..params.flip_smooth_rounds {
        if stats.bad_after == 0 {
            break;
        }
        stats.flips += super::flip::raise_worst(mesh, &params.flips, params.target, &mut qs);
        let s = search_moves(mesh, params, &mut qs);
        stats.moves += s.moves;
        stats.bad_after = s.bad_after;
        stats.min_q_after = s.min_q_after;
    }
    stats
}

/// [`remove_slivers`] where few tetrahedra are below `params.target`: the same
/// passes on the part of the mesh around them only. The part is the stars
/// of the bad tetrahedra's nodes and of their neighbours; only those nodes
/// (whose whole star is in the part) may move, and a flip needs a closed
/// edge ring or a face with two tetrahedra in the part, which are then the
/// mesh's own, so the rest of the mesh is untouched and stays conforming.
/// Returns `None` when no tetrahedron is below `params.target`, else what
/// [`remove_slivers`] did and the tetrahedra still below it (all of
/// them: the others are untouched and were not).
///
/// Why: after the polish, case K keeps about ten such tetrahedra among
/// 2.75 M, and [`remove_slivers`] on the whole mesh (objectives, node tables and
/// flip tables of every tetrahedron) took about a second for them.
pub(crate) fn remove_slivers_near_bad(
    mesh: &mut TetMesh,
    params: &SliverParams,
) -> Option<(SliverStats, Vec<[u32; 4]>)> {
    let TetMesh {
        pos,
        movable,
        d,
        tets,
    } = mesh;
    let bad: Vec<usize> = (0..tets.len())
        .filter(|&t| objective_of(pos, &tets[t]) < params.target)
        .collect();
    if bad.is_empty() {
        return None;
    }
    let n = pos.len();
    let (start, inc) = node_tets(n, tets);
    let star = |v: usize| &inc[start[v] as usize..start[v + 1] as usize];
    // the nodes of the bad tetrahedra, then their neighbours
    let mut inner = vec![false; n];
    let mut ring: Vec<usize> = Vec::new();
    for &t in &bad {
        for &v in &tets[t] {
            if !std::mem::replace(&mut inner[v as usize], true) {
                ring.push(v as usize);
            }
        }
    }
    for k in 0..ring.len() {
        for &t in star(ring[k]) {
            for &w in &tets[t as usize] {
                if !std::mem::replace(&mut inner[w as usize], true) {
                    ring.push(w as usize);
                }
            }
        }
    }
    // their stars, renumbered locally
    let mut in_part = vec![false; tets.len()];
    let mut local = vec![u32::MAX; n];
    let mut global: Vec<usize> = Vec::new();
    let mut part: Vec<[u32; 4]> = Vec::new();
    for &v in &ring {
        for &t in star(v) {
            if std::mem::replace(&mut in_part[t as usize], true) {
                continue;
            }
            part.push(tets[t as usize].map(|w| {
                let w = w as usize;
                if local[w] == u32::MAX {
                    local[w] = global.len() as u32;
                    global.push(w);
                }
                local[w]
            }));
        }
    }
    let mut local_mesh = TetMesh {
        pos: global.iter().map(|&g| pos[g]).collect(),
        movable: global.iter().map(|&g| movable[g] && inner[g]).collect(),
        d: global.iter().map(|&g| d[g]).collect(),
        tets: part,
    };
    let stats = remove_slivers(&mut local_mesh, params);
    let TetMesh {
        pos: lpos,
        tets: part,
        ..
    } = local_mesh;
    for (l, &g) in global.iter().enumerate() {
        pos[g] = lpos[l];
    }
    let mut k = 0;
    tets.retain(|_| {
        k += 1;
        !in_part[k - 1]
    });
    let still_bad = part
        .iter()
        .filter(|t| objective_of(&lpos, t) < params.target)
        .map(|t| t.map(|l| global[l as usize] as u32))
        .collect();
    tets.extend(part.iter().map(|t| t.map(|l| global[l as usize] as u32)));
    Some((stats, still_bad))
}

/// The node moves of [`remove_slivers`]: a pattern search per free node
/// of a tetrahedron below `params.target`, worst first. `qs[i]` is the
/// objective of `mesh.tets[i]`, on entry and on return.
fn search_moves(mesh: &mut TetMesh, params: &SliverParams, qs: &mut [f64]) -> SliverStats {
    let TetMesh {
        pos,
        movable,
        d,
        tets,
    } = mesh;
    let (movable, d, tets): (&[bool], &[f64], &[[u32; 4]]) = (movable, d, tets);
    let n = pos.len();
    let (start, inc) = node_tets(n, tets);
    let star = |v: usize| &inc[start[v] as usize..start[v + 1] as usize];
    // the objectives are kept current as nodes move (topology is fixed
    // within a pass): the rounds read their work from them instead of
    // re-evaluating 2.7 M tetrahedra each (case K)
    let mut stats = SliverStats {
        bad_before: qs.iter().filter(|&&q| q < params.target).count(),
        min_q_before: qs.iter().cloned().fold(1.0, f64::min),
        ..Default::default()
    };
    let origin: Vec<P3> = pos.to_vec();
    // the 6 axis and 8 diagonal directions
    let dirs: Vec<V3> = {
        let mut v = Vec::new();
        for x in -1..=1 {
            for y in -1..=1 {
                for z in -1..=1 {
                    let k = (x != 0) as u8 + (y != 0) as u8 + (z != 0) as u8;
                    if k == 1 || k == 3 {
                        v.push(V3::new(x as f64, y as f64, z as f64).normalize());
                    }
                }
            }
        }
        v
    };
    // a node whose star the search could not improve is not searched again
    // in this pass
    let mut stuck = vec![false; n];
    let mut order: Vec<u32> = Vec::new();
    for _round in 0..params.rounds {
        // nodes of bad tets, worst first
        let mut work: Vec<(f64, usize)> = Vec::new();
        let mut seen = vec![false; n];
        for (t, &q) in tets.iter().zip(qs.iter()) {
            if q < params.target {
                for &v in t {
                    let v = v as usize;
                    if movable[v] && !seen[v] && !stuck[v] {
                        seen[v] = true;
                        work.push((q, v));
                    }
                }
            }
        }
        if work.is_empty() {
            break;
        }
        work.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut moved_any = false;
        for &(_, v) in &work {
            // the star worst first: a trial move is refused as soon as one
            // tetrahedron is no better than the best so far, which the
            // worst ones decide most often (the same moves as evaluating
            // the whole star, at a fraction of the objectives)
            order.clear();
            order.extend_from_slice(star(v));
            order.sort_by(|&s, &t| qs[s as usize].total_cmp(&qs[t as usize]));
            let mut best = qs[order[0] as usize];
            // the star gathered once for the whole search (its other
            // corners do not move meanwhile; see Star)
            let sg = Star::gather(pos, tets, &order, v);
            let p0 = pos[v];
            let mut x = p0;
            let mut step = 0.1 * d[v];
            while step > 0.01 * d[v] {
                let mut improved = false;
                for dir in &dirs {
                    let cand = x + dir * step;
                    if (cand - origin[v]).norm() > params.max_move * d[v] {
                        continue;
                    }
                    if let Some(w) = sg
                        .worst_above(&cand, best + 1e-9)
                        .filter(|_| sg.positive(&cand))
                    {
                        best = w;
                        improved = true;
                        x = cand;
                    }
                }
                if !improved {
                    step *= 0.5;
                }
            }
            pos[v] = x;
            if pos[v] == p0 {
                stuck[v] = true;
            } else {
                for &t in star(v) {
                    qs[t as usize] = objective_of(pos, &tets[t as usize]);
                }
                stats.moves += 1;
                moved_any = true;
            }
        }
        if !moved_any {
            break;
        }
    }
    stats.bad_after = qs.iter().filter(|&&q| q < params.target).count();
    stats.min_q_after = qs.iter().cloned().fold(1.0, f64::min);
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::tet::mesh::testing::{
        assert_positive, boundary_faces, jittered_mesh, volume, worst_objective,
    };

    /// What the pass exists for: on a jittered lattice with tetrahedra
    /// below the target, it raises the worst objective, leaves fewer below
    /// the target, no tetrahedron inverted, the boundary and the volume as
    /// they were, and the fixed nodes in place.
    #[test]
    fn remove_slivers_raises_the_worst_and_inverts_nothing() {
        let mut mesh = jittered_mesh(6, 0.45);
        let (pos0, tets0) = (mesh.pos.clone(), mesh.tets.clone());
        let w0 = worst_objective(&pos0, &tets0);
        assert!(w0 < TARGET_Q, "{w0}");
        let stats = remove_slivers(&mut mesh, &SliverParams::default());
        let w1 = worst_objective(&mesh.pos, &mesh.tets);
        assert!(w1 > w0, "worst {w0} -> {w1}");
        assert!(stats.bad_after < stats.bad_before, "{stats:?}");
        assert!(stats.moves > 0 || stats.flips > 0);
        assert!((stats.min_q_after - w1).abs() < 1e-12);
        assert_positive(&mesh.pos, &mesh.tets);
        assert_eq!(boundary_faces(&tets0), boundary_faces(&mesh.tets));
        assert!((volume(&mesh.pos, &mesh.tets) - volume(&pos0, &tets0)).abs() < 1e-9);
        for (i, (p, p0)) in mesh.pos.iter().zip(&pos0).enumerate() {
            assert!(mesh.movable[i] || p == p0, "fixed node {i} moved");
        }
    }

    /// [`remove_slivers_near_bad`] works on the neighbourhood of the bad
    /// tetrahedra only: nodes more than one edge away from a bad
    /// tetrahedron's corners keep their place, tetrahedra without a node in
    /// that neighbourhood are kept as they are, and inside it the result
    /// has [`remove_slivers`]'s guarantees: every tetrahedron positive, the same
    /// volume and boundary faces, a higher worst objective.
    #[test]
    fn remove_slivers_near_bad_stays_near_the_bad_tetrahedra() {
        // a BCC lattice (cube corners and centres, Delaunay tetrahedra all
        // of radius ratio 0.95) with one node pushed towards a neighbour
        let k = 7;
        let mut rnd = crate::volume::jitter_source(7);
        let mut pos = Vec::new();
        let mut movable = Vec::new();
        for i in 0..k {
            for j in 0..k {
                for l in 0..k {
                    let inner = i > 0 && j > 0 && l > 0 && i < k - 1 && j < k - 1 && l < k - 1;
                    let e = if inner { 1e-4 } else { 0.0 };
                    pos.push(P3::new(
                        i as f64 + e * rnd(),
                        j as f64 + e * rnd(),
                        l as f64 + e * rnd(),
                    ));
                    movable.push(inner);
                    if i < k - 1 && j < k - 1 && l < k - 1 {
                        pos.push(P3::new(i as f64 + 0.5, j as f64 + 0.5, l as f64 + 0.5));
                        movable.push(true);
                    }
                }
            }
        }
        let centre = pos
            .iter()
            .position(|p| (p - P3::new(3.5, 3.5, 3.5)).norm() < 1e-9)
            .unwrap();
        pos[centre] += V3::new(0.28, 0.22, 0.1);
        let coords: Vec<[f64; 3]> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tets0 = bubblemesh_delaunay::tetrahedralize(&coords).unwrap().tets;
        let pos0 = pos.clone();
        let w0 = worst_objective(&pos, &tets0);
        assert!(w0 < TARGET_Q);
        // the neighbourhood, found independently
        let mut near = vec![false; pos.len()];
        for t in tets0.iter().filter(|t| objective_of(&pos, t) < TARGET_Q) {
            for &v in t {
                near[v as usize] = true;
            }
        }
        let core = near.clone();
        for t in &tets0 {
            if t.iter().any(|&v| core[v as usize]) {
                for &v in t {
                    near[v as usize] = true;
                }
            }
        }
        assert!(
            near.iter().any(|&x| !x),
            "the test needs nodes away from the bad tetrahedra"
        );
        let d = vec![1.0; pos.len()];
        let mut mesh = TetMesh {
            pos,
            movable: movable.clone(),
            d: d.clone(),
            tets: tets0.clone(),
        };
        let (stats, still_bad) =
            remove_slivers_near_bad(&mut mesh, &SliverParams::default()).expect("bad tetrahedra");
        let TetMesh { pos, tets, .. } = mesh;
        let bad_now: Vec<&[u32; 4]> = tets
            .iter()
            .filter(|t| objective_of(&pos, t) < TARGET_Q)
            .collect();
        assert_eq!(bad_now.len(), still_bad.len());
        assert!(bad_now.iter().all(|t| still_bad.contains(t)));
        assert!(stats.bad_after < stats.bad_before);
        assert!(worst_objective(&pos, &tets) > w0);
        assert_positive(&pos, &tets);
        for (v, (p, p0)) in pos.iter().zip(&pos0).enumerate() {
            assert!(
                near[v] || p == p0,
                "node {v} moved away from the bad tetrahedra"
            );
            assert!(movable[v] || p == p0, "fixed node {v} moved");
        }
        let sorted = |t: &[u32; 4]| {
            let mut t = *t;
            t.sort_unstable();
            t
        };
        let now: std::collections::HashSet<[u32; 4]> = tets.iter().map(sorted).collect();
        for t in tets0
            .iter()
            .filter(|t| t.iter().all(|&v| !near[v as usize]))
        {
            assert!(
                now.contains(&sorted(t)),
                "a tetrahedron away from the bad ones changed"
            );
        }
        assert!((volume(&pos, &tets) - volume(&pos0, &tets0)).abs() < 1e-9);
        assert_eq!(boundary_faces(&tets0), boundary_faces(&tets));
        // nothing left to do on a mesh without bad tetrahedra
        let mut good = TetMesh {
            pos: pos0.clone(),
            movable,
            d,
            tets: tets0.clone(),
        };
        good.tets.retain(|t| objective_of(&pos0, t) >= TARGET_Q);
        assert!(remove_slivers_near_bad(&mut good, &SliverParams::default()).is_none());
    }
}
