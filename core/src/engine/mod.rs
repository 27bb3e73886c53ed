//! The bubble engine: meshing in the order of dimensions (thesis §3.2.3).
//!
//! 1. Vertex bubbles: one fixed node per model vertex.
//! 2. Edges (`crate::edge`): stage 1 by recursive bisection (§4.1.1);
//!    stage 2 places the number of bubbles of eq. 4.7.1 and relaxes the
//!    chain to the force balance (§4.2–4.5).
//! 3. Faces ([`crate::face`]): stage 1 by the oblique quadtree (§4.1.2);
//!    stage 2 by damped dynamics with population control (§4.3–4.7),
//!    bubbles held on the face through their (u,v) (§4.5); then
//!    constrained Delaunay connection in (u,v). The faces of each volume
//!    are then oriented outward.
//! 4. Volumes ([`crate::volume`]): stage 1 on a lattice, stage 2, Delaunay
//!    tetrahedralization and the tetrahedral passes.
//!
//! Bubbles of lower dimensions are fixed while the next dimension is packed,
//! so each dimension sees the finished mesh of the ones below it as its
//! boundary. The finished mesh passes [`crate::verify::verify`] before it
//! leaves the engine: a mesh that is not valid is never returned.
//!
//! Why a loop of attempts ([`mesh_model`] around `mesh_once`): a face that
//! cannot be given a valid mesh at the requested spacing usually can at a
//! finer one, so a failed attempt names the faces and edges to refine
//! ([`refine`]) and the whole model is meshed again; the report lists every
//! face meshed finer than asked.
//!
//! The run tells [`Options::observer`] what it does ([`Event`]): the face
//! and volume stages report stage 1 and each stage-2 step with borrowed
//! snapshots of the bubbles; this module reports each entity finished and
//! the passes of each volume (from its report, once the volume is done).

mod memo;
pub mod refine;

use std::time::Instant;

use crate::edge::mesh_edge;
use crate::error::check_spacing;
use crate::face::{mesh_face, orient, FaceInputs, FaceReport};
use crate::mesh::{Element, Mesh, Node};
use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};
use crate::volume;

pub use crate::bubbles::dynamics::Integrator;
pub use crate::bubbles::system::{EnergySample, RelaxSettings, RelaxStats};
pub use crate::error::MeshError;
pub use crate::options::{
    Event, ObserverFn, Options, Timings, VolumeLattice, DEFAULT_CIRCLE_POINTS, MAX_CIRCLE_POINTS,
};

/// What the run did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Report {
    /// The highest dimension meshed.
    pub dim: u8,
    /// Stage 1 only (no stage 2).
    pub fast: bool,
    /// The stage-2 integrator (none with `fast`).
    pub integrator: Option<Integrator>,
    /// Nodes of the mesh.
    pub nodes: usize,
    /// Line elements (edge segments).
    pub lines: usize,
    /// Triangles.
    pub triangles: usize,
    /// Tetrahedra.
    pub tetrahedra: usize,
    /// Wall-clock seconds per phase.
    pub timings: Timings,
    /// What was done on each face.
    pub faces: Vec<FaceReport>,
    /// What was done in each volume.
    pub volumes: Vec<volume::VolumeReport>,
    /// Faces meshed with a spacing finer than requested because the
    /// requested one could not give them a valid mesh ([`refine`]).
    pub refined: Vec<refine::RefinedFace>,
    /// Places (balls) meshed finer than requested because boundary
    /// triangles there were missing from the tetrahedralization
    /// ([`refine`]).
    pub refined_places: Vec<refine::RefinedPlace>,
    /// How many times the model was meshed again finer (0: once, as asked).
    pub refinement_rounds: usize,
    /// Faces of a solid mesh whose edges were meshed again with their
    /// nodes staggered across strips narrower than the spacing
    /// ([`crate::edge::stagger`]; surface meshes stagger everywhere, solid
    /// ones only where a face could not be connected without it).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub staggered_faces: Vec<String>,
    /// Faces of the last round whose inputs (boundary nodes, spacing) were
    /// those of an earlier round: their mesh was replayed, not made again
    /// (the same triangles; see `engine::memo`).
    pub faces_replayed: usize,
    /// Where separate parts of the mesh (solids of an assembly) touch
    /// without being joined ([`crate::verify::touching_parts`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub touching: Option<crate::verify::Touching>,
    /// A volume whose faces do not close it ([`crate::verify::open_shell`]):
    /// its surface mesh is open there (its tetrahedra would have failed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub open_shell: Option<crate::verify::OpenShell>,
    /// A volume whose surface mesh passes through itself
    /// ([`crate::verify::SelfCrossing`]; surface meshes only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub self_crossing: Option<crate::verify::SelfCrossing>,
    /// Edges meshed finer than requested to keep the least number of
    /// nodes per turn, and the faces graded from them
    /// ([`crate::circle_points`]); absent where none was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub circle_points: Option<crate::circle_points::CirclePointsReport>,
}

impl Report {
    /// The stage-2 steps of each face that ran one, in face order.
    pub fn stage2_steps_per_face(&self) -> Vec<usize> {
        self.faces
            .iter()
            .filter_map(|f| f.relax.as_ref().map(|r| r.steps))
            .collect()
    }
}

/// Relative distance (of the model's size) within which two vertices of a
/// face are one point for [`Model::pinch`].
const PINCH_TOL: f64 = 1e-9;

/// Refuses a face whose boundary touches itself ([`Model::pinch`]) before
/// any meshing: refinement cannot separate two nodes at one point, and
/// retrying it only took time (as_gehause_rohteil.stp: 12 s to fail with
/// "two mesh nodes coincide").
fn refuse_pinched_faces(model: &Model) -> Result<(), MeshError> {
    let Some((lo, hi)) = model.bbox() else {
        return Ok(());
    };
    let tol = PINCH_TOL * (hi - lo).norm();
    for f in 0..model.faces.len() {
        if let Some((a, b)) = model.pinch(f, tol) {
            let p = model.vertices[a as usize].point;
            return Err(MeshError::Invalid(format!(
                "{}: its boundary touches itself at ({}, {}, {}): {} and {} are two vertices at one point, joined by no edge (a hole touching the outer loop?); a mesh cannot keep two nodes at one point apart — repair the face in the CAD system so that one vertex is shared",
                model.describe(EntityRef::new(2, f as u32)),
                p.x,
                p.y,
                p.z,
                model.describe(EntityRef::new(0, a)),
                model.describe(EntityRef::new(0, b)),
            )));
        }
    }
    Ok(())
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
    // what no refinement can cure is refused before any meshing
    refuse_pinched_faces(model)?;
    mesh_refining(model, spacing, opts)
}

/// [`mesh_model`]'s attempts: meshes the model, and after a failure that a
/// finer spacing may cure, meshes it again with the failing faces or places
/// refined (faces that did not change are replayed).
fn mesh_refining(
    model: &Model,
    spacing: &dyn Spacing,
    opts: &Options,
) -> Result<(Mesh, Report), MeshError> {
    let t_start = Instant::now();
    let mut refinement = refine::Refinement::new(model);
    let mut rounds = 0;
    // edges, faces and vertices take at least `circle_points` nodes per
    // turn of a curved edge; volumes are packed with `spacing` itself
    let mut capped = crate::circle_points::CirclePoints::new(model, spacing, opts.circle_points);
    // the cap's report once it was dropped (see below)
    let mut dropped: Option<crate::circle_points::CirclePointsReport> = None;
    // released faces that failed again and were refined once with the cap on
    let mut retried: std::collections::HashSet<u32> = Default::default();
    // faces whose inputs did not change since the last attempt are replayed
    let mut memos: memo::FaceMemos = Vec::new();
    let mut edge_memos: memo::EdgeMemos = Vec::new();
    // the surface triangles of the first attempt that asked for places
    let mut before_places: Option<usize> = None;
    // faces of a solid mesh whose edges take staggered nodes
    let mut staggered: std::collections::BTreeSet<u32> = Default::default();
    loop {
        rounds += 1;
        let (cap_state, edge_cap_state) = cap_states(model, capped.as_ref());
        let boundary_spacing: &dyn Spacing = match &capped {
            Some(c) => c,
            None => spacing,
        };
        let (face_boxes, edge_boxes) = (memo::boxes(&memos), memo::edge_boxes(&edge_memos));
        let refined = refine::Refined {
            inner: boundary_spacing,
            refinement: &refinement,
            face_boxes: &face_boxes,
            edge_boxes: &edge_boxes,
        };
        let replay = Replay {
            memos: &mut memos,
            edge_memos: &mut edge_memos,
            refinement: &refinement,
            cap_state: &cap_state,
            edge_cap_state: &edge_cap_state,
            staggered: &staggered,
        };
        match mesh_once(model, &refined, spacing, opts, &refinement, replay) {
            Ok((mesh, mut report)) => {
                report.circle_points = capped
                    .as_ref()
                    .map(|c| c.report().clone())
                    .or(dropped.take());
                report.refined = refinement.faces(model);
                report.refined_places = refinement.places();
                report.refinement_rounds = rounds - 1;
                report.staggered_faces = staggered
                    .iter()
                    .map(|&f| model.describe(EntityRef::new(2, f)))
                    .collect();
                report.timings.total_s = t_start.elapsed().as_secs_f64();
                return Ok((mesh, report));
            }
            Err(failed) => {
                let reason = failed.error.to_string();
                if stagger_first(model, opts, &failed, &mut staggered) {
                    continue;
                }
                // a released face that fails again is refined once with the
                // cap kept (as_0053's six countersink cones fold at the
                // requested spacing and mesh at half of it; dropping the cap
                // made the whole part 20 times more tetrahedra than Gmsh's,
                // with touching faces refined to an eighth); if it fails
                // again (as_tie_rod.step's narrow fillets fold with their
                // capped neighbours around them), or the volume stage fails
                // while faces are released, the cap is dropped for the whole
                // model, which is then meshed as without it, from its first
                // round
                if let Some(c) = capped.as_ref() {
                    let released_again: Vec<u32> = failed
                        .faces
                        .iter()
                        .copied()
                        .filter(|&f| c.is_released(f))
                        .collect();
                    let again = released_again.iter().any(|f| retried.contains(f));
                    retried.extend(released_again.iter().copied());
                    let drop = if failed.spots.is_empty() {
                        again
                    } else {
                        !c.report().released.is_empty()
                    };
                    if drop {
                        let mut r = c.report().clone();
                        r.dropped = Some(reason.clone());
                        dropped = Some(r);
                        capped = None;
                        // and the refinement made with it: from here on the
                        // run is the one without the cap
                        refinement = refine::Refinement::new(model);
                        before_places = None;
                        continue;
                    }
                }
                // a face graded finer by the circle-point cap that fails is
                // first meshed again with the requested spacing inside (its
                // capped edges stay): a narrow fillet of small radius meshes
                // from its boundary at the requested spacing, while the
                // cap's finer spacing puts interior bubbles on its tight bend
                let released: Vec<u32> = match capped.as_mut() {
                    Some(c) if failed.spots.is_empty() => failed
                        .faces
                        .iter()
                        .copied()
                        .filter(|&f| c.release(model, f, &reason))
                        .collect(),
                    _ => Vec::new(),
                };
                let (faces, reasons) = to_refine(&failed, &released, &reason);
                if let Some(why) = places_stop(&failed, &mut before_places, rounds, &refinement) {
                    let source = Box::new(failed.error);
                    return Err(MeshError::RefinementStopped { why, source });
                }
                let bumped = if !failed.spots.is_empty() {
                    let d_at = |p: &crate::geom::P3| {
                        spacing.spacing(&SpacingQuery {
                            point: *p,
                            entity: crate::model::EntityRef::new(3, 0),
                            params: [0.0, 0.0],
                        })
                    };
                    refinement.bump_spots(&failed.spots, d_at, &reason)
                } else if !faces.is_empty() || released.is_empty() {
                    refinement.bump(model, &faces, &reasons, &failed.edges, &reason)
                } else {
                    false
                };
                if failed.faces.is_empty() && failed.edges.is_empty() && failed.spots.is_empty()
                    || opts.fast
                    || rounds > refine::MAX_ROUNDS
                    || (!bumped && released.is_empty())
                {
                    return Err(failed.error);
                }
            }
        }
    }
}

/// Whether `failed`, an attempt of a solid mesh, is met first by meshing
/// the edges of its failing faces again with staggered nodes (their ids
/// join `staggered`): a solid mesh keeps its edges' nodes side by side
/// (its tetrahedra are better so), and a face that cannot be connected so
/// has its edges staggered before anything is made finer (a narrow band
/// between two arcs of a cylinder, rp_5_026: staggered it meshes at the
/// size asked, side by side it failed every refinement). False for
/// surface meshes, failures that name places, and faces staggered already.
fn stagger_first(
    model: &Model,
    opts: &Options,
    failed: &Failed,
    staggered: &mut std::collections::BTreeSet<u32>,
) -> bool {
    let solid = opts.dim.unwrap_or(model.dim()) >= 3;
    if !solid || opts.fast || !failed.spots.is_empty() {
        return false;
    }
    let before = staggered.len();
    staggered.extend(failed.faces.iter().copied());
    staggered.len() > before
}

/// The faces of `failed` to refine, those not `released`, with why each
/// failed (`reason`, the attempt's error, where its own is not known).
fn to_refine(failed: &Failed, released: &[u32], reason: &str) -> (Vec<u32>, Vec<String>) {
    failed
        .faces
        .iter()
        .enumerate()
        .filter(|(_, f)| !released.contains(f))
        .map(|(k, &f)| {
            let why = failed.reasons.get(k).cloned();
            (f, why.unwrap_or_else(|| reason.to_string()))
        })
        .unzip()
}

/// Why refinement by places stops after attempt `rounds` failed as
/// `failed` (see [`refine::PLACE_GROWTH`]), or `None` to go on.
/// `before_places` is the surface triangles of the first attempt that
/// asked for places (set by the first such).
fn places_stop(
    failed: &Failed,
    before_places: &mut Option<usize>,
    rounds: usize,
    refinement: &refine::Refinement,
) -> Option<String> {
    if failed.spots.is_empty() || failed.triangles == 0 {
        return None;
    }
    let first = *before_places.get_or_insert(failed.triangles);
    (failed.triangles as f64 > refine::PLACE_GROWTH * first as f64).then(|| {
        format!(
            "meshing the places where this happens finer grew the surface mesh from {first} \
             to {} triangles in {} rounds without curing them: faces there meet at a very \
             sharp angle or close a wall far thinner than the spacing (the place there: {})",
            failed.triangles,
            rounds - 1,
            refinement
                .place_near(&failed.spots[0].0)
                .unwrap_or_default()
        )
    })
}

/// Per face and per edge: the circle-point cap kept (1), released (2) or
/// gone (0), for the memos' keys.
fn cap_states(
    model: &Model,
    capped: Option<&crate::circle_points::CirclePoints<'_>>,
) -> (Vec<u64>, Vec<u64>) {
    let state = |released: bool| match capped {
        None => 0,
        Some(_) if released => 2,
        Some(_) => 1,
    };
    (
        (0..model.faces.len() as u32)
            .map(|f| state(capped.is_some_and(|c| c.is_released(f))))
            .collect(),
        (0..model.edges.len() as u32)
            .map(|e| state(capped.is_some_and(|c| c.is_edge_released(e))))
            .collect(),
    )
}

/// A failed attempt: the error, and the faces and edges whose refinement
/// may cure it.
struct Failed {
    error: MeshError,
    faces: Vec<u32>,
    /// Why each of `faces` failed, where known (else the error's text).
    reasons: Vec<String>,
    edges: Vec<u32>,
    /// Balls (centre, radius) to mesh finer instead of whole faces.
    spots: Vec<(crate::geom::P3, f64)>,
    /// Triangles of the attempt's surface mesh when a volume failed (0:
    /// it failed before).
    triangles: usize,
}

impl From<MeshError> for Box<Failed> {
    fn from(error: MeshError) -> Self {
        /// The faces, edges and places whose refinement may cure `e`
        /// (places replace faces where the error names them).
        type Culprits = (Vec<u32>, Vec<u32>, Vec<(crate::geom::P3, f64)>);
        fn culprits(e: &MeshError) -> Culprits {
            match e {
                MeshError::In { source, .. } => culprits(source),
                MeshError::Refinable { faces, spots, .. } if spots.is_empty() => {
                    (faces.clone(), vec![], vec![])
                }
                MeshError::Refinable { spots, .. } => (vec![], vec![], spots.clone()),
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
                    (f, e, vec![])
                }
                _ => (vec![], vec![], vec![]),
            }
        }
        let (faces, edges, spots) = culprits(&error);
        Box::new(Failed {
            error,
            faces,
            reasons: vec![],
            edges,
            spots,
            triangles: 0,
        })
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
    replay: Replay<'_>,
) -> Result<(Mesh, Report), Box<Failed>> {
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
    let mut a = Attempt {
        model,
        spacing,
        opts,
        mesh: Mesh::default(),
        node_d: Vec::new(),
        report: Report {
            dim,
            fast: opts.fast,
            integrator: (!opts.fast).then_some(opts.relax.integrator),
            ..Default::default()
        },
        walls: Vec::new(),
    };
    a.mesh.set_entities_from(model);

    // 1. vertex bubbles
    a.vertices()?;
    // 2. edges
    let t_edges = Instant::now();
    let mut replay = replay;
    let edge_nodes = if dim >= 1 {
        a.edges(refinement, &mut replay)?
    } else {
        Vec::new()
    };
    a.report.timings.edges_s = t_edges.elapsed().as_secs_f64();
    // 3. faces
    if dim >= 2 {
        a.faces(&edge_nodes, replay)?;
    }
    // closed shells: every volume's face triangles outward (a face shared
    // by two volumes keeps the first volume's orientation)
    if dim >= 3 {
        // a face mesh the shells cannot be walked through (two faces joined
        // across a chord, an edge in four triangles) is named, so that its
        // faces can be refined, before the volume stage refuses the shell
        crate::verify::verify_face_topology(model, &a.mesh).map_err(MeshError::Check)?;
    }
    if dim >= 2 {
        orient_volume_faces(model, &mut a.mesh, dim >= 3)?;
    }
    // 4. volumes
    if dim >= 3 {
        if let Err(e) = a.volumes(volume_spacing) {
            let mut failed: Box<Failed> = e.into();
            failed.triangles = a.mesh.triangles.len();
            return Err(failed);
        }
    }
    let Attempt {
        mesh, mut report, ..
    } = a;
    // never silently wrong: the mesh leaves the engine only after its check
    crate::verify::verify(model, &mesh, dim).map_err(MeshError::Check)?;
    report.touching = crate::verify::touching_parts(&mesh);
    report.open_shell = crate::verify::open_shell(model);
    // a volume's tetrahedra already show its surface does not cross itself
    if dim < 3 {
        report.self_crossing = crate::volume::crossing::self_crossing(model, &mesh);
    }
    report.nodes = mesh.nodes.len();
    report.lines = mesh.lines.len();
    report.triangles = mesh.triangles.len();
    report.tetrahedra = mesh.tetrahedra.len();
    Ok((mesh, report))
}

/// What the edges and faces of an attempt may replay from the last one
/// (see [`memo`]).
struct Replay<'m> {
    memos: &'m mut memo::FaceMemos,
    edge_memos: &'m mut memo::EdgeMemos,
    refinement: &'m refine::Refinement,
    /// Per face: the circle-point cap kept (1), released (2) or gone (0).
    cap_state: &'m [u64],
    /// The same per edge.
    edge_cap_state: &'m [u64],
    /// Faces of a solid mesh whose edges take staggered nodes.
    staggered: &'m std::collections::BTreeSet<u32>,
}

/// A face meshed: its nodes and triangles or why not, and the time it took.
type Meshed = (
    Box<Result<(FaceReport, crate::face::FaceOut), MeshError>>,
    crate::options::Timings,
);

/// What a face gave, before it is appended to the mesh.
enum FaceWork {
    /// Its remembered mesh replays ([`memo::replays`]).
    Replay,
    /// Meshed.
    Meshed(Meshed),
}

/// The state of one attempt: what is meshed so far, dimension by
/// dimension.
struct Attempt<'a> {
    model: &'a Model,
    spacing: &'a dyn Spacing,
    opts: &'a Options,
    mesh: Mesh,
    /// The node spacing at each node, for the fixed bubbles of the next
    /// dimension.
    node_d: Vec<f64>,
    report: Report,
    /// The slabs between twin faces (see [`crate::face::twin`]): no
    /// volume bubble stays in one.
    walls: Vec<crate::face::twin::Wall>,
}

impl Attempt<'_> {
    /// One fixed node per model vertex.
    fn vertices(&mut self) -> Result<(), MeshError> {
        let model = self.model;
        for (i, v) in model.vertices.iter().enumerate() {
            let e = EntityRef::new(0, i as u32);
            if !(v.point.x.is_finite() && v.point.y.is_finite() && v.point.z.is_finite()) {
                return Err(MeshError::Invalid(format!(
                    "{} has a non-finite position",
                    model.describe(e)
                )));
            }
            let d = self.spacing.spacing(&SpacingQuery {
                point: v.point,
                entity: e,
                params: [0.0; 2],
            });
            self.node_d
                .push(check_spacing(d, v.point, e).map_err(|x| x.within(model.describe(e)))?);
            self.mesh.nodes.push(Node {
                pos: v.point,
                entity: e,
                params: [0.0; 2],
            });
        }
        Ok(())
    }

    /// Meshes every edge; returns the node ids along each.
    fn edges(
        &mut self,
        refinement: &refine::Refinement,
        memory: &mut Replay<'_>,
    ) -> Result<Vec<Vec<u32>>, MeshError> {
        let (model, spacing, opts) = (self.model, self.spacing, self.opts);
        let mesh = &mut self.mesh;
        let node_d = &mut self.node_d;
        let mut edge_nodes: Vec<Vec<u32>> = Vec::with_capacity(model.edges.len());
        // vertex pairs joined by an edge meshed as one segment: a second such
        // edge between the same vertices (two arcs of a circle, a line beside an
        // arc, both shorter than the spacing) gets a middle node, or the two
        // edges would share one mesh segment and their faces one mesh edge
        let mut single_segment: std::collections::HashSet<(u32, u32)> = Default::default();
        let solid = self.report.dim >= 3;
        // ghosts across every face of a surface mesh, and across the faces
        // of a solid one that could not be connected without them (see
        // `mesh_refining`): staggered strips serve surface meshes, while
        // the tetrahedra on their obtuse triangles came out flatter
        // (docs/decisions.md, session 25)
        let mut neighbours = if opts.fast || (solid && memory.staggered.is_empty()) {
            vec![Vec::new(); model.edges.len()]
        } else {
            crate::edge::stagger::earlier_neighbours(model)
        };
        if solid {
            for row in &mut neighbours {
                row.retain(|(_, f)| memory.staggered.contains(f));
            }
        }
        let mut sides = Default::default();
        for (ei, edge) in model.edges.iter().enumerate() {
            let e = EntityRef::new(1, ei as u32);
            let start = opts.warm.as_deref().and_then(|w| w.of(e));
            let ghosts = if opts.fast || start.is_some() || neighbours[ei].is_empty() {
                Vec::new()
            } else {
                crate::edge::stagger::ghosts_of_edge(
                    model,
                    ei,
                    &neighbours[ei],
                    &edge_nodes,
                    mesh,
                    node_d,
                    &mut sides,
                )
            };
            // what the edge's nodes depend on besides the places near it
            let d_bits = |v: u32| node_d.get(v as usize).map_or(u64::MAX, |d| d.to_bits());
            let mut key = vec![
                refinement.edge_level(ei) as u64,
                memory.edge_cap_state.get(ei).copied().unwrap_or(0),
                spacing.constant_on(e).map_or(u64::MAX, f64::to_bits),
                spacing.constant().map_or(u64::MAX, f64::to_bits),
                d_bits(edge.start),
                d_bits(edge.end),
            ];
            key.extend(
                ghosts
                    .iter()
                    .flat_map(|g| [g.t.to_bits(), g.width.to_bits()]),
            );
            let replayed = opts
                .replay_unchanged
                .then(|| {
                    memo::replay_edge(
                        memory.edge_memos,
                        refinement,
                        ei,
                        &key,
                        (edge.start, edge.end),
                        mesh,
                        node_d,
                    )
                })
                .flatten();
            let mut ids = match replayed {
                Some(ids) => ids,
                None => {
                    let ids =
                        mesh_edge(model, ei, spacing, opts.fast, start, &ghosts, mesh, node_d)
                            .map_err(|x| x.within(model.describe(e)))?;
                    memo::record_edge(
                        memory.edge_memos,
                        model.edges.len(),
                        refinement,
                        ei,
                        key,
                        &ids,
                        mesh,
                        node_d,
                    );
                    ids
                }
            };
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
            edge_nodes.push(ids);
            opts.tell(&Event::Done {
                entity: e,
                mesh: &*mesh,
            });
        }
        Ok(edge_nodes)
    }

    /// Meshes every face. A face that fails does not stop the others, so
    /// that one refinement round covers every face that needs it; the
    /// error names them all.
    fn faces(&mut self, edge_nodes: &[Vec<u32>], memory: Replay<'_>) -> Result<(), Box<Failed>> {
        let (model, spacing, opts) = (self.model, self.spacing, self.opts);
        let node_d = &self.node_d;
        let mut failed: Vec<(u32, MeshError)> = Vec::new();
        // what the spacing on a face depends on besides its boundary
        let spacing_key = |fi: usize| {
            let e = EntityRef::new(2, fi as u32);
            [
                memory.refinement.face_level(fi) as u64,
                memory.cap_state.get(fi).copied().unwrap_or(0),
                spacing.constant_on(e).map_or(u64::MAX, f64::to_bits),
                spacing.constant().map_or(u64::MAX, f64::to_bits),
            ]
        };
        // a face meshed from the edges' mesh alone (faces only read the
        // mesh, so they can be meshed side by side)
        let mesh_one = |fi: usize, mesh: &Mesh| -> Meshed {
            let mut timings = crate::options::Timings::default();
            let inputs = FaceInputs {
                model,
                spacing,
                opts,
                edge_nodes,
                node_d,
            };
            let mut face = |grow: bool| mesh_face(&inputs, fi, mesh, &mut timings, grow);
            // a grown start that cannot be connected (measured: the dome
            // sheet's pole cap at size 1.5, "constraint segments cross") is
            // retried from the quadtree's start
            let r = match face(true) {
                Err(MeshError::Connect(_)) if !opts.fast => face(false),
                r => r,
            };
            (Box::new(r), timings)
        };
        let work = |fi: usize, mesh: &Mesh, memos: &memo::FaceMemos| -> FaceWork {
            let at = memo::Attempted {
                model,
                refinement: memory.refinement,
                edge_nodes,
                node_d,
            };
            if opts.replay_unchanged && memo::replays(memos, &at, fi, &spacing_key(fi), mesh) {
                FaceWork::Replay
            } else {
                FaceWork::Meshed(mesh_one(fi, mesh))
            }
        };
        // side by side where the caller allows geometry and spacing to be
        // asked from rayon's threads; the same mesh either way, since each
        // face's outcome is appended in face order below
        let n = model.faces.len();
        // the two sides of thin walls (see face::twin)
        let mut twins = crate::face::twin::Twins::new(model, &self.mesh, edge_nodes, node_d);
        let mut ready: Vec<Option<FaceWork>> = if opts.relax.parallel && n > 1 {
            use rayon::prelude::*;
            let (mesh, memos) = (&self.mesh, &*memory.memos);
            (0..n)
                .into_par_iter()
                .map(|fi| Some(work(fi, mesh, memos)))
                .collect()
        } else {
            Vec::new()
        };
        for fi in 0..n {
            let e = EntityRef::new(2, fi as u32);
            let outcome = match ready.get_mut(fi).and_then(Option::take) {
                Some(w) => w,
                None => work(fi, &self.mesh, memory.memos),
            };
            let at = memo::Attempted {
                model,
                refinement: memory.refinement,
                edge_nodes,
                node_d,
            };
            let (result, timings) = match outcome {
                FaceWork::Replay => {
                    match memo::replay(memory.memos, &at, fi, &mut self.mesh) {
                        Some(fr) => {
                            self.report.faces.push(fr);
                            self.report.faces_replayed += 1;
                            twins.meshed(fi);
                            opts.tell(&Event::Done {
                                entity: e,
                                mesh: &self.mesh,
                            });
                            continue;
                        }
                        // `replays` found its memo, so this is not met;
                        // meshing the face is right anyway
                        None => mesh_one(fi, &self.mesh),
                    }
                }
                FaceWork::Meshed(m) => m,
            };
            self.report.timings.add(&timings);
            match *result {
                Ok((mut fr, mut out)) => {
                    // the second side of a wall thinner than the spacing
                    // takes the first side's mesh (see face::twin)
                    twins.take(model, spacing, &mut self.mesh, fi, &mut fr, &mut out);
                    twins.meshed(fi);
                    let before = (self.mesh.nodes.len(), self.mesh.triangles.len());
                    out.append_to(&mut self.mesh, e);
                    memo::record(
                        memory.memos,
                        &at,
                        fi,
                        &spacing_key(fi),
                        &self.mesh,
                        before,
                        &fr,
                    );
                    self.report.faces.push(fr);
                    opts.tell(&Event::Done {
                        entity: e,
                        mesh: &self.mesh,
                    });
                }
                Err(err @ (MeshError::BadSpacing { .. } | MeshError::TooManyBubbles { .. })) => {
                    return Err(err.within(model.describe(e)).into())
                }
                // the other faces are meshed all the same, so that one
                // refinement round covers every face that needs it
                Err(err) => failed.push((fi as u32, err.within(model.describe(e)))),
            }
        }
        self.walls = twins.walls;
        if !failed.is_empty() {
            let faces = failed.iter().map(|f| f.0).collect();
            let reasons = failed.iter().map(|f| f.1.to_string()).collect();
            let error = failed.swap_remove(0).1;
            return Err(Box::new(Failed {
                error,
                faces,
                reasons,
                edges: vec![],
                spots: vec![],
                triangles: 0,
            }));
        }
        Ok(())
    }

    /// Meshes every volume, packed with `volume_spacing` (see
    /// [`mesh_once`]).
    fn volumes(&mut self, volume_spacing: &dyn Spacing) -> Result<(), MeshError> {
        let (model, opts) = (self.model, self.opts);
        for vi in 0..model.volumes.len() {
            let e = EntityRef::new(3, vi as u32);
            let (flips, splits) = volume::recover_boundary(model, vi, &mut self.mesh);
            // the face nodes (and the splits' nodes) are the fixed bubbles
            // of the volumes: their spacing
            for n in &self.mesh.nodes[self.node_d.len()..] {
                let d = self.spacing.spacing(&SpacingQuery {
                    point: n.pos,
                    entity: n.entity,
                    params: n.params,
                });
                self.node_d.push(check_spacing(d, n.pos, n.entity)?);
            }
            let job =
                volume::VolumeJob::new(model, vi, volume_spacing, opts, &self.node_d, &self.walls);
            let mut vr = volume::mesh_volume(&job, &mut self.mesh, &mut self.report.timings)
                .map_err(|x| x.within(model.describe(e)))?;
            vr.boundary_flips = flips;
            vr.boundary_splits = splits;
            tell_passes(opts, e, &vr);
            self.report.volumes.push(vr);
            opts.tell(&Event::Done {
                entity: e,
                mesh: &self.mesh,
            });
        }
        Ok(())
    }
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

/// Tells the observer of the improvement passes of volume `entity`, from
/// its report (the volume stage times each pass).
fn tell_passes(opts: &Options, entity: EntityRef, r: &volume::VolumeReport) {
    if opts.observer.is_none() {
        return;
    }
    /// A pass: its name, seconds and counts.
    type Pass<'a> = (&'static str, f64, &'a [(&'static str, f64)]);
    let passes: [Pass; 4] = [
        ("odt", r.odt_s, &[("iterations", r.odt_iterations as f64)]),
        (
            "delaunay",
            r.delaunay_s,
            &[
                ("tetrahedra", r.tetrahedra as f64),
                ("recovery_removed", r.recovery_removed as f64),
            ],
        ),
        ("slivers", r.sliver_s, &[("steiner", r.steiner as f64)]),
        (
            "polish",
            r.polish_s,
            &[
                ("moves", r.polish_moves as f64),
                ("flips", r.polish_flips as f64),
            ],
        ),
    ];
    for (name, seconds, stats) in passes {
        opts.tell(&Event::Pass {
            entity,
            name,
            seconds,
            stats,
        });
    }
}
