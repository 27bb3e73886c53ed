//! Volumes (thesis §3.2.3, §4.1.3, §4.3.3): bubbles inside a solid whose
//! boundary is already meshed.
//!
//! - The boundary: the triangles of the volume's faces, oriented outward
//!   (`shell`); their nodes are the fixed bubbles.
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
//!   polish (measurements: docs/decisions.md). Where BCC meets a thin part's boundary unrelaxed it is
//!   worse, so it is given up when its first tetrahedralization
//!   looks poor ([`BCC_MAX_BAD`], locked slivers, recovery removals) or
//!   its result is ([`BCC_FLOOR_RR`]), for the same lattice with the
//!   bubbles within [`BCC_LAYER`] spacings of the boundary relaxed by stage
//!   2 and ODT smoothing and the others held ([`Lattice::BccLayer`]): the
//!   thesis's method where the boundary needs it, at the cost of that layer
//!   only. The thesis's FCC path stays available
//!   ([`VolumeLattice::Fcc`], `--fcc`), and is always used for a varying
//!   spacing (a BCC octree measured the same as FCC on case I, 0.904
//!   against 0.903).
//! - Inside/outside: the adapter's exact answer where it has one, and
//!   always the boundary mesh (`Shell::inside`), so no bubble leaves the
//!   meshed boundary.

pub use crate::options::VolumeLattice;

pub(crate) mod connect;
pub(crate) mod crossing;
mod keep;
pub(crate) mod recover;
pub(crate) mod shell;
pub(crate) mod split;
pub(crate) mod tet;
mod wall;
mod warm;

pub use tet::SliverStats;

use crate::geom::{VolumeGeometry, P3, V3};
use crate::model::EntityRef;

use crate::bubbles::constraint::Carrier;
use crate::error::MeshError;
use crate::face::placement::MAX_BUBBLES_PER_ENTITY;
use crate::spacing::{Spacing, SpacingQuery};
use shell::Shell;
use tet::mesh::TetMesh;
use tet::star::TARGET_Q;

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

/// A BCC start is given up for [`Lattice::BccLayer`] when more than this
/// fraction of its Delaunay tetrahedra are below the sliver target
/// (`TARGET_Q`). Where the lattice meets the boundary's
/// bubbles unrelaxed, thin parts get many poor tetrahedra, and the sliver
/// pass then costs more than stage 2 and ODT would have: b3d_flange at 1.5
/// had 3.6 % (mean 0.899 in 28 s against FCC's 0.912 in 10 s), b3d_bracket
/// 2.9 %, a unit cube at d = 0.1 5.0 % (0.905 against 0.910); bulky ones
/// stay below: the unit cube at d = 0.05 1.3 %, the ball at 0.08 1.2 %,
/// b3d_nurbs_torus 1.7 %, case K 0.9 %.
pub const BCC_MAX_BAD: f64 = 0.02;

/// A BCC start is also given up for [`Lattice::BccLayer`] when, after the
/// sliver pass and the polish, a tetrahedron is below this floor
/// (`below_bcc_floor`): radius ratio [`BCC_FLOOR_RR`], dihedral angles
/// within [`BCC_FLOOR_DIHEDRAL`] (the quality bounds asked of volume meshes
/// are 0.45 and [25°, 140°]). The relaxed paths (FCC,
/// [`Lattice::BccLayer`]) usually reach the sliver target 0.55 (26.8°); BCC
/// leaves a few tetrahedra just below it next to the boundary of large
/// volumes (case K: ten or so at 0.52–0.55, 25.4°–26.8°, depending on the
/// face meshes) and that is kept, for 3–10× less time.
///
/// Why the measures themselves and not a floor on the
/// `tet::star::objective`: the objective maps 25° to 0.514 but 140°
/// to 0.530, and a floor of 0.53 on it sent case K to FCC (168 s instead
/// of 15 s) for four tetrahedra at 25.4°, inside the bounds.
pub const BCC_FLOOR_RR: f64 = 0.5;
/// See [`BCC_FLOOR_RR`]: the smallest and largest dihedral angle, degrees.
pub const BCC_FLOOR_DIHEDRAL: (f64, f64) = (25.0, 140.0);

/// How far from the boundary, in spacings, a [`Lattice::BccLayer`] start
/// relaxes its bubbles: the force reaches 1.5 spacings, so the second
/// lattice layer off the boundary bubbles still feels them. Measured on
/// the fixtures at `mesh_size` (one thread) against FCC and stage 2 over
/// the whole volume, where the BCC start is given up and the layer is at
/// most [`BCC_LAYER_MAX_SHARE`] of the lattice:
/// fillet_small 4.7 → 2.6 s, mean radius ratio 0.914 → 0.932, block_holes
/// 5.5 → 4.1 s (0.915 → 0.926), b3d_spring 24 → 21 s (0.914 → 0.928),
/// smallest dihedral angle 26.8° on both; 1.5 spacings left loft's worst
/// tetrahedron at 0.516 (25.3°). docs/decisions.md has the rest.
pub const BCC_LAYER: f64 = 2.0;

/// A [`Lattice::BccLayer`] start is made only where at most this share of
/// the lattice's bubbles lie in the layer; thinner volumes take the FCC
/// path. Where the layer is most of the volume the two cost the same, and
/// the FCC path's tetrahedra were as good or better: at diag/20 on
/// `../shared/realstep` (layer shares near 1) a layered start lowered the
/// mean radius ratio on 12 of 27 solids (as_0044 0.875 → 0.867,
/// face_recognition 0.832 → 0.815), fixtures/step/flange_revolved (0.69)
/// ended at radius ratio 0.520 instead of 0.550 and b3d_flange (0.75) at a
/// mean of 0.911 instead of 0.912.
pub const BCC_LAYER_MAX_SHARE: f64 = 0.6;

/// ODT iterations ([`tet::odt`]) of the first round's Steiner points
/// before they are connected, when they are at least a quarter of the free
/// nodes (thin parts, where the lattice fits few bubbles and the Steiner
/// points, placed 0.29·d off slivers, are most of the interior). They alone
/// move, the Delaunay tetrahedralizations taken around them.
///
/// Measured on the 27 realstep solids at diag/20 (one thread): 68.8 s →
/// 49.2 s in all, mean radius ratio up on every solid where it runs
/// (as_0083 0.730 → 0.820 and 7.6 → 3.0 s, as_0050 0.695 → 0.757, as_0053
/// 0.724 → 0.783). Before, the six Steiner rounds' re-connections and
/// sliver passes did this smoothing slowly (as_0083: mean 0.633 after the
/// first round, 0.705 after the sixth). Smoothing every free node instead
/// cost a tetrahedralization of the whole volume per iteration and left
/// fixtures/step/b3d_bottle's worst tetrahedron at radius ratio 0.0015 (the
/// new points alone: 0.37); 5 iterations gave less (as_0083 0.792), 20 more
/// at a higher cost (as_40mm_capot 16 s). docs/decisions.md has the rest.
pub const STEINER_ODT_ITERATIONS: usize = 10;

/// Whether tetrahedron `t` is below the BCC floor ([`BCC_FLOOR_RR`]).
fn below_bcc_floor(pos: &[P3], t: &[u32; 4]) -> bool {
    // an objective of 0.55 or more means ρ ≥ 0.55 and angles within
    // [26.8°, 138.5°]: the measures only for the few below
    if tet::star::objective_of(pos, t) >= 0.55 {
        return false;
    }
    let [a, b, c, d] = t.map(|k| pos[k as usize]);
    let (lo, hi) = crate::measure::dihedral_extremes(&a, &b, &c, &d);
    crate::measure::tet_radius_ratio(&a, &b, &c, &d) < BCC_FLOOR_RR
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
    /// Body-centred cubic whose bubbles within [`BCC_LAYER`] spacings of
    /// the boundary are relaxed by stage 2 and ODT smoothing, the others
    /// held where the lattice put them until the sliver pass and the
    /// polish (uniform spacing only, when [`Lattice::Bcc`] is given up).
    #[serde(rename = "bcc_layer")]
    BccLayer,
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
    fn constant_on(&self, e: EntityRef) -> Option<f64> {
        self.inner.constant_on(e).map(|c| c * self.factor)
    }
}

/// Bubbles moving inside a volume.
#[derive(Clone, Copy)]
pub(crate) struct InVolume<'a> {
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
pub(crate) fn lattice_seeds(
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
    if let Some(d) = spacing.constant_on(entity) {
        let (basis, a): (&[V3], f64) = match lattice {
            Lattice::Fcc => (&fcc, std::f64::consts::SQRT_2 * d),
            Lattice::Bcc | Lattice::BccLayer => {
                // `spacing` is packed (VOLUME_PACKING·d) for stage 2, which
                // a BCC lattice skips: its cube is BCC_CELL·d of the
                // requested d
                jitter = BCC_JITTER * d;
                (&bcc, BCC_CELL / VOLUME_PACKING * d)
            }
        };
        let n = [0, 1, 2].map(|k| (ext[k] / a).ceil() as usize + 1);
        let total = (n[0] as f64) * (n[1] as f64) * (n[2] as f64) * basis.len() as f64;
        if total.is_nan() || total > MAX_BUBBLES_PER_ENTITY as f64 * 2.0 {
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
    /// When a BCC start was given up (for [`Lattice::BccLayer`], or FCC
    /// where the layer is most of the volume): the fraction of its
    /// tetrahedra below the sliver target right after the connection (see
    /// [`BCC_MAX_BAD`]), or below [`BCC_FLOOR_RR`] at the end.
    pub bcc_rejected: Option<f64>,
    /// Free bubbles in the mesh.
    pub bubbles: usize,
    pub tetrahedra: usize,
    /// Free bubbles removed to recover boundary triangles.
    pub recovery_removed: usize,
    /// Optimal-Delaunay smoothing iterations.
    pub odt_iterations: usize,
    /// Of those, the iterations whose tetrahedralization was built anew
    /// (the others moved the last one's by flips).
    pub odt_rebuilt: usize,
    /// Seconds in ODT smoothing, the conforming Delaunay connection and
    /// sliver removal.
    pub odt_s: f64,
    pub delaunay_s: f64,
    pub sliver_s: f64,
    /// Sliver-removal statistics.
    pub slivers: SliverStats,
    /// Node moves and flips of the mean-quality step (the polish), and its
    /// seconds.
    pub polish_moves: usize,
    pub polish_flips: usize,
    pub polish_s: f64,
    /// Steiner points added inside slivers that smoothing and flips could
    /// not remove.
    pub steiner: usize,
    /// Steiner points inserted in place at the end for slivers among
    /// fixed nodes and kept ([`tet::insert`]; `steiner_in_place` says when
    /// one is kept).
    pub steiner_in_place: usize,
    /// Free bubbles dropped after stage 2 because they lay between twin
    /// faces ([`drop_in_walls`]).
    pub in_walls: usize,
    /// Pairs of boundary triangles turned to the Delaunay diagonal of
    /// their quadrilateral before the connection ([`recover`]).
    pub boundary_flips: usize,
    /// Flat tetrahedra on a boundary quadrilateral removed at the end,
    /// their pairs turned ([`recover::turn_flat_quads`]).
    pub flat_quads: usize,
    /// Prisms of twin walls whose tetrahedra were re-split at the end
    /// ([`wall::Prisms::split`]).
    pub wall_prisms: usize,
    /// Boundary edges split on the geometry before the connection, and
    /// where ([`split`]): there the face meshes are finer than requested.
    pub boundary_splits: split::Splits,
    /// A warm start (§4.8): old bubbles kept fixed, old bubbles carried
    /// over as stage 1, FCC seeds added where they left room ([`warm`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warm: Option<[usize; 3]>,
    /// Kept bubbles of a continuous re-meshing freed for the sliver pass:
    /// corners of a tetrahedron below the sliver target whose corners were
    /// all fixed ([`warm`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warm_released: Option<usize>,
    /// Old tetrahedra a re-meshing kept as they were ([`keep`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kept_tets: Option<usize>,
    pub relax: Option<crate::bubbles::system::RelaxStats>,
}

/// The outward-oriented boundary triangles (global node ids) of volume
/// `vi`: the triangles of its faces.
pub(crate) fn boundary_of(
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
    shell::orient_outward(&pos, &mut tris)?;
    Ok(tris)
}

/// A failed tetrahedralization as a [`MeshError`]: boundary triangles that
/// are not faces of the tetrahedralization name their faces, which a finer
/// surface mesh may make Delaunay ([`crate::engine::refine`]).
fn connect_error(
    e: connect::Connect3dError,
    boundary: &[[u32; 3]],
    model: &crate::model::Model,
    mesh: &crate::mesh::Mesh,
) -> MeshError {
    let connect::Connect3dError::NotConforming { triangles, .. } = &e else {
        return MeshError::Volume(e);
    };
    use crate::measure::sorted3;
    // each boundary triangle's face
    let face_of: std::collections::HashMap<[u32; 3], EntityRef> = mesh
        .triangles
        .iter()
        .map(|t| (sorted3(t.nodes), t.entity))
        .collect();
    let mut faces: Vec<u32> = triangles
        .iter()
        .filter_map(|&k| boundary.get(k as usize))
        .filter_map(|&t| face_of.get(&sorted3(t)))
        .map(|e| e.id)
        .collect();
    faces.sort_unstable();
    faces.dedup();
    // the missing triangles' circumballs: a finer surface mesh there makes
    // their balls smaller than the gap to whatever blocks them
    let spots = triangles
        .iter()
        .filter_map(|&k| boundary.get(k as usize))
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.nodes[v as usize].pos);
            crate::measure::triangle_circumball(&a, &b, &c)
        })
        .collect();
    // a boundary that passes through itself has no tetrahedralization:
    // say where, and whose faces
    let mut message = e.to_string();
    let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
    if let Some((i, j, p)) = crossing::first_crossing(&pos, boundary) {
        let face = |k: usize| {
            face_of
                .get(&sorted3(boundary[k]))
                .map_or_else(|| "a face".to_string(), |&e| model.describe(e))
        };
        message += &format!(
            "; the surface mesh passes through itself: {} crosses {} at ({:.6}, {:.6}, {:.6}) \
             (where the model's faces themselves cross, the solid is invalid and no size cures it)",
            face(i),
            face(j),
            p.x,
            p.y,
            p.z
        );
    }
    MeshError::Refinable {
        message,
        faces,
        spots,
    }
}

/// What meshing one volume reads: the model, the volume, the requested
/// spacing, the options, the spacing at every node already meshed and the
/// slabs between twin faces.
pub(super) struct VolumeJob<'a> {
    model: &'a crate::model::Model,
    vi: usize,
    entity: EntityRef,
    /// d(x) as requested (the volume's bubbles are packed at
    /// [`VOLUME_PACKING`] of it).
    spacing: &'a dyn Spacing,
    opts: &'a crate::options::Options,
    node_d: &'a [f64],
    /// The slabs between twin faces: free bubbles there are dropped.
    walls: &'a [crate::face::twin::Wall],
}

impl<'a> VolumeJob<'a> {
    /// Volume `vi` of `model`, packed with `spacing`; `node_d` the spacing
    /// at each node of the mesh so far, `walls` the slabs between twin
    /// faces.
    pub(super) fn new(
        model: &'a crate::model::Model,
        vi: usize,
        spacing: &'a dyn Spacing,
        opts: &'a crate::options::Options,
        node_d: &'a [f64],
        walls: &'a [crate::face::twin::Wall],
    ) -> Self {
        VolumeJob {
            model,
            vi,
            entity: EntityRef::new(3, vi as u32),
            spacing,
            opts,
            node_d,
            walls,
        }
    }
}

/// The volume's boundary in the volume's own numbering: node `k` below
/// `fixed_ids.len()` is the global node `fixed_ids[k]`.
struct Boundary {
    /// The outward triangles, global node ids (for error messages).
    global: Vec<[u32; 3]>,
    /// The same triangles, local node ids.
    local: Vec<[u32; 3]>,
    fixed_ids: Vec<u32>,
    /// The local id of each of `fixed_ids` (global → local).
    local_id: std::collections::HashMap<u32, u32>,
    fixed_pos: Vec<P3>,
    fixed_d: Vec<f64>,
    shell: Shell,
    /// The bounding box of the boundary nodes.
    lo: P3,
    hi: P3,
}

impl Boundary {
    /// The boundary of `job`'s volume, whose faces are meshed in `mesh`.
    fn of(job: &VolumeJob<'_>, mesh: &crate::mesh::Mesh) -> Result<Boundary, MeshError> {
        let global = boundary_of(job.model, job.vi, mesh)?;
        if global.is_empty() {
            return Err(MeshError::Invalid(
                "the volume's faces have no triangles".into(),
            ));
        }
        // fixed bubbles: the boundary nodes
        let mut local_id: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
        let mut fixed_ids: Vec<u32> = Vec::new();
        for t in &global {
            for &v in t {
                local_id.entry(v).or_insert_with(|| {
                    fixed_ids.push(v);
                    (fixed_ids.len() - 1) as u32
                });
            }
        }
        let fixed_pos: Vec<P3> = fixed_ids
            .iter()
            .map(|&i| mesh.nodes[i as usize].pos)
            .collect();
        let fixed_d: Vec<f64> = fixed_ids.iter().map(|&i| job.node_d[i as usize]).collect();
        let local: Vec<[u32; 3]> = global.iter().map(|t| t.map(|v| local_id[&v])).collect();
        let shell = Shell::new(fixed_pos.clone(), &local);
        let (mut lo, mut hi) = (fixed_pos[0], fixed_pos[0]);
        for p in &fixed_pos {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        Ok(Boundary {
            global,
            local,
            fixed_ids,
            local_id,
            fixed_pos,
            fixed_d,
            shell,
            lo,
            hi,
        })
    }

    fn n_fixed(&self) -> usize {
        self.fixed_ids.len()
    }

    /// Stage 1's `lattice` seeds inside `carrier`'s volume, clear of the
    /// boundary's bubbles ([`lattice_seeds`] over the boundary's box).
    fn seeds(
        &self,
        carrier: &InVolume<'_>,
        spacing: &dyn Spacing,
        lattice: Lattice,
    ) -> Result<Vec<(P3, f64)>, MeshError> {
        lattice_seeds(
            carrier,
            spacing,
            self.lo,
            self.hi,
            &self.fixed_pos,
            &self.fixed_d,
            lattice,
        )
    }
}

/// How one attempt at a volume ended.
enum Attempt {
    /// The volume is meshed (and written into the mesh).
    Done(Box<VolumeReport>),
    /// A BCC start was given up: this fraction of its tetrahedra made it
    /// so. Nothing was written into the mesh.
    GiveUp(f64),
    /// A [`Lattice::BccLayer`] start was not made: more than
    /// [`BCC_LAYER_MAX_SHARE`] of its bubbles are in the layer.
    Thin,
}

/// Makes the boundary of volume `vi` Delaunay where it can, before
/// [`mesh_volume`]: co-spherical quadrilaterals of the face meshes turned
/// the way the tetrahedralization will have them ([`recover`]), then the
/// triangles still missing split on the geometry ([`split`]; the new nodes
/// are appended to `mesh.nodes`). Faces of volumes meshed before `vi` are
/// neither turned nor split: their triangles are faces of that volume's
/// tetrahedra already. Returns the pairs turned and the splits.
pub(super) fn recover_boundary(
    model: &crate::model::Model,
    vi: usize,
    mesh: &mut crate::mesh::Mesh,
) -> (usize, split::Splits) {
    let faces: std::collections::HashSet<u32> = model.volumes[vi].faces.iter().copied().collect();
    let idx = recover::triangles_of(mesh, &faces);
    let mut delaunay = recover::BoundaryDelaunay::of(mesh, &idx);
    let own = recover::own_faces(model, vi);
    let turnable: Vec<usize> = idx
        .iter()
        .copied()
        .filter(|&k| own.contains(&mesh.triangles[k].entity.id))
        .collect();
    let flips = match delaunay.as_mut() {
        Some(bd) => recover::flip_with(mesh, &turnable, bd.faces()),
        None => 0,
    };
    (
        flips,
        split::split_to_delaunay(model, mesh, vi, delaunay.as_mut()),
    )
}

/// Meshes volume `vi` whose faces are meshed in `mesh`: a BCC start where
/// the spacing is uniform (see the module docs), and the thesis's FCC
/// start when there is none or the BCC one is given up.
pub(super) fn mesh_volume(
    job: &VolumeJob<'_>,
    mesh: &mut crate::mesh::Mesh,
    timings: &mut crate::options::Timings,
) -> Result<VolumeReport, MeshError> {
    let (vi, spacing, opts) = (job.vi, job.spacing, job.opts);
    // a warm start (§4.8) replaces stage 1 by the old bubbles, which came
    // from the FCC path (relaxed, ODT-smoothed): it takes that path
    let warm = (!opts.fast)
        .then(|| {
            opts.warm
                .as_deref()
                .and_then(|w| w.of(EntityRef::new(3, vi as u32)))
        })
        .flatten();
    let mut lattice = match (
        opts.volume_lattice,
        spacing.constant_on(EntityRef::new(3, vi as u32)),
    ) {
        _ if warm.is_some() => Lattice::Fcc,
        (VolumeLattice::Auto, Some(_)) => Lattice::Bcc,
        _ => Lattice::Fcc,
    };
    let mut rejected = None;
    loop {
        let boundary = Boundary::of(job, mesh)?;
        let t_try = std::time::Instant::now();
        let staged = timings.stage1_s + timings.stage2_s;
        match attempt(job, &boundary, lattice, warm, mesh, timings)? {
            Attempt::Done(mut rep) => {
                if rejected.is_some() {
                    rep.bcc_rejected = rejected;
                }
                return Ok(*rep);
            }
            Attempt::GiveUp(frac) => {
                // nothing of the BCC attempt is in the mesh yet: nodes and
                // tetrahedra are only written by a finished attempt; its
                // time beyond its stage 1 was its connection
                let staged = timings.stage1_s + timings.stage2_s - staged;
                timings.connect_s += (t_try.elapsed().as_secs_f64() - staged).max(0.0);
                rejected = Some(frac);
                lattice = Lattice::BccLayer;
            }
            Attempt::Thin => lattice = Lattice::Fcc,
        }
    }
}

/// One attempt at the volume from `lattice` (or from the old bubbles of a
/// warm start), in the order of its phases: stage 1 (seeds), stage 2
/// (relaxation) and ODT smoothing (FCC only), the connection, sliver
/// removal with Steiner points, the polish, the check for flat
/// tetrahedra, and writing the result into `mesh`.
///
/// Local node numbering: the boundary's nodes, then a warm start's kept
/// bubbles (`n_keep` in all: none of them moves), then the free bubbles.
fn attempt(
    job: &VolumeJob<'_>,
    boundary: &Boundary,
    lattice: Lattice,
    warm: Option<&crate::remesh::warm::EntityStart>,
    mesh: &mut crate::mesh::Mesh,
    timings: &mut crate::options::Timings,
) -> Result<Attempt, MeshError> {
    use std::time::Instant;
    let t0 = Instant::now();
    let scaled = Scaled {
        inner: job.spacing,
        factor: VOLUME_PACKING,
    };
    let carrier = InVolume {
        entity: job.entity,
        geometry: job.model.volumes[job.vi].geometry.as_deref(),
        shell: &boundary.shell,
    };
    let mut rep = VolumeReport {
        volume: job.vi as u32,
        name: job.model.volumes[job.vi].name.clone(),
        lattice: Some(lattice),
        boundary_bubbles: boundary.n_fixed(),
        boundary_triangles: boundary.global.len(),
        ..Default::default()
    };
    let (mut sys, far) = match warm {
        Some(start) => {
            let (sys, far) = warm_bubbles(boundary, &scaled, carrier, start, &mut rep)?;
            (sys, Some(far))
        }
        None if lattice == Lattice::BccLayer => {
            match layered_bubbles(boundary, &scaled, carrier, &mut rep)? {
                Some((sys, far)) => (sys, Some(far)),
                None => {
                    timings.stage1_s += t0.elapsed().as_secs_f64();
                    return Ok(Attempt::Thin);
                }
            }
        }
        None => (
            seed_bubbles(boundary, &scaled, carrier, lattice, &mut rep)?,
            None,
        ),
    };
    timings.stage1_s += t0.elapsed().as_secs_f64();
    job.opts
        .stage1_done(job.entity, sys.n_fixed, &sys.pos, &sys.d);
    // a BCC lattice needs neither stage 2 nor ODT (module docs)
    let relax = !job.opts.fast && lattice != Lattice::Bcc;
    if relax {
        let t2 = Instant::now();
        rep.relax = Some(relax_bubbles(job, &mut sys, warm.is_some())?);
        timings.stage2_s += t2.elapsed().as_secs_f64();
    }
    if let Some(far) = far {
        crate::face::warm::restore(&mut sys, far);
    }

    let t3 = Instant::now();
    let layered = lattice == Lattice::BccLayer;
    let n_keep = sys.n_fixed;
    let mut tm = TetMesh {
        movable: (0..sys.pos.len()).map(|i| i >= n_keep).collect(),
        pos: std::mem::take(&mut sys.pos),
        d: std::mem::take(&mut sys.d),
        tets: Vec::new(),
    };
    if relax {
        let inside = |p: &P3| sys.carrier.contains_point(p);
        // a warm start smooths the free nodes among the kept ones near
        // them only
        let params = tet::odt::OdtParams {
            local: warm.is_some() || layered,
            iterations: match warm {
                Some(_) => warm::ODT_ITERATIONS,
                None => tet::odt::OdtParams::default().iterations,
            },
            ..Default::default()
        };
        let odt = tet::odt::odt_smooth(&mut tm, &params, inside);
        rep.odt_iterations = odt.iterations;
        rep.odt_rebuilt = odt.rebuilt;
    }
    rep.odt_s = t3.elapsed().as_secs_f64();
    rep.in_walls = drop_in_walls(job.walls, n_keep, &mut tm);
    // a re-meshing keeps the old tetrahedra among its kept nodes
    if let Some(old) = warm.map(|w| w.tets.as_slice()).filter(|t| !t.is_empty()) {
        let inside = |p: &P3| sys.carrier.contains_point(p);
        let sizes = (boundary.n_fixed(), n_keep);
        if let Some(merged) = connect_keeping(&tm, sizes, &boundary.local, old, inside, &mut rep) {
            write_volume(job.entity, boundary, &merged, &mut rep, mesh);
            timings.connect_s += t3.elapsed().as_secs_f64();
            return Ok(Attempt::Done(Box::new(rep)));
        }
    }
    // the lattice's bubbles held in stage 2 and ODT move in the sliver
    // pass and the polish
    let n_keep = if layered { boundary.n_fixed() } else { n_keep };
    let first_qs = match connect_first(job, boundary, lattice, n_keep, &mut tm, &mut rep, mesh)? {
        First::GiveUp(frac) => return Ok(Attempt::GiveUp(frac)),
        First::Connected(qs) => qs,
    };
    // twin walls as prisms before the sliver pass spends Steiner points on
    // the slivers between them (see [`wall`]), and again after it, whose
    // re-connections make them anew
    let mut prisms = wall::Prisms::new(job.walls, &boundary.local_id, &tm.pos);
    let first_qs = match prisms.split(&mut tm) {
        0 => first_qs,
        _ => Some(tm.objectives()),
    };
    let t = Instant::now();
    if !job.opts.fast {
        let inside = |p: &P3| sys.carrier.contains_point(p);
        // a continuous re-meshing may move kept bubbles where slivers
        // need it; a local one keeps them where they were
        let release = warm.is_some() && !job.opts.warm.as_deref().is_some_and(|w| w.local);
        remove_slivers(
            (&boundary.local, boundary.n_fixed()),
            &mut prisms,
            n_keep,
            release,
            &mut tm,
            first_qs,
            inside,
            &mut rep,
            &|e| connect_error(e, &boundary.global, job.model, mesh),
        )?;
    }
    rep.sliver_s = t.elapsed().as_secs_f64();
    if !job.opts.fast {
        if let Some(frac) = polish(lattice, &mut tm, &mut rep) {
            return Ok(Attempt::GiveUp(frac));
        }
    }
    rep.wall_prisms = prisms.split(&mut tm);
    if !job.opts.fast {
        let inside = |p: &P3| sys.carrier.contains_point(p);
        rep.steiner_in_place = steiner_in_place(&mut tm, inside);
    }
    rep.flat_quads = remove_flat_quads(job, boundary, &mut tm, mesh);
    refuse_flat(&tm, rep.steiner)?;
    write_volume(job.entity, boundary, &tm, &mut rep, mesh);
    timings.connect_s += t3.elapsed().as_secs_f64();
    Ok(Attempt::Done(Box::new(rep)))
}

/// [`recover::turn_flat_quads`] on `tm`, the finished tetrahedra of
/// `job`'s volume: the flat tetrahedra on boundary quadrilaterals are
/// removed from `tm` and their pairs turned in `mesh`. Faces of volumes
/// meshed before this one are left as they are. Returns how many.
fn remove_flat_quads(
    job: &VolumeJob<'_>,
    boundary: &Boundary,
    tm: &mut TetMesh,
    mesh: &mut crate::mesh::Mesh,
) -> usize {
    let n_fixed = boundary.n_fixed();
    let flat: Vec<usize> = (0..tm.tets.len())
        .filter(|&i| {
            let t = &tm.tets[i];
            t.iter().all(|&k| (k as usize) < n_fixed)
                && crate::measure::tet_radius_ratio_of(&tm.pos, t) < tet::steiner::FLAT_Q
        })
        .collect();
    if flat.is_empty() {
        return 0;
    }
    let mut uses: std::collections::HashMap<u32, usize> = Default::default();
    for &f in &job.model.volumes[job.vi].faces {
        *uses.entry(f).or_default() += 1;
    }
    // a face listed twice bounds the volume on both sides
    let mut faces = recover::own_faces(job.model, job.vi);
    faces.retain(|f| uses[f] == 1);
    let gone = recover::turn_flat_quads(mesh, &faces, &boundary.fixed_ids, &tm.tets, &flat);
    let mut keep = vec![true; tm.tets.len()];
    for &i in &gone {
        keep[i] = false;
    }
    let mut keep = keep.into_iter();
    tm.tets.retain(|_| keep.next().unwrap_or(true));
    gone.len()
}

/// The volume's tetrahedra with the old ones `old` kept where they can be
/// ([`keep`]'s module docs): `tm` holds the volume's nodes after stage 2 and the ODT
/// smoothing (the first `n_fixed` on its boundary, the first `n_keep`
/// fixed), `boundary` its outward triangles, `inside` its inside test.
/// The result's first `n_keep` nodes are `tm`'s, then the free ones (new
/// positions) and Steiner points; `None` when no old tetrahedron can stay
/// or the kept ones and the cavity's do not make the volume, and then
/// `rep` is untouched.
fn connect_keeping(
    tm: &TetMesh,
    (n_fixed, n_keep): (usize, usize),
    boundary: &[[u32; 3]],
    old: &[[P3; 4]],
    inside: impl Fn(&P3) -> bool,
    rep: &mut VolumeReport,
) -> Option<TetMesh> {
    let mut kept = keep::kept_tets(&tm.pos, n_fixed, n_keep, boundary, old);
    for _ in 0..=keep::RECOVERY_ROUNDS {
        if kept.is_empty() {
            return None;
        }
        let Some(cav) = keep::Cavity::of(tm.pos.len(), n_keep, boundary, &kept) else {
            // nothing changed in this volume
            let out = TetMesh {
                pos: tm.pos[..n_keep].to_vec(),
                d: tm.d[..n_keep].to_vec(),
                movable: vec![false; n_keep],
                tets: kept,
            };
            if !keep::is_complex(&out.pos, &out.tets, boundary) {
                return None;
            }
            rep.kept_tets = Some(out.tets.len());
            return Some(out);
        };
        let pos: Vec<P3> = cav.nodes.iter().map(|&k| tm.pos[k as usize]).collect();
        let t = std::time::Instant::now();
        let conn = match connect::connect_volume(&pos, cav.n_fixed, &cav.boundary) {
            Ok(conn) => conn,
            Err(connect::Connect3dError::NotConforming { triangles, .. }) => {
                if !keep::hand_over(&tm.pos, &cav, &triangles, &mut kept) {
                    return None;
                }
                continue;
            }
            Err(_) => return None,
        };
        let mut r = rep.clone();
        r.delaunay_s = t.elapsed().as_secs_f64();
        r.recovery_removed = conn.removed;
        let mut c = TetMesh {
            movable: (0..pos.len())
                .map(|i| i >= cav.n_keep && conn.kept[i])
                .collect(),
            d: cav.nodes.iter().map(|&k| tm.d[k as usize]).collect(),
            pos,
            tets: conn.tets,
        };
        let t = std::time::Instant::now();
        {
            // Steiner points only where nothing is kept (the grid is built
            // when the first is asked for: most cavities need none)
            let grid = std::cell::OnceCell::new();
            let in_cavity = |p: &P3| {
                inside(p)
                    && grid
                        .get_or_init(|| keep::TetGrid::new(&tm.pos, &kept))
                        .containing(p)
                        .next()
                        .is_none()
            };
            // a Steiner round's re-connection that misses boundary
            // triangles hands their kept tetrahedra over as above
            // (a re-meshing's cavity keeps no twin walls of its own)
            let done = remove_slivers(
                (&cav.boundary, cav.n_fixed),
                &mut wall::Prisms::default(),
                cav.n_keep,
                false,
                &mut c,
                None,
                in_cavity,
                &mut r,
                &|e: connect::Connect3dError| MeshError::Volume(e),
            );
            match done {
                Ok(()) => {}
                Err(MeshError::Volume(connect::Connect3dError::NotConforming {
                    triangles,
                    ..
                })) => {
                    drop(grid);
                    if !keep::hand_over(&tm.pos, &cav, &triangles, &mut kept) {
                        return None;
                    }
                    continue;
                }
                Err(_) => return None,
            }
        }
        r.sliver_s = t.elapsed().as_secs_f64();
        if polish(Lattice::Fcc, &mut c, &mut r).is_some() {
            return None;
        }
        if let Some(s) = keep::raise_worst(&mut c) {
            r.slivers.moves += s.moves;
            r.slivers.flips += s.flips;
        }
        refuse_flat(&c, r.steiner).ok()?;
        r.kept_tets = Some(kept.len());
        let out = keep::merged(tm, n_keep, kept, &c, &cav);
        if !keep::is_complex(&out.pos, &out.tets, boundary) {
            return None;
        }
        *rep = r;
        return Some(out);
    }
    None
}

/// Stage 1: the boundary nodes as fixed bubbles and the `lattice` seeds
/// inside as free ones (their count goes into `rep`).
fn seed_bubbles<'a>(
    boundary: &Boundary,
    spacing: &'a Scaled<'a>,
    carrier: InVolume<'a>,
    lattice: Lattice,
    rep: &mut VolumeReport,
) -> Result<crate::bubbles::system::System<'a, InVolume<'a>>, MeshError> {
    let seeds = boundary.seeds(&carrier, spacing, lattice)?;
    rep.stage1_bubbles = seeds.len();
    let mut sys = crate::bubbles::system::System::with_fixed(
        carrier,
        spacing,
        3,
        boundary.fixed_pos.clone(),
        vec![[0.0; 2]; boundary.n_fixed()],
        boundary.fixed_d.clone(),
        boundary.fixed_ids.clone(),
    );
    for (p, d) in seeds {
        sys.push_free(p, [0.0; 2], d);
    }
    Ok(sys)
}

/// A stage-1 system with fixed bubbles beyond the boundary's (a warm
/// start's kept ones, a [`Lattice::BccLayer`] start's held ones), and those
/// of them set aside during stage 2.
type Held<'a> = (
    crate::bubbles::system::System<'a, InVolume<'a>>,
    crate::face::warm::Far,
);

/// Stage 1 of a warm start (§4.8, [`warm`]): the old bubbles, the FCC
/// seeds where they left room.
fn warm_bubbles<'a>(
    boundary: &'a Boundary,
    spacing: &'a Scaled<'a>,
    carrier: InVolume<'a>,
    start: &crate::remesh::warm::EntityStart,
    rep: &mut VolumeReport,
) -> Result<Held<'a>, MeshError> {
    let fixed = warm::Fixed {
        pos: &boundary.fixed_pos,
        d: &boundary.fixed_d,
        ids: &boundary.fixed_ids,
    };
    let inside = |p: &P3| carrier.contains_point(p);
    let fill = |pos: &[P3], d: &[f64]| {
        lattice_seeds(
            &carrier,
            spacing,
            boundary.lo,
            boundary.hi,
            pos,
            d,
            Lattice::Fcc,
        )
    };
    let (sys, counts, far) = warm::stage1(fixed, spacing, carrier, inside, fill, start)?;
    rep.stage1_bubbles = counts[1] + counts[2];
    rep.warm = Some(counts);
    Ok((sys, far))
}

/// Stage 1 of a [`Lattice::BccLayer`] start (`None` where more than
/// [`BCC_LAYER_MAX_SHARE`] of the seeds are in the layer): the BCC seeds, those within
/// [`BCC_LAYER`] of their (packed) spacings of a boundary bubble free, the
/// others fixed as kept bubbles ([`KEPT_ID`](crate::bubbles::system::KEPT_ID):
/// population control leaves room next to them alone), those far from
/// every free one set aside during stage 2 as a warm start's are
/// ([`crate::face::warm::assemble`]; put back with
/// [`crate::face::warm::restore`]).
fn layered_bubbles<'a>(
    boundary: &Boundary,
    spacing: &'a Scaled<'a>,
    carrier: InVolume<'a>,
    rep: &mut VolumeReport,
) -> Result<Option<Held<'a>>, MeshError> {
    let seeds = boundary.seeds(&carrier, spacing, Lattice::Bcc)?;
    rep.stage1_bubbles = seeds.len();
    let dmax = boundary
        .fixed_d
        .iter()
        .chain(seeds.iter().map(|s| &s.1))
        .cloned()
        .fold(f64::MIN_POSITIVE, f64::max);
    let w = BCC_LAYER;
    let grid = crate::bubbles::grid::Grid::new(&boundary.fixed_pos, w * dmax);
    let mut fixed_pos = boundary.fixed_pos.clone();
    let mut fixed_d = boundary.fixed_d.clone();
    let mut fixed_ids = boundary.fixed_ids.clone();
    let mut free = Vec::new();
    for (p, d) in seeds {
        let mut near = false;
        grid.query(&p, w * dmax, |j| {
            near |= (boundary.fixed_pos[j as usize] - p).norm() <= w * d;
        });
        if near {
            free.push(crate::face::placement::Seed {
                pos: p,
                params: [0.0; 2],
                d,
            });
        } else {
            fixed_pos.push(p);
            fixed_d.push(d);
            fixed_ids.push(crate::bubbles::system::KEPT_ID);
        }
    }
    let held = fixed_pos.len() - boundary.n_fixed();
    if free.len() as f64 > BCC_LAYER_MAX_SHARE * (free.len() + held) as f64 {
        return Ok(None);
    }
    let fixed = crate::face::warm::Fixed {
        uv: vec![[0.0; 2]; fixed_pos.len()],
        pos: fixed_pos,
        d: fixed_d,
        ids: fixed_ids,
    };
    Ok(Some(crate::face::warm::assemble(
        carrier,
        spacing,
        3,
        fixed,
        boundary.n_fixed(),
        free,
    )))
}

/// Stage 2: the bubbles' dynamics, at most [`VOLUME_MAX_STEPS`] steps.
fn relax_bubbles(
    job: &VolumeJob<'_>,
    sys: &mut crate::bubbles::system::System<'_, InVolume<'_>>,
    warm: bool,
) -> Result<crate::bubbles::system::RelaxStats, MeshError> {
    // stage 1 is already a balanced FCC packing away from the boundary,
    // and the ODT smoothing after stage 2 finishes the job: more steps
    // cost time in proportion to the bubbles and did not improve the
    // tetrahedra (measured on cases H, I with bench/run_3d.py); a warm
    // start only settles the footprint of a change (§4.8.2)
    let mut settings = crate::bubbles::system::RelaxSettings {
        max_steps: job.opts.relax.max_steps.min(VOLUME_MAX_STEPS),
        ..job.opts.relax
    };
    if warm {
        settings.max_steps = settings.max_steps.min(warm::STAGE2_STEPS);
        settings.tol = settings.tol.max(crate::remesh::warm::WARM_TOL);
    }
    sys.relax(
        &settings,
        job.opts
            .relax_observer(job.entity, settings.max_steps, sys.n_fixed),
    )
}

/// How the first connection ended.
enum First {
    /// Connected; after a BCC start, every tetrahedron's objective (handed
    /// on to the sliver pass).
    Connected(Option<Vec<f64>>),
    /// The BCC start looks poor: give it up (this fraction of its
    /// tetrahedra below the sliver target).
    GiveUp(f64),
}

/// The conforming Delaunay connection of `tm`'s nodes; after a BCC start,
/// the test whether to give it up ([`BCC_MAX_BAD`], locked slivers,
/// recovery removals). Sets `tm`'s tetrahedra and which nodes may move
/// (none of the first `n_keep`).
fn connect_first(
    job: &VolumeJob<'_>,
    boundary: &Boundary,
    lattice: Lattice,
    n_keep: usize,
    tm: &mut TetMesh,
    rep: &mut VolumeReport,
    mesh: &crate::mesh::Mesh,
) -> Result<First, MeshError> {
    let n_fixed = boundary.n_fixed();
    let t = std::time::Instant::now();
    let conn = connect::connect_volume(&tm.pos, n_fixed, &boundary.local)
        .map_err(|e| connect_error(e, &boundary.global, job.model, mesh))?;
    rep.delaunay_s = t.elapsed().as_secs_f64();
    let mut first_qs = None;
    if lattice != Lattice::Fcc && !job.opts.fast {
        let qs: Vec<f64> = conn
            .tets
            .iter()
            .map(|t| tet::star::objective_of(&tm.pos, t))
            .collect();
        let poor = |k: usize| qs[k] < TARGET_Q;
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
        if lattice == Lattice::Bcc && (frac > BCC_MAX_BAD || locked || conn.removed > 0) {
            return Ok(First::GiveUp(frac));
        }
        first_qs = Some(qs);
    }
    rep.recovery_removed = conn.removed;
    tm.movable = (0..tm.pos.len())
        .map(|i| i >= n_keep && conn.kept[i])
        .collect();
    tm.tets = conn.tets;
    Ok(First::Connected(first_qs))
}

/// Sliver removal, then up to [`tet::steiner::STEINER_ROUNDS`] rounds of
/// Steiner points for the slivers among fixed nodes (fewer where they stop
/// converging: [`tet::steiner::STEINER_FEW`]), each followed by a
/// re-connection and another sliver pass (the first round's points, where
/// they are many, smoothed before: [`STEINER_ODT_ITERATIONS`]). `first_qs`: the objectives of
/// the tetrahedra, if the caller has them. The first `n_keep` nodes keep
/// their indices and never move, except, with `release`, the kept bubbles
/// of a warm start at the corners of a sliver among fixed nodes.
///
/// The tetrahedra's boundary is `sides`: the boundary triangles (local
/// node ids, outward), whose corners are the first `n_fixed` nodes; a
/// failed re-connection is reported through `failed`.
#[allow(clippy::too_many_arguments)]
fn remove_slivers(
    sides: (&[[u32; 3]], usize),
    prisms: &mut wall::Prisms<'_>,
    n_keep: usize,
    release: bool,
    tm: &mut TetMesh,
    first_qs: Option<Vec<f64>>,
    inside: impl Fn(&P3) -> bool,
    rep: &mut VolumeReport,
    failed: &dyn Fn(connect::Connect3dError) -> MeshError,
) -> Result<(), MeshError> {
    use tet::sliver::{remove_slivers, remove_slivers_given, SliverParams};
    use tet::steiner::{steiner_points, with_points, SteinerRounds, FLAT_Q, STEINER_ROUNDS};
    let params = SliverParams::default();
    let (local, n_fixed) = sides;
    // the Delaunay tetrahedralization's flat tetrahedra among boundary
    // nodes: flips remove most, but which ones they leave depends on the
    // order they meet them, so every one gets its Steiner points now
    // (see steiner::steiner_points)
    if release {
        // the old mesh had its kept bubbles where they are for its own
        // connectivity, which the new Delaunay one need not be: where that
        // leaves a sliver among fixed nodes, its kept corners move (a
        // Steiner point costs a re-connection, and stays a node)
        let mut freed = Vec::new();
        for t in &tm.tets {
            if locked(t, &tm.movable) && tet::star::objective_of(&tm.pos, t) < TARGET_Q {
                freed.extend(
                    t.iter()
                        .map(|&k| k as usize)
                        .filter(|&k| k >= n_fixed && k < n_keep),
                );
            }
        }
        freed.sort_unstable();
        freed.dedup();
        for &k in &freed {
            tm.movable[k] = true;
        }
        rep.warm_released = Some(freed.len());
    }
    let mut work: Vec<[u32; 4]> = tm
        .tets
        .iter()
        .filter(|t| {
            locked(t, &tm.movable)
                && crate::measure::tet_radius_ratio_of(&tm.pos, t) < FLAT_Q
                && !prisms.within(t)
        })
        .cloned()
        .collect();
    rep.slivers = match first_qs {
        Some(qs) => remove_slivers_given(tm, &params, qs),
        None => remove_slivers(tm, &params),
    };
    // when to stop (see STEINER_FEW)
    let mut rounds = SteinerRounds::default();
    for round in 0..STEINER_ROUNDS {
        // and those that the sliver pass left
        work.extend(tm.tets.iter().filter(|t| {
            locked(t, &tm.movable)
                && tet::star::objective_of(&tm.pos, t) < TARGET_Q
                && !prisms.within(t)
        }));
        let extra = steiner_points(&tm.pos, &work, &tm.d, |p: &P3| {
            inside(p) && !prisms.holds(p)
        });
        let go_on = rounds.worth_a_round(round, &tm.pos, &work, extra.len());
        work.clear();
        if !go_on {
            break;
        }
        rep.steiner += extra.len();
        let extra_n = extra.len();
        // the kept nodes, then the new ones; fixed nodes keep their
        // indices (the boundary triangles refer to them)
        let (mut pos2, mut d2) = with_points(tm, n_keep, extra);
        let first_new = pos2.len() - extra_n;
        if round == 0 && 4 * extra_n >= pos2.len() - n_keep {
            // the new points alone move, the Delaunay tetrahedralizations
            // taken around them (the smoothing connects the nodes afresh
            // each iteration, so it needs no tetrahedra of its own)
            let mut pre = TetMesh {
                movable: (0..pos2.len()).map(|i| i >= first_new).collect(),
                pos: pos2,
                d: d2,
                tets: Vec::new(),
            };
            let odt = tet::odt::OdtParams {
                iterations: STEINER_ODT_ITERATIONS,
                local: true,
                ..Default::default()
            };
            tet::odt::odt_smooth(&mut pre, &odt, &inside);
            (pos2, d2) = (pre.pos, pre.d);
        }
        let conn = connect::connect_volume(&pos2, n_fixed, local).map_err(failed)?;
        rep.recovery_removed += conn.removed;
        *tm = TetMesh {
            movable: (0..pos2.len())
                .map(|i| i >= n_keep && conn.kept[i])
                .collect(),
            tets: conn.tets,
            pos: pos2,
            d: d2,
        };
        prisms.split(tm);
        let s = remove_slivers(tm, &params);
        rep.slivers.moves += s.moves;
        rep.slivers.flips += s.flips;
        rep.slivers.bad_after = s.bad_after;
        rep.slivers.min_q_after = s.min_q_after;
    }
    Ok(())
}

/// The mean-quality polish, then the sliver pass again around what is left
/// below the target. Returns the fraction that makes a BCC start be given
/// up ([`BCC_FLOOR_RR`]), if it is.
fn polish(lattice: Lattice, tm: &mut TetMesh, rep: &mut VolumeReport) -> Option<f64> {
    let t = std::time::Instant::now();
    let params = tet::polish::PolishParams {
        // no flip round after BCC (see PolishParams::flip_rounds)
        flip_rounds: match lattice {
            Lattice::Bcc => 0,
            Lattice::Fcc | Lattice::BccLayer => tet::polish::PolishParams::default().flip_rounds,
        },
        ..Default::default()
    };
    let stats = tet::polish::polish(tm, &params);
    rep.polish_moves = stats.moves;
    rep.polish_flips = stats.flips;
    rep.polish_s = t.elapsed().as_secs_f64();
    // the polish's flips give the sliver pass new room; where it left
    // nothing below TARGET_Q, the polish made nothing so (its moves and
    // flips keep every star's worst above min(before, TARGET_Q)): that
    // saves a scan of the mesh
    if rep.slivers.bad_after == 0 {
        return None;
    }
    let (s, still_bad) =
        tet::sliver::remove_slivers_near_bad(tm, &tet::sliver::SliverParams::default())?;
    rep.slivers.moves += s.moves;
    rep.slivers.flips += s.flips;
    rep.slivers.bad_after = s.bad_after;
    rep.slivers.min_q_after = s.min_q_after;
    // below the floor means below TARGET_Q: only those can be
    let left = if lattice == Lattice::Bcc {
        still_bad
            .iter()
            .filter(|t| below_bcc_floor(&tm.pos, t))
            .count()
    } else {
        0
    };
    // worse than the thesis's path usually leaves: take that one (measured
    // on fixtures/step/loft.step: 4 tetrahedra of the BCC start stayed at
    // 0.51, dihedral angle 24.8°)
    (left > 0).then(|| left as f64 / tm.tets.len().max(1) as f64)
}

/// Drops the free bubbles (index `n_keep` on, before the connection)
/// that lie between two twin faces ([`crate::face::twin::Wall`]): the wall
/// is thinner than the spacing and its tetrahedra are the prisms between
/// the faces' nodes; a bubble inside makes slivers of them (the plate of
/// `cli/tests/sweep_finds/thin_plate.step`, 1 thick at d = 8, kept four
/// FCC seeds at mid-plane: smallest dihedral angle 3.2°, 5.85° without
/// them). Returns how many.
fn drop_in_walls(walls: &[crate::face::twin::Wall], n_keep: usize, tm: &mut TetMesh) -> usize {
    if walls.is_empty() || tm.pos.len() <= n_keep {
        return 0;
    }
    let stays: Vec<bool> = (0..tm.pos.len())
        .map(|i| i < n_keep || !walls.iter().any(|w| w.holds(&tm.pos[i])))
        .collect();
    let dropped = stays.iter().filter(|&&s| !s).count();
    if dropped > 0 {
        fn retain<T>(v: &mut Vec<T>, stays: &[bool]) {
            let mut it = stays.iter();
            v.retain(|_| it.next().copied().unwrap_or(true));
        }
        retain(&mut tm.pos, &stays);
        retain(&mut tm.d, &stays);
        retain(&mut tm.movable, &stays);
    }
    dropped
}

/// Tetrahedra among fixed nodes whose objective is below this get a
/// Steiner point in [`steiner_in_place`] (0.3: a smallest dihedral angle
/// of about 14.6°). Measured on random seeds 1–7 against 0.15: 15 more
/// meshes changed, none with a smaller angle, means down by at most
/// 0.0009, rp_3_008 14.04° → 15.41° (Gmsh 14.35°).
const IN_PLACE_Q: f64 = 0.3;

/// How far [`steiner_in_place`] may lower the volume's mean radius ratio.
const MEAN_SLACK: f64 = 0.001;

/// At most this many points of [`steiner_in_place`].
const IN_PLACE_POINTS: usize = 8;

/// Whether tetrahedron `t` has all four corners fixed (`movable` false):
/// no pass that moves nodes can change it.
fn locked(t: &[u32; 4], movable: &[bool]) -> bool {
    t.iter().all(|&k| !movable[k as usize])
}

/// Steiner points inserted in place ([`tet::insert`]), one at a time, each
/// for the mesh's worst tetrahedron by objective or the one with its
/// smallest dihedral angle, where its corners are all fixed nodes (no
/// other pass can move it) and its objective is below [`IN_PLACE_Q`],
/// followed by the sliver pass around what is below the target. A point
/// is kept where the tetrahedra it and the sliver pass made are all better
/// than the one it was for, the mesh's worst objective and smallest
/// dihedral angle do not fall and one of them rises, and the volume's mean
/// radius ratio stays within [`MEAN_SLACK`] of what it was before the
/// first; otherwise the mesh is put back and the other of the two is
/// tried. Returns how many points were kept.
///
/// Why those two: only they can raise what a point is kept for. The
/// worst by objective alone missed slivers with the smallest angle
/// (rp_8_007: 1.04°, now 2.11°, where the worst objective was another
/// tetrahedron's, with a twin); every tetrahedron among fixed nodes, worst
/// first, found the same points but cost up to 0.75 s per try on a 44k
/// tetrahedron volume (as_0082 6.8 → 18.2 s for none kept).
///
/// Each point is the first of centroid ± s·d·n (n the normal of the
/// tetrahedron's mean plane, d the mean spacing of its corners, s = 0.29,
/// 0.12, 0.05) that `inside` accepts and that goes in: the re-connected
/// Steiner rounds of [`remove_slivers`] use 0.29·d, which a wall thinner
/// than about 0.6·d does not hold, and there the boundary recovery would
/// remove any point anyway (see [`tet::insert`]).
///
/// Why one at a time: a point for every such tetrahedron at once lowered
/// rp_7_038's mean by 0.0028 (10 points, most of them for tetrahedra no
/// worse than the rest of the rib) where the worst one alone was the
/// gain.
fn steiner_in_place(tm: &mut TetMesh, inside: impl Fn(&P3) -> bool) -> usize {
    use tet::steiner::mean_plane_normal;
    let mean = |tm: &TetMesh| tet::mesh::mean_radius_ratio(&tm.pos, &tm.tets);
    // flat tetrahedra are not counted: those on a boundary quadrilateral
    // are turned away after this pass ([`remove_flat_quads`]), any other
    // refuses the volume ([`refuse_flat`]) for a finer surface there
    let flat = |tm: &TetMesh, t: &[u32; 4]| {
        crate::measure::tet_radius_ratio_of(&tm.pos, t) < tet::steiner::FLAT_Q
    };
    // the mesh's worst tetrahedron by objective and the one with its
    // smallest dihedral angle (the first of equals), in one pass: the
    // objective's worst can rise while another tetrahedron's angle falls
    // (rp_1_002: 5.48° → 2.75° where a radius ratio was the worst)
    type Extreme = Option<(f64, usize)>;
    let extremes = |tm: &TetMesh| -> (Extreme, Extreme) {
        let lower = |m: Extreme, v: f64, i: usize| match m {
            Some((w, _)) if v.total_cmp(&w) != std::cmp::Ordering::Less => m,
            _ => Some((v, i)),
        };
        let (mut worst, mut least) = (None, None);
        for (i, t) in tm.tets.iter().enumerate() {
            if flat(tm, t) {
                continue;
            }
            let p = t.map(|k| tm.pos[k as usize]);
            worst = lower(worst, tet::star::objective(&p[0], &p[1], &p[2], &p[3]), i);
            let angle = crate::measure::dihedral_extremes(&p[0], &p[1], &p[2], &p[3]).0;
            least = lower(least, angle, i);
        }
        (worst, least)
    };
    // most volumes have no tetrahedron among fixed nodes below IN_PLACE_Q:
    // this look at those few saves the whole mesh's objectives
    if !tm.tets.iter().any(|t| {
        locked(t, &tm.movable) && !flat(tm, t) && tet::star::objective_of(&tm.pos, t) < IN_PLACE_Q
    }) {
        return 0;
    }
    let floor = mean(tm) - MEAN_SLACK;
    // (after a kept point, what was measured of it)
    let (mut worst_now, mut least_now) = extremes(tm);
    let value = |w: Option<(f64, usize)>| w.map_or(f64::INFINITY, |w| w.0);
    let mut tried = std::collections::HashSet::new();
    let mut kept = 0;
    while kept < IN_PLACE_POINTS {
        // only these two can raise what the pass keeps a point for; each
        // one tried once (by its sorted corners: indices move)
        let candidate = [worst_now, least_now]
            .into_iter()
            .flatten()
            .find_map(|(_, i)| {
                let t = tm.tets[i];
                let q = tet::star::objective_of(&tm.pos, &t);
                (locked(&t, &tm.movable)
                    && q < IN_PLACE_Q
                    && !tried.contains(&crate::measure::sorted4(t)))
                .then_some((q, i))
            });
        let Some((q, i)) = candidate else {
            break;
        };
        let t = tm.tets[i];
        tried.insert(crate::measure::sorted4(t));
        let p = t.map(|k| tm.pos[k as usize]);
        let Some((n, nn)) = mean_plane_normal(&p) else {
            continue;
        };
        let c = P3::from((p[0].coords + p[1].coords + p[2].coords + p[3].coords) / 4.0);
        let dc = t.iter().map(|&k| tm.d[k as usize]).sum::<f64>() / 4.0;
        let before = tm.clone();
        let mut ins = tet::insert::Inserter::new(tm);
        let added = [0.29, 0.12, 0.05]
            .into_iter()
            .flat_map(|s| [s, -s])
            .map(|s| c + n * (s * dc / nn))
            .any(|q| inside(&q) && ins.insert(i, q, dc).is_some());
        ins.finish();
        if !added {
            continue;
        }
        tet::sliver::remove_slivers_near_bad(tm, &tet::sliver::SliverParams::default());
        // the tetrahedra the point and the sliver pass made
        let old: std::collections::HashSet<[u32; 4]> = before
            .tets
            .iter()
            .map(|&t| crate::measure::sorted4(t))
            .collect();
        let made = tm
            .tets
            .iter()
            .filter(|&&t| !old.contains(&crate::measure::sorted4(t)) && !flat(tm, &t))
            .map(|t| tet::star::objective_of(&tm.pos, t))
            .fold(f64::INFINITY, f64::min);
        let (worst_after, least_after) = extremes(tm);
        let (w0, w1) = (value(worst_now), value(worst_after));
        let (a0, a1) = (value(least_now), value(least_after));
        // kept where the point's tetrahedra are better than the one it
        // replaced, the mesh's worst objective and smallest angle do not
        // fall and one of them rises (a point that leaves both where they
        // were only spends the mean), and the mean stays above the floor
        if made > q && w1 >= w0 && a1 >= a0 && (w1 > w0 || a1 > a0) && mean(tm) >= floor {
            kept += 1;
            (worst_now, least_now) = (worst_after, least_after);
        } else {
            *tm = before;
        }
    }
    kept
}

/// Never hand out a flat tetrahedron (a solver divides by its volume):
/// refuse the volume instead, naming where.
fn refuse_flat(tm: &TetMesh, steiner: usize) -> Result<(), MeshError> {
    let flat = tet::steiner::FLAT_Q;
    // each flat tetrahedron as a ball (centroid, farthest corner): a
    // finer surface mesh there (a place, see engine::refine) gives its
    // corners room
    let spots: Vec<(P3, f64)> = tm
        .tets
        .iter()
        .filter(|t| crate::measure::tet_radius_ratio_of(&tm.pos, t) < flat)
        .take(connect::MAX_REPORTED)
        .map(|t| {
            let c = P3::from(
                t.iter()
                    .fold(V3::zeros(), |a, &k| a + tm.pos[k as usize].coords)
                    / 4.0,
            );
            let r = t
                .iter()
                .map(|&k| (tm.pos[k as usize] - c).norm())
                .fold(0.0, f64::max);
            (c, r)
        })
        .collect();
    let Some(&(c, _)) = spots.first() else {
        return Ok(());
    };
    Err(MeshError::Refinable {
        message: format!(
            "a tetrahedron near ({:.6}, {:.6}, {:.6}) stays flat (radius ratio below {:e}) after \
             sliver removal and {} Steiner point(s); try a smaller size there",
            c.x, c.y, c.z, flat, steiner
        ),
        faces: vec![],
        spots,
    })
}

/// Adds the volume's free nodes that a tetrahedron uses, and its
/// tetrahedra, to `mesh`.
fn write_volume(
    entity: EntityRef,
    boundary: &Boundary,
    tm: &TetMesh,
    rep: &mut VolumeReport,
    mesh: &mut crate::mesh::Mesh,
) {
    let (pos, tets) = (&tm.pos, &tm.tets);
    let n_fixed = boundary.n_fixed();
    let mut referenced = vec![false; pos.len()];
    for t in tets {
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
                entity,
                params: [0.0; 2],
            });
        }
    }
    rep.bubbles = (n_fixed..pos.len()).filter(|&i| referenced[i]).count();
    for t in tets {
        mesh.tetrahedra.push(crate::mesh::Element {
            nodes: t.map(|l| {
                let l = l as usize;
                if l < n_fixed {
                    boundary.fixed_ids[l]
                } else {
                    node_of[l]
                }
            }),
            entity,
        });
    }
    rep.tetrahedra = tets.len();
}
