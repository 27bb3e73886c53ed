//! Element quality, with the same definitions as the independent checker
//! `meshkit/meshcheck.py` (so that our numbers and its numbers agree).
//!
//! Definitions (all evaluated in 3D):
//! - triangle radius ratio q = 2 r_in / r_circ
//!   = (b+c−a)(c+a−b)(a+b−c) / (abc), clipped to [0, 1], 0 when undefined;
//! - triangle angles via `atan2(|u×v|, u·v)`, the third as π − the other two;
//! - a triangle-mesh vertex is *interior* when it is used by a triangle and
//!   none of its edges is a boundary edge (an edge in exactly one triangle);
//!   its valence is the number of distinct edges at it;
//! - tetrahedron radius ratio q = 3 r_in / r_circ = 108 V² / (S |N|) with S
//!   the surface area and N = |a|²(b×c) + |b|²(c×a) + |c|²(a×b), clipped to
//!   [0, 1], 0 when undefined;
//! - dihedral angle at the edge shared by faces i and j = π − ∠(n_i, n_j)
//!   with outward face normals, 0 when undefined (degenerate faces);
//! - a tetrahedron is *inverted* when its signed volume is ≤ 1e-12 L³, where
//!   L³ is the mean absolute volume (meshcheck's "negative + zero volume");
//! - spacing conformance: for every unique edge of the analysed elements
//!   (tetrahedra if any, else triangles), r = L / d(midpoint);
//! - percentiles are numpy's default (linear interpolation between order
//!   statistics); standard deviations are population ones (numpy `std`).
//!
//! Unlike meshcheck, which looks at tetrahedra *or* triangles, the report has
//! a triangle section whenever the mesh has triangles and a tetrahedron
//! section whenever it has tetrahedra.
//!
//! Cost: O(n log n) in the number of elements (edges are found by sorting
//! packed 64-bit keys).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use crate::geom::{P3, V3};
use crate::measure::clip01;
use crate::mesh::Mesh;
use crate::model::EntityRef;
use crate::spacing::{Spacing, SpacingQuery};

const DEG: f64 = 180.0 / std::f64::consts::PI;

/// Element and node counts of the mesh.
#[derive(Serialize, Clone, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Nodes.
    pub nodes: usize,
    /// Line segments.
    pub lines: usize,
    /// Triangles.
    pub triangles: usize,
    /// Tetrahedra.
    pub tetrahedra: usize,
}

/// Triangle quality (keys as in meshcheck's `triangles` section).
#[derive(Serialize, Clone, Debug)]
pub struct TriangleQuality {
    /// Triangles analysed.
    pub count: usize,
    /// Radius ratio q = 2 r_in / r_circ (1 for an equilateral triangle).
    pub q_min: f64,
    /// Mean radius ratio.
    pub q_mean: f64,
    /// 1st percentile of the radius ratio.
    pub q_p1: f64,
    /// 5th percentile of the radius ratio.
    pub q_p5: f64,
    /// Smallest angle of the mesh, degrees.
    pub min_angle_min: f64,
    /// Mean over triangles of the triangle's smallest angle, degrees.
    pub min_angle_mean: f64,
    /// Largest angle of the mesh, degrees.
    pub max_angle_max: f64,
    /// Mean over triangles of the triangle's largest angle, degrees.
    pub max_angle_mean: f64,
    /// Percentage (0–100) of triangles whose smallest angle is < 20°.
    pub pct_min_angle_lt20: f64,
    /// Percentage (0–100) of triangles whose smallest angle is < 30°.
    pub pct_min_angle_lt30: f64,
    /// Triangles with coincident or collinear corners (counted with angles
    /// 0° and 180°).
    pub degenerate: usize,
    /// Number of interior vertices (see the module documentation).
    pub n_interior_vertices: usize,
    /// Valence → number of interior vertices with that valence.
    pub valence_hist: BTreeMap<u32, usize>,
    /// Fraction of interior vertices with valence 6 (`None` without any).
    pub valence6_fraction: Option<f64>,
    /// Mean valence of interior vertices (`None` without any).
    pub valence_mean: Option<f64>,
    /// Sum of the triangle areas.
    pub area: f64,
}

/// Tetrahedron quality (keys as in meshcheck's `tets` section).
#[derive(Serialize, Clone, Debug)]
pub struct TetQuality {
    /// Tetrahedra analysed.
    pub count: usize,
    /// Radius ratio q = 3 r_in / r_circ (1 for a regular tetrahedron).
    pub q_min: f64,
    /// Mean radius ratio.
    pub q_mean: f64,
    /// 1st percentile of the radius ratio.
    pub q_p1: f64,
    /// 5th percentile of the radius ratio.
    pub q_p5: f64,
    /// Smallest dihedral angle of the mesh, degrees.
    pub dihedral_min: f64,
    /// Largest dihedral angle of the mesh, degrees.
    pub dihedral_max: f64,
    /// Mean over tetrahedra of the tetrahedron's smallest dihedral angle.
    pub min_dihedral_mean: f64,
    /// Percentage (0–100) of tetrahedra whose smallest dihedral is < 10°.
    pub pct_min_dihedral_lt10: f64,
    /// Percentage (0–100) of tetrahedra whose smallest dihedral is < 20°.
    pub pct_min_dihedral_lt20: f64,
    /// Tetrahedra with non-positive signed volume (≤ the zero tolerance).
    pub inverted: usize,
    /// Of those, the ones with |V| within the zero tolerance.
    pub zero_volume: usize,
    /// Sum of |V|.
    pub volume: f64,
}

/// Lengths of the unique edges of the analysed elements.
#[derive(Serialize, Clone, Debug)]
pub struct EdgeLengths {
    /// Unique edges.
    pub count: usize,
    /// Shortest, in model units.
    pub length_min: f64,
    /// Mean, in model units.
    pub length_mean: f64,
    /// Longest, in model units.
    pub length_max: f64,
}

/// How well edge lengths follow the spacing d: r = L / d(midpoint) per edge.
#[derive(Serialize, Clone, Debug)]
pub struct SpacingConformance {
    /// Edges measured.
    pub edges: usize,
    /// Mean of r.
    pub ratio_mean: f64,
    /// Population standard deviation.
    pub ratio_std: f64,
    /// Smallest r.
    pub ratio_min: f64,
    /// Largest r.
    pub ratio_max: f64,
    /// 1st percentile of r.
    pub ratio_p1: f64,
    /// 5th percentile of r.
    pub ratio_p5: f64,
    /// Median of r.
    pub ratio_p50: f64,
    /// 95th percentile of r.
    pub ratio_p95: f64,
    /// 99th percentile of r.
    pub ratio_p99: f64,
    /// Fraction (0–1) of edges with r in [1/√2, √2].
    pub frac_within_sqrt2: f64,
    /// Fraction (0–1) of edges with r in [0.8, 1.25].
    #[serde(rename = "frac_within_0.8_1.25")]
    pub frac_within_0_8_1_25: f64,
}

/// The quality report of a mesh. Sections are `None` when the mesh has no
/// elements of that kind (or no spacing was given).
#[derive(Serialize, Clone, Debug)]
pub struct QualityReport {
    /// Element and node counts.
    pub counts: Counts,
    /// Triangle quality.
    pub triangles: Option<TriangleQuality>,
    /// Tetrahedron quality.
    pub tets: Option<TetQuality>,
    /// Edges of the analysed elements: tetrahedra if any, else triangles.
    pub edges: Option<EdgeLengths>,
    /// Edge lengths against the spacing, when one was given.
    pub spacing: Option<SpacingConformance>,
}

/// The radius ratio below which [`poor_elements`] reports an element: a
/// triangle of q 0.01 has a smallest angle of about 0.3°.
pub const POOR_Q: f64 = 0.01;

/// The elements of one entity whose radius ratio is below a threshold
/// ([`poor_elements`]): where the geometry is thinner than the spacing
/// resolves, the mesh must have such elements (a 0.5 chamfer meshed at
/// d = 1.1), and the user is told where rather than left to find them.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct PoorElements {
    /// Dimension of the entity: 2 face, 3 volume.
    pub dim: u8,
    /// Its id in the model.
    pub id: u32,
    /// Its name in the model, if any.
    pub name: Option<String>,
    /// How many of its elements are below the threshold (degenerate ones
    /// included).
    pub count: usize,
    /// The smallest radius ratio among them (0 for a degenerate element,
    /// negative for an inverted tetrahedron).
    pub worst_q: f64,
    /// The centroid of the worst element, in model coordinates.
    pub at: [f64; 3],
    /// The worst element's smallest height (triangle: 2·area / longest
    /// edge; tetrahedron: 3·volume / largest face area), in model units:
    /// about the thickness of the feature that forced it.
    pub thickness: f64,
}

/// Per face and per volume with elements of radius ratio below `threshold`
/// (default use: [`POOR_Q`]), the count, the worst element, where it is and
/// the feature size that forced it; ordered by dimension and id.
pub fn poor_elements(mesh: &Mesh, threshold: f64) -> Vec<PoorElements> {
    let mut by: BTreeMap<(u8, u32), PoorElements> = BTreeMap::new();
    let mut note = |e: EntityRef, q: f64, p: &[P3], thickness: f64| {
        let q = if q.is_nan() { 0.0 } else { q };
        if q >= threshold {
            return;
        }
        let s = by.entry((e.dim, e.id)).or_insert(PoorElements {
            dim: e.dim,
            id: e.id,
            name: None,
            count: 0,
            worst_q: f64::INFINITY,
            at: [0.0; 3],
            thickness: 0.0,
        });
        s.count += 1;
        if q < s.worst_q {
            s.worst_q = q;
            let c = p.iter().fold(V3::zeros(), |a, x| a + x.coords) / p.len() as f64;
            s.at = [c.x, c.y, c.z];
            s.thickness = thickness;
        }
    };
    for t in &mesh.triangles {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
        let twice_area = (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
        let longest = [
            (p[1] - p[0]).norm(),
            (p[2] - p[1]).norm(),
            (p[0] - p[2]).norm(),
        ]
        .into_iter()
        .fold(0.0, f64::max);
        let h = if longest > 0.0 {
            twice_area / longest
        } else {
            0.0
        };
        note(
            t.entity,
            crate::measure::triangle_radius_ratio(&p[0], &p[1], &p[2]),
            &p,
            h,
        );
    }
    for t in &mesh.tetrahedra {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
        let vol6 = crate::measure::tet_volume6(&p[0], &p[1], &p[2], &p[3]).abs();
        let largest = crate::measure::TET_FACES
            .iter()
            .map(|f| crate::measure::triangle_area(&p[f[0]], &p[f[1]], &p[f[2]]))
            .fold(0.0, f64::max);
        // 3·V / A with V = vol6 / 6
        let h = if largest > 0.0 {
            0.5 * vol6 / largest
        } else {
            0.0
        };
        let q = crate::measure::tet_radius_ratio(&p[0], &p[1], &p[2], &p[3]);
        note(t.entity, q, &p, h);
    }
    by.into_values()
        .map(|mut s| {
            s.name = mesh
                .entities
                .iter()
                .find(|e| e.entity.dim == s.dim && e.entity.id == s.id)
                .and_then(|e| e.name.clone());
            s
        })
        .collect()
}

/// Analyses `mesh`; with a spacing, also the edge-length conformance to it.
///
/// Element node indices must be `< mesh.nodes.len()` (the [`Mesh`]
/// invariant); the function panics otherwise.
pub fn analyse(mesh: &Mesh, spacing: Option<&dyn Spacing>) -> QualityReport {
    let counts = Counts {
        nodes: mesh.nodes.len(),
        lines: mesh.lines.len(),
        triangles: mesh.triangles.len(),
        tetrahedra: mesh.tetrahedra.len(),
    };
    let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();

    let mut tri_edges = None;
    let triangles = if mesh.triangles.is_empty() {
        None
    } else {
        let edges = sorted_edges(mesh.triangles.iter().map(|t| t.nodes));
        let tq = triangle_quality(&pos, mesh, &edges);
        tri_edges = Some(edges);
        Some(tq)
    };
    let tets = (!mesh.tetrahedra.is_empty()).then(|| tet_quality(&pos, mesh));

    // Unique edges of the analysed elements, each with one element using it.
    let use_tets = !mesh.tetrahedra.is_empty();
    let edges = if use_tets {
        sorted_edges(mesh.tetrahedra.iter().map(|t| t.nodes))
    } else {
        tri_edges.unwrap_or_default()
    };
    let entity_of = |e: u32| {
        if use_tets {
            mesh.tetrahedra[e as usize].entity
        } else {
            mesh.triangles[e as usize].entity
        }
    };
    let unique: Vec<(u64, u32)> = unique_edges(&edges).map(|(k, e, _)| (k, e)).collect();
    drop(edges);

    let lengths: Vec<f64> = unique
        .iter()
        .map(|&(k, _)| {
            let (a, b) = unpack(k);
            (pos[b] - pos[a]).norm()
        })
        .collect();
    let edge_lengths = (!lengths.is_empty()).then(|| EdgeLengths {
        count: lengths.len(),
        length_min: lengths.iter().copied().fold(f64::INFINITY, f64::min),
        length_mean: mean(&lengths),
        length_max: lengths.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    });

    let spacing = match spacing {
        Some(s) if !unique.is_empty() => {
            let d = edge_spacing(s, &pos, &unique, &entity_of);
            let ratios: Vec<f64> = lengths.iter().zip(&d).map(|(l, d)| l / d).collect();
            Some(conformance(ratios))
        }
        _ => None,
    };

    QualityReport {
        counts,
        triangles,
        tets,
        edges: edge_lengths,
        spacing,
    }
}

impl QualityReport {
    /// A short, aligned, human-readable table for the terminal.
    pub fn table(&self) -> String {
        let c = &self.counts;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{:<11} {} nodes, {} lines, {} triangles, {} tetrahedra",
            "mesh", c.nodes, c.lines, c.triangles, c.tetrahedra
        );
        if let Some(t) = &self.triangles {
            let _ = writeln!(
                s,
                "{:<11} q min {:.3}  mean {:.3}  p1 {:.3}  p5 {:.3}",
                "triangles", t.q_min, t.q_mean, t.q_p1, t.q_p5
            );
            let _ = writeln!(
                s,
                "{:<11} min {:.1}°  mean-min {:.1}°  max {:.1}°  <20°: {:.2}%  <30°: {:.2}%",
                "  angles",
                t.min_angle_min,
                t.min_angle_mean,
                t.max_angle_max,
                t.pct_min_angle_lt20,
                t.pct_min_angle_lt30
            );
            if t.degenerate > 0 {
                let _ = writeln!(
                    s,
                    "{:<11} {} degenerate triangle(s) (coincident or collinear corners)",
                    "  warning", t.degenerate
                );
            }
            let v6 = t
                .valence6_fraction
                .map_or("-".to_string(), |f| format!("{:.1}%", 100.0 * f));
            let _ = writeln!(
                s,
                "{:<11} valence-6 {}  of {} interior vertices  area {:.6}",
                "  topology", v6, t.n_interior_vertices, t.area
            );
        }
        if let Some(t) = &self.tets {
            let _ = writeln!(
                s,
                "{:<11} q min {:.3}  mean {:.3}  p1 {:.3}  p5 {:.3}",
                "tetrahedra", t.q_min, t.q_mean, t.q_p1, t.q_p5
            );
            let _ = writeln!(
                s,
                "{:<11} min {:.1}°  max {:.1}°  <10°: {:.2}%  <20°: {:.2}%",
                "  dihedral",
                t.dihedral_min,
                t.dihedral_max,
                t.pct_min_dihedral_lt10,
                t.pct_min_dihedral_lt20
            );
            let _ = writeln!(
                s,
                "{:<11} inverted {}  volume {:.6}",
                "  validity", t.inverted, t.volume
            );
        }
        if let Some(e) = &self.edges {
            let _ = writeln!(
                s,
                "{:<11} {} edges, length min {}  mean {}  max {}",
                "edges",
                e.count,
                short(e.length_min),
                short(e.length_mean),
                short(e.length_max)
            );
        }
        if let Some(r) = &self.spacing {
            let _ = writeln!(
                s,
                "{:<11} L/d mean {:.3}  std {:.3}  p5 {:.3}  p50 {:.3}  p95 {:.3}",
                "spacing", r.ratio_mean, r.ratio_std, r.ratio_p5, r.ratio_p50, r.ratio_p95
            );
            let _ = writeln!(
                s,
                "{:<11} in [1/√2, √2]: {:.1}%  in [0.8, 1.25]: {:.1}%",
                "",
                100.0 * r.frac_within_sqrt2,
                100.0 * r.frac_within_0_8_1_25
            );
        }
        s
    }
}

/// Four significant digits, in exponent form outside [1e-3, 1e5).
fn short(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || a.is_nan() {
        format!("{x}")
    } else if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}

// --------------------------------------------------------------------------
// edges

/// Packs an undirected edge into a key ordering (min, max).
fn pack(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    ((lo as u64) << 32) | hi as u64
}

fn unpack(k: u64) -> (usize, usize) {
    ((k >> 32) as usize, (k & 0xffff_ffff) as usize)
}

/// All (edge key, element index) pairs of the elements, sorted (so equal
/// edges are adjacent, and the lowest element index comes first).
///
/// A counting sort on the edge's lower node, then a sort of each node's
/// few pairs: the same order as one sort of all pairs, which took about
/// 1.5 s of case K's 16.5 M pairs (2.75 M tetrahedra) against a few
/// tenths. Why not a crate: the bucket pass is ten lines.
fn sorted_edges<const N: usize>(elems: impl Iterator<Item = [u32; N]> + Clone) -> Vec<(u64, u32)> {
    let per = N * (N - 1) / 2;
    let low = |a: u32, b: u32| a.min(b) as usize;
    let mut start: Vec<usize> = Vec::new();
    for nodes in elems.clone() {
        for i in 0..N {
            for j in i + 1..N {
                let k = low(nodes[i], nodes[j]);
                if k + 2 > start.len() {
                    start.resize(k + 2, 0);
                }
                start[k + 1] += 1;
            }
        }
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    let total = start.last().copied().unwrap_or(0);
    debug_assert!(total % per.max(1) == 0);
    let mut out = vec![(0u64, 0u32); total];
    let mut next = start.clone();
    for (e, nodes) in elems.enumerate() {
        for i in 0..N {
            for j in i + 1..N {
                let k = low(nodes[i], nodes[j]);
                out[next[k]] = (pack(nodes[i], nodes[j]), e as u32);
                next[k] += 1;
            }
        }
    }
    for w in start.windows(2) {
        out[w[0]..w[1]].sort_unstable();
    }
    out
}

/// Runs of equal keys in sorted pairs: (key, first element, multiplicity).
fn unique_edges(sorted: &[(u64, u32)]) -> impl Iterator<Item = (u64, u32, usize)> + '_ {
    sorted
        .chunk_by(|a, b| a.0 == b.0)
        .map(|run| (run[0].0, run[0].1, run.len()))
}

/// d at the midpoint of every unique edge, queried on the entity of one
/// element using the edge.
fn edge_spacing(
    s: &dyn Spacing,
    pos: &[P3],
    unique: &[(u64, u32)],
    entity_of: &dyn Fn(u32) -> EntityRef,
) -> Vec<f64> {
    if let Some(c) = s.constant() {
        return vec![c; unique.len()];
    }
    const CHUNK: usize = 4096;
    let mut out = vec![0.0; unique.len()];
    let mut qs = Vec::with_capacity(CHUNK);
    for (chunk, dst) in unique.chunks(CHUNK).zip(out.chunks_mut(CHUNK)) {
        qs.clear();
        qs.extend(chunk.iter().map(|&(k, e)| {
            let (a, b) = unpack(k);
            SpacingQuery {
                point: nalgebra::center(&pos[a], &pos[b]),
                entity: entity_of(e),
                params: [0.0, 0.0],
            }
        }));
        s.spacing_batch(&qs, dst);
    }
    out
}

// --------------------------------------------------------------------------
// statistics

fn mean(a: &[f64]) -> f64 {
    if a.is_empty() {
        return f64::NAN;
    }
    a.iter().sum::<f64>() / a.len() as f64
}

fn pct(count: usize, total: usize) -> f64 {
    if total == 0 {
        0.0
    } else {
        100.0 * count as f64 / total as f64
    }
}

/// numpy's default percentile (linear interpolation) of sorted data, p in
/// [0, 100]. NaN for empty data.
fn percentile_sorted(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let x = p / 100.0 * (n - 1) as f64;
    let lo = (x.floor() as usize).min(n - 1);
    let hi = (lo + 1).min(n - 1);
    let t = x - lo as f64;
    let (a, b) = (sorted[lo], sorted[hi]);
    if t == 0.0 {
        a
    } else {
        a + (b - a) * t
    }
}

fn sort_floats(mut a: Vec<f64>) -> Vec<f64> {
    a.sort_unstable_by(f64::total_cmp);
    a
}

fn conformance(ratios: Vec<f64>) -> SpacingConformance {
    let n = ratios.len();
    let m = mean(&ratios);
    let var = ratios.iter().map(|r| (r - m) * (r - m)).sum::<f64>() / n as f64;
    let (lo, hi) = (std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::SQRT_2);
    let within = ratios.iter().filter(|&&r| r >= lo && r <= hi).count();
    let within8 = ratios
        .iter()
        .filter(|&&r| (0.8..=1.25).contains(&r))
        .count();
    let r = sort_floats(ratios);
    SpacingConformance {
        edges: n,
        ratio_mean: m,
        ratio_std: var.sqrt(),
        ratio_min: r[0],
        ratio_max: r[n - 1],
        ratio_p1: percentile_sorted(&r, 1.0),
        ratio_p5: percentile_sorted(&r, 5.0),
        ratio_p50: percentile_sorted(&r, 50.0),
        ratio_p95: percentile_sorted(&r, 95.0),
        ratio_p99: percentile_sorted(&r, 99.0),
        frac_within_sqrt2: within as f64 / n as f64,
        frac_within_0_8_1_25: within8 as f64 / n as f64,
    }
}

// --------------------------------------------------------------------------
// triangles

/// Radius ratio and smallest/largest angle (degrees) of one triangle.
fn triangle_shape(a: &P3, b: &P3, c: &P3) -> (f64, f64, f64, f64) {
    let (ab, bc, ca) = (b - a, c - b, a - c);
    let (la, lb, lc) = (bc.norm(), ca.norm(), ab.norm());
    let area = 0.5 * ab.cross(&(-ca)).norm();
    let [aa, ab_, ac] = crate::measure::triangle_angles(a, b, c);
    let q = crate::measure::triangle_radius_ratio(a, b, c);
    if is_degenerate(la, lb, lc, area) {
        // coincident or collinear corners: no meaningful third angle (π
        // minus two angles of π each gave −180°); report the limit shape
        return (q, 0.0, 180.0, area);
    }
    let amin = (aa.min(ab_).min(ac) * DEG).clamp(0.0, 180.0);
    let amax = (aa.max(ab_).max(ac) * DEG).clamp(0.0, 180.0);
    (q, amin, amax, area)
}

/// A triangle of edge lengths `la lb lc` and `area` is degenerate when two
/// corners coincide or all three are collinear (to rounding), or a
/// coordinate is not finite.
fn is_degenerate(la: f64, lb: f64, lc: f64, area: f64) -> bool {
    let longest = la.max(lb).max(lc);
    let proper = area > 4.0 * f64::EPSILON * longest * longest && la.min(lb).min(lc) > 0.0;
    !proper
}

fn triangle_quality(pos: &[P3], mesh: &Mesh, edges: &[(u64, u32)]) -> TriangleQuality {
    let n = mesh.triangles.len();
    let mut q = Vec::with_capacity(n);
    let (mut amin_min, mut amin_sum, mut amax_max, mut amax_sum) =
        (f64::INFINITY, 0.0, f64::NEG_INFINITY, 0.0);
    let (mut lt20, mut lt30, mut area) = (0usize, 0usize, 0.0);
    let mut degenerate = 0usize;
    for t in &mesh.triangles {
        let [a, b, c] = t.nodes.map(|i| &pos[i as usize]);
        let (qq, amin, amax, ar) = triangle_shape(a, b, c);
        let (la, lb, lc) = ((c - b).norm(), (a - c).norm(), (b - a).norm());
        degenerate += is_degenerate(la, lb, lc, ar) as usize;
        q.push(qq);
        amin_min = amin_min.min(amin);
        amax_max = amax_max.max(amax);
        amin_sum += amin;
        amax_sum += amax;
        lt20 += (amin < 20.0) as usize;
        lt30 += (amin < 30.0) as usize;
        area += ar;
    }

    // Valence of interior vertices.
    let nn = pos.len();
    let mut deg = vec![0u32; nn];
    let mut bdeg = vec![0u32; nn];
    let mut used = vec![false; nn];
    for t in &mesh.triangles {
        for &v in &t.nodes {
            used[v as usize] = true;
        }
    }
    for (k, _, mult) in unique_edges(edges) {
        let (a, b) = unpack(k);
        deg[a] += 1;
        deg[b] += 1;
        if mult == 1 {
            bdeg[a] += 1;
            bdeg[b] += 1;
        }
    }
    let mut hist = BTreeMap::new();
    let (mut n_int, mut n6, mut vsum) = (0usize, 0usize, 0u64);
    for v in 0..nn {
        if used[v] && bdeg[v] == 0 {
            n_int += 1;
            n6 += (deg[v] == 6) as usize;
            vsum += deg[v] as u64;
            *hist.entry(deg[v]).or_insert(0) += 1;
        }
    }

    let q_mean = mean(&q);
    let q = sort_floats(q);
    TriangleQuality {
        count: n,
        q_min: q[0],
        q_mean,
        q_p1: percentile_sorted(&q, 1.0),
        q_p5: percentile_sorted(&q, 5.0),
        min_angle_min: amin_min,
        min_angle_mean: amin_sum / n as f64,
        max_angle_max: amax_max,
        max_angle_mean: amax_sum / n as f64,
        pct_min_angle_lt20: pct(lt20, n),
        pct_min_angle_lt30: pct(lt30, n),
        degenerate,
        n_interior_vertices: n_int,
        valence_hist: hist,
        valence6_fraction: (n_int > 0).then(|| n6 as f64 / n_int as f64),
        valence_mean: (n_int > 0).then(|| vsum as f64 / n_int as f64),
        area,
    }
}

// --------------------------------------------------------------------------
// tetrahedra

/// Signed volume, radius ratio, smallest and largest dihedral (degrees),
/// from [`crate::measure`]: the radius ratio of an inverted tetrahedron is
/// that of its mirror image (clipped to [0, 1], 0 when undefined), and a
/// tetrahedron with a face of zero area has the smallest dihedral angle 0
/// (undefined angles count as 0).
fn tet_shape(p0: &P3, p1: &P3, p2: &P3, p3: &P3) -> (f64, f64, f64, f64) {
    let v = crate::measure::tet_volume6(p0, p1, p2, p3) / 6.0;
    let q = clip01(crate::measure::tet_radius_ratio(p0, p1, p2, p3).abs());
    let (mut dmin, dmax) = crate::measure::dihedral_extremes(p0, p1, p2, p3);
    let p = [p0, p1, p2, p3];
    let zero_face = crate::measure::TET_FACES.iter().any(|f| {
        let a2 = (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]])).norm();
        a2.is_nan() || a2 <= 0.0
    });
    if zero_face || dmin.is_nan() {
        dmin = 0.0;
    }
    (v, q, dmin, if dmax.is_nan() { 0.0 } else { dmax })
}

fn tet_quality(pos: &[P3], mesh: &Mesh) -> TetQuality {
    let n = mesh.tetrahedra.len();
    let mut q = Vec::with_capacity(n);
    let mut vols = Vec::with_capacity(n);
    let (mut dmin_min, mut dmax_max, mut dmin_sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    let (mut lt10, mut lt20) = (0usize, 0usize);
    for t in &mesh.tetrahedra {
        let [p0, p1, p2, p3] = t.nodes.map(|i| &pos[i as usize]);
        let (v, qq, dmin, dmax) = tet_shape(p0, p1, p2, p3);
        vols.push(v);
        q.push(qq);
        dmin_min = dmin_min.min(dmin);
        dmax_max = dmax_max.max(dmax);
        dmin_sum += dmin;
        lt10 += (dmin < 10.0) as usize;
        lt20 += (dmin < 20.0) as usize;
    }
    let volume: f64 = vols.iter().map(|v| v.abs()).sum();
    let tol = 1e-12 * volume / n as f64;
    let inverted = vols.iter().filter(|&&v| v <= tol || v.is_nan()).count();
    let zero_volume = vols
        .iter()
        .filter(|&&v| v.abs() <= tol || v.is_nan())
        .count();
    let q_mean = mean(&q);
    let q = sort_floats(q);
    TetQuality {
        count: n,
        q_min: q[0],
        q_mean,
        q_p1: percentile_sorted(&q, 1.0),
        q_p5: percentile_sorted(&q, 5.0),
        dihedral_min: dmin_min,
        dihedral_max: dmax_max,
        min_dihedral_mean: dmin_sum / n as f64,
        pct_min_dihedral_lt10: pct(lt10, n),
        pct_min_dihedral_lt20: pct(lt20, n),
        inverted,
        zero_volume,
        volume,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Element, Node};
    use crate::spacing::Constant;

    /// A face with one sliver triangle (height 1e-3 on a base of 1) and a
    /// face of good triangles: only the first is reported, with the
    /// sliver's centroid and its height as the thickness; a flat
    /// tetrahedron is reported for its volume the same way.
    #[test]
    fn poor_elements_name_the_entity_the_place_and_the_thickness() {
        let node = |x: f64, y: f64, z: f64| Node {
            pos: P3::new(x, y, z),
            entity: EntityRef::new(2, 0),
            params: [0.0; 2],
        };
        let tri = |n: [u32; 3], f: u32| Element {
            nodes: n,
            entity: EntityRef::new(2, f),
        };
        let mesh = Mesh {
            nodes: vec![
                node(0.0, 0.0, 0.0),
                node(1.0, 0.0, 0.0),
                node(0.5, 1e-3, 0.0),
                node(0.5, 0.866, 0.0),
                node(0.5, 0.3, 1e-3),
            ],
            triangles: vec![tri([0, 1, 2], 0), tri([0, 1, 3], 1)],
            tetrahedra: vec![Element {
                nodes: [0, 1, 3, 4],
                entity: EntityRef::new(3, 0),
            }],
            ..Default::default()
        };
        let poor = poor_elements(&mesh, POOR_Q);
        assert_eq!(poor.len(), 2, "{poor:?}");
        let f = &poor[0];
        assert_eq!((f.dim, f.id, f.count), (2, 0, 1));
        assert!(f.worst_q > 0.0 && f.worst_q < POOR_Q, "{}", f.worst_q);
        assert!((f.thickness - 1e-3).abs() < 1e-9, "{}", f.thickness);
        assert!((f.at[0] - 0.5).abs() < 1e-12 && (f.at[1] - 1e-3 / 3.0).abs() < 1e-12);
        let v = &poor[1];
        assert_eq!((v.dim, v.id, v.count), (3, 0, 1));
        // the tet's height over its base triangle (0, 1, 3) is the 1e-3 of node 4
        assert!((v.thickness - 1e-3).abs() < 1e-6, "{}", v.thickness);
        // a threshold below every element reports nothing
        assert!(poor_elements(&mesh, 0.0).is_empty());
    }

    /// The bucketed [`sorted_edges`] gives exactly the order of one sort of
    /// every (edge, element) pair, shared edges and gaps in the node
    /// numbering included.
    #[test]
    fn sorted_edges_is_the_full_sort() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: u32| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % u64::from(m)) as u32
        };
        let tets: Vec<[u32; 4]> = (0..2000)
            .map(|_| {
                let a = next(300) * 3;
                [a, a + 1 + next(40), a + 50 + next(40), a + 100 + next(40)]
            })
            .collect();
        let mut full: Vec<(u64, u32)> = Vec::new();
        for (e, t) in tets.iter().enumerate() {
            for i in 0..4 {
                for j in i + 1..4 {
                    full.push((pack(t[i], t[j]), e as u32));
                }
            }
        }
        full.sort_unstable();
        let got = sorted_edges(tets.iter().cloned());
        assert_eq!(got, full);
        assert!(unique_edges(&got).any(|(_, _, m)| m > 1));
    }

    fn node(x: f64, y: f64, z: f64) -> Node {
        Node {
            pos: P3::new(x, y, z),
            entity: EntityRef::new(2, 0),
            params: [0.0, 0.0],
        }
    }

    fn tri_mesh(pts: &[[f64; 3]], tris: &[[u32; 3]]) -> Mesh {
        Mesh {
            nodes: pts.iter().map(|p| node(p[0], p[1], p[2])).collect(),
            triangles: tris
                .iter()
                .map(|&nodes| Element {
                    nodes,
                    entity: EntityRef::new(2, 0),
                })
                .collect(),
            ..Mesh::default()
        }
    }

    fn tet_mesh(pts: &[[f64; 3]], tets: &[[u32; 4]]) -> Mesh {
        Mesh {
            nodes: pts.iter().map(|p| node(p[0], p[1], p[2])).collect(),
            tetrahedra: tets
                .iter()
                .map(|&nodes| Element {
                    nodes,
                    entity: EntityRef::new(3, 0),
                })
                .collect(),
            ..Mesh::default()
        }
    }

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b}");
    }

    #[test]
    fn equilateral_triangle() {
        let s3 = 3f64.sqrt();
        let m = tri_mesh(
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, s3 / 2.0, 0.0]],
            &[[0, 1, 2]],
        );
        let r = analyse(&m, Some(&Constant(1.0)));
        let t = r.triangles.unwrap();
        close(t.q_min, 1.0, 1e-12);
        close(t.min_angle_min, 60.0, 1e-9);
        close(t.max_angle_max, 60.0, 1e-9);
        close(t.area, s3 / 4.0, 1e-12);
        assert_eq!(t.n_interior_vertices, 0);
        assert_eq!(t.valence6_fraction, None);
        let s = r.spacing.unwrap();
        assert_eq!(s.edges, 3);
        close(s.ratio_mean, 1.0, 1e-12);
        close(s.ratio_std, 0.0, 1e-12);
        assert!(r.tets.is_none());
    }

    #[test]
    fn right_isoceles_triangle() {
        // r_in = (2 - √2)/2, R = √2/2 → 2 r/R = 2(√2 − 1).
        let m = tri_mesh(
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[[0, 1, 2]],
        );
        let t = analyse(&m, None).triangles.unwrap();
        close(t.q_min, 2.0 * (2f64.sqrt() - 1.0), 1e-12);
        close(t.min_angle_min, 45.0, 1e-9);
        close(t.max_angle_max, 90.0, 1e-9);
        close(t.pct_min_angle_lt30, 0.0, 0.0);
        close(t.area, 0.5, 1e-15);
    }

    #[test]
    fn triangle_in_3d_and_degenerate() {
        // Same right triangle, rotated out of plane: same q.
        let m = tri_mesh(
            &[
                [0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 2.0, 0.0],
            ],
            &[[0, 1, 2], [0, 1, 3]],
        );
        let t = analyse(&m, None).triangles.unwrap();
        close(t.q_mean, (2.0 * (2f64.sqrt() - 1.0) + 0.0) / 2.0, 1e-12);
        close(t.q_min, 0.0, 0.0);
        close(t.min_angle_min, 0.0, 1e-9);
        close(t.pct_min_angle_lt20, 50.0, 1e-12);
    }

    #[test]
    fn regular_tetrahedron() {
        let pts = [
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ];
        // Orient positively.
        let m = tet_mesh(&pts, &[[0, 1, 2, 3]]);
        let k = if tet_shape(
            &m.nodes[0].pos,
            &m.nodes[1].pos,
            &m.nodes[2].pos,
            &m.nodes[3].pos,
        )
        .0 > 0.0
        {
            [0, 1, 2, 3]
        } else {
            [1, 0, 2, 3]
        };
        let m = tet_mesh(&pts, &[k]);
        let r = analyse(&m, Some(&Constant(2.0 * 2f64.sqrt())));
        let t = r.tets.unwrap();
        let dih = (1.0f64 / 3.0).acos() * DEG;
        close(t.q_min, 1.0, 1e-12);
        close(t.dihedral_min, dih, 1e-9);
        close(t.dihedral_max, dih, 1e-9);
        close(t.volume, 8.0 / 3.0, 1e-12);
        assert_eq!(t.inverted, 0);
        let s = r.spacing.unwrap();
        assert_eq!(s.edges, 6);
        close(s.ratio_mean, 1.0, 1e-12);
        assert!(r.triangles.is_none());
    }

    #[test]
    fn corner_tetrahedron() {
        let m = tet_mesh(
            &[
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            &[[0, 1, 2, 3]],
        );
        let t = analyse(&m, None).tets.unwrap();
        close(t.dihedral_max, 90.0, 1e-9);
        close(t.dihedral_min, (1.0 / 3f64.sqrt()).acos() * DEG, 1e-9);
        let s3 = 3f64.sqrt();
        close(t.q_min, 3.0 * (1.0 / (3.0 + s3)) / (s3 / 2.0), 1e-12);
        close(t.volume, 1.0 / 6.0, 1e-15);
        assert_eq!(t.inverted, 0);
    }

    #[test]
    fn inverted_tetrahedra_are_counted() {
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [2.0, 0.0, 0.0],
        ];
        // Positive, negative (swapped), and flat (all in z = 0).
        let m = tet_mesh(&pts, &[[0, 1, 2, 3], [1, 0, 2, 3], [0, 1, 2, 5]]);
        let t = analyse(&m, None).tets.unwrap();
        assert_eq!(t.inverted, 2);
        assert_eq!(t.zero_volume, 1);
        // The swapped one has the same shape as the positive one.
        let s3 = 3f64.sqrt();
        let qc = 3.0 * (1.0 / (3.0 + s3)) / (s3 / 2.0);
        close(t.q_mean, 2.0 * qc / 3.0, 1e-12);
        close(t.q_p5, 0.1 * qc, 1e-12);
        close(t.volume, 2.0 / 6.0, 1e-15);
        // Degenerate tet: dihedral 0 (undefined angles) and q 0.
        close(t.dihedral_min, 0.0, 1e-9);
        close(t.q_min, 0.0, 0.0);
    }

    fn hexagon() -> Mesh {
        let mut pts = vec![[0.0, 0.0, 0.0]];
        for i in 0..6 {
            let a = i as f64 * std::f64::consts::PI / 3.0;
            pts.push([a.cos(), a.sin(), 0.0]);
        }
        let tris: Vec<[u32; 3]> = (0..6).map(|i| [0, 1 + i, 1 + (i + 1) % 6]).collect();
        tri_mesh(&pts, &tris)
    }

    #[test]
    fn hexagon_valence() {
        let r = analyse(&hexagon(), None);
        let t = r.triangles.unwrap();
        assert_eq!(t.n_interior_vertices, 1);
        assert_eq!(t.valence_hist, BTreeMap::from([(6, 1)]));
        assert_eq!(t.valence6_fraction, Some(1.0));
        assert_eq!(t.valence_mean, Some(6.0));
        close(t.q_mean, 1.0, 1e-12);
        close(t.area, 6.0 * 3f64.sqrt() / 4.0, 1e-12);
        let e = r.edges.unwrap();
        assert_eq!(e.count, 12);
        close(e.length_min, 1.0, 1e-12);
        close(e.length_max, 1.0, 1e-12);
    }

    #[test]
    fn valence_ignores_vertices_on_the_boundary() {
        // Drop one triangle: the centre is now on the boundary.
        let mut m = hexagon();
        m.triangles.pop();
        let t = analyse(&m, None).triangles.unwrap();
        assert_eq!(t.n_interior_vertices, 0);
        assert!(t.valence_hist.is_empty());
    }

    /// d(x) = 1 + x, per-edge.
    struct Linear;
    impl Spacing for Linear {
        fn spacing(&self, q: &SpacingQuery) -> f64 {
            assert_eq!(q.entity, EntityRef::new(2, 0));
            1.0 + q.point.x
        }
    }

    #[test]
    fn spacing_statistics_on_a_known_mesh() {
        // Unit square split along the diagonal (0,0)-(1,1): 5 edges.
        // Edges and midpoints x: bottom (0,0)-(1,0) L=1, x=.5 → r=1/1.5;
        // right (1,0)-(1,1) L=1, x=1 → r=.5; top (1,1)-(0,1) L=1, x=.5 → 1/1.5;
        // left (0,1)-(0,0) L=1, x=0 → r=1; diagonal L=√2, x=.5 → √2/1.5.
        let m = tri_mesh(
            &[
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            &[[0, 1, 2], [0, 2, 3]],
        );
        let r = analyse(&m, Some(&Linear)).spacing.unwrap();
        let mut want = [2.0 / 3.0, 0.5, 2.0 / 3.0, 1.0, 2f64.sqrt() / 1.5];
        assert_eq!(r.edges, 5);
        let mean = want.iter().sum::<f64>() / 5.0;
        let std = (want.iter().map(|w| (w - mean).powi(2)).sum::<f64>() / 5.0).sqrt();
        close(r.ratio_mean, mean, 1e-12);
        close(r.ratio_std, std, 1e-12);
        want.sort_by(f64::total_cmp);
        close(r.ratio_min, 0.5, 1e-12);
        close(r.ratio_max, 1.0, 1e-12);
        close(r.ratio_p50, 2.0 / 3.0, 1e-12);
        // numpy: p5 → index 0.2 between 0.5 and 2/3.
        close(r.ratio_p5, 0.5 + 0.2 * (2.0 / 3.0 - 0.5), 1e-12);
        // p95 → index 3.8 between √2/1.5 (0.9428) and 1.
        close(r.ratio_p95, want[3] + 0.8 * (want[4] - want[3]), 1e-12);
        // Within [1/√2, √2]: 0.943 and 1 → 2/5; within [0.8, 1.25]: same.
        close(r.frac_within_sqrt2, 0.4, 1e-12);
        close(r.frac_within_0_8_1_25, 0.4, 1e-12);
        let json = serde_json::to_string(&r).unwrap();
        assert!(json.contains("\"frac_within_0.8_1.25\":0.4"), "{json}");
    }

    #[test]
    fn percentiles_match_numpy() {
        let a = [1.0, 2.0, 3.0, 4.0, 10.0];
        // numpy.percentile([1,2,3,4,10], [0, 1, 5, 50, 99, 100])
        close(percentile_sorted(&a, 0.0), 1.0, 0.0);
        close(percentile_sorted(&a, 1.0), 1.04, 1e-12);
        close(percentile_sorted(&a, 5.0), 1.2, 1e-12);
        close(percentile_sorted(&a, 50.0), 3.0, 0.0);
        close(percentile_sorted(&a, 99.0), 9.76, 1e-12);
        close(percentile_sorted(&a, 100.0), 10.0, 0.0);
        close(percentile_sorted(&[7.0], 1.0), 7.0, 0.0);
    }

    #[test]
    fn table_and_json_mention_every_section() {
        let r = analyse(&hexagon(), Some(&Constant(1.0)));
        let t = r.table();
        assert!(t.contains("7 nodes"), "{t}");
        assert!(t.contains("valence-6 100.0%"), "{t}");
        assert!(t.contains("L/d mean 1.000"), "{t}");
        let json = serde_json::to_value(&r).unwrap();
        assert_eq!(json["triangles"]["valence_hist"]["6"], 1);
        assert_eq!(json["counts"]["triangles"], 6);
    }

    /// Timing on a 600k-triangle grid: `cargo test -p bubblemesh-core --release
    /// -- --ignored --nocapture large_mesh_is_fast`.
    #[test]
    #[ignore]
    fn large_mesh_is_fast() {
        let n = 548usize; // 2·547² ≈ 598k triangles
        let mut pts = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                pts.push([i as f64, j as f64 + 0.3 * (i as f64).sin(), 0.0]);
            }
        }
        let mut tris = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32);
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            }
        }
        let m = tri_mesh(&pts, &tris);
        let t0 = std::time::Instant::now();
        let r = analyse(&m, Some(&Linear));
        let dt = t0.elapsed();
        println!("{} triangles in {:?}\n{}", m.triangles.len(), dt, r.table());
        assert!(dt.as_secs_f64() < 1.0);
    }

    /// Triangles with coincident corners report angles 0° and 180° and
    /// are counted, never a negative angle.
    #[test]
    fn degenerate_triangles_report_sane_angles_and_a_count() {
        let m = tri_mesh(
            &[
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.3, 0.7, 0.0],
            ],
            &[[0, 1, 2], [3, 3, 3], [0, 0, 1], [1, 3, 2]],
        );
        let r = analyse(&m, None);
        let t = r.triangles.as_ref().unwrap();
        assert_eq!(t.degenerate, 3);
        assert_eq!(t.min_angle_min, 0.0);
        assert_eq!(t.max_angle_max, 180.0);
        assert!(t.min_angle_mean >= 0.0);
        let table = r.table();
        assert!(!table.contains("-180"), "{table}");
        assert!(table.contains("3 degenerate"), "{table}");
    }
}
