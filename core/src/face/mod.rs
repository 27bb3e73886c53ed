//! Face meshing (thesis §4.1.2, §4.3–4.7): stage 1 by the oblique
//! quadtree, stage 2 by damped dynamics with population control, bubbles
//! held on the face through their (u,v) (§4.5); then constrained Delaunay
//! connection in (u,v) and the 2D improvement.

pub mod conformal;
pub mod connect;
pub mod growth;
pub mod improve;
pub mod orient;
pub mod placement;
pub mod region;

use std::time::Instant;

use crate::bubbles::constraint::{self, Carrier, OnFace};
use crate::bubbles::grid;
use crate::bubbles::system::{self, RelaxStats, System};
use crate::error::{check_spacing, MeshError};
use crate::geom::{P3, V3};
use crate::mesh::{Element, Mesh, Node};
use crate::model::{EntityRef, Model};
use crate::options::{Options, Timings};
use crate::spacing::{Spacing, SpacingQuery};

use region::Region;

/// Seed a boundary layer before the quadtree lattice (measured: no gain on
/// cases A–C with the current relaxation, so off; kept for surfaces).
const APEX_LAYER: bool = false;

/// Bubbles closer than this many spacings to a singular point of the
/// parametrization are connected in their tangent plane (a cap), not in (u,v).
const CAP_RADIUS: f64 = 5.0;

/// Rounds of edge relaxation and Delaunay flips after connection
/// ([`improve`]).
const IMPROVE_ROUNDS: usize = 6;

/// After a conformal-lattice start (`conformal`), the mean lift runs over
/// the bubbles of every triangle below this radius ratio, for at most
/// [`LATTICE_MEAN_ROUNDS`] rounds (cases B and C: 0.99 and 6 rounds gave a
/// mean 0.001 lower, 0.9999 and 20 rounds the same as this).
const LATTICE_MEAN_Q: f64 = 0.999;

const LATTICE_MEAN_ROUNDS: usize = 10;

/// What happened on one face.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FaceReport {
    pub face: u32,
    pub name: Option<String>,
    pub boundary_bubbles: usize,
    /// Free bubbles after stage 1.
    pub stage1_bubbles: usize,
    /// Free bubbles at the end.
    pub bubbles: usize,
    pub triangles: usize,
    /// Stage-2 statistics and energy history (absent with `--fast`).
    pub relax: Option<RelaxStats>,
    /// Cones (five-, seven-valent) of the conformal lattice when the face's
    /// mesh was rebuilt from it (graded planar faces; see `conformal`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lattice_cones: Option<(usize, usize)>,
}

/// The parameter box `(lo, hi)` of a surface (its `domain()` is
/// `([u0, u1], [v0, v1])`).
fn domain_box(s: &dyn crate::geom::Surface) -> ([f64; 2], [f64; 2]) {
    let (u, v) = s.domain();
    ([u[0], v[0]], [u[1], v[1]])
}

/// Median |S_u| and |S_v| over the points `uv` (a sample of at most 257),
/// for [`connect::SurfacePoints::scale`].
fn parameter_scale(surface: &dyn crate::geom::Surface, uv: &[[f64; 2]]) -> [f64; 2] {
    let step = (uv.len() / 257).max(1);
    let mut su: Vec<f64> = Vec::new();
    let mut sv: Vec<f64> = Vec::new();
    for q in uv.iter().step_by(step) {
        let d = surface.derivs(q[0], q[1]);
        let (a, b) = (d.su.norm(), d.sv.norm());
        if a.is_finite() && a > 0.0 && b.is_finite() && b > 0.0 {
            su.push(a);
            sv.push(b);
        }
    }
    if su.is_empty() {
        return [1.0, 1.0];
    }
    su.sort_by(|a, b| a.total_cmp(b));
    sv.sort_by(|a, b| a.total_cmp(b));
    [su[su.len() / 2], sv[sv.len() / 2]]
}

/// Meshes one face: stage 1, stage 2, connection.
#[allow(clippy::too_many_arguments)]
pub(crate) fn mesh_face(
    model: &Model,
    fi: usize,
    spacing: &dyn Spacing,
    opts: &Options,
    edge_nodes: &[Vec<u32>],
    mesh: &mut Mesh,
    node_d: &[f64],
    timings: &mut Timings,
    grow: bool,
) -> Result<FaceReport, MeshError> {
    let face = &model.faces[fi];
    let fe = EntityRef::new(2, fi as u32);
    let surface = face.surface.as_ref();
    if face.loops.is_empty() && surface.periods().iter().all(|p| p.is_none()) {
        return Err(MeshError::Invalid(
            "the face has no boundary loop and its surface is not closed (not periodic)".into(),
        ));
    }
    let t1 = Instant::now();

    // fixed bubbles: boundary and embedded nodes, each once, with (u,v)
    let mut local_of: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    let mut fixed_ids: Vec<u32> = Vec::new();
    let mut fixed_uv: Vec<[f64; 2]> = Vec::new();
    let mut hint: Option<[f64; 2]> = None;
    // (u,v) of a boundary node: from the edge's pcurve on this face when the
    // model has one (exact), else by inverse mapping from the previous node
    let pcurve_uv = |edge: u32, id: u32, at_end: Option<bool>| -> Option<[f64; 2]> {
        let pc = model.pcurves.get(&(fi as u32, edge))?;
        let e = &model.edges[edge as usize];
        let t = match at_end {
            Some(false) => e.t0,
            Some(true) => e.t1,
            None => mesh.nodes[id as usize].params[0],
        };
        let q = pc.point(t);
        Some([q.x, q.y])
    };
    let mut add_fixed = |id: u32,
                         known: Option<[f64; 2]>,
                         hint: &mut Option<[f64; 2]>|
     -> Result<usize, MeshError> {
        if let Some(&l) = local_of.get(&id) {
            *hint = Some(fixed_uv[l]);
            return Ok(l);
        }
        let p = mesh.nodes[id as usize].pos;
        let uv = match known {
            Some(mut uv) => {
                // a pcurve may end on the far side of a seam (u = 2π)
                let lo = domain_box(surface).0;
                for c in 0..2 {
                    if let Some(p) = surface.periods()[c] {
                        uv[c] = lo[c] + (uv[c] - lo[c]).rem_euclid(p);
                    }
                }
                uv
            }
            None => surface.inverse(&p, *hint).ok_or_else(|| {
                MeshError::Invalid(format!(
                    "boundary point ({}, {}, {}) cannot be mapped to the surface's (u,v)",
                    p.x, p.y, p.z
                ))
            })?,
        };
        *hint = Some(uv);
        let l = fixed_ids.len();
        local_of.insert(id, l);
        fixed_ids.push(id);
        fixed_uv.push(uv);
        Ok(l)
    };
    let chain = |u: &crate::model::EdgeUse| -> Result<Vec<u32>, MeshError> {
        let ids = edge_nodes.get(u.edge as usize).ok_or_else(|| {
            MeshError::Invalid(format!("a loop uses edge {} which does not exist", u.edge))
        })?;
        Ok(if u.forward {
            ids.clone()
        } else {
            ids.iter().rev().cloned().collect()
        })
    };
    let mut segments: Vec<[usize; 2]> = Vec::new();
    let mut boundary: Vec<[usize; 2]> = Vec::new();
    let mut loop_locals: Vec<Vec<usize>> = Vec::new();
    for (li, lp) in face.loops.iter().enumerate() {
        // node ids with their (u,v) when a pcurve gives it
        let mut ids: Vec<(u32, Option<[f64; 2]>)> = Vec::new();
        for u in &lp.edges {
            let c = chain(u)?;
            let m = c.len();
            let with_uv: Vec<(u32, Option<[f64; 2]>)> = c
                .iter()
                .enumerate()
                .map(|(k, &id)| {
                    let at_end = if k == 0 {
                        Some(!u.forward)
                    } else if k + 1 == m {
                        Some(u.forward)
                    } else {
                        None
                    };
                    (id, pcurve_uv(u.edge, id, at_end))
                })
                .collect();
            if let Some(&(last, _)) = ids.last() {
                if last != c[0] {
                    return Err(MeshError::Invalid(format!(
                        "loop {li} is not connected at edge {} (its first vertex is not the previous edge's last)",
                        u.edge
                    )));
                }
                ids.pop();
            }
            ids.extend(with_uv);
        }
        if ids.len() < 3 || ids.first().map(|x| x.0) != ids.last().map(|x| x.0) {
            return Err(MeshError::Invalid(format!("loop {li} is not closed")));
        }
        ids.pop();
        let locals: Vec<usize> = ids
            .iter()
            .map(|&(id, uv)| add_fixed(id, uv, &mut hint))
            .collect::<Result<_, _>>()?;
        for k in 0..locals.len() {
            segments.push([locals[k], locals[(k + 1) % locals.len()]]);
        }
        loop_locals.push(locals);
    }
    for &ee in &face.embedded_edges {
        let c = chain(&crate::model::EdgeUse {
            edge: ee,
            forward: true,
        })?;
        let locals: Vec<usize> = c
            .iter()
            .map(|&id| add_fixed(id, None, &mut hint))
            .collect::<Result<_, _>>()?;
        for w in locals.windows(2) {
            segments.push([w[0], w[1]]);
        }
    }
    for &v in &face.embedded_vertices {
        add_fixed(v, None, &mut hint)?;
    }
    let loops_uv: Vec<Vec<[f64; 2]>> = loop_locals
        .iter()
        .map(|l| l.iter().map(|&k| fixed_uv[k]).collect())
        .collect();
    // directed boundary segments with the face on their left: the first loop
    // is the outer one (face inside it), the others holes (face outside)
    let periods = surface.periods();
    if periods[0].is_some() && periods[1].is_some() && !loops_uv.is_empty() {
        return Err(MeshError::Unsupported(
            "a face with boundary loops on a surface periodic in both u and v (a trimmed torus) is not supported yet"
                .into(),
        ));
    }
    let region = if periods.iter().any(|p| p.is_some()) || loops_uv.is_empty() {
        Region::periodic(&loops_uv, periods, domain_box(surface))
    } else {
        Region::new(&loops_uv)
    };
    // directed boundary segments with the face on their left. On a plane
    // (or any non-periodic parametrization) the first loop is the outer one
    // (face inside it) and the others holes, told apart by signed area; on a
    // periodic surface a loop may close only through the period (a circle
    // around a cylinder), so the side is found by asking the region about
    // points just left of the loop's segments.
    for (li, (locals, luv)) in loop_locals.iter().zip(&loops_uv).enumerate() {
        let face_on_left = if periods.iter().all(|p| p.is_none()) {
            // relative to the loop's first point: far from the origin (a
            // unit square at (1e8, 1e8)) the products of absolute
            // coordinates cancel and the sign is noise
            let o = luv.first().copied().unwrap_or([0.0, 0.0]);
            let area2: f64 = (0..luv.len())
                .map(|k| {
                    let (a, b) = (luv[k], luv[(k + 1) % luv.len()]);
                    let (a, b) = ([a[0] - o[0], a[1] - o[1]], [b[0] - o[0], b[1] - o[1]]);
                    a[0] * b[1] - b[0] * a[1]
                })
                .sum();
            let ccw = area2 > 0.0;
            if li == 0 {
                ccw
            } else {
                !ccw
            }
        } else {
            let mut votes = 0i32;
            let m = luv.len();
            for k in (0..m).step_by((m / 16).max(1)) {
                let a = luv[k];
                let mut b = luv[(k + 1) % m];
                for c in 0..2 {
                    if let Some(p) = periods[c] {
                        b[c] = a[c] + ((b[c] - a[c]) - p * ((b[c] - a[c]) / p).round());
                    }
                }
                let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
                let left = [mid[0] - 0.01 * (b[1] - a[1]), mid[1] + 0.01 * (b[0] - a[0])];
                let right = [mid[0] + 0.01 * (b[1] - a[1]), mid[1] - 0.01 * (b[0] - a[0])];
                votes += region.contains(left[0], left[1]) as i32
                    - region.contains(right[0], right[1]) as i32;
            }
            votes >= 0
        };
        for k in 0..locals.len() {
            let (a, b) = (locals[k], locals[(k + 1) % locals.len()]);
            boundary.push(if face_on_left { [a, b] } else { [b, a] });
        }
    }
    let (lo, hi) = region.bbox();
    let carrier = OnFace::new(surface, region, fe);

    // stage 1: oblique quadtree
    let uniform_leaf = spacing.constant().filter(|_| surface.is_planar()).map(|d| {
        let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let dv = surface.derivs(c[0], c[1]);
        // parameter length of one spacing along u (1 on a plane)
        d / dv.su.norm().max(f64::MIN_POSITIVE)
    });
    let mut d_at = |p: &P3, uv: [f64; 2]| -> Result<f64, MeshError> {
        let d = spacing.spacing(&SpacingQuery {
            point: *p,
            entity: fe,
            params: uv,
        });
        check_spacing(d, *p, fe)
    };
    let mut d_outside = fixed_ids
        .iter()
        .map(|&id| node_d[id as usize])
        .fold(f64::INFINITY, f64::min);
    if !d_outside.is_finite() {
        // a closed face has no boundary bubbles: sample the spacing on it
        for k in 0..=8 {
            for l in 0..=8 {
                let uv = [
                    lo[0] + (hi[0] - lo[0]) * k as f64 / 8.0,
                    lo[1] + (hi[1] - lo[1]) * l as f64 / 8.0,
                ];
                if carrier.contains(uv) {
                    let p = carrier.point(uv);
                    d_outside = d_outside.min(d_at(&p, uv)?);
                }
            }
        }
    }
    let seeds = placement::oblique_quadtree(&carrier, lo, hi, uniform_leaf, d_outside, &mut d_at)?;

    // boundary layer: one bubble over each boundary segment, at the apex of
    // the near-equilateral triangle on it (see `placement::apex_seeds`)
    let fixed_pos: Vec<P3> = fixed_ids
        .iter()
        .map(|&id| mesh.nodes[id as usize].pos)
        .collect();
    let fixed_d: Vec<f64> = fixed_ids.iter().map(|&id| node_d[id as usize]).collect();
    let apex = if APEX_LAYER {
        placement::apex_seeds(
            &carrier, &boundary, &fixed_pos, &fixed_uv, &fixed_d, &mut d_at,
        )?
    } else {
        Vec::new()
    };
    // keep the apex seeds, then the lattice seeds, that do not crowd a
    // fixed bubble or an earlier accepted seed (closer than 0.75 r0); seeds
    // of one uniform lattice cannot crowd each other, so that check is only
    // made for a varying spacing
    // on curved faces stage 2 starts from one grown crystal (see `growth`);
    // the quadtree's seeds fill what the growth did not reach. Planar faces
    // keep the quadtree: its lattice is exact for a uniform spacing, and for
    // a graded one growth measured no better (cases B, C: q mean 0.981 and
    // 0.979 grown, 0.982 and 0.978 from the quadtree, q min lower grown)
    let grown = if grow && !opts.fast && !surface.is_planar() {
        match growth_start(&seeds, &fixed_pos, surface, lo, hi) {
            Some(start) => {
                let obstacles: Vec<(P3, f64)> = fixed_pos
                    .iter()
                    .cloned()
                    .zip(fixed_d.iter().cloned())
                    .chain(apex.iter().map(|s| (s.pos, s.d)))
                    .collect();
                growth::grow(&carrier, start, &obstacles, &mut d_at)?
            }
            None => Vec::new(),
        }
    } else {
        Vec::new()
    };
    let all: Vec<placement::Seed> = apex.into_iter().chain(grown).chain(seeds).collect();
    let accepted = {
        let dmin_fixed = fixed_d.iter().cloned().fold(f64::INFINITY, f64::min);
        let dmax_fixed = fixed_d.iter().cloned().fold(0.0f64, f64::max);
        let fixed_grid = grid::Grid::new(&fixed_pos, 1.5 * dmin_fixed);
        let crowds = |p: &P3,
                      d: f64,
                      pos: &[P3],
                      ds: &[f64],
                      g: &grid::Grid,
                      reach: f64,
                      skip: &dyn Fn(usize) -> bool| {
            let mut hit = false;
            g.query(p, 0.75 * 0.5 * (d + reach), |j| {
                let j = j as usize;
                if !hit && !skip(j) && (pos[j] - p).norm() < 0.75 * 0.5 * (d + ds[j]) {
                    hit = true;
                }
            });
            hit
        };
        let mut keep: Vec<bool> = all
            .iter()
            .map(|s| {
                !crowds(
                    &s.pos,
                    s.d,
                    &fixed_pos,
                    &fixed_d,
                    &fixed_grid,
                    dmax_fixed,
                    &|_| false,
                )
            })
            .collect();
        if spacing.constant().is_none() || APEX_LAYER || !surface.is_planar() {
            let spos: Vec<P3> = all.iter().map(|s| s.pos).collect();
            let sd: Vec<f64> = all.iter().map(|s| s.d).collect();
            let dmin = sd.iter().cloned().fold(f64::INFINITY, f64::min);
            let dmax = sd.iter().cloned().fold(0.0f64, f64::max);
            let g = grid::Grid::new(&spos, 1.5 * dmin);
            for i in 0..all.len() {
                if keep[i] {
                    let earlier_kept = |j: usize| !(j < i && keep[j]);
                    if crowds(&spos[i], sd[i], &spos, &sd, &g, dmax, &earlier_kept) {
                        keep[i] = false;
                    }
                }
            }
        }
        all.into_iter()
            .zip(keep)
            .filter(|(_, k)| *k)
            .map(|(s, _)| s)
            .collect::<Vec<_>>()
    };
    let seeds = accepted;
    let mut sys = System {
        carrier,
        spacing,
        dim: 2,
        n_fixed: fixed_ids.len(),
        pos: fixed_pos,
        params: fixed_uv,
        vel: vec![V3::zeros(); fixed_ids.len()],
        d: fixed_d,
        fixed_ids,
        // the pressure helps graded packings anneal; with a uniform spacing
        // it only slows the lattice down (measured on cases E and G)
        pressure: if spacing.constant().is_some() {
            1.0
        } else {
            system::PRESSURE
        },
    };
    // the quadtree's root starts left of the box, so on a periodic surface
    // a seed may lie one period off: stage 2 wraps the bubbles it moves, but
    // with stage 1 alone (`--fast`) the connection needs every (u,v) in the
    // fundamental domain
    for s in seeds {
        let uv = sys.carrier.region.wrap(s.params);
        sys.push_free(s.pos, uv, s.d);
    }
    let mut fr = FaceReport {
        face: fi as u32,
        name: face.name.clone(),
        boundary_bubbles: sys.n_fixed,
        stage1_bubbles: sys.n() - sys.n_fixed,
        ..Default::default()
    };
    timings.stage1_s += t1.elapsed().as_secs_f64();
    opts.stage1_done(fe, sys.n_fixed, &sys.pos, &sys.d);

    // whether the face bounds a volume that is meshed next
    let bounds_volume = opts.dim.unwrap_or(model.dim()) >= 3
        && model.volumes.iter().any(|v| v.faces.contains(&(fi as u32)));

    // stage 2
    if !opts.fast {
        let t2 = Instant::now();
        // a uniformly spaced face that only bounds a volume stops earlier
        // (see system::PLATEAU_BOUNDARY)
        let settings = if bounds_volume && spacing.constant().is_some() {
            system::RelaxSettings {
                plateau: opts.relax.plateau.max(system::PLATEAU_BOUNDARY),
                ..opts.relax
            }
        } else {
            opts.relax
        };
        let stats = sys.relax(
            &settings,
            opts.relax_observer(fe, settings.max_steps, sys.n_fixed),
        )?;
        fr.relax = Some(stats);
        timings.stage2_s += t2.elapsed().as_secs_f64();
    }
    fr.bubbles = sys.n() - sys.n_fixed;

    // connection
    let t3 = Instant::now();
    let keep = |c: [f64; 2]| {
        sys.carrier.region.contains(c[0], c[1]) && surface.trim(c[0], c[1]).unwrap_or(true)
    };
    let mut tris = if surface.is_planar() {
        connect::triangulate(&sys.params, &segments, &boundary, keep)?
    } else {
        let normal: Vec<V3> = sys
            .params
            .iter()
            .map(|&uv| sys.carrier.normal(uv))
            .collect();
        let poles = surface.singular_points();
        // bubbles near a pole or an apex are connected in the tangent plane;
        // fixed ones too (an apex vertex), unless a boundary segment ends
        // there (segments stay in the (u,v) triangulation)
        let mut on_segment = vec![false; sys.n()];
        for s in &segments {
            on_segment[s[0]] = true;
            on_segment[s[1]] = true;
        }
        let singular: Vec<bool> = (0..sys.n())
            .map(|i| {
                !on_segment[i]
                    && poles
                        .iter()
                        .any(|q| (sys.pos[i] - q).norm() < CAP_RADIUS * sys.d[i])
            })
            .collect();
        let pts = connect::SurfacePoints {
            uv: &sys.params,
            pos: &sys.pos,
            normal: &normal,
            d: &sys.d,
            singular: &singular,
            periods,
            origin: domain_box(surface).0,
            scale: parameter_scale(surface, &sys.params),
        };
        connect::triangulate_surface(&pts, &segments, &boundary)?
    };
    if !opts.fast && IMPROVE_ROUNDS > 0 {
        improve::improve(&mut sys, &mut tris, &segments, IMPROVE_ROUNDS)?;
    }
    // a graded planar face: try the lattice conformal to the spacing (see
    // `conformal`) and keep it if its mean radius ratio is better. Not on a
    // face bounding a volume meshed next: the tetrahedra do not gain from it
    // (case I: q mean 0.901 with it, 0.902 without) and it cost 2.3 s there.
    let t_lattice = Instant::now();
    if !opts.fast
        && !bounds_volume
        && surface.is_planar()
        && spacing.constant().is_none()
        && isometric(surface, lo, hi)
    {
        if let Some((cones, relax)) = conformal_restart(
            &mut sys,
            &mut tris,
            &segments,
            &boundary,
            &loop_locals,
            fe,
            &opts.relax,
        )? {
            fr.lattice_cones = Some(cones);
            fr.relax = Some(relax);
        }
    }
    let lattice_s = t_lattice.elapsed().as_secs_f64();
    timings.lattice_s += lattice_s;
    let nf = sys.n_fixed;
    // free bubbles become nodes; one the connection left without a triangle
    // (it sat within half a spacing of another near a singular point) is
    // dropped rather than left as an unreferenced node
    let mut referenced = vec![false; sys.n()];
    for t in &tris {
        for &v in t {
            referenced[v] = true;
        }
    }
    let mut node_of = vec![u32::MAX; sys.n()];
    for i in nf..sys.n() {
        if referenced[i] {
            node_of[i] = mesh.nodes.len() as u32;
            mesh.nodes.push(Node {
                pos: sys.pos[i],
                entity: fe,
                params: sys.params[i],
            });
        }
    }
    fr.bubbles = (nf..sys.n()).filter(|&i| referenced[i]).count();
    let global = |l: usize| -> u32 {
        if l < nf {
            sys.fixed_ids[l]
        } else {
            node_of[l]
        }
    };
    for t in &tris {
        mesh.triangles.push(Element {
            nodes: [global(t[0]), global(t[1]), global(t[2])],
            entity: fe,
        });
    }
    fr.triangles = tris.len();
    if tris.is_empty() {
        return Err(MeshError::Invalid(
            "the face produced no triangles (is its parameter region empty, or the spacing larger than the face?)"
                .into(),
        ));
    }
    timings.connect_s += t3.elapsed().as_secs_f64() - lattice_s;
    Ok(fr)
}

/// Whether a planar face's (u,v) is an isometry (unit, orthogonal partials
/// at the middle of its box; a plane's partials are constant), so that a
/// spacing is a (u,v) length.
fn isometric(surface: &dyn crate::geom::Surface, lo: [f64; 2], hi: [f64; 2]) -> bool {
    let dv = surface.derivs(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
    (dv.su.norm() - 1.0).abs() < 1e-9
        && (dv.sv.norm() - 1.0).abs() < 1e-9
        && dv.su.dot(&dv.sv).abs() < 1e-9
}

/// Rebuilds a graded planar face from the lattice conformal to its spacing
/// (`conformal::lattice_seeds` over the current mesh) as a new stage 1, and
/// keeps the result if its mean radius ratio is higher and its edges are in
/// the spacing band [1/√2, √2] as often (or at least 99.5 % of them);
/// otherwise the packed mesh stays. Returns the cones placed and the second
/// stage 2's statistics when the lattice mesh was kept.
fn conformal_restart<C: constraint::Carrier>(
    sys: &mut system::System<'_, C>,
    tris: &mut Vec<[usize; 3]>,
    segments: &[[usize; 2]],
    boundary: &[[usize; 2]],
    loop_locals: &[Vec<usize>],
    fe: EntityRef,
    settings: &system::RelaxSettings,
) -> Result<Option<((usize, usize), system::RelaxStats)>, MeshError> {
    let nf = sys.n_fixed;
    let holes: Vec<Vec<usize>> = loop_locals.iter().skip(1).cloned().collect();
    let bg = conformal::Background {
        uv: &sys.params,
        tris,
        n_fixed: nf,
        holes: &holes,
        segments,
    };
    let spacing = sys.spacing;
    let carrier = &sys.carrier;
    let mut d_uv = |uv: [f64; 2]| {
        spacing.spacing(&SpacingQuery {
            point: carrier.point(uv),
            entity: fe,
            params: uv,
        })
    };
    let Some(lattice) = conformal::lattice_seeds(&bg, &mut d_uv) else {
        return Ok(None);
    };
    let mean_q = |sys: &system::System<'_, C>, tris: &[[usize; 3]]| {
        tris.iter()
            .map(|t| improve::radius_ratio(&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]]))
            .sum::<f64>()
            / tris.len().max(1) as f64
    };
    // edges with L/d in [1/√2, √2], d the mean of the ends' spacings (each
    // interior edge counted once, boundary edges by their orientation, alike
    // in both meshes)
    let in_band = |sys: &system::System<'_, C>, tris: &[[usize; 3]]| {
        let (mut inside, mut all) = (0usize, 0usize);
        for t in tris {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if a < b {
                    let r = (sys.pos[a] - sys.pos[b]).norm() / (0.5 * (sys.d[a] + sys.d[b]));
                    all += 1;
                    inside += (r >= std::f64::consts::FRAC_1_SQRT_2
                        && r <= std::f64::consts::SQRT_2) as usize;
                }
            }
        }
        inside as f64 / all.max(1) as f64
    };
    let before = (mean_q(sys, tris), in_band(sys, tris));
    let saved = (
        sys.pos.split_off(nf),
        sys.params.split_off(nf),
        sys.vel.split_off(nf),
        sys.d.split_off(nf),
    );
    for (uv, d) in &lattice.seeds {
        if sys.carrier.contains(*uv) {
            let p = sys.carrier.point(*uv);
            sys.push_free(p, *uv, *d);
        }
    }
    // the lattice is stage 1: stage 2 relaxes it (it keeps its topology and
    // evens out what the seams between layouts left), then the connection
    // and improvement as before, and more rounds of the mean lift, as the
    // lattice leaves only the positions to settle. An error on this path
    // (say a constraint the connection cannot keep) leaves the packed mesh.
    let attempt = (|| -> Result<_, MeshError> {
        let relax = sys.relax(settings, |_, _, _| {})?;
        let carrier = &sys.carrier;
        let mut new_tris =
            connect::triangulate(&sys.params, segments, boundary, |c| carrier.contains(c))?;
        improve::improve(sys, &mut new_tris, segments, IMPROVE_ROUNDS)?;
        improve::lift_mean(
            sys,
            &mut new_tris,
            segments,
            LATTICE_MEAN_Q,
            LATTICE_MEAN_ROUNDS,
        )?;
        Ok((relax, new_tris))
    })();
    // kept only if better in mean radius ratio and no worse in spacing
    match attempt {
        Ok((relax, new_tris))
            if !new_tris.is_empty()
                && mean_q(sys, &new_tris) > before.0
                && in_band(sys, &new_tris) >= before.1.min(0.995) =>
        {
            *tris = new_tris;
            Ok(Some((lattice.cones, relax)))
        }
        _ => {
            sys.pos.truncate(nf);
            sys.params.truncate(nf);
            sys.vel.truncate(nf);
            sys.d.truncate(nf);
            sys.pos.extend(saved.0);
            sys.params.extend(saved.1);
            sys.vel.extend(saved.2);
            sys.d.extend(saved.3);
            Ok(None)
        }
    }
}

/// Where lattice growth starts on a face: the stage-1 seed farthest from the
/// boundary bubbles (relative to its spacing), so the crystal meets the
/// boundary last. On a face without boundary (a closed surface) the seed
/// where the surface is flattest (smallest |Gaussian curvature|·d²; ties:
/// nearest the middle of the parameter box): on case G's torus, starting
/// on its top circle (K = 0) gave q mean/min 0.991/0.893, on the inner
/// equator (K < 0) 0.990/0.875, on the outer one 0.992/0.816. A sample of
/// at most about 512 seeds is examined.
fn growth_start<'s>(
    seeds: &'s [placement::Seed],
    fixed: &[P3],
    surface: &dyn crate::geom::Surface,
    lo: [f64; 2],
    hi: [f64; 2],
) -> Option<&'s placement::Seed> {
    let stride = seeds.len() / 512 + 1;
    let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let score = |s: &placement::Seed| -> (f64, f64) {
        if fixed.is_empty() {
            let k =
                crate::curvature::principal_curvatures(&surface.derivs(s.params[0], s.params[1]))
                    .map(|c| (c.k1 * c.k2).abs() * s.d * s.d)
                    .unwrap_or(f64::INFINITY);
            // flatness rounded so that equal curvature ties
            let flat = -(k * 1e6).round();
            let off = (s.params[0] - mid[0]).powi(2) + (s.params[1] - mid[1]).powi(2);
            (flat, -off)
        } else {
            let r = fixed
                .iter()
                .map(|q| (q - s.pos).norm())
                .fold(f64::INFINITY, f64::min);
            (r / s.d, 0.0)
        }
    };
    seeds
        .iter()
        .step_by(stride)
        .map(|s| (score(s), s))
        .max_by(|a, b| a.0 .0.total_cmp(&b.0 .0).then(a.0 .1.total_cmp(&b.0 .1)))
        .map(|(_, s)| s)
}
