//! Consistent orientation of face meshes that no closed volume orients:
//! shells that bound no solid (a STEP `SHELL_BASED_SURFACE_MODEL`, an open
//! or closed shell without a `MANIFOLD_SOLID_BREP`) and solids whose
//! boundary the volume stage cannot walk.
//!
//! Each face's triangles are consistently oriented among themselves (they
//! are counter-clockwise in the face's (u,v)); whether the face agrees with
//! its neighbour is decided where the two meet: along a model edge used by
//! exactly two faces, their triangles must run the edge in opposite
//! directions. A breadth-first walk over such edges gives each face a flip
//! relative to the first face of its component; a closed component is then
//! turned so that it encloses a positive volume (outward normals), an open
//! one so that most of its triangles keep the orientation the model gave.

use std::collections::HashMap;

use crate::mesh::Mesh;
use crate::model::Model;

/// Orients the triangles of `faces` (model face ids) consistently, as the
/// module docs say. With `voids_inside` (the faces of one volume), every
/// closed component but the one enclosing the largest volume is a void and
/// is turned to enclose a negative volume. Faces whose edges meet more than
/// two faces are oriented through their other edges only.
pub(crate) fn orient_faces(model: &Model, mesh: &mut Mesh, faces: &[u32], voids_inside: bool) {
    if faces.is_empty() {
        return;
    }
    let local: HashMap<u32, usize> = faces.iter().enumerate().map(|(k, &f)| (f, k)).collect();
    // edge -> the faces (local index) using it in a loop
    let mut users: HashMap<u32, Vec<usize>> = HashMap::new();
    for (k, &f) in faces.iter().enumerate() {
        for u in model.faces[f as usize]
            .loops
            .iter()
            .flat_map(|l| l.edges.iter())
        {
            users.entry(u.edge).or_default().push(k);
        }
    }
    // one segment of each edge: (lower node, higher node) -> edge
    let mut seg_of_edge: HashMap<u32, (u32, u32)> = HashMap::new();
    for l in &mesh.lines {
        seg_of_edge
            .entry(l.entity.id)
            .or_insert((l.nodes[0], l.nodes[1]));
    }
    let wanted: HashMap<(u32, u32), u32> = users
        .iter()
        .filter(|(_, us)| us.len() == 2 && us[0] != us[1])
        .filter_map(|(&e, _)| seg_of_edge.get(&e).map(|&(a, b)| ((a.min(b), a.max(b)), e)))
        .collect();
    // how each face's triangles run each wanted segment: edge -> (face, ascending)
    let mut runs: HashMap<u32, Vec<(usize, bool)>> = HashMap::new();
    let mut tris_of: Vec<Vec<usize>> = vec![Vec::new(); faces.len()];
    for (ti, t) in mesh.triangles.iter().enumerate() {
        if t.entity.dim != 2 {
            continue;
        }
        let Some(&k) = local.get(&t.entity.id) else {
            continue;
        };
        tris_of[k].push(ti);
        let [a, b, c] = t.nodes;
        for (p, q) in [(a, b), (b, c), (c, a)] {
            if let Some(&e) = wanted.get(&(p.min(q), p.max(q))) {
                runs.entry(e).or_default().push((k, p < q));
            }
        }
    }
    // neighbours with the relative flip: `true` when the two faces run the
    // shared edge the same way (one of them must turn)
    let mut nb: Vec<Vec<(usize, bool)>> = vec![Vec::new(); faces.len()];
    for r in runs.values() {
        if let [(f, a), (g, b)] = r[..] {
            if f != g {
                nb[f].push((g, a == b));
                nb[g].push((f, a == b));
            }
        }
    }
    let mut flip: Vec<Option<bool>> = vec![None; faces.len()];
    let mut components: Vec<Vec<usize>> = Vec::new();
    for s in 0..faces.len() {
        if flip[s].is_some() {
            continue;
        }
        flip[s] = Some(false);
        let mut comp = vec![s];
        let mut stack = vec![s];
        while let Some(f) = stack.pop() {
            let ff = flip[f].unwrap_or(false);
            for &(g, differ) in &nb[f] {
                if flip[g].is_none() {
                    flip[g] = Some(ff ^ differ);
                    comp.push(g);
                    stack.push(g);
                }
            }
        }
        components.push(comp);
    }
    // closed components: every edge their faces use is used twice within
    let mut volumes: Vec<(usize, f64, bool)> = Vec::new();
    for (ci, comp) in components.iter().enumerate() {
        let mut count: HashMap<u32, u32> = HashMap::new();
        for &k in comp {
            for u in model.faces[faces[k] as usize]
                .loops
                .iter()
                .flat_map(|l| l.edges.iter())
            {
                *count.entry(u.edge).or_default() += 1;
            }
        }
        let closed = !count.is_empty() && count.values().all(|&n| n % 2 == 0);
        // signed volume (divergence theorem) about the first node, for precision
        let mut v6 = 0.0;
        let mut unflipped = 0i64;
        let mut origin = None;
        for &k in comp {
            let fl = flip[k].unwrap_or(false);
            unflipped += if fl { -1 } else { 1 } * tris_of[k].len() as i64;
            for &ti in &tris_of[k] {
                let [a, b, c] = mesh.triangles[ti].nodes;
                let o = *origin.get_or_insert(mesh.nodes[a as usize].pos);
                let (pa, pb, pc) = (
                    mesh.nodes[a as usize].pos - o,
                    mesh.nodes[b as usize].pos - o,
                    mesh.nodes[c as usize].pos - o,
                );
                let d = pa.dot(&pb.cross(&pc));
                v6 += if fl { -d } else { d };
            }
        }
        if closed {
            volumes.push((ci, v6, true));
        } else if unflipped < 0 {
            for &k in comp {
                flip[k] = flip[k].map(|x| !x);
            }
        }
    }
    let outer = if voids_inside {
        volumes
            .iter()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map(|v| v.0)
    } else {
        None
    };
    for &(ci, v6, _) in &volumes {
        let want_positive = !voids_inside || Some(ci) == outer;
        if (v6 > 0.0) != want_positive {
            for &k in &components[ci] {
                flip[k] = flip[k].map(|x| !x);
            }
        }
    }
    for (k, tris) in tris_of.iter().enumerate() {
        if flip[k] == Some(true) {
            for &ti in tris {
                mesh.triangles[ti].nodes.swap(1, 2);
            }
        }
    }
}
