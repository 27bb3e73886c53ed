//! Volumes (thesis §3.2.3, §4.1.3, §4.3.3): bubbles inside a solid whose
//! boundary is already meshed.
//!
//! - The boundary: the triangles of the volume's faces, oriented outward
//!   ([`shell`]); their nodes are the fixed bubbles.
//! - Stage 1 (§4.1.3, Fig. 4.6): a face-centred cubic packing. With a
//!   uniform spacing d it is the exact FCC lattice of nearest-neighbour
//!   distance d (cube side a = √2·d, 4 bubbles per cube); with a varying
//!   spacing an octree of cubes, each leaf holding the 4 FCC bubbles of its
//!   size — the rhomboid octree of the thesis, expressed on the cubic cell of
//!   the FCC lattice. A cube is split while its side exceeds
//!   [`OCTREE_SPLIT`]·√2·d at its centre (the factor makes the mean density
//!   right when leaf sizes fall anywhere within a factor 2 of the target).
//! - Stage 2: the same dynamics as on faces, with the volume's equivalent
//!   stiffness (eq. 4.3.4) and population control for twelve neighbours
//!   ([`crate::bubbles::population::control_volume`]).
//! - Uniform spacing (not in the thesis): a body-centred cubic lattice
//!   instead ([`Lattice::Bcc`]), and neither stage 2 nor ODT smoothing.
//!   Why: FCC is the packing the forces favour, but its Delaunay
//!   tetrahedralization splits every octahedral hole into four tetrahedra
//!   of radius ratio 0.80, so everything after it (stage 2, 20 ODT
//!   iterations, the polish) works to move the nodes away from FCC. The
//!   Delaunay tetrahedra of BCC are all congruent: radius ratio 0.949,
//!   dihedral angles 60° and 90°, edges 0.87·a and a. Any lattice is in
//!   force balance by symmetry, and measured on a unit cube stage 2 and
//!   ODT gave it nothing (d = 0.05: mean 0.927 with both, 0.926 without),
//!   so only the layer next to the boundary needs the sliver pass and the
//!   polish. Unit cube, one thread (bench/run_3d.py), d = 0.05 (case H):
//!   mean 0.913 → 0.925, 6.5 s → 3.0 s; d = 0.015 (case K): 0.917 → 0.941,
//!   251 s → 63 s (session 7, after the sliver pass, flips and polish were
//!   made cheaper and one flip round kept after BCC: 17.1 s, mean 0.941,
//!   2.1× Gmsh HXT's time in the same run; session 8, with the
//!   tetrahedra in node order and the local passes: 9.1 s, mean 0.941,
//!   1.76×; session 9, with the sliver pass flipping before it smooths,
//!   no flip round in the polish after BCC and the faces' looser plateau
//!   ([`crate::bubbles::system::PLATEAU_BOUNDARY`]): 7.7–8.4 s, q 0.550 / 0.940,
//!   1.02–1.30× in three runs). Where BCC meets a thin part's boundary unrelaxed it is
//!   worse, so it is given up for FCC when its first tetrahedralization
//!   looks poor ([`BCC_MAX_BAD`], locked slivers, recovery removals) or
//!   its result is ([`BCC_FLOOR_RR`]). The thesis's FCC path stays available
//!   ([`VolumeLattice::Fcc`], `--fcc`), and is always used for a varying
//!   spacing (a BCC octree measured the same as FCC on case I, 0.904
//!   against 0.903).
//! - Inside/outside: the adapter's exact answer where it has one, and
//!   always the boundary mesh ([`Shell::inside`]), so no bubble leaves the
//!   meshed boundary.

pub use crate::options::VolumeLattice;

pub mod connect;
pub mod shell;
pub mod tet;

use crate::geom::{VolumeGeometry, P3, V3};
use crate::model::EntityRef;

use crate::bubbles::constraint::Carrier;
use crate::error::MeshError;
use crate::face::placement::MAX_BUBBLES_PER_ENTITY;
use crate::spacing::{Spacing, SpacingQuery};
use shell::Shell;

/// Octree split factor for varying spacing (see the module docs): a leaf of
/// side s holds 4 bubbles, FCC density needs s = √2·d, and with leaf sides
/// spread log-uniformly over (S/2, S] the mean of 1/s³ matches at
/// S = 1.5·√2·d.
pub const OCTREE_SPLIT: f64 = 1.5;

/// Stage-1 bubbles closer than this fraction of the stable distance to a
/// boundary bubble are dropped (the first FCC layer off a (100) plane is at
/// d/√2 = 0.71·d).
pub const BOUNDARY_CLEARANCE: f64 = 0.65;

/// Volume bubbles are packed at this fraction of d(x). In a Delaunay
/// tetrahedralization of a face-centred cubic packing each node has 12
/// nearest-neighbour edges and one octahedral diagonal of length √2·d per
/// node, so the mean edge is 1.06·d; packing at 0.95·d centres the edge
/// lengths on the requested spacing (measured on case H with
/// `bench/run_3d.py`). The boundary (face) bubbles keep d.
pub const VOLUME_PACKING: f64 = 0.95;

/// Upper bound on stage-2 steps in a volume (see `mesh_volume`).
pub const VOLUME_MAX_STEPS: usize = 100;

/// Cube side of the BCC lattice per unit spacing: its Delaunay edges are 8
/// of √3/2·a and 6 of a per node, mean (6 + 4√3)/14·a = 0.9234·a, so
/// a = 1.0829·d puts the mean edge on d.
pub const BCC_CELL: f64 = 1.082_93;

/// Relative size of the deterministic jitter given to BCC seeds: a perfect
/// lattice has eight cospherical points per cube, which sends the
/// Delaunay kernel's in-sphere tests to exact arithmetic and symbolic
/// perturbation (3.5 s instead of 1.2 s for 100k points); 1e-6·d changes
/// no Delaunay tetrahedron of BCC (it has no degenerate one).
pub const BCC_JITTER: f64 = 1e-6;

/// A BCC start is given up for FCC and stage 2 when more than this
/// fraction of its Delaunay tetrahedra are below the sliver target
/// ([`tet::sliver::TARGET_Q`]). Where the lattice meets the boundary's
/// bubbles unrelaxed, thin parts get many poor tetrahedra, and the sliver
/// pass then costs more than stage 2 and ODT would have: b3d_flange at 1.5
/// had 3.6 % (mean 0.899 in 28 s against FCC's 0.912 in 10 s), b3d_bracket
/// 2.9 %, a unit cube at d = 0.1 5.0 % (0.905 against 0.910); bulky ones
/// stay below: the unit cube at d = 0.05 1.3 %, the ball at 0.08 1.2 %,
/// b3d_nurbs_torus 1.7 %, case K 0.9 %.
pub const BCC_MAX_BAD: f64 = 0.02;

/// A BCC start is also given up for FCC when, after the sliver pass and
/// the polish, a tetrahedron is below this floor ([`below_bcc_floor`]):
/// radius ratio [`BCC_FLOOR_RR`], dihedral angles within
/// [`BCC_FLOOR_DIHEDRAL`] (issue 5's bounds are 0.45 and [25°, 140°]). The
/// FCC path usually reaches the sliver target 0.55 (26.8°); BCC leaves a
/// few tetrahedra just below it next to the boundary of large volumes (case
/// K: ten or so at 0.52–0.55, 25.4°–26.8°, depending on the face meshes)
/// and that is kept, for 3–10× less time.
///
/// Why the measures themselves and not a floor on the
/// [`tet::sliver::objective`]: the objective maps 25° to 0.514 but 140°
/// to 0.530, and a floor of 0.53 on it sent case K to FCC (168 s instead
/// of 15 s) for four tetrahedra at 25.4°, inside the bounds.
pub const BCC_FLOOR_RR: f64 = 0.5;
/// See [`BCC_FLOOR_RR`]: the smallest and largest dihedral angle, degrees.
pub const BCC_FLOOR_DIHEDRAL: (f64, f64) = (25.0, 140.0);

/// Whether tetrahedron `t` is below the BCC floor ([`BCC_FLOOR_RR`]).
fn below_bcc_floor(pos: &[P3], t: &[u32; 4]) -> bool {
    // an objective of 0.55 or more means ρ ≥ 0.55 and angles within
    // [26.8°, 138.5°]: the measures only for the few below
    if tet::sliver::objective_of(pos, t) >= 0.55 {
        return false;
    }
    let [a, b, c, d] = t.map(|k| pos[k as usize]);
    let (lo, hi) = tet::sliver::dihedral_extremes(&a, &b, &c, &d);
    tet::sliver::radius_ratio(&a, &b, &c, &d) < BCC_FLOOR_RR
        || lo < BCC_FLOOR_DIHEDRAL.0
        || hi > BCC_FLOOR_DIHEDRAL.1
}

/// The stage-1 lattice of a volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Lattice {
    /// Face-centred cubic, the thesis's (§4.1.3): 4 bubbles per cube of
    /// side √2·d, an octree of such cubes for a varying spacing.
    Fcc,
    /// Body-centred cubic: 2 bubbles per cube of side [`BCC_CELL`]·d,
    /// for a uniform spacing only.
    Bcc,
}

/// d(x) scaled by a constant factor.
struct Scaled<'a> {
    inner: &'a dyn Spacing,
    factor: f64,
}

impl Spacing for Scaled<'_> {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.inner.spacing(q) * self.factor
    }
    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        self.inner.spacing_batch(qs, out);
        for o in out.iter_mut() {
            *o *= self.factor;
        }
    }
    fn constant(&self) -> Option<f64> {
        self.inner.constant().map(|c| c * self.factor)
    }
}

/// Bubbles moving inside a volume.
pub struct InVolume<'a> {
    pub entity: EntityRef,
    pub geometry: Option<&'a dyn VolumeGeometry>,
    pub shell: &'a Shell,
}

impl InVolume<'_> {
    /// Inside the meshed boundary and, where the adapter answers, inside
    /// the true volume.
    pub fn contains_point(&self, p: &P3) -> bool {
        self.shell.inside(p) && self.geometry.and_then(|g| g.contains(p)).unwrap_or(true)
    }
}

impl Carrier for InVolume<'_> {
    fn entity(&self) -> EntityRef {
        self.entity
    }
    fn advance(&self, pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])> {
        let p = pos + dx;
        self.contains_point(&p).then_some((p, params))
    }
    fn frame(&self, _params: [f64; 2]) -> (V3, V3) {
        (V3::x(), V3::y())
    }
    fn dim(&self) -> u8 {
        3
    }
    fn project(&self, _params: [f64; 2], v: &V3) -> V3 {
        *v
    }
    fn contains(&self, _params: [f64; 2]) -> bool {
        true
    }
    fn point(&self, _params: [f64; 2]) -> P3 {
        P3::origin()
    }
    fn normal(&self, _params: [f64; 2]) -> V3 {
        V3::z()
    }
    fn planar(&self) -> bool {
        false
    }
}

/// Deterministic uniform numbers in [−0.5, 0.5) (xorshift64 from `seed`,
/// which must not be 0): the BCC seeds' jitter, and test inputs.
pub(crate) fn jitter_source(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// Stage 1 for a volume: bubbles of `lattice` inside `carrier`'s volume
/// within the box `lo..hi`, with their spacing. Bubbles too close to a
/// fixed bubble (`fixed`, with diameters `fixed_d`) are left out.
/// [`Lattice::Bcc`] needs a uniform spacing (else FCC is used).
pub fn lattice_seeds(
    carrier: &InVolume<'_>,
    spacing: &dyn Spacing,
    lo: P3,
    hi: P3,
    fixed: &[P3],
    fixed_d: &[f64],
    lattice: Lattice,
) -> Result<Vec<(P3, f64)>, MeshError> {
    let entity = carrier.entity;
    let d_at = |p: &P3| -> Result<f64, MeshError> {
        let d = spacing.spacing(&SpacingQuery {
            point: *p,
            entity,
            params: [0.0; 2],
        });
        crate::error::check_spacing(d, *p, entity)
    };
    let ext = hi - lo;
    let mut cand: Vec<P3> = Vec::new();
    let fcc = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(0.5, 0.5, 0.0),
        V3::new(0.5, 0.0, 0.5),
        V3::new(0.0, 0.5, 0.5),
    ];
    let bcc = [V3::new(0.0, 0.0, 0.0), V3::new(0.5, 0.5, 0.5)];
    let mut jitter = 0.0;
    if let Some(d) = spacing.constant() {
        let (basis, a): (&[V3], f64) = match lattice {
            Lattice::Fcc => (&fcc, std::f64::consts::SQRT_2 * d),
            Lattice::Bcc => {
                // `spacing` is packed (VOLUME_PACKING·d) for stage 2, which
                // a BCC lattice skips: its cube is BCC_CELL·d of the
                // requested d
                jitter = BCC_JITTER * d;
                (&bcc, BCC_CELL / VOLUME_PACKING * d)
            }
        };
        let n = [0, 1, 2].map(|k| (ext[k] / a).ceil() as usize + 1);
        let total = (n[0] as f64) * (n[1] as f64) * (n[2] as f64) * basis.len() as f64;
        if !(total <= MAX_BUBBLES_PER_ENTITY as f64 * 2.0) {
            return Err(MeshError::TooManyBubbles {
                limit: MAX_BUBBLES_PER_ENTITY,
            });
        }
        // centre the lattice in the box
        let off = [0, 1, 2].map(|k| lo[k] + 0.5 * (ext[k] - (n[k] - 1) as f64 * a));
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    for b in basis {
                        cand.push(P3::new(
                            off[0] + (i as f64 + b.x) * a,
                            off[1] + (j as f64 + b.y) * a,
                            off[2] + (k as f64 + b.z) * a,
                        ));
                    }
                }
            }
        }
    } else {
        let side = ext.max().max(f64::MIN_POSITIVE);
        let mut stack = vec![(lo, side, 0u32)];
        while let Some((c0, s, depth)) = stack.pop() {
            let centre = c0 + V3::repeat(0.5 * s);
            let d = d_at(&centre)?;
            if s > OCTREE_SPLIT * std::f64::consts::SQRT_2 * d && depth < 24 {
                for k in 0..8 {
                    let o = V3::new((k & 1) as f64, (k >> 1 & 1) as f64, (k >> 2 & 1) as f64);
                    let c = c0 + o * (0.5 * s);
                    // skip octants entirely beyond the box
                    if (0..3).any(|a| c[a] > hi[a]) {
                        continue;
                    }
                    stack.push((c, 0.5 * s, depth + 1));
                }
            } else {
                for b in &fcc {
                    cand.push(c0 + b * s);
                }
                if cand.len() > MAX_BUBBLES_PER_ENTITY * 2 {
                    return Err(MeshError::TooManyBubbles {
                        limit: MAX_BUBBLES_PER_ENTITY,
                    });
                }
            }
        }
    }
    // keep those inside and clear of the boundary
    let dmax_fixed = fixed_d.iter().cloned().fold(0.0f64, f64::max);
    let grid = crate::bubbles::grid::Grid::new(fixed, dmax_fixed.max(f64::MIN_POSITIVE));
    let mut out = Vec::new();
    // a fixed seed: the same mesh on every run
    let mut unit = jitter_source(0x9E37_79B9_7F4A_7C15);
    for mut p in cand {
        if jitter > 0.0 {
            p += V3::new(unit(), unit(), unit()) * jitter;
        }
        if !(0..3).all(|k| p[k] > lo[k] && p[k] < hi[k]) || !carrier.contains_point(&p) {
            continue;
        }
        let d = d_at(&p)?;
        let mut clear = true;
        grid.query(&p, BOUNDARY_CLEARANCE * 0.5 * (d + dmax_fixed), |j| {
            let j = j as usize;
            if clear && (fixed[j] - p).norm() < BOUNDARY_CLEARANCE * 0.5 * (d + fixed_d[j]) {
                clear = false;
            }
        });
        if clear {
            out.push((p, d));
        }
    }
    if out.len() > MAX_BUBBLES_PER_ENTITY {
        return Err(MeshError::TooManyBubbles {
            limit: MAX_BUBBLES_PER_ENTITY,
        });
    }
    Ok(out)
}

/// What happened in one volume.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct VolumeReport {
    pub volume: u32,
    pub name: Option<String>,
    pub boundary_bubbles: usize,
    pub boundary_triangles: usize,
    pub stage1_bubbles: usize,
    /// The stage-1 lattice used.
    pub lattice: Option<Lattice>,
    /// When a BCC start was given up for FCC: the fraction of its
    /// tetrahedra below the sliver target right after the connection (see
    /// [`BCC_MAX_BAD`]), or below [`BCC_FLOOR_RR`] at the end.
    pub bcc_rejected: Option<f64>,
    /// Free bubbles in the mesh.
    pub bubbles: usize,
    pub tetrahedra: usize,
    /// Free bubbles removed to recover boundary triangles.
    pub recovery_removed: usize,
    /// Optimal-Delaunay smoothing iterations ([`tet::odt`]).
    pub odt_iterations: usize,
    /// Seconds in ODT smoothing, the conforming Delaunay connection and
    /// sliver removal.
    pub odt_s: f64,
    pub delaunay_s: f64,
    pub sliver_s: f64,
    /// Sliver-removal statistics.
    pub slivers: tet::sliver::SliverStats,
    /// Node moves and flips of the mean-quality step
    /// ([`tet::polish::polish`]), and its seconds.
    pub polish_moves: usize,
    pub polish_flips: usize,
    pub polish_s: f64,
    /// Steiner points added inside slivers that smoothing and flips could
    /// not remove ([`tet::sliver::steiner_points`]).
    pub steiner: usize,
    pub relax: Option<crate::bubbles::system::RelaxStats>,
}

/// The outward-oriented boundary triangles (global node ids) of volume
/// `vi`: the triangles of its faces.
pub fn boundary_of(
    model: &crate::model::Model,
    vi: usize,
    mesh: &crate::mesh::Mesh,
) -> Result<Vec<[u32; 3]>, MeshError> {
    let faces: std::collections::HashSet<u32> = model.volumes[vi].faces.iter().cloned().collect();
    let mut tris: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .filter(|t| t.entity.dim == 2 && faces.contains(&t.entity.id))
        .map(|t| t.nodes)
        .collect();
    // a face listed twice (an internal face of a non-manifold solid) bounds
    // the volume on both sides: not supported here
    let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
    shell::orient_outward(&pos, &mut tris).map_err(MeshError::Invalid)?;
    Ok(tris)
}

/// A failed tetrahedralization as a [`MeshError`]: boundary triangles that
/// are not faces of the tetrahedralization name their faces, which a finer
/// surface mesh may make Delaunay ([`crate::engine::refine`]).
fn connect_error(
    e: connect::Connect3dError,
    boundary: &[[u32; 3]],
    mesh: &crate::mesh::Mesh,
) -> MeshError {
    let connect::Connect3dError::NotConforming { triangles, .. } = &e else {
        return MeshError::Invalid(e.to_string());
    };
    let sorted = |mut t: [u32; 3]| {
        t.sort_unstable();
        t
    };
    let wanted: std::collections::HashSet<[u32; 3]> = triangles
        .iter()
        .filter_map(|&k| boundary.get(k as usize))
        .map(|&t| sorted(t))
        .collect();
    let mut faces: Vec<u32> = mesh
        .triangles
        .iter()
        .filter(|t| wanted.contains(&sorted(t.nodes)))
        .map(|t| t.entity.id)
        .collect();
    faces.sort_unstable();
    faces.dedup();
    MeshError::Refinable {
        message: e.to_string(),
        faces,
    }
}

/// Meshes volume `vi` again from the thesis's FCC start, after its BCC
/// start was given up (`frac`: the fraction of its tetrahedra that made
/// it so, recorded in the report). Nothing of the BCC attempt is in `mesh`
/// yet: nodes and tetrahedra are only added at the end of
/// [`mesh_volume`].
#[allow(clippy::too_many_arguments)]
fn redo_from_fcc(
    model: &crate::model::Model,
    vi: usize,
    spacing: &dyn Spacing,
    opts: &crate::options::Options,
    mesh: &mut crate::mesh::Mesh,
    node_d: &[f64],
    timings: &mut crate::options::Timings,
    frac: f64,
) -> Result<VolumeReport, MeshError> {
    let fcc = crate::options::Options {
        volume_lattice: VolumeLattice::Fcc,
        ..opts.clone()
    };
    let mut r = mesh_volume(model, vi, spacing, &fcc, mesh, node_d, timings)?;
    r.bcc_rejected = Some(frac);
    Ok(r)
}

/// Meshes volume `vi` whose faces are meshed in `mesh`.
#[allow(clippy::too_many_arguments)]
pub(super) fn mesh_volume(
    model: &crate::model::Model,
    vi: usize,
    spacing: &dyn Spacing,
    opts: &crate::options::Options,
    mesh: &mut crate::mesh::Mesh,
    node_d: &[f64],
    timings: &mut crate::options::Timings,
) -> Result<VolumeReport, MeshError> {
    use std::time::Instant;
    let t0 = Instant::now();
    let ve = EntityRef::new(3, vi as u32);
    let volume = &model.volumes[vi];
    let boundary = boundary_of(model, vi, mesh)?;
    if boundary.is_empty() {
        return Err(MeshError::Invalid(
            "the volume's faces have no triangles".into(),
        ));
    }
    // fixed bubbles: the boundary nodes
    let mut local: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
    let mut fixed_ids: Vec<u32> = Vec::new();
    for t in &boundary {
        for &v in t {
            local.entry(v).or_insert_with(|| {
                fixed_ids.push(v);
                (fixed_ids.len() - 1) as u32
            });
        }
    }
    let fixed_pos: Vec<P3> = fixed_ids
        .iter()
        .map(|&i| mesh.nodes[i as usize].pos)
        .collect();
    let fixed_d: Vec<f64> = fixed_ids.iter().map(|&i| node_d[i as usize]).collect();
    let local_tris: Vec<[u32; 3]> = boundary.iter().map(|t| t.map(|v| local[&v])).collect();
    let shell = Shell::new(fixed_pos.clone(), &local_tris);
    let (mut lo, mut hi) = (fixed_pos[0], fixed_pos[0]);
    for p in &fixed_pos {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let packing = VOLUME_PACKING;
    let scaled = Scaled {
        inner: spacing,
        factor: packing,
    };
    let requested = spacing;
    let spacing: &dyn Spacing = &scaled;
    let lattice = match (opts.volume_lattice, spacing.constant()) {
        (VolumeLattice::Auto, Some(_)) => Lattice::Bcc,
        _ => Lattice::Fcc,
    };
    let carrier = InVolume {
        entity: ve,
        geometry: volume.geometry.as_deref(),
        shell: &shell,
    };
    let seeds = lattice_seeds(&carrier, spacing, lo, hi, &fixed_pos, &fixed_d, lattice)?;
    let n_fixed = fixed_ids.len();
    let mut rep = VolumeReport {
        volume: vi as u32,
        name: volume.name.clone(),
        lattice: Some(lattice),
        boundary_bubbles: n_fixed,
        boundary_triangles: boundary.len(),
        stage1_bubbles: seeds.len(),
        ..Default::default()
    };
    let mut sys = crate::bubbles::system::System {
        carrier,
        spacing,
        dim: 3,
        n_fixed,
        pos: fixed_pos,
        params: vec![[0.0; 2]; n_fixed],
        vel: vec![V3::zeros(); n_fixed],
        d: fixed_d,
        fixed_ids: fixed_ids.clone(),
        pressure: if spacing.constant().is_some() {
            1.0
        } else {
            crate::bubbles::system::PRESSURE
        },
    };
    for (p, d) in seeds {
        sys.push_free(p, [0.0; 2], d);
    }
    timings.stage1_s += t0.elapsed().as_secs_f64();
    opts.stage1_done(ve, sys.n_fixed, &sys.pos, &sys.d);
    // a BCC lattice needs neither stage 2 nor ODT (module docs)
    let relax = !opts.fast && lattice == Lattice::Fcc;
    if relax {
        let t2 = Instant::now();
        // stage 1 is already a balanced FCC packing away from the boundary,
        // and the ODT smoothing after stage 2 finishes the job: more steps
        // cost time in proportion to the bubbles and did not improve the
        // tetrahedra (measured on cases H, I with bench/run_3d.py)
        let settings = crate::bubbles::system::RelaxSettings {
            max_steps: opts.relax.max_steps.min(VOLUME_MAX_STEPS),
            ..opts.relax
        };
        let stats = sys.relax(
            &settings,
            opts.relax_observer(ve, settings.max_steps, sys.n_fixed),
        )?;
        rep.relax = Some(stats);
        timings.stage2_s += t2.elapsed().as_secs_f64();
    }

    // connection
    let t3 = Instant::now();
    if relax {
        rep.odt_iterations = tet::odt::smooth(
            &mut sys.pos,
            n_fixed,
            &sys.d,
            &sys.carrier,
            tet::odt::ITERATIONS,
        );
    }
    rep.odt_s = t3.elapsed().as_secs_f64();
    let t = Instant::now();
    let conn = connect::connect_volume(&sys.pos, n_fixed, &local_tris)
        .map_err(|e| connect_error(e, &boundary, mesh))?;
    rep.delaunay_s = t.elapsed().as_secs_f64();
    // the objectives of the first tetrahedralization: read here after a BCC
    // start, and handed on to the sliver pass
    let mut first_qs: Option<Vec<f64>> = None;
    if lattice == Lattice::Bcc && !opts.fast {
        let qs: Vec<f64> = conn
            .tets
            .iter()
            .map(|t| tet::sliver::objective_of(&sys.pos, t))
            .collect();
        let poor = |k: usize| qs[k] < tet::sliver::TARGET_Q;
        let frac = (0..qs.len()).filter(|&k| poor(k)).count() as f64 / qs.len().max(1) as f64;
        // poor tetrahedra among boundary nodes only (or nodes the recovery
        // removed) need Steiner rounds, each a full re-connection:
        // block_holes.step at 0.8 spent 62 s there with BCC (1.9 % poor, 9
        // Steiner points), FCC none in 41 s in all
        let fixed = |k: u32| (k as usize) < n_fixed || !conn.kept[k as usize];
        let locked = conn
            .tets
            .iter()
            .enumerate()
            .any(|(ti, t)| t.iter().all(|&k| fixed(k)) && poor(ti));
        if frac > BCC_MAX_BAD || locked || conn.removed > 0 {
            return redo_from_fcc(model, vi, requested, opts, mesh, node_d, timings, frac);
        }
        first_qs = Some(qs);
    }
    rep.recovery_removed = conn.removed;
    let mut tets = conn.tets;
    let mut pos = sys.pos.clone();
    let mut d = sys.d.clone();
    let mut movable: Vec<bool> = (0..pos.len())
        .map(|i| i >= n_fixed && conn.kept[i])
        .collect();
    let t = Instant::now();
    if !opts.fast {
        // the Delaunay tetrahedralization's flat tetrahedra among boundary
        // nodes: flips remove most, but which ones they leave depends on the
        // order they meet them, so every one gets its Steiner points now
        // (see sliver::steiner_points)
        let locked = |t: &[u32; 4], movable: &[bool]| t.iter().all(|&k| !movable[k as usize]);
        let mut work: Vec<[u32; 4]> = tets
            .iter()
            .filter(|t| {
                locked(t, &movable) && tet::sliver::radius_ratio_of(&pos, t) < tet::sliver::FLAT_Q
            })
            .cloned()
            .collect();
        rep.slivers = match first_qs.take() {
            Some(qs) => tet::sliver::improve_with(&mut pos, &mut movable, &mut tets, &d, qs),
            None => tet::sliver::improve(&mut pos, &mut movable, &mut tets, &d),
        };
        for _ in 0..tet::sliver::STEINER_ROUNDS {
            // and those that improve() left
            work.extend(tets.iter().filter(|t| {
                locked(t, &movable) && tet::sliver::objective_of(&pos, t) < tet::sliver::TARGET_Q
            }));
            let extra =
                tet::sliver::steiner_points(&pos, &work, &d, |p| sys.carrier.contains_point(p));
            work.clear();
            if extra.is_empty() {
                break;
            }
            rep.steiner += extra.len();
            // the kept nodes, then the new ones; fixed nodes keep their
            // indices (the boundary triangles refer to them)
            let mut pos2: Vec<P3> = Vec::with_capacity(pos.len() + extra.len());
            let mut d2: Vec<f64> = Vec::with_capacity(pos.len() + extra.len());
            for i in 0..pos.len() {
                if i < n_fixed || movable[i] {
                    pos2.push(pos[i]);
                    d2.push(d[i]);
                }
            }
            for (p, dp) in extra {
                pos2.push(p);
                d2.push(dp);
            }
            let conn = connect::connect_volume(&pos2, n_fixed, &local_tris)
                .map_err(|e| connect_error(e, &boundary, mesh))?;
            rep.recovery_removed += conn.removed;
            movable = (0..pos2.len())
                .map(|i| i >= n_fixed && conn.kept[i])
                .collect();
            tets = conn.tets;
            pos = pos2;
            d = d2;
            let s = tet::sliver::improve(&mut pos, &mut movable, &mut tets, &d);
            rep.slivers.moves += s.moves;
            rep.slivers.flips += s.flips;
            rep.slivers.bad_after = s.bad_after;
            rep.slivers.min_q_after = s.min_q_after;
        }
    }
    rep.sliver_s = t.elapsed().as_secs_f64();
    if !opts.fast {
        let t = Instant::now();
        // no flip round after BCC (see FLIP_ROUNDS)
        let rounds = match lattice {
            Lattice::Bcc => 0,
            Lattice::Fcc => tet::polish::FLIP_ROUNDS,
        };
        let stats = tet::polish::polish(&mut pos, &movable, &mut tets, &d, rounds);
        rep.polish_moves = stats.moves;
        rep.polish_flips = stats.flips;
        rep.polish_s = t.elapsed().as_secs_f64();
        // the polish's flips give the sliver pass new room; where it left
        // nothing below TARGET_Q, the polish made nothing so (its moves and
        // flips keep every star's worst above min(before, TARGET_Q)): that
        // saves a scan of the mesh
        let s = if rep.slivers.bad_after > 0 {
            tet::sliver::improve_near_bad(&mut pos, &movable, &mut tets, &d)
        } else {
            None
        };
        if let Some((s, still_bad)) = s {
            rep.slivers.moves += s.moves;
            rep.slivers.flips += s.flips;
            rep.slivers.bad_after = s.bad_after;
            rep.slivers.min_q_after = s.min_q_after;
            // below the floor means below TARGET_Q: only those can be
            let left = if lattice == Lattice::Bcc {
                still_bad
                    .iter()
                    .filter(|t| below_bcc_floor(&pos, t))
                    .count()
            } else {
                0
            };
            if left > 0 {
                // worse than the thesis's path usually leaves: take that
                // one (measured on fixtures/step/loft.step: 4 tetrahedra
                // of the BCC start stayed at 0.51, dihedral angle 24.8°)
                let frac = left as f64 / tets.len().max(1) as f64;
                return redo_from_fcc(model, vi, requested, opts, mesh, node_d, timings, frac);
            }
        }
    }
    // never hand out a flat tetrahedron (a solver divides by its volume):
    // refuse the volume instead, naming where
    if let Some(t) = tets
        .iter()
        .find(|t| tet::sliver::radius_ratio_of(&pos, t) < tet::sliver::FLAT_Q)
    {
        let c = t
            .iter()
            .fold(V3::zeros(), |a, &k| a + pos[k as usize].coords)
            / 4.0;
        return Err(MeshError::Invalid(format!(
            "a tetrahedron near ({:.6}, {:.6}, {:.6}) stays flat (radius ratio below {:e}) after \
             sliver removal and {} Steiner point(s); try a smaller size there",
            c.x,
            c.y,
            c.z,
            tet::sliver::FLAT_Q,
            rep.steiner
        )));
    }
    let mut referenced = vec![false; pos.len()];
    for t in &tets {
        for &v in t {
            referenced[v as usize] = true;
        }
    }
    let mut node_of = vec![u32::MAX; pos.len()];
    for i in n_fixed..pos.len() {
        if referenced[i] {
            node_of[i] = mesh.nodes.len() as u32;
            mesh.nodes.push(crate::mesh::Node {
                pos: pos[i],
                entity: ve,
                params: [0.0; 2],
            });
        }
    }
    rep.bubbles = (n_fixed..pos.len()).filter(|&i| referenced[i]).count();
    for t in &tets {
        mesh.tetrahedra.push(crate::mesh::Element {
            nodes: t.map(|l| {
                let l = l as usize;
                if l < n_fixed {
                    fixed_ids[l]
                } else {
                    node_of[l]
                }
            }),
            entity: ve,
        });
    }
    rep.tetrahedra = tets.len();
    timings.connect_s += t3.elapsed().as_secs_f64();
    Ok(rep)
}
