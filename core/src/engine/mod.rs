//! The bubble engine: meshing in the order of dimensions (thesis §3.2.3).
//!
//! 1. Vertex bubbles: one fixed node per model vertex.
//! 2. Edge meshing: stage 1 by recursive bisection (§4.1.1); stage 2 places
//!    the number of bubbles of eq. 4.7.1 and relaxes the chain to the force
//!    balance (§4.2–4.5).
//! 3. Face meshing: stage 1 by the oblique quadtree (§4.1.2); stage 2 by
//!    damped dynamics with population control (§4.3–4.7), bubbles held on
//!    the face through their (u,v) (§4.5); then constrained Delaunay
//!    connection in (u,v).
//!
//! Bubbles of lower dimensions are fixed while the next dimension is packed.

pub mod conformal;
pub mod constraint;
pub mod dynamics;
pub mod flip;
pub mod force;
pub mod grid;
pub mod growth;
pub mod improve;
pub(crate) mod incidence;
pub mod odt;
mod orient;
pub mod placement;
pub mod polish;
pub mod population;
pub mod refine;
pub mod region;
pub mod shell;
pub mod sliver;
pub mod system;
pub mod volume;

use std::sync::Arc;
use std::time::Instant;

use crate::connect::{self, ConnectError};
use crate::geom::{Curve, P3, V3};
use crate::mesh::{Element, Mesh, Node};
use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};

pub use dynamics::Integrator;
pub use system::{RelaxSettings, RelaxStats};
pub use volume::VolumeLattice;

use constraint::{Carrier, OnFace};
use region::Region;
use system::System;

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

/// Progress of a long run, for progress bars.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub phase: &'static str,
    pub entity: EntityRef,
    pub step: usize,
    pub max_steps: usize,
}

/// A progress callback.
pub type ProgressFn = Arc<dyn Fn(Progress) + Send + Sync>;

/// The stage-2 step callback of `entity`: forwards each step to
/// `progress`, if there is one, as phase "relax".
fn relax_progress(
    progress: &Option<ProgressFn>,
    entity: EntityRef,
    max_steps: usize,
) -> impl FnMut(usize) + '_ {
    move |step| {
        if let Some(p) = progress {
            p(Progress {
                phase: "relax",
                entity,
                step,
                max_steps,
            });
        }
    }
}

/// Engine options.
#[derive(Clone)]
pub struct Options {
    /// Highest dimension to mesh (default: the model's).
    pub dim: Option<u8>,
    /// Stage 1 only (§4.1): fast, lower quality.
    pub fast: bool,
    /// Stage-2 settings (integrator, step limit, tolerance).
    pub relax: RelaxSettings,
    /// The stage-1 lattice of volumes (BCC where the spacing is uniform,
    /// by default; see [`volume`]).
    pub volume_lattice: volume::VolumeLattice,
    pub progress: Option<ProgressFn>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            dim: None,
            fast: false,
            relax: RelaxSettings::default(),
            volume_lattice: volume::VolumeLattice::default(),
            progress: None,
        }
    }
}

impl std::fmt::Debug for Options {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Options")
            .field("dim", &self.dim)
            .field("fast", &self.fast)
            .field("relax", &self.relax)
            .field("volume_lattice", &self.volume_lattice)
            .finish()
    }
}

/// One sample of the energy history (thesis Fig. 5.7), in engine units
/// (k0 · model length²).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct EnergySample {
    pub step: usize,
    pub kinetic: f64,
    pub potential: f64,
    pub total: f64,
    pub bubbles: usize,
}

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

/// Wall-clock seconds per phase.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Timings {
    pub edges_s: f64,
    pub stage1_s: f64,
    pub stage2_s: f64,
    pub connect_s: f64,
    /// The conformal-lattice restart of graded planar faces (flattening,
    /// its stage 2, connection and improvement; `conformal`).
    pub lattice_s: f64,
    pub total_s: f64,
}

/// What the run did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Report {
    pub dim: u8,
    pub fast: bool,
    pub integrator: Option<Integrator>,
    pub nodes: usize,
    pub lines: usize,
    pub triangles: usize,
    pub tetrahedra: usize,
    pub timings: Timings,
    pub faces: Vec<FaceReport>,
    pub volumes: Vec<volume::VolumeReport>,
    /// Faces meshed with a spacing finer than requested because the
    /// requested one could not give them a valid mesh ([`refine`]).
    pub refined: Vec<refine::RefinedFace>,
    /// How many times the model was meshed again finer (0: once, as asked).
    pub refinement_rounds: usize,
}

/// A meshing failure. Messages name the entity and the reason.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("the spacing is {value} at ({x}, {y}, {z}) on {entity}; a spacing must be finite and > 0", x = point.x, y = point.y, z = point.z)]
    BadSpacing {
        value: f64,
        point: P3,
        entity: EntityRef,
    },
    #[error("the spacing asks for more than {limit} bubbles on one entity; is the size in the model's units?")]
    TooManyBubbles { limit: usize },
    #[error("{0}")]
    Invalid(String),
    #[error("{0}")]
    Unsupported(String),
    #[error("cannot triangulate: {0}")]
    Connect(#[from] ConnectError),
    /// A step failed where a finer spacing on `faces` may succeed (a
    /// surface mesh that is not Delaunay enough for boundary recovery).
    #[error("{message}")]
    Refinable { message: String, faces: Vec<u32> },
    /// The finished mesh failed [`crate::verify::verify`]: nothing may be
    /// written.
    #[error("{0}")]
    Check(#[from] crate::verify::CheckError),
    #[error("{what}: {source}")]
    In {
        what: String,
        #[source]
        source: Box<MeshError>,
    },
}

impl MeshError {
    fn within(self, what: String) -> MeshError {
        match self {
            e @ MeshError::In { .. } => e,
            e => MeshError::In {
                what,
                source: Box::new(e),
            },
        }
    }
}

/// The parameter box `(lo, hi)` of a surface (its `domain()` is
/// `([u0, u1], [v0, v1])`).
fn domain_box(s: &dyn crate::geom::Surface) -> ([f64; 2], [f64; 2]) {
    let (u, v) = s.domain();
    ([u[0], v[0]], [u[1], v[1]])
}

pub(crate) fn check_spacing(d: f64, point: P3, entity: EntityRef) -> Result<f64, MeshError> {
    if d.is_finite() && d > 0.0 {
        Ok(d)
    } else {
        Err(MeshError::BadSpacing {
            value: d,
            point,
            entity,
        })
    }
}

/// Meshes `model` with the node spacing `spacing`, in the order of
/// dimensions, up to `opts.dim` (default: the model's dimension).
///
/// A face that cannot be connected at the requested spacing, or whose mesh
/// fails the final check, is meshed again with a finer spacing inside it and
/// on its edges ([`refine`]); the report lists every such face. The mesh
/// returned has passed [`crate::verify::verify`].
pub fn mesh_model(
    model: &Model,
    spacing: &dyn Spacing,
    opts: &Options,
) -> Result<(Mesh, Report), MeshError> {
    let t_start = Instant::now();
    let mut refinement = refine::Refinement::new(model);
    let mut rounds = 0;
    loop {
        rounds += 1;
        let refined = refine::Refined {
            inner: spacing,
            refinement: &refinement,
        };
        match mesh_once(model, &refined, spacing, opts, &refinement) {
            Ok((mesh, mut report)) => {
                report.refined = refinement.faces(model);
                report.refinement_rounds = rounds - 1;
                report.timings.total_s = t_start.elapsed().as_secs_f64();
                return Ok((mesh, report));
            }
            Err(failed) => {
                let reason = failed.error.to_string();
                if failed.faces.is_empty() && failed.edges.is_empty()
                    || opts.fast
                    || rounds > refine::MAX_ROUNDS
                    || !refinement.bump(
                        model,
                        &failed.faces,
                        &failed.reasons,
                        &failed.edges,
                        &reason,
                    )
                {
                    return Err(failed.error);
                }
            }
        }
    }
}

/// A failed attempt: the error, and the faces and edges whose refinement
/// may cure it.
struct Failed {
    error: MeshError,
    faces: Vec<u32>,
    /// Why each of `faces` failed, where known (else the error's text).
    reasons: Vec<String>,
    edges: Vec<u32>,
}

impl From<MeshError> for Failed {
    fn from(error: MeshError) -> Self {
        /// The faces and edges whose refinement may cure `e`.
        fn culprits(e: &MeshError) -> (Vec<u32>, Vec<u32>) {
            match e {
                MeshError::In { source, .. } => culprits(source),
                MeshError::Refinable { faces, .. } => (faces.clone(), vec![]),
                MeshError::Check(c) if c.refinable => {
                    let mut f = Vec::new();
                    let mut e = Vec::new();
                    for x in std::iter::once(c.entity).chain(c.also.iter().copied()) {
                        match x.dim {
                            2 => f.push(x.id),
                            1 => e.push(x.id),
                            _ => {}
                        }
                    }
                    (f, e)
                }
                _ => (vec![], vec![]),
            }
        }
        let (faces, edges) = culprits(&error);
        Failed {
            error,
            faces,
            reasons: vec![],
            edges,
        }
    }
}

/// One attempt of [`mesh_model`] at the spacing `spacing` (already refined
/// by `refinement`). Volumes are packed with `volume_spacing`, the requested
/// spacing, which agrees with `spacing` inside volumes but keeps telling
/// when it is uniform (the BCC start needs that).
fn mesh_once(
    model: &Model,
    spacing: &dyn Spacing,
    volume_spacing: &dyn Spacing,
    opts: &Options,
    refinement: &refine::Refinement,
) -> Result<(Mesh, Report), Failed> {
    let model_dim = model.dim();
    let dim = opts.dim.unwrap_or(model_dim);
    if dim > model_dim {
        return Err(MeshError::Invalid(format!(
            "asked for a {dim}D mesh but the model's highest dimension is {model_dim} \
             ({} vertices, {} edges, {} faces, {} volumes)",
            model.vertices.len(),
            model.edges.len(),
            model.faces.len(),
            model.volumes.len()
        ))
        .into());
    }
    let mut mesh = Mesh::default();
    mesh.set_entities_from(model);
    let mut report = Report {
        dim,
        fast: opts.fast,
        integrator: (!opts.fast).then_some(opts.relax.integrator),
        ..Default::default()
    };
    // node spacing at each node, for the fixed bubbles of the next dimension
    let mut node_d: Vec<f64> = Vec::new();

    // 1. vertex bubbles
    for (i, v) in model.vertices.iter().enumerate() {
        let e = EntityRef::new(0, i as u32);
        if !(v.point.x.is_finite() && v.point.y.is_finite() && v.point.z.is_finite()) {
            return Err(MeshError::Invalid(format!(
                "{} has a non-finite position",
                model.describe(e)
            ))
            .into());
        }
        let d = spacing.spacing(&SpacingQuery {
            point: v.point,
            entity: e,
            params: [0.0; 2],
        });
        node_d.push(check_spacing(d, v.point, e).map_err(|x| x.within(model.describe(e)))?);
        mesh.nodes.push(Node {
            pos: v.point,
            entity: e,
            params: [0.0; 2],
        });
    }

    // 2. edges
    let t_edges = Instant::now();
    let mut edge_nodes: Vec<Vec<u32>> = Vec::with_capacity(model.edges.len());
    // vertex pairs joined by an edge meshed as one segment: a second such
    // edge between the same vertices (two arcs of a circle, a line beside an
    // arc, both shorter than the spacing) gets a middle node, or the two
    // edges would share one mesh segment and their faces one mesh edge
    let mut single_segment: std::collections::HashSet<(u32, u32)> = Default::default();
    if dim >= 1 {
        for (ei, edge) in model.edges.iter().enumerate() {
            let e = EntityRef::new(1, ei as u32);
            let mut ids = mesh_edge(model, ei, spacing, opts.fast, &mut mesh, &mut node_d)
                .map_err(|x| x.within(model.describe(e)))?;
            // at least the refinement's segments (a refined edge shorter
            // than its spacing), and two where another one-segment edge
            // already joins the same vertices: equal parameter steps
            let mut want = refinement.min_segments(ei);
            if ids.len() == 2
                && want < 2
                && !single_segment.insert((edge.start.min(edge.end), edge.start.max(edge.end)))
            {
                want = want.max(2);
            }
            if ids.len() - 1 < want {
                mesh.nodes.truncate(mesh.nodes.len() + 2 - ids.len());
                node_d.truncate(node_d.len() + 2 - ids.len());
                ids.truncate(1);
                for k in 1..want {
                    let t = edge.t0 + (edge.t1 - edge.t0) * k as f64 / want as f64;
                    let p = edge.curve.point(t);
                    let d = spacing.spacing(&SpacingQuery {
                        point: p,
                        entity: e,
                        params: [t, 0.0],
                    });
                    node_d.push(check_spacing(d, p, e).map_err(|x| x.within(model.describe(e)))?);
                    ids.push(mesh.nodes.len() as u32);
                    mesh.nodes.push(Node {
                        pos: p,
                        entity: e,
                        params: [t, 0.0],
                    });
                }
                ids.push(edge.end);
            }
            for w in ids.windows(2) {
                mesh.lines.push(Element {
                    nodes: [w[0], w[1]],
                    entity: e,
                });
            }
            let _ = edge;
            edge_nodes.push(ids);
        }
    }
    report.timings.edges_s = t_edges.elapsed().as_secs_f64();

    // 3. faces
    if dim >= 2 {
        let mut failed: Vec<(u32, MeshError)> = Vec::new();
        for fi in 0..model.faces.len() {
            let e = EntityRef::new(2, fi as u32);
            let mut face = |grow: bool| {
                mesh_face(
                    model,
                    fi,
                    spacing,
                    opts,
                    &edge_nodes,
                    &mut mesh,
                    &node_d,
                    &mut report.timings,
                    grow,
                )
            };
            // a grown start that cannot be connected (measured: the dome
            // sheet's pole cap at size 1.5, "constraint segments cross") is
            // retried from the quadtree's start; a failed connection leaves
            // the mesh untouched
            match match face(true) {
                Err(MeshError::Connect(_)) if !opts.fast => face(false),
                r => r,
            } {
                Ok(fr) => report.faces.push(fr),
                Err(err @ (MeshError::BadSpacing { .. } | MeshError::TooManyBubbles { .. })) => {
                    return Err(err.within(model.describe(e)).into())
                }
                // the other faces are meshed all the same, so that one
                // refinement round covers every face that needs it
                Err(err) => failed.push((fi as u32, err.within(model.describe(e)))),
            }
        }
        if !failed.is_empty() {
            let faces = failed.iter().map(|f| f.0).collect();
            let reasons = failed.iter().map(|f| f.1.to_string()).collect();
            let error = failed.swap_remove(0).1;
            return Err(Failed {
                error,
                faces,
                reasons,
                edges: vec![],
            });
        }
    }
    // closed shells: every volume's face triangles outward (a face shared
    // by two volumes keeps the first volume's orientation)
    if dim >= 3 {
        // a face mesh the shells cannot be walked through (two faces joined
        // across a chord, an edge in four triangles) is named, so that its
        // faces can be refined, before the volume stage refuses the shell
        crate::verify::verify_face_topology(model, &mesh).map_err(MeshError::Check)?;
    }
    if dim >= 2 {
        orient_volume_faces(model, &mut mesh, dim >= 3)?;
    }

    // 4. volumes
    if dim >= 3 {
        // the face nodes are the fixed bubbles of the volumes: their spacing
        for n in &mesh.nodes[node_d.len()..] {
            let d = spacing.spacing(&SpacingQuery {
                point: n.pos,
                entity: n.entity,
                params: n.params,
            });
            node_d.push(check_spacing(d, n.pos, n.entity)?);
        }
        for vi in 0..model.volumes.len() {
            let e = EntityRef::new(3, vi as u32);
            let vr = volume::mesh_volume(
                model,
                vi,
                volume_spacing,
                opts,
                &mut mesh,
                &node_d,
                &mut report.timings,
            )
            .map_err(|x| x.within(model.describe(e)))?;
            report.volumes.push(vr);
        }
    }
    // never silently wrong: the mesh leaves the engine only after its check
    crate::verify::verify(model, &mesh, dim).map_err(MeshError::Check)?;
    report.nodes = mesh.nodes.len();
    report.lines = mesh.lines.len();
    report.triangles = mesh.triangles.len();
    report.tetrahedra = mesh.tetrahedra.len();
    Ok((mesh, report))
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

/// Orients the triangles of each volume's faces outward (the first volume
/// that claims a face decides). A volume whose faces do not close is an
/// error when `strict` (volume meshing needs it), else left as meshed.
fn orient_volume_faces(model: &Model, mesh: &mut Mesh, strict: bool) -> Result<(), MeshError> {
    let mut done = vec![false; model.faces.len()];
    for vi in 0..model.volumes.len() {
        let e = EntityRef::new(3, vi as u32);
        let oriented = match volume::boundary_of(model, vi, mesh) {
            Ok(t) => t,
            Err(err) if strict => return Err(err.within(model.describe(e))),
            Err(_) => {
                // a surface mesh all the same: orient the faces among themselves
                let faces: Vec<u32> = model.volumes[vi]
                    .faces
                    .iter()
                    .copied()
                    .filter(|&f| !done[f as usize])
                    .collect();
                orient::orient_faces(model, mesh, &faces, true);
                for f in faces {
                    done[f as usize] = true;
                }
                continue;
            }
        };
        let by_key: std::collections::HashMap<[u32; 3], [u32; 3]> = oriented
            .iter()
            .map(|t| {
                let mut k = *t;
                k.sort_unstable();
                (k, *t)
            })
            .collect();
        let faces: Vec<u32> = model.volumes[vi].faces.clone();
        for t in mesh.triangles.iter_mut() {
            if t.entity.dim != 2 || !faces.contains(&t.entity.id) || done[t.entity.id as usize] {
                continue;
            }
            let mut k = t.nodes;
            k.sort_unstable();
            if let Some(o) = by_key.get(&k) {
                t.nodes = *o;
            }
        }
        for f in faces {
            done[f as usize] = true;
        }
    }
    // faces of no volume (shells that bound no solid, sheets): consistent
    // among themselves, closed shells outward
    let free: Vec<u32> = (0..model.faces.len() as u32)
        .filter(|&f| !done[f as usize])
        .collect();
    orient::orient_faces(model, mesh, &free, false);
    Ok(())
}

/// Meshes one edge; returns its node ids from start vertex to end vertex.
fn mesh_edge(
    model: &Model,
    ei: usize,
    spacing: &dyn Spacing,
    fast: bool,
    mesh: &mut Mesh,
    node_d: &mut Vec<f64>,
) -> Result<Vec<u32>, MeshError> {
    let edge = &model.edges[ei];
    let e = EntityRef::new(1, ei as u32);
    let curve: &dyn Curve = edge.curve.as_ref();
    let (t0, t1) = (edge.t0, edge.t1);
    if !(t0.is_finite() && t1.is_finite()) || t0 == t1 {
        return Err(MeshError::Invalid(format!(
            "parameter range [{t0}, {t1}] is empty or not finite"
        )));
    }
    for k in 0..=8 {
        let t = t0 + (t1 - t0) * k as f64 / 8.0;
        let p = curve.point(t);
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(MeshError::Invalid(format!(
                "the curve is not finite at t = {t}"
            )));
        }
    }
    let closed = edge.start == edge.end;
    let mut d_at = |t: f64, p: &P3| -> Result<f64, MeshError> {
        let d = spacing.spacing(&SpacingQuery {
            point: *p,
            entity: e,
            params: [t, 0.0],
        });
        check_spacing(d, *p, e)
    };
    let mut ts = if fast {
        placement::bisect_edge(curve, t0, t1, &mut d_at, closed)?
    } else {
        placement::equidistribute_edge(curve, t0, t1, &mut d_at, closed)?
    };
    if !fast {
        let (sd, ed) = (node_d[edge.start as usize], node_d[edge.end as usize]);
        relax_chain(curve, t0, t1, sd, ed, &mut ts, &mut d_at)?;
    }
    let mut ids = Vec::with_capacity(ts.len() + 2);
    ids.push(edge.start);
    for t in ts {
        let p = curve.point(t);
        let d = d_at(t, &p)?;
        ids.push(mesh.nodes.len() as u32);
        mesh.nodes.push(Node {
            pos: p,
            entity: e,
            params: [t, 0.0],
        });
        node_d.push(d);
    }
    ids.push(edge.end);
    Ok(ids)
}

/// Stage 2 on a curve: damped dynamics of the chain of edge bubbles with the
/// end bubbles fixed, each bubble kept on the curve by eq. 4.5.1
/// (Δt = Δx·C'/|C'|²). Bubbles keep their order along the curve.
fn relax_chain(
    curve: &dyn Curve,
    t0: f64,
    t1: f64,
    d_start: f64,
    d_end: f64,
    ts: &mut [f64],
    d_at: &mut dyn FnMut(f64, &P3) -> Result<f64, MeshError>,
) -> Result<(), MeshError> {
    let n = ts.len();
    if n == 0 {
        return Ok(());
    }
    let h = dynamics::time_step(1);
    let c = dynamics::damping(1);
    let mut t: Vec<f64> = std::iter::once(t0)
        .chain(ts.iter().cloned())
        .chain(std::iter::once(t1))
        .collect();
    let mut p: Vec<P3> = t.iter().map(|&s| curve.point(s)).collect();
    let mut d = vec![0.0; n + 2];
    d[0] = d_start;
    d[n + 1] = d_end;
    for k in 1..=n {
        d[k] = d_at(t[k], &p[k])?;
    }
    let mut v = vec![V3::zeros(); n + 2];
    for _step in 0..2000 {
        let mut max_move: f64 = 0.0;
        let mut f = vec![V3::zeros(); n + 2];
        for k in 0..=n {
            let delta = p[k + 1] - p[k];
            let r = delta.norm();
            let r0 = 0.5 * (d[k] + d[k + 1]);
            if r > 0.0 {
                let fm = force::magnitude(r, r0, dynamics::K0) * (delta / r);
                f[k] -= fm;
                f[k + 1] += fm;
            }
        }
        for k in 1..=n {
            let tan = curve.d1(t[k]);
            let tt = tan.norm_squared();
            if tt <= 0.0 {
                continue;
            }
            let a = (f[k] - v[k] * c) / dynamics::MASS;
            let dx = v[k] * h;
            v[k] += a * h;
            // keep the velocity tangent
            v[k] = tan * (v[k].dot(&tan) / tt);
            let dt = dx.dot(&tan) / tt; // eq. 4.5.1
            let lo = t[k - 1] + 1e-9 * (t1 - t0);
            let hi = t[k + 1] - 1e-9 * (t1 - t0);
            let nt = (t[k] + dt).clamp(lo.min(hi), hi.max(lo));
            let np = curve.point(nt);
            max_move = max_move.max((np - p[k]).norm() / d[k]);
            t[k] = nt;
            p[k] = np;
            d[k] = d_at(nt, &np)?;
        }
        if max_move < 1e-6 {
            break;
        }
    }
    ts.copy_from_slice(&t[1..=n]);
    Ok(())
}

/// Meshes one face: stage 1, stage 2, connection.
#[allow(clippy::too_many_arguments)]
fn mesh_face(
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
            relax_progress(&opts.progress, fe, settings.max_steps),
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
        let relax = sys.relax(settings, |_| {})?;
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
