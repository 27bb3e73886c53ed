//! Face meshing (thesis §4.1.2, §4.3–4.7): stage 1 by the oblique
//! quadtree, stage 2 by damped dynamics with population control, bubbles
//! held on the face through their (u,v) (§4.5); then constrained Delaunay
//! connection in (u,v) and the 2D improvement.
//!
//! [`mesh_face`] runs the phases in order; each is a method of one face's
//! context (`FaceJob`):
//! - the boundary bubbles: the nodes of the face's edges and embedded
//!   entities, fixed (§3.2.3), with their (u,v), and the face's [`region`];
//! - stage 1: [`placement`] (the oblique quadtree, §4.1.2), on curved faces
//!   after a crystal from [`growth`];
//! - stage 2: [`crate::bubbles::relax`] with the face's [`carrier`];
//! - connection: [`connect`] (constrained Delaunay in (u,v), caps in the
//!   tangent plane near singular points), then [`improve`]; where two
//!   rows of triangles may mesh a strip better than one, its middle row
//!   ([`placement::strip_rows`]) is tried and kept if the face is better
//!   (not on faces bounding a volume meshed next);
//! - on a graded planar face, a second start from the lattice conformal to
//!   the spacing ([`conformal`]), kept when it is better;
//! - the new nodes and triangles into the mesh.
//!
//! [`orient`] turns the faces of a closed shell outward afterwards. Where
//! a planar face is the second side of a wall thinner than the spacing,
//! it takes the first side's mesh carried across instead ([`twin`]: the
//! volume between them is then a layer of prisms, not of slivers).

pub(crate) mod carrier;
pub(crate) mod conformal;
pub(crate) mod connect;
pub(crate) mod growth;
pub(crate) mod improve;
pub(crate) mod orient;
pub(crate) mod placement;
pub(crate) mod region;
pub(crate) mod skinny;
pub(crate) mod twin;
pub(crate) mod warm;

use std::collections::HashMap;
use std::time::Instant;

use crate::bubbles::constraint::{self, Carrier};
use crate::bubbles::system::{self, RelaxStats, System};
use crate::error::MeshError;
use crate::geom::{P3, V3};
use crate::measure::mean_and_least_radius_ratio as mean_and_least;
use crate::mesh::{Element, Mesh, Node};
use crate::model::{EntityRef, Model};
use crate::options::{Options, Timings};
use crate::spacing::{Spacing, SpacingQuery};

use carrier::OnFace;
use region::Region;

/// The face pipeline's tuning, each value with how it was measured.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FaceParams {
    /// Seed a boundary layer before the quadtree lattice where the spacing
    /// is uniform. Measured on `../shared/realstep` as surfaces at diag/25:
    /// mean radius ratio +0.005 to +0.012 on most parts, whose faces are a
    /// few spacings across, so the boundary layer is much of the mesh; on
    /// the graded cases B and C it cost 0.005 of the mean and 0.06 of the
    /// minimum, so not where the spacing varies. A warm start seeds the
    /// layer too where the face changed (`warm::stage1`): without it the
    /// warm minimum radius ratio fell 0.05 below from-scratch's
    /// (core/tests/remesh.rs).
    pub apex_layer_uniform: bool,
    /// Bubbles closer than this many spacings to a singular point of the
    /// parametrization are connected in their tangent plane (a cap), not in
    /// (u,v). Where such caps do not connect (on a sphere of a few
    /// spacings' radius they reach past its equator and fold in their
    /// plane), the radii of [`CAP_RETRY_RADII`] are tried in turn.
    pub cap_radius: f64,
    /// Rounds of edge relaxation and Delaunay flips after connection
    /// ([`improve`]).
    pub improve_rounds: usize,
    /// After a conformal-lattice start ([`conformal`]), the mean lift runs
    /// over the bubbles of every triangle below this radius ratio, for at
    /// most `lattice_mean_rounds` rounds (cases B and C: 0.99 and 6 rounds
    /// gave a mean 0.001 lower, 0.9999 and 20 rounds the same as this).
    pub lattice_mean_q: f64,
    /// See `lattice_mean_q`.
    pub lattice_mean_rounds: usize,
    /// Rounds of the last pass, which raises the face's smallest angles
    /// ([`improve::lift_angle`]).
    pub angle_rounds: usize,
}

/// Smaller cap radii (in spacings) for a curved face whose caps of
/// `cap_radius` do not connect. A cap of radius ρ on a sphere of radius R
/// spans an angle ρ/R on each side of its pole, and its tangent-plane fill
/// folds when that nears π/2: 5 spacings reach the equator of a sphere of
/// radius 3.2·d (void_box at diag/25: R = 3.85·d failed, Gmsh meshed it);
/// 1.5 spacings keep the ring of bubbles next to the pole.
const CAP_RETRY_RADII: [f64; 2] = [2.5, 1.5];

impl FaceParams {
    /// The values in use.
    pub const DEFAULT: FaceParams = FaceParams {
        apex_layer_uniform: true,
        cap_radius: 5.0,
        improve_rounds: 6,
        lattice_mean_q: 0.999,
        lattice_mean_rounds: 10,
        angle_rounds: 3,
    };
}

impl Default for FaceParams {
    fn default() -> Self {
        FaceParams::DEFAULT
    }
}

/// The face pipeline's settings.
const PRM: FaceParams = FaceParams::DEFAULT;

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
    /// Of `bubbles`, those added after stage 2 as the middle row of a
    /// strip ([`placement::strip_rows`]).
    #[serde(skip_serializing_if = "is_zero")]
    pub strip_row_bubbles: usize,
    pub triangles: usize,
    /// Stage-2 statistics and energy history (absent with `--fast`).
    pub relax: Option<RelaxStats>,
    /// Cones (five-, seven-valent) of the conformal lattice when the face's
    /// mesh was rebuilt from it (graded planar faces; see `conformal`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lattice_cones: Option<(usize, usize)>,
    /// Nodes added at the circumcentres of skinny triangles (see
    /// [`skinny`]).
    #[serde(skip_serializing_if = "is_zero")]
    pub skinny_split: usize,
    /// A warm start (§4.8): old bubbles kept fixed, old bubbles carried
    /// over as stage 1, quadtree seeds added where they left room.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warm: Option<[usize; 3]>,
    /// Why the face was connected in one plane (its mean tangent plane,
    /// [`connect::triangulate_projected`]) instead of its (u,v): the
    /// error of the (u,v) connection at this spacing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub connected_in_plane: Option<String>,
    /// Where the caps around the face's singular points (poles, apexes)
    /// were made smaller than `cap_radius` spacings to connect it: the
    /// radius used, in spacings, and the error with the usual caps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub smaller_caps: Option<(f64, String)>,
    /// Why a convex face (a small sphere) was connected as the convex hull
    /// of its bubbles ([`connect::triangulate_hull`]): the error of the
    /// (u,v) connection at this spacing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub connected_as_hull: Option<String>,
    /// Why the face was connected with caps only at the singular points it
    /// reaches (none at a pole its parameter box stops short of, inside a
    /// hole around it): the error with caps at every singular point.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caps_only_where_reached: Option<String>,
    /// Why the face was connected with its (u,v) triangles that are flat
    /// against the surface filled in the tangent plane
    /// ([`connect::triangulate_surface_filling_flat`]): the error of the
    /// (u,v) connection at this spacing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flat_uv_filled: Option<String>,
    /// The face whose mesh this one took, carried across a wall thinner
    /// than the spacing ([`twin`]); `bubbles` and `triangles` are then the
    /// carried ones.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub twin_of: Option<u32>,
}

/// How a curved face was connected where its (u,v) connection with caps of
/// `cap_radius` spacings failed; recorded in its [`FaceReport`].
enum Fallback {
    /// Caps of this many spacings around its singular points.
    SmallerCaps(f64, String),
    /// The whole face in its mean tangent plane.
    InPlane(String),
    /// A convex face as the convex hull of its bubbles.
    Hull(String),
    /// Caps only at the singular points the face reaches.
    CapsWhereReached(String),
    /// The (u,v) triangles flat against the surface filled in the tangent
    /// plane ([`connect::triangulate_surface_filling_flat`]).
    FlatFilled(String),
}

impl FaceReport {
    /// Records how the face was last connected (`None`: in (u,v) as usual).
    fn record(&mut self, fallback: Option<Fallback>) {
        self.connected_in_plane = None;
        self.smaller_caps = None;
        self.connected_as_hull = None;
        self.caps_only_where_reached = None;
        self.flat_uv_filled = None;
        match fallback {
            None => {}
            Some(Fallback::SmallerCaps(r, why)) => self.smaller_caps = Some((r, why)),
            Some(Fallback::InPlane(why)) => self.connected_in_plane = Some(why),
            Some(Fallback::Hull(why)) => self.connected_as_hull = Some(why),
            Some(Fallback::CapsWhereReached(why)) => self.caps_only_where_reached = Some(why),
            Some(Fallback::FlatFilled(why)) => self.flat_uv_filled = Some(why),
        }
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
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

/// What every face of a model is meshed with: the model, the spacing, the
/// options and the mesh of the edges and vertices so far.
pub(crate) struct FaceInputs<'a> {
    pub model: &'a Model,
    pub spacing: &'a dyn Spacing,
    pub opts: &'a Options,
    /// The node ids along each edge, from its start to its end.
    pub edge_nodes: &'a [Vec<u32>],
    /// d at each node of the mesh so far.
    pub node_d: &'a [f64],
}

/// One face being meshed: the inputs and what is known about the face
/// before its bubbles are placed.
struct FaceJob<'a> {
    inputs: &'a FaceInputs<'a>,
    fi: usize,
    fe: EntityRef,
    face: &'a crate::model::Face,
    surface: &'a dyn crate::geom::Surface,
    /// Whether stage 1 may start from a grown crystal (see [`growth`]).
    grow: bool,
    /// Whether the face bounds a volume that is meshed next.
    bounds_volume: bool,
}

/// The fixed bubbles of a face (its boundary and embedded nodes, each once,
/// with their (u,v)) and the constraint segments between them.
struct Boundary {
    /// Local index of each global node id among the fixed bubbles.
    local_of: std::collections::HashMap<u32, usize>,
    ids: Vec<u32>,
    uv: Vec<[f64; 2]>,
    /// The last (u,v) found, where the next inverse mapping starts.
    hint: Option<[f64; 2]>,
    /// Segments the mesh must contain (loops and embedded edges).
    segments: Vec<[usize; 2]>,
    /// The loops' segments directed with the face on their left.
    directed: Vec<[usize; 2]>,
    /// Each loop's fixed bubbles in order.
    loop_locals: Vec<Vec<usize>>,
}

/// Meshes one face (thesis §4.1–4.7) as a sequence of phases: the boundary
/// bubbles and the face's (u,v) region, stage 1 (the oblique quadtree, on
/// curved faces a grown crystal), stage 2 (relaxation), connection (a
/// constrained Delaunay triangulation), the 2D improvement, on a graded
/// planar face the conformal-lattice restart, and the new nodes and
/// triangles ([`FaceOut`], for [`FaceOut::append_to`] the mesh). `mesh`
/// holds the nodes of the face's edges and vertices; it is only read, so
/// faces can be meshed side by side. `grow` allows stage 1's grown start.
pub(crate) fn mesh_face(
    inputs: &FaceInputs<'_>,
    fi: usize,
    mesh: &Mesh,
    timings: &mut Timings,
    grow: bool,
) -> Result<(FaceReport, FaceOut), MeshError> {
    let job = FaceJob::new(inputs, fi, grow)?;
    let t1 = Instant::now();
    let mut boundary = job.boundary_bubbles(mesh)?;
    let region = job.region(&mut boundary)?;
    let (lo, hi) = region.bbox();
    let carrier = OnFace::new(job.surface, region, job.fe);
    // a warm start (§4.8) replaces stage 1 by the old bubbles
    let start = (!inputs.opts.fast)
        .then(|| inputs.opts.warm.as_deref().and_then(|w| w.of(job.fe)))
        .flatten();
    let (mut sys, warm_counts, far) = match start {
        Some(st) => {
            let fixed = warm::Fixed {
                pos: boundary
                    .ids
                    .iter()
                    .map(|&id| mesh.nodes[id as usize].pos)
                    .collect(),
                d: boundary
                    .ids
                    .iter()
                    .map(|&id| inputs.node_d[id as usize])
                    .collect(),
                uv: boundary.uv.clone(),
                ids: boundary.ids.clone(),
            };
            // the boundary layer of a uniform spacing, as from scratch
            // (`FaceJob::stage1`); the warm start keeps it where the face
            // changed
            let apex = if PRM.apex_layer_uniform && inputs.spacing.constant_on(job.fe).is_some() {
                let mut d_at = placement::spacing_on(inputs.spacing, job.fe);
                let ring = placement::Ring {
                    directed: &boundary.directed,
                    pos: &fixed.pos,
                    uv: &boundary.uv,
                    d: &fixed.d,
                };
                placement::apex_seeds(&carrier, &ring, &mut d_at)?
            } else {
                Vec::new()
            };
            let (sys, c, far) = warm::stage1(carrier, inputs.spacing, fixed, apex, st)?;
            (sys, Some(c), Some(far))
        }
        None => (job.stage1(carrier, &boundary, mesh)?, None, None),
    };
    let mut fr = FaceReport {
        face: fi as u32,
        name: job.face.name.clone(),
        boundary_bubbles: sys.n_fixed,
        stage1_bubbles: sys.n() - sys.n_fixed,
        warm: warm_counts.map(|c| [c.kept, c.carried, c.filled]),
        ..Default::default()
    };
    timings.stage1_s += t1.elapsed().as_secs_f64();
    inputs
        .opts
        .stage1_done(job.fe, sys.n_fixed, &sys.pos, &sys.d);

    if !inputs.opts.fast {
        let t2 = Instant::now();
        fr.relax = Some(job.stage2(&mut sys, start.is_some())?);
        timings.stage2_s += t2.elapsed().as_secs_f64();
    }
    fr.bubbles = sys.n() - sys.n_fixed;
    if let Some(far) = far {
        warm::restore(&mut sys, far);
    }

    let t3 = Instant::now();
    let (mut tris, fallback) = job.connect_and_improve(&mut sys, &boundary, None)?;
    fr.record(fallback);
    if !inputs.opts.fast && !job.bounds_volume {
        job.strip_rows(&mut sys, &boundary, &mut tris, &mut fr)?;
    }
    let t_lattice = Instant::now();
    // a warm start keeps its packing (the old one came from the lattice)
    if start.is_none() && job.wants_conformal_lattice(lo, hi) {
        if let Some((cones, relax)) =
            conformal_restart(&mut sys, &mut tris, &boundary, job.fe, &inputs.opts.relax)?
        {
            fr.lattice_cones = Some(cones);
            fr.relax = Some(relax);
        }
    }
    let lattice_s = t_lattice.elapsed().as_secs_f64();
    timings.lattice_s += lattice_s;
    // the skinny triangles split, then the smallest angles lifted (a face
    // that bounds a volume keeps its triangles as the volume's boundary
    // needs them: its smallest angle is not the mesh's)
    if !inputs.opts.fast && !job.bounds_volume && job.surface.is_planar() {
        fr.skinny_split = skinny::split_skinny(&mut sys, &mut tris, &mut |sys| {
            job.connect_and_improve(sys, &boundary, None)
                .map(|(t, _)| t)
        })?;
    }
    if !inputs.opts.fast && !job.bounds_volume {
        improve::lift_angle(&mut sys, &mut tris, &boundary.segments, PRM.angle_rounds)?;
    }
    let out = job.emit(&sys, &tris);
    fr.bubbles = out.nodes.len() - out.kept;
    fr.triangles = tris.len();
    if tris.is_empty() {
        return Err(MeshError::Invalid(
            "the face produced no triangles (is its parameter region empty, or the spacing larger than the face?)"
                .into(),
        ));
    }
    timings.connect_s += t3.elapsed().as_secs_f64() - lattice_s;
    Ok((fr, out))
}

/// The free bubbles of a face's system (positions, parameters,
/// velocities, spacings), kept aside while another start or connection is
/// tried, and put back when it is not kept.
struct Packing {
    pos: Vec<P3>,
    params: Vec<[f64; 2]>,
    vel: Vec<V3>,
    d: Vec<f64>,
}

impl Packing {
    /// A copy of the free bubbles (they stay in `sys`).
    fn copy_of<C: constraint::Carrier>(sys: &System<'_, C>) -> Self {
        let nf = sys.n_fixed;
        Packing {
            pos: sys.pos[nf..].to_vec(),
            params: sys.params[nf..].to_vec(),
            vel: sys.vel[nf..].to_vec(),
            d: sys.d[nf..].to_vec(),
        }
    }

    /// The free bubbles, taken out of `sys` (the fixed ones stay).
    fn take<C: constraint::Carrier>(sys: &mut System<'_, C>) -> Self {
        let nf = sys.n_fixed;
        Packing {
            pos: sys.pos.split_off(nf),
            params: sys.params.split_off(nf),
            vel: sys.vel.split_off(nf),
            d: sys.d.split_off(nf),
        }
    }

    /// Makes these the free bubbles of `sys` again, in place of its own.
    fn restore<C: constraint::Carrier>(self, sys: &mut System<'_, C>) {
        let nf = sys.n_fixed;
        sys.pos.truncate(nf);
        sys.params.truncate(nf);
        sys.vel.truncate(nf);
        sys.d.truncate(nf);
        sys.pos.extend(self.pos);
        sys.params.extend(self.params);
        sys.vel.extend(self.vel);
        sys.d.extend(self.d);
    }
}

/// Whether a face meshed with (mean, least) radius ratios `new` is better
/// than with `old`: a higher mean, and a least one no lower.
fn better_than(new: (f64, f64), old: (f64, f64)) -> bool {
    new.0 > old.0 && new.1 >= old.1
}

/// A face's new nodes and triangles, to be appended to the mesh.
#[derive(Debug)]
pub(crate) struct FaceOut {
    /// The new nodes, in order: a warm start's kept boundary bubbles
    /// (`kept` of them), then the free bubbles.
    nodes: Vec<Node>,
    /// How many of `nodes` are kept bubbles of a warm start.
    kept: usize,
    /// The triangles; a corner below [`FaceOut::OWN`] is a node of the
    /// mesh already, else `OWN + k` is `nodes[k]`.
    triangles: Vec<[u32; 3]>,
}

impl FaceOut {
    /// Corners at and above this are the face's own new nodes (a mesh's
    /// node ids stay below it: 2³¹ nodes would be some 100 GB).
    const OWN: u32 = 1 << 31;

    /// Appends the nodes and triangles to `mesh`, numbering the new nodes
    /// from its current end: the same mesh as if the face had been meshed
    /// into it directly.
    pub(crate) fn append_to(self, mesh: &mut Mesh, fe: EntityRef) {
        let first = mesh.nodes.len() as u32;
        mesh.nodes.extend(self.nodes);
        mesh.triangles
            .extend(self.triangles.into_iter().map(|t| Element {
                nodes: t.map(|c| {
                    if c >= Self::OWN {
                        first + (c - Self::OWN)
                    } else {
                        c
                    }
                }),
                entity: fe,
            }));
    }
}

impl<'a> FaceJob<'a> {
    fn new(inputs: &'a FaceInputs<'a>, fi: usize, grow: bool) -> Result<Self, MeshError> {
        let model = inputs.model;
        let face = &model.faces[fi];
        let surface = face.surface.as_ref();
        if face.loops.is_empty() && surface.periods().iter().all(|p| p.is_none()) {
            return Err(MeshError::Invalid(
                "the face has no boundary loop and its surface is not closed (not periodic)".into(),
            ));
        }
        let bounds_volume = inputs.opts.dim.unwrap_or(model.dim()) >= 3
            && model.volumes.iter().any(|v| v.faces.contains(&(fi as u32)));
        Ok(FaceJob {
            inputs,
            fi,
            fe: EntityRef::new(2, fi as u32),
            face,
            surface,
            grow,
            bounds_volume,
        })
    }

    /// The face's fixed bubbles: the nodes of its loops' edges, of its
    /// embedded edges and its embedded vertices, each once, with (u,v), and
    /// the constraint segments between them (the thesis's order of
    /// dimensions, §3.2.3: the boundary is meshed and fixed first).
    fn boundary_bubbles(&self, mesh: &Mesh) -> Result<Boundary, MeshError> {
        let model = self.inputs.model;
        let fi = self.fi;
        let mut b = Boundary {
            local_of: std::collections::HashMap::new(),
            ids: Vec::new(),
            uv: Vec::new(),
            hint: None,
            segments: Vec::new(),
            directed: Vec::new(),
            loop_locals: Vec::new(),
        };
        // (u,v) of a boundary node: from the edge's pcurve on this face when
        // the model has one (exact), else by inverse mapping from the
        // previous node
        let pcurve_uv = |edge: u32, id: u32, at_end: Option<bool>| -> Option<[f64; 2]> {
            let pc = model.pcurves.get(&(fi as u32, edge))?;
            let t = edge_parameter(&model.edges[edge as usize], mesh, id, at_end);
            let q = pc.point(t);
            Some([q.x, q.y])
        };
        for (li, lp) in self.face.loops.iter().enumerate() {
            // node ids with their (u,v) when a pcurve gives it
            let mut ids: Vec<(u32, Option<[f64; 2]>)> = Vec::new();
            for u in &lp.edges {
                let c = self.chain(u)?;
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
                self.check_steps_around_poles(u, &c, mesh, &with_uv, &mut b)?;
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
                .map(|&(id, uv)| self.add_fixed(&mut b, mesh, id, uv))
                .collect::<Result<_, _>>()?;
            for k in 0..locals.len() {
                b.segments.push([locals[k], locals[(k + 1) % locals.len()]]);
            }
            b.loop_locals.push(locals);
        }
        for &ee in &self.face.embedded_edges {
            let c = self.chain(&crate::model::EdgeUse {
                edge: ee,
                forward: true,
            })?;
            let locals: Vec<usize> = c
                .iter()
                .map(|&id| self.add_fixed(&mut b, mesh, id, None))
                .collect::<Result<_, _>>()?;
            for w in locals.windows(2) {
                b.segments.push([w[0], w[1]]);
            }
        }
        for &v in &self.face.embedded_vertices {
            self.add_fixed(&mut b, mesh, v, None)?;
        }
        Ok(b)
    }

    /// Refuses an edge's chain of nodes `chain` (as the loop uses it) when
    /// two consecutive nodes are so far apart, around a pole of a periodic
    /// surface, that their (u,v) cannot tell which way the edge runs between
    /// them: the region and the connection join boundary nodes by the
    /// nearer of a periodic coordinate's two ways round, and a loop passing
    /// close to a pole turns u by nearly a period within a short arc (a
    /// hole around a sphere's pole, 0.1 mm off it, with seven nodes per
    /// turn was read as not going round it, and the face was meshed as its
    /// hole: rp_4_009 of the random parts). The edge's own curve decides,
    /// walked between the nodes with the (u,v) steps bisected until each
    /// turns less than an eighth of a period (a curve through the pole
    /// itself never gets there and is left to the caps); a step that turns
    /// more than 0.48 of a period, or the other way than the nearer one, is a
    /// connection error (the face is meshed again finer, where more nodes
    /// make the steps short). `with_uv` holds the pcurve's (u,v) where
    /// known; the others are found as [`Self::add_fixed`] does.
    fn check_steps_around_poles(
        &self,
        u: &crate::model::EdgeUse,
        chain: &[u32],
        mesh: &Mesh,
        with_uv: &[(u32, Option<[f64; 2]>)],
        b: &mut Boundary,
    ) -> Result<(), MeshError> {
        let surface = self.surface;
        let periods = surface.periods();
        if periods.iter().all(|p| p.is_none()) || chain.len() < 2 {
            return Ok(());
        }
        let e = &self.inputs.model.edges[u.edge as usize];
        let m = chain.len();
        // the edge's parameter at the k-th node of the chain (its ends are
        // the edge's, in the loop's direction)
        let t_of = |k: usize| {
            let at_end = (k == 0)
                .then_some(!u.forward)
                .or((k + 1 == m).then_some(u.forward));
            edge_parameter(e, mesh, chain[k], at_end)
        };
        // the wrapped difference b − a in each periodic direction
        let step = |a: [f64; 2], b: [f64; 2]| -> [f64; 2] {
            let mut d = [0.0; 2];
            for c in 0..2 {
                if let Some(p) = periods[c] {
                    d[c] = crate::geom::nearest_turn(b[c] - a[c], p);
                }
            }
            d
        };
        let far = |d: [f64; 2], frac: f64| {
            (0..2).any(|c| periods[c].is_some_and(|p| d[c].abs() > frac * p))
        };
        let mut uv_prev: Option<[f64; 2]> = None;
        for k in 0..m {
            let uv = self.add_fixed(b, mesh, chain[k], with_uv[k].1)?;
            let uv = b.uv[uv];
            let Some(a) = uv_prev.replace(uv) else {
                continue;
            };
            let near = step(a, uv);
            if !far(near, 0.25) {
                continue;
            }
            // walk the curve from node k − 1 to node k
            let (t0, t1) = (t_of(k - 1), t_of(k));
            let invert = |t: f64, hint: [f64; 2]| {
                surface
                    .inverse(&e.curve.point(t), Some(hint))
                    .ok_or_else(|| {
                        let p = e.curve.point(t);
                        MeshError::Invalid(format!(
                            "boundary point ({}, {}, {}) cannot be mapped to the surface's (u,v)",
                            p.x, p.y, p.z
                        ))
                    })
            };
            const K: usize = 8;
            let mut samples: Vec<(f64, [f64; 2])> = vec![(0.0, a)];
            for j in 1..K {
                let s = j as f64 / K as f64;
                let hint = samples[j - 1].1;
                samples.push((s, invert(t0 + (t1 - t0) * s, hint)?));
            }
            samples.push((1.0, uv));
            crate::geom::bisect_steps(
                &mut samples,
                64 * K,
                |p0, p1| far(step(p0, p1), 0.125),
                |sm, p0| invert(t0 + (t1 - t0) * sm, p0),
            )?;
            // a step still turning at the end ran through the pole itself
            // (a meridian across it, a line through a cone's apex): the
            // curve cannot tell the way, the caps around the pole connect
            // it as before
            if samples.windows(2).any(|w| far(step(w[0].1, w[1].1), 0.125)) {
                continue;
            }
            let mut walked = [0.0; 2];
            for w in samples.windows(2) {
                let d = step(w[0].1, w[1].1);
                walked = [walked[0] + d[0], walked[1] + d[1]];
            }
            let wrong_way =
                (0..2).any(|c| periods[c].is_some_and(|p| (walked[c] - near[c]).abs() > 1e-6 * p));
            if wrong_way || far(walked, 0.48) {
                let (pa, pb) = (
                    mesh.nodes[chain[k - 1] as usize].pos,
                    mesh.nodes[chain[k] as usize].pos,
                );
                return Err(MeshError::Connect(connect::ConnectError::Coarse(format!(
                    "its boundary turns {:.2} of a turn round its surface (near a pole, or \
                     along a long arc) between the nodes at ({}, {}, {}) and ({}, {}, {}) on edge \
                     {}: too few nodes there to tell which way it goes",
                    (0..2)
                        .filter_map(|c| periods[c].map(|p| walked[c].abs() / p))
                        .fold(0.0, f64::max),
                    pa.x,
                    pa.y,
                    pa.z,
                    pb.x,
                    pb.y,
                    pb.z,
                    u.edge,
                ))));
            }
        }
        Ok(())
    }

    /// The node ids along an edge as the loop uses it.
    fn chain(&self, u: &crate::model::EdgeUse) -> Result<Vec<u32>, MeshError> {
        let ids = self.inputs.edge_nodes.get(u.edge as usize).ok_or_else(|| {
            MeshError::Invalid(format!("a loop uses edge {} which does not exist", u.edge))
        })?;
        Ok(if u.forward {
            ids.clone()
        } else {
            ids.iter().rev().cloned().collect()
        })
    }

    /// Adds node `id` as a fixed bubble (once) and returns its local index.
    /// Its (u,v) is `known` (from a pcurve) or found by inverse mapping.
    fn add_fixed(
        &self,
        b: &mut Boundary,
        mesh: &Mesh,
        id: u32,
        known: Option<[f64; 2]>,
    ) -> Result<usize, MeshError> {
        let surface = self.surface;
        if let Some(&l) = b.local_of.get(&id) {
            b.hint = Some(b.uv[l]);
            return Ok(l);
        }
        let p = mesh.nodes[id as usize].pos;
        let uv = match known {
            // a pcurve may end on the far side of a seam (u = 2π)
            Some(uv) => crate::geom::wrap_periodic(uv, surface.periods(), domain_box(surface).0),
            None => surface.inverse(&p, b.hint).ok_or_else(|| {
                MeshError::Invalid(format!(
                    "boundary point ({}, {}, {}) cannot be mapped to the surface's (u,v)",
                    p.x, p.y, p.z
                ))
            })?,
        };
        b.hint = Some(uv);
        let l = b.ids.len();
        b.local_of.insert(id, l);
        b.ids.push(id);
        b.uv.push(uv);
        Ok(l)
    }

    /// The face's (u,v) region bounded by its loops, and the loops'
    /// segments directed with the face on their left (into
    /// `boundary.directed`).
    fn region(&self, boundary: &mut Boundary) -> Result<Region, MeshError> {
        let surface = self.surface;
        let loops_uv: Vec<Vec<[f64; 2]>> = boundary
            .loop_locals
            .iter()
            .map(|l| l.iter().map(|&k| boundary.uv[k]).collect())
            .collect();
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
        // (or any non-periodic parametrization) the first loop is the outer
        // one (face inside it) and the others holes, told apart by signed
        // area; on a periodic surface a loop may close only through the
        // period (a circle around a cylinder), so the side is found by asking
        // the region about points just left of the loop's segments.
        for (li, (locals, luv)) in boundary.loop_locals.iter().zip(&loops_uv).enumerate() {
            let face_on_left = if periods.iter().all(|p| p.is_none()) {
                let ccw = signed_area2(luv) > 0.0;
                if li == 0 {
                    ccw
                } else {
                    !ccw
                }
            } else {
                face_left_of_periodic_loop(&region, luv, periods)
            };
            for k in 0..locals.len() {
                let (a, b) = (locals[k], locals[(k + 1) % locals.len()]);
                boundary
                    .directed
                    .push(if face_on_left { [a, b] } else { [b, a] });
            }
        }
        Ok(region)
    }

    /// Stage 1 (§4.1.2): the oblique quadtree's seeds, on a curved face
    /// after a grown crystal (see [`growth`]), those that do not crowd a
    /// fixed bubble or an earlier seed; returns the bubble system with the
    /// fixed bubbles and the seeds.
    fn stage1(
        &self,
        carrier: OnFace<'a>,
        boundary: &Boundary,
        mesh: &Mesh,
    ) -> Result<System<'a, OnFace<'a>>, MeshError> {
        let (surface, spacing, fe) = (self.surface, self.inputs.spacing, self.fe);
        let node_d = self.inputs.node_d;
        let (lo, hi) = carrier.region.bbox();
        let uniform_leaf = spacing
            .constant_on(fe)
            .filter(|_| surface.is_planar())
            .map(|d| {
                let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
                let dv = surface.derivs(c[0], c[1]);
                // parameter length of one spacing along u (1 on a plane)
                d / dv.su.norm().max(f64::MIN_POSITIVE)
            });
        let mut d_at = placement::spacing_on(spacing, fe);
        let mut d_outside = boundary
            .ids
            .iter()
            .map(|&id| node_d[id as usize])
            .fold([f64::INFINITY, 0.0], |[lo, hi], d| [lo.min(d), hi.max(d)]);
        if !d_outside[0].is_finite() {
            // a closed face has no boundary bubbles: sample the spacing on it
            for k in 0..=8 {
                for l in 0..=8 {
                    let uv = [
                        lo[0] + (hi[0] - lo[0]) * k as f64 / 8.0,
                        lo[1] + (hi[1] - lo[1]) * l as f64 / 8.0,
                    ];
                    if carrier.contains(uv) {
                        let p = carrier.point(uv);
                        let d = d_at(&p, uv)?;
                        d_outside = [d_outside[0].min(d), d_outside[1].max(d)];
                    }
                }
            }
        }
        if !(d_outside[1] >= d_outside[0]) {
            // nothing sampled: outside corners never split a cell
            d_outside = [f64::INFINITY; 2];
        }
        let seeds =
            placement::oblique_quadtree(&carrier, lo, hi, uniform_leaf, d_outside, &mut d_at)?;

        // boundary layer: one bubble over each boundary segment, at the apex
        // of the near-equilateral triangle on it (see `placement::apex_seeds`)
        let fixed_pos: Vec<P3> = boundary
            .ids
            .iter()
            .map(|&id| mesh.nodes[id as usize].pos)
            .collect();
        let fixed_d: Vec<f64> = boundary.ids.iter().map(|&id| node_d[id as usize]).collect();
        let uniform = spacing.constant_on(fe);
        let with_apex = PRM.apex_layer_uniform && uniform.is_some();
        // boundary layer: one bubble over each boundary segment, at the apex
        // of the near-equilateral triangle on it (see `placement::apex_seeds`)
        let ring = placement::Ring {
            directed: &boundary.directed,
            pos: &fixed_pos,
            uv: &boundary.uv,
            d: &fixed_d,
        };
        let apex = if with_apex {
            placement::apex_seeds(&carrier, &ring, &mut d_at)?
        } else {
            Vec::new()
        };
        // on curved faces stage 2 starts from one grown crystal (see
        // `growth`); the quadtree's seeds fill what the growth did not reach.
        // Planar faces keep the quadtree: its lattice is exact for a uniform
        // spacing, and for a graded one growth measured no better (cases B,
        // C: q mean 0.981 and 0.979 grown, 0.982 and 0.978 from the
        // quadtree, q min lower grown)
        let grown = if self.grow && !self.inputs.opts.fast && !surface.is_planar() {
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
        // seeds of one uniform lattice cannot crowd each other, so that
        // check is only made for a varying spacing
        let check_seeds = uniform.is_none() || with_apex || !surface.is_planar();
        let seeds = placement::after_strips(&carrier, &ring, &mut d_at, all, check_seeds)?;
        let mut sys = System::with_fixed(
            carrier,
            spacing,
            2,
            fixed_pos,
            boundary.uv.clone(),
            fixed_d,
            boundary.ids.clone(),
        );
        // the quadtree's root starts left of the box, so on a periodic
        // surface a seed may lie one period off: stage 2 wraps the bubbles it
        // moves, but with stage 1 alone (`--fast`) the connection needs every
        // (u,v) in the fundamental domain
        for s in seeds {
            let uv = sys.carrier.region.wrap(s.params);
            sys.push_free(s.pos, uv, s.d);
        }
        Ok(sys)
    }

    /// Adds the middle rows of strips that two rows of triangles may mesh
    /// better than one ([`placement::strip_rows`]) to the connected and
    /// improved bubbles `sys`, `tris`, and keeps them when the face is
    /// [`better`] with them (the new bubbles and their two rings improved
    /// again); the report counts them.
    ///
    /// Not on a face bounding a volume meshed next (the caller checks):
    /// the tetrahedra did not gain from them, and where the two walls of
    /// a thin solid face each other the rows left the surface mesh
    /// non-Delaunay across it (as_tie_rod.step at diag/20: boundary
    /// recovery failed, and the refinement rounds after it ended with the
    /// cap of curved edges dropped, 553 tetrahedra of mean radius ratio
    /// 0.52 instead of 2,537 of 0.67) or left flat tetrahedra that six
    /// Steiner rounds did not split (fixtures/step/b3d_bottle.step at
    /// size 1: least radius ratio 3·10⁻⁵ instead of 0.38).
    fn strip_rows(
        &self,
        sys: &mut System<'a, OnFace<'a>>,
        boundary: &Boundary,
        tris: &mut Vec<[usize; 3]>,
        fr: &mut FaceReport,
    ) -> Result<(), MeshError> {
        let nf = sys.n_fixed;
        let ring = placement::Ring {
            directed: &boundary.directed,
            pos: &sys.pos[..nf],
            uv: &sys.params[..nf],
            d: &sys.d[..nf],
        };
        let mut d_at = placement::spacing_on(self.inputs.spacing, self.fe);
        let rows = placement::strip_rows(
            &sys.carrier,
            &ring,
            (&sys.pos[nf..], &sys.d[nf..]),
            &mut d_at,
        )?;
        if rows.is_empty() {
            return Ok(());
        }
        let without = Packing::copy_of(sys);
        let before = mean_and_least(&sys.pos, tris);
        let (n_rows, first_row) = (rows.len(), sys.n());
        for s in rows {
            let uv = sys.carrier.region.wrap(s.params);
            sys.push_free(s.pos, uv, s.d);
        }
        match self.connect_and_improve(sys, boundary, Some(first_row)) {
            Ok((t, fallback))
                if !t.is_empty()
                    && (tris.is_empty() || better_than(mean_and_least(&sys.pos, &t), before)) =>
            {
                *tris = t;
                fr.record(fallback);
                fr.strip_row_bubbles = n_rows;
            }
            // without them the face was connected: an error with them
            // only means they are not kept
            _ => without.restore(sys),
        }
        Ok(())
    }

    /// Connection, then the 2D improvement (which moves free bubbles):
    /// of all, or with `near` of those within two rings of bubbles
    /// `near..` (bubbles added to an improved packing).
    fn connect_and_improve(
        &self,
        sys: &mut System<'a, OnFace<'a>>,
        boundary: &Boundary,
        near: Option<usize>,
    ) -> Result<(Vec<[usize; 3]>, Option<Fallback>), MeshError> {
        let (mut tris, fallback) = self.connect(sys, boundary)?;
        if !self.inputs.opts.fast && PRM.improve_rounds > 0 {
            let movable = near.map(|from| {
                let new: Vec<bool> = (0..sys.n()).map(|i| i >= from).collect();
                improve::within_rings(new, &tris, 2)
            });
            improve::improve_where(
                sys,
                &mut tris,
                &boundary.segments,
                PRM.improve_rounds,
                movable.as_deref(),
            )?;
        }
        Ok((tris, fallback))
    }

    /// Stage 2 (§4.3–4.7): relaxation with population control.
    fn stage2(
        &self,
        sys: &mut System<'a, OnFace<'a>>,
        warm: bool,
    ) -> Result<RelaxStats, MeshError> {
        let opts = self.inputs.opts;
        let uniform = self.inputs.spacing.constant_on(self.fe).is_some();
        // a uniformly spaced face that only bounds a volume stops earlier
        // (see system::PLATEAU_BOUNDARY); one of a surface mesh takes long
        // steps (see RelaxSettings::long_steps)
        let settings = if self.bounds_volume && uniform {
            system::RelaxSettings {
                plateau: opts.relax.plateau.max(system::PLATEAU_BOUNDARY),
                ..opts.relax
            }
        } else {
            system::RelaxSettings {
                long_steps: uniform && !self.bounds_volume && !warm,
                ..opts.relax
            }
        };
        // a warm start is near a balance: a short stage 2 (§4.8.2)
        let settings = if warm {
            system::RelaxSettings {
                max_steps: settings.max_steps.min(crate::remesh::warm::WARM_MAX_STEPS),
                tol: settings.tol.max(crate::remesh::warm::WARM_TOL),
                ..settings
            }
        } else {
            settings
        };
        sys.relax(
            &settings,
            opts.relax_observer(self.fe, settings.step_limit(), sys.n_fixed),
        )
    }

    /// Connection (§4.8): constrained Delaunay triangulation in (u,v) on a
    /// plane; on a curved surface in (u,v) scaled to the surface, and in the
    /// tangent plane near a singular point (a cap). Where that fails on a
    /// curved face, with smaller caps ([`CAP_RETRY_RADII`]), then the whole
    /// face in its mean tangent plane if it is a graph over it; the second
    /// value says which, and why (u,v) failed.
    fn connect(
        &self,
        sys: &System<'a, OnFace<'a>>,
        boundary: &Boundary,
    ) -> Result<(Vec<[usize; 3]>, Option<Fallback>), MeshError> {
        let surface = self.surface;
        let (segments, directed) = (&boundary.segments, &boundary.directed);
        let keep = |c: [f64; 2]| {
            sys.carrier.region.contains(c[0], c[1]) && surface.trim(c[0], c[1]).unwrap_or(true)
        };
        if surface.is_planar() {
            return Ok((
                connect::triangulate(&sys.params, segments, directed, keep)?,
                None,
            ));
        }
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
        for s in segments {
            on_segment[s[0]] = true;
            on_segment[s[1]] = true;
        }
        let singular_near = |poles: &[P3], radius: f64| -> Vec<bool> {
            (0..sys.n())
                .map(|i| {
                    !on_segment[i]
                        && poles
                            .iter()
                            .any(|q| (sys.pos[i] - q).norm() < radius * sys.d[i])
                })
                .collect()
        };
        let singular_within = |radius: f64| singular_near(&poles, radius);
        let singular = singular_within(PRM.cap_radius);
        let pts = connect::SurfacePoints {
            uv: &sys.params,
            pos: &sys.pos,
            normal: &normal,
            d: &sys.d,
            singular: &singular,
            periods: surface.periods(),
            origin: domain_box(surface).0,
            scale: parameter_scale(surface, &sys.params),
        };
        let retryable = |e: &connect::ConnectError| {
            matches!(
                e,
                connect::ConnectError::Coarse(_)
                    | connect::ConnectError::Crossing(..)
                    | connect::ConnectError::Duplicate(..)
            )
        };
        let face_area = std::cell::OnceCell::new();
        let with_fixed = |r| accepted(sys, &face_area, directed, r);
        let first = match with_fixed(connect::triangulate_surface(&pts, segments, directed)) {
            Ok(tris) => return Ok((tris, None)),
            Err(e) if retryable(&e) => e,
            Err(e) => return Err(e.into()),
        };
        // smaller caps, where there are caps
        if singular.iter().any(|&s| s) {
            for radius in CAP_RETRY_RADII {
                let smaller = singular_within(radius);
                let retry = connect::SurfacePoints {
                    singular: &smaller,
                    ..pts
                };
                if let Ok(tris) =
                    with_fixed(connect::triangulate_surface(&retry, segments, directed))
                {
                    return Ok((tris, Some(Fallback::SmallerCaps(radius, first.to_string()))));
                }
            }
        }
        // caps only at the singular points the face reaches: a band of a
        // sphere between two holes around its poles has no cap there,
        // whose tangent-plane connection would run over the hole (a cone
        // frustum's cap at its apex, outside it too, is kept where it
        // connects: it meshes the frustum better)
        let reached: Vec<P3> = poles
            .iter()
            .filter(|q| reaches(surface, q))
            .copied()
            .collect();
        if reached.len() < poles.len() {
            let inside = singular_near(&reached, PRM.cap_radius);
            let retry = connect::SurfacePoints {
                singular: &inside,
                ..pts
            };
            if let Ok(tris) = with_fixed(connect::triangulate_surface(&retry, segments, directed)) {
                return Ok((tris, Some(Fallback::CapsWhereReached(first.to_string()))));
            }
        }
        // the face as a graph over one plane, where it is one: valid at any
        // spacing, and checked like the rest
        if let Ok(tris) = with_fixed(connect::triangulate_projected(&pts, segments, directed)) {
            return Ok((tris, Some(Fallback::InPlane(first.to_string()))));
        }
        // a convex face (a small sphere, whole or less a cap): its
        // bubbles' hull less the hull over its holes
        if let Ok(tris) = with_fixed(connect::triangulate_hull(&pts, segments, directed)) {
            return Ok((tris, Some(Fallback::Hull(first.to_string()))));
        }
        // a face of boundary nodes alone: its (u,v) triangles flat against
        // the surface filled in the tangent plane with the singular points
        // (a dimple bounded by a circle of latitude has all its boundary
        // nodes on one (u,v) line). Not where free bubbles are: those
        // faces are meshed finer instead, and came out closer to their
        // area so (dimple_below_spacing.step: 40.7 of 44.4 mm² refined,
        // 37.1 filled)
        if sys.n() == sys.n_fixed {
            if let Ok(tris) = with_fixed(connect::triangulate_surface_filling_flat(
                &pts, segments, directed,
            )) {
                return Ok((tris, Some(Fallback::FlatFilled(first.to_string()))));
            }
        }
        Err(first.into())
    }

    /// Whether the face is rebuilt from the lattice conformal to its spacing
    /// (see [`conformal`]): a graded planar face with an isometric (u,v).
    /// Not on a face bounding a volume meshed next: the tetrahedra do not
    /// gain from it (case I: q mean 0.901 with it, 0.902 without) and it
    /// cost 2.3 s there.
    fn wants_conformal_lattice(&self, lo: [f64; 2], hi: [f64; 2]) -> bool {
        !self.inputs.opts.fast
            && !self.bounds_volume
            && self.surface.is_planar()
            && self.inputs.spacing.constant_on(self.fe).is_none()
            && isometric(self.surface, lo, hi)
    }

    /// The free bubbles become nodes and the triangles elements
    /// ([`FaceOut`]). A bubble the connection left without a triangle (it
    /// sat within half a spacing of another near a singular point) is
    /// dropped rather than left as an unreferenced node.
    fn emit(&self, sys: &System<'a, OnFace<'a>>, tris: &[[usize; 3]]) -> FaceOut {
        let nf = sys.n_fixed;
        let fe = self.fe;
        let mut referenced = vec![false; sys.n()];
        for t in tris {
            for &v in t {
                referenced[v] = true;
            }
        }
        let mut node_of = vec![u32::MAX; sys.n()];
        let mut nodes: Vec<Node> = Vec::new();
        let mut own = |i: usize, nodes: &mut Vec<Node>| {
            node_of[i] = FaceOut::OWN + nodes.len() as u32;
            nodes.push(Node {
                pos: sys.pos[i],
                entity: fe,
                params: sys.params[i],
            });
        };
        // kept bubbles of a warm start become nodes at their old
        // coordinates (see `warm`)
        for i in (0..nf).filter(|&i| sys.fixed_ids[i] == warm::KEPT && referenced[i]) {
            own(i, &mut nodes);
        }
        let kept = nodes.len();
        for i in (nf..sys.n()).filter(|&i| referenced[i]) {
            own(i, &mut nodes);
        }
        let global = |l: usize| -> u32 {
            if l < nf && sys.fixed_ids[l] != warm::KEPT {
                sys.fixed_ids[l]
            } else {
                node_of[l]
            }
        };
        FaceOut {
            nodes,
            kept,
            triangles: tris
                .iter()
                .map(|t| [global(t[0]), global(t[1]), global(t[2])])
                .collect(),
        }
    }
}

/// Twice the signed area of a (u,v) polygon, positive when counterclockwise.
/// Relative to the polygon's first point: far from the origin (a unit square
/// at (1e8, 1e8)) the products of absolute coordinates cancel and the sign
/// is noise.
fn signed_area2(luv: &[[f64; 2]]) -> f64 {
    let o = luv.first().copied().unwrap_or([0.0, 0.0]);
    (0..luv.len())
        .map(|k| {
            let (a, b) = (luv[k], luv[(k + 1) % luv.len()]);
            let (a, b) = ([a[0] - o[0], a[1] - o[1]], [b[0] - o[0], b[1] - o[1]]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

/// Whether the face lies left of a loop on a periodic surface, by a vote of
/// the region about points just left and right of (up to 16 of) its
/// segments.
fn face_left_of_periodic_loop(
    region: &Region,
    luv: &[[f64; 2]],
    periods: [Option<f64>; 2],
) -> bool {
    let mut votes = 0i32;
    let m = luv.len();
    for k in (0..m).step_by((m / 16).max(1)) {
        let a = luv[k];
        let mut b = luv[(k + 1) % m];
        for c in 0..2 {
            if let Some(p) = periods[c] {
                b[c] = a[c] + crate::geom::nearest_turn(b[c] - a[c], p);
            }
        }
        let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        // probes ever closer to the segment until exactly one side is in
        // the region: a face narrower than 1 % of a segment (a band around
        // a tiny hole, 0.001 high under segments of 1.26 rad) has both
        // first probes outside it
        for eps in [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7] {
            let left = [mid[0] - eps * (b[1] - a[1]), mid[1] + eps * (b[0] - a[0])];
            let right = [mid[0] + eps * (b[1] - a[1]), mid[1] - eps * (b[0] - a[0])];
            let (l, r) = (
                region.contains(left[0], left[1]),
                region.contains(right[0], right[1]),
            );
            if l != r {
                votes += if l { 1 } else { -1 };
                break;
            }
        }
    }
    votes >= 0
}

/// A connection `r` of a curved face's bubbles `sys`, refused (a coarse
/// connection) where it does not cover the face once (an edge in other
/// than one triangle per loop segment of `directed` along it, two
/// elsewhere: a tangent-plane cap that left a gap beside it was caught
/// only by the final check, and the face was refined eight times and
/// refused, rp_7_027 of the random parts; refused here, the smaller caps
/// connect it at the size asked), where it leaves out a fixed bubble (an
/// embedded vertex near a pole a cap left out), or where its triangles
/// cover less than [`AREA_FLOOR`] of the face's area (sampled once into
/// `face_area`; faces of at least [`AREA_JUDGED`] squared spacings).
fn accepted(
    sys: &System<'_, OnFace<'_>>,
    face_area: &std::cell::OnceCell<Option<f64>>,
    directed: &[[usize; 2]],
    r: Result<Vec<[usize; 3]>, connect::ConnectError>,
) -> Result<Vec<[usize; 3]>, connect::ConnectError> {
    let tris = r?;
    if let Some(e) = connect::first_gap(&tris, directed) {
        let p = sys.pos[e[0]];
        return Err(connect::ConnectError::Coarse(format!(
            "its triangles leave a gap or overlap at the edge from ({}, {}, {})",
            p.x, p.y, p.z
        )));
    }
    let d_mean = sys.d.iter().sum::<f64>() / sys.d.len().max(1) as f64;
    if let Some([i, _]) = connect::first_coincident(&sys.pos, sys.n_fixed, COINCIDENT * d_mean) {
        let p = sys.pos[i];
        return Err(connect::ConnectError::Coarse(format!(
            "two of its nodes coincide at ({}, {}, {}): its triangles fold over each other",
            p.x, p.y, p.z
        )));
    }
    let judged = face_area
        .get_or_init(|| sampled_area(&sys.carrier))
        .filter(|&a| a >= AREA_JUDGED * d_mean * d_mean);
    if let Some(area) = judged {
        let flat: f64 = tris
            .iter()
            .map(|t| crate::measure::triangle_area(&sys.pos[t[0]], &sys.pos[t[1]], &sys.pos[t[2]]))
            .sum();
        if flat < AREA_FLOOR * area {
            return Err(connect::ConnectError::Coarse(format!(
                "its triangles cover {flat:.4e} of its {area:.4e} (model units²): they cut \
                 through the surface instead of following it"
            )));
        }
    }
    match connect::corners(sys.n(), &tris)[..sys.n_fixed]
        .iter()
        .position(|&u| !u)
    {
        None => Ok(tris),
        Some(i) => Err(connect::ConnectError::Coarse(format!(
            "the fixed node at ({}, {}, {}) is left out of the triangles",
            sys.pos[i].x, sys.pos[i].y, sys.pos[i].z
        ))),
    }
}

/// Two nodes of a curved face closer than this many spacings (their
/// bubbles' mean) are one point ([`connect::first_coincident`]). Far
/// below any distance the packing leaves between bubbles (a pin hole of
/// radius d/250 and height d/8000, as_0086, has nodes d/8000 apart), far
/// above rounding.
const COINCIDENT: f64 = 1e-9;

/// Faces smaller than this many squared spacings (their bubbles' mean)
/// are not held to [`AREA_FLOOR`]: they have room for a handful of nodes
/// only. A sphere of radius 1.06 less a cap at d = 1.45 (6.3 d², rp_1_023
/// of the random parts) is connected as a cone of 8 nodes covering 0.57
/// of it; refused, its finer levels connected worse (0.44 at d = 0.39)
/// and the part was refused. The half-covered void of rp_5_025 is 13.5 d².
const AREA_JUDGED: f64 = 8.0;

/// The least share of a curved face's area its flat triangles may cover.
/// Triangles whose corners lie on the surface cover a little less than
/// it (the chord error: a sphere of radius 0.7 d at seven nodes per turn,
/// 18 % less); far less means triangles cutting through the surface: a
/// void's sphere less a small cap, 13 bubbles at d = r, connected with
/// smaller caps, had half its area (rp_5_025 of the random parts at
/// diag/20).
const AREA_FLOOR: f64 = 0.6;

/// The area of a face (model units²) sampled on a 40 × 40 grid over its
/// (u,v) box: Σ |S_u × S_v| Δu Δv at the cell centres inside its region.
/// `None` when fewer than 100 centres are inside (the face is a sliver of
/// its box: too few samples to judge) or the sum is not finite.
fn sampled_area(carrier: &OnFace<'_>) -> Option<f64> {
    const N: usize = 40;
    let (lo, hi) = carrier.region.bbox();
    let (du, dv) = ((hi[0] - lo[0]) / N as f64, (hi[1] - lo[1]) / N as f64);
    if !(du > 0.0 && dv > 0.0 && du.is_finite() && dv.is_finite()) {
        return None;
    }
    let (mut inside, mut sum) = (0usize, 0.0);
    for i in 0..N {
        for j in 0..N {
            let uv = [lo[0] + (i as f64 + 0.5) * du, lo[1] + (j as f64 + 0.5) * dv];
            if carrier.region.contains(uv[0], uv[1]) {
                let (_, su, sv) = carrier.surface.tangents(uv[0], uv[1]);
                sum += su.cross(&sv).norm();
                inside += 1;
            }
        }
    }
    let area = sum * du * dv;
    (inside >= 100 && area.is_finite()).then_some(area)
}

/// The parameter of edge `e` at mesh node `id`: its start or end where
/// `at_end` says the node is one (`Some(false)`, `Some(true)`), else the
/// node's own `[t, 0]`.
fn edge_parameter(e: &crate::model::Edge, mesh: &Mesh, id: u32, at_end: Option<bool>) -> f64 {
    match at_end {
        Some(false) => e.t0,
        Some(true) => e.t1,
        None => mesh.nodes[id as usize].params[0],
    }
}

/// Whether the parameter box of `surface` (its `domain()`; a face's view
/// of its surface has the face's box) reaches its singular point `q`: the
/// point's parameters, clamped into the box in the non-periodic
/// directions, are still at `q` (any u maps to a sphere's pole), within a
/// millionth of the box's size in model space. Unbounded boxes reach
/// everything.
fn reaches(surface: &dyn crate::geom::Surface, q: &P3) -> bool {
    let (lo, hi) = domain_box(surface);
    if !lo.iter().chain(&hi).all(|x| x.is_finite()) {
        return true;
    }
    let periods = surface.periods();
    let size = (surface.point(lo[0], lo[1]) - surface.point(hi[0], hi[1]))
        .norm()
        .max((surface.point(lo[0], hi[1]) - surface.point(hi[0], lo[1])).norm());
    surface.inverse(q, None).is_none_or(|uv| {
        let mut c = uv;
        for k in 0..2 {
            if periods[k].is_none() {
                c[k] = c[k].clamp(lo[k], hi[k]);
            }
        }
        (surface.point(c[0], c[1]) - q).norm() <= 1e-6 * size
    })
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

/// Whether `tris` (counter-clockwise in (u,v)) cover a face once: every
/// directed boundary segment of `boundary` in exactly one triangle, every
/// other edge in two, once each way. The lattice restart's passes move
/// bubbles after its connection; on as_40mm_capot a graded face came out
/// with an edge in four triangles, and the final check then failed the
/// whole model.
fn covers_once(tris: &[[usize; 3]], boundary: &[[usize; 2]]) -> bool {
    let mut uses: HashMap<(usize, usize), i32> = HashMap::with_capacity(3 * tris.len());
    for t in tris {
        for k in 0..3 {
            *uses.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    let directed: std::collections::HashSet<(usize, usize)> =
        boundary.iter().map(|&[a, b]| (a, b)).collect();
    // a segment run both ways (a slit) is an interior edge here
    let on_boundary: std::collections::HashSet<(usize, usize)> = directed
        .iter()
        .copied()
        .filter(|&(a, b)| !directed.contains(&(b, a)))
        .collect();
    uses.iter().all(|(&(a, b), &n)| {
        n == 1
            && if on_boundary.contains(&(a, b)) {
                !uses.contains_key(&(b, a))
            } else {
                uses.get(&(b, a)) == Some(&1)
            }
    }) && on_boundary.iter().all(|e| uses.contains_key(e))
}

/// What a kept conformal restart reports: the cones placed (five-,
/// seven-valent) and the second stage 2's statistics.
type Restart = ((usize, usize), system::RelaxStats);

/// Rebuilds a graded planar face from the lattice conformal to its spacing
/// (`conformal::lattice_seeds` over the current mesh) as a new stage 1, and
/// keeps the result if its mean radius ratio is higher and its edges are in
/// the spacing band [1/√2, √2] as often (or at least 99.5 % of them);
/// otherwise the packed mesh stays. Returns the cones placed and the second
/// stage 2's statistics when the lattice mesh was kept.
fn conformal_restart<C: constraint::Carrier>(
    sys: &mut system::System<'_, C>,
    tris: &mut Vec<[usize; 3]>,
    fixed: &Boundary,
    fe: EntityRef,
    settings: &system::RelaxSettings,
) -> Result<Option<Restart>, MeshError> {
    let (segments, boundary) = (&fixed.segments[..], &fixed.directed[..]);
    let loop_locals = &fixed.loop_locals;
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
    let mean_q =
        |sys: &system::System<'_, C>, tris: &[[usize; 3]]| mean_and_least(&sys.pos, tris).0;
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
                    inside += (std::f64::consts::FRAC_1_SQRT_2..=std::f64::consts::SQRT_2)
                        .contains(&r) as usize;
                }
            }
        }
        inside as f64 / all.max(1) as f64
    };
    let before = (mean_q(sys, tris), in_band(sys, tris));
    let saved = Packing::take(sys);
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
        improve::improve(sys, &mut new_tris, segments, PRM.improve_rounds)?;
        improve::lift_mean(
            sys,
            &mut new_tris,
            segments,
            PRM.lattice_mean_q,
            PRM.lattice_mean_rounds,
        )?;
        Ok((relax, new_tris))
    })();
    // kept only if a manifold cover of the face, better in mean radius
    // ratio and no worse in spacing
    match attempt {
        Ok((relax, new_tris))
            if !new_tris.is_empty()
                && covers_once(&new_tris, boundary)
                && mean_q(sys, &new_tris) > before.0
                && in_band(sys, &new_tris) >= before.1.min(0.995) =>
        {
            *tris = new_tris;
            Ok(Some((lattice.cones, relax)))
        }
        _ => {
            saved.restore(sys);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of four boundary nodes and a centre node: four triangles
    /// cover it once; a duplicated triangle (an edge in four triangles, as
    /// as_40mm_capot's lattice restart once gave), a missing one or a
    /// reversed one do not.
    #[test]
    fn covers_once_refuses_overlaps_gaps_and_flips() {
        let boundary = [[0, 1], [1, 2], [2, 3], [3, 0]];
        let fan = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        assert!(covers_once(&fan, &boundary));
        let mut twice = fan.clone();
        twice.push([1, 2, 4]);
        assert!(!covers_once(&twice, &boundary));
        assert!(!covers_once(&fan[..3], &boundary));
        let mut flipped = fan.clone();
        flipped[2] = [3, 2, 4];
        assert!(!covers_once(&flipped, &boundary));
    }

    /// The wall of a hole of radius 0.025 and height 0.001 (face 7 of
    /// `as_0086_ski_part_with_hole.step` in `../shared/realstep`): a band
    /// in (u,v) a thousand times narrower than its boundary segments. Each
    /// loop's side is found, though probes 1 % of a segment off the loop
    /// miss the band on both sides (which once put the face on the left of
    /// both loops, and the face came out without triangles).
    #[test]
    fn thin_periodic_band_loop_sides() {
        let tau = std::f64::consts::TAU;
        let bottom: Vec<[f64; 2]> = (0..5).map(|k| [k as f64 * tau / 5.0, 0.0]).collect();
        let top: Vec<[f64; 2]> = (0..5)
            .rev()
            .map(|k| [k as f64 * tau / 5.0, 0.001])
            .collect();
        let periods = [Some(tau), None];
        let region = region::Region::periodic(
            &[bottom.clone(), top.clone()],
            periods,
            ([0.0, -1.0], [tau, 1.0]),
        );
        assert!(face_left_of_periodic_loop(&region, &bottom, periods));
        assert!(face_left_of_periodic_loop(&region, &top, periods));
        let reversed: Vec<[f64; 2]> = bottom.iter().rev().copied().collect();
        assert!(!face_left_of_periodic_loop(&region, &reversed, periods));
        let reversed: Vec<[f64; 2]> = top.iter().rev().copied().collect();
        assert!(!face_left_of_periodic_loop(&region, &reversed, periods));
    }
}
