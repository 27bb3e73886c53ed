//! Twin faces: the two sides of a wall thinner than the spacing get one
//! mesh, the second a translate of the first.
//!
//! Across a wall of thickness t below the spacing d no bubble fits, so the
//! volume's tetrahedra join the nodes of one side to those of the other.
//! Two independently packed sides leave those nodes offset by about half a
//! spacing and the tetrahedra between them are slivers. Where each node of
//! one side lies straight across from one of the other, the wall is a
//! layer of prisms of height t, each three tetrahedra of radius ratio about
//! 0.28 at t/d = 1/8. On as_0086's plate (1 thick, d = 8) the Delaunay
//! tetrahedralization of the two sides' nodes has a smallest dihedral
//! angle of 0.7° and a mean radius ratio of 0.22 as packed, 5.3° and 0.27
//! as twins.
//!
//! Two planar faces are twins when their normals are parallel and one
//! translation t along the normal, shorter than the least spacing at their
//! boundary nodes, carries the earlier face's boundary nodes onto the
//! later one's, node for node, and its boundary segments onto the later
//! one's. Their boundaries then bound congruent regions, so the earlier
//! face's triangulation carried by t is a triangulation of the later one:
//! the same triangles, the same quality. It is taken unless the spacing at
//! a carried node differs by more than [`SPACING_TOLERANCE`] from the
//! spacing at the node it comes from (a spacing that changes across the
//! wall keeps each side its own mesh).
//!
//! The later face's boundary nodes are then put exactly where the earlier
//! face's are carried (they matched within [`MATCH`]·d): four nodes of two
//! segments across the wall must be coplanar to the last bit, or the
//! Delaunay tetrahedralization makes a flat tetrahedron of them.

use std::collections::HashMap;

use crate::geom::{P3, V3};
use crate::mesh::{Mesh, Node};
use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};

use super::{FaceOut, FaceReport};

/// How far (relative) the spacing at a carried node may differ from the
/// spacing at the node it was carried from.
pub(crate) const SPACING_TOLERANCE: f64 = 0.1;

/// Boundary nodes of two twins coincide (after the translation) within
/// this fraction of the spacing: the edges are packed independently, so
/// congruent edges give their nodes in the last bits.
const MATCH: f64 = 1e-6;

/// A planar face's boundary as twinning compares it.
#[derive(Clone, Debug)]
struct Outline {
    /// The unit normal of the plane (the sign is the parametrization's).
    normal: V3,
    /// The boundary nodes, each once, ascending.
    nodes: Vec<u32>,
    /// The boundary segments, each with its lower node first, sorted.
    segments: Vec<[u32; 2]>,
    /// The mean of the boundary nodes' positions.
    centroid: P3,
    /// A point of the plane from the surface alone (at
    /// [`inside_domain`]), not from the mesh.
    origin: P3,
    /// The least spacing at the boundary nodes.
    d: f64,
}

/// The outline of every face that may have a twin: planar, with no
/// embedded edge or vertex, its boundary meshed (`edge_nodes`, the nodes
/// of each edge in order, their spacing in `node_d`).
fn outlines(
    model: &Model,
    mesh: &Mesh,
    edge_nodes: &[Vec<u32>],
    node_d: &[f64],
) -> Vec<Option<Outline>> {
    model
        .faces
        .iter()
        .map(|f| {
            if !f.surface.is_planar()
                || !f.embedded_edges.is_empty()
                || !f.embedded_vertices.is_empty()
                || f.loops.is_empty()
            {
                return None;
            }
            let [u, v] = inside_domain(f.surface.as_ref());
            let (origin, su, sv) = f.surface.tangents(u, v);
            if ![origin.x, origin.y, origin.z].iter().all(|c| c.is_finite()) {
                return None;
            }
            let normal = su.cross(&sv).try_normalize(0.0)?;
            let mut segments = Vec::new();
            for use_ in f.loops.iter().flat_map(|l| l.edges.iter()) {
                let ids = edge_nodes.get(use_.edge as usize)?;
                for w in ids.windows(2) {
                    segments.push([w[0].min(w[1]), w[0].max(w[1])]);
                }
            }
            segments.sort_unstable();
            let mut nodes: Vec<u32> = segments.iter().flatten().copied().collect();
            nodes.sort_unstable();
            nodes.dedup();
            if nodes.len() < 3 {
                return None;
            }
            let centroid = P3::from(
                nodes
                    .iter()
                    .fold(V3::zeros(), |a, &k| a + mesh.nodes[k as usize].pos.coords)
                    / nodes.len() as f64,
            );
            let d = nodes
                .iter()
                .map(|&k| node_d.get(k as usize).copied().unwrap_or(f64::NAN))
                .fold(f64::INFINITY, f64::min);
            (d.is_finite() && d > 0.0).then_some(Outline {
                normal,
                nodes,
                segments,
                centroid,
                origin,
                d,
            })
        })
        .collect()
}

/// The slab between two twin faces, as the volume stage asks of it.
#[derive(Clone, Debug)]
pub(crate) struct Wall {
    /// The earlier face's triangles.
    triangles: Vec<[P3; 3]>,
    /// The unit normal of the two planes.
    normal: V3,
    /// Where the earlier face's plane is along `normal` (p·normal).
    from: f64,
    /// How far the later face's plane is from it along `normal` (signed).
    across: f64,
}

impl Wall {
    /// Whether `p` lies between the two faces: strictly between their
    /// planes (by more than 1e-9 of the thickness) and, seen along the
    /// normal, inside the face.
    pub(crate) fn holds(&self, p: &P3) -> bool {
        let s = (p.coords.dot(&self.normal) - self.from) / self.across;
        if !(s > 1e-9 && s < 1.0 - 1e-9) {
            return false;
        }
        // p's shadow on the earlier face's plane, in one of its triangles
        let q = p - self.normal * (s * self.across);
        self.triangles.iter().any(|[a, b, c]| {
            let n = (b - a).cross(&(c - a));
            let side = |u: &P3, v: &P3| (v - u).cross(&(q - u)).dot(&n) >= 0.0;
            side(a, b) && side(b, c) && side(c, a)
        })
    }
}

/// What twinning keeps over one face stage: the faces' outlines, which
/// faces are in the mesh, the nodes a twin has moved or read, and the
/// walls found.
pub(crate) struct Twins {
    outlines: Vec<Option<Outline>>,
    meshed: Vec<bool>,
    /// Boundary nodes a twin has snapped or carried from: none is moved
    /// again, so that snapping is the same whatever the nodes' positions
    /// were before (a re-meshing starts from the snapped ones; a node at
    /// two twins' corner, as where two ribs cross, would otherwise follow
    /// the order of the snaps).
    pinned: std::collections::HashSet<u32>,
    /// The slabs between the twins found.
    pub(crate) walls: Vec<Wall>,
}

impl Twins {
    /// Before the faces of `model` are meshed: their outlines (see
    /// [`outlines`]).
    pub(crate) fn new(model: &Model, mesh: &Mesh, edge_nodes: &[Vec<u32>], node_d: &[f64]) -> Self {
        Twins {
            outlines: outlines(model, mesh, edge_nodes, node_d),
            meshed: vec![false; model.faces.len()],
            pinned: Default::default(),
            walls: Vec::new(),
        }
    }

    /// Face `f`'s mesh is in the mesh now.
    pub(crate) fn meshed(&mut self, f: usize) {
        self.meshed[f] = true;
    }

    /// Face `b`'s mesh `out` (and its report) replaced by its twin's
    /// carried across the wall, where an earlier face in `mesh` is its
    /// twin (see the module docs); the wall between them kept.
    pub(crate) fn take(
        &mut self,
        model: &Model,
        spacing: &dyn Spacing,
        mesh: &mut Mesh,
        b: usize,
        report: &mut FaceReport,
        out: &mut FaceOut,
    ) {
        let Some((a, t, map)) = find(&self.outlines, &self.meshed, mesh, b) else {
            return;
        };
        // b's boundary nodes put exactly where a's are carried (module
        // docs; on as_0086 they were 1e-14 apart, and 24 flat tetrahedra
        // sent the volume to a refinement round), those a twin has not
        // pinned already
        let snapped: Vec<(u32, P3)> = map
            .iter()
            .filter(|(_, kb)| !self.pinned.contains(kb))
            .map(|(&ka, &kb)| (kb, mesh.nodes[ka as usize].pos + t))
            .collect();
        let pinned: Vec<u32> = map.iter().flat_map(|(&ka, &kb)| [ka, kb]).collect();
        let Some((carried, triangles)) = carry(model, spacing, mesh, (a, t, map), b) else {
            return;
        };
        for (kb, p) in snapped {
            mesh.nodes[kb as usize].pos = p;
        }
        self.pinned.extend(pinned);
        report.twin_of = Some(a as u32);
        report.bubbles = carried.nodes.len();
        report.triangles = carried.triangles.len();
        *out = carried;
        let (Some(normal), Some(first)) = (t.try_normalize(0.0), triangles.first()) else {
            return;
        };
        self.walls.push(Wall {
            from: first[0].coords.dot(&normal),
            triangles,
            normal,
            across: t.norm(),
        });
    }
}

/// The earlier face whose mesh face `b` takes, carried by a translation
/// (see the module docs): `(a, t, boundary node of a → boundary node of
/// b)`. `meshed[a]` says which faces are in `mesh` now.
fn find(
    outlines: &[Option<Outline>],
    meshed: &[bool],
    mesh: &Mesh,
    b: usize,
) -> Option<(usize, V3, HashMap<u32, u32>)> {
    let ob = outlines.get(b)?.as_ref()?;
    (0..b).find_map(|a| {
        let oa = outlines[a].as_ref()?;
        if !meshed[a]
            || oa.nodes.len() != ob.nodes.len()
            || oa.segments.len() != ob.segments.len()
            || oa.normal.cross(&ob.normal).norm() > 1e-9
        {
            return None;
        }
        let d = oa.d.min(ob.d);
        let t = ob.centroid - oa.centroid;
        let across = t.dot(&ob.normal);
        // along the normal, shorter than the spacing, not zero
        if (t - ob.normal * across).norm() > MATCH * d || !(across.abs() < d) || across == 0.0 {
            return None;
        }
        let map = match_nodes(mesh, &oa.nodes, &ob.nodes, &t, MATCH * d)?;
        let mut carried: Vec<[u32; 2]> = oa
            .segments
            .iter()
            .map(|s| {
                let (p, q) = (map[&s[0]], map[&s[1]]);
                [p.min(q), p.max(q)]
            })
            .collect();
        carried.sort_unstable();
        if carried != ob.segments {
            return None;
        }
        // the translation along the normal, from the two planes alone:
        // where the plane is normal to an axis, the carried nodes then
        // differ from theirs in that coordinate alone; and it does not
        // depend on where b's nodes are, so that snapping them twice (a
        // re-meshing of a twinned mesh) puts them where it put them once
        let across = (ob.origin - oa.origin).dot(&ob.normal);
        across.is_finite().then(|| (a, ob.normal * across, map))
    })
}

/// Each of `from` carried by `t` to the one of `to` within `tol`, one to
/// one; `None` where any has no partner.
fn match_nodes(
    mesh: &Mesh,
    from: &[u32],
    to: &[u32],
    t: &V3,
    tol: f64,
) -> Option<HashMap<u32, u32>> {
    // a grid of cells of side `tol`: a partner is in the cell of the
    // carried point or a neighbour
    let cell = |p: &P3| [p.x, p.y, p.z].map(|c| (c / tol).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for &k in to {
        grid.entry(cell(&mesh.nodes[k as usize].pos))
            .or_default()
            .push(k);
    }
    let mut map = HashMap::with_capacity(from.len());
    let mut taken = std::collections::HashSet::with_capacity(from.len());
    for &k in from {
        let p = mesh.nodes[k as usize].pos + t;
        let c = cell(&p);
        let mut partner = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &j in grid
                        .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        .into_iter()
                        .flatten()
                    {
                        if (mesh.nodes[j as usize].pos - p).norm() <= tol {
                            partner = partner.or(Some(j));
                        }
                    }
                }
            }
        }
        let j = partner?;
        if !taken.insert(j) {
            return None;
        }
        map.insert(k, j);
    }
    Some(map)
}

/// Face `a`'s mesh (its triangles and own nodes in `mesh`) carried by `t`
/// onto face `b`, boundary nodes through `map`; triangles counter-clockwise
/// in `b`'s (u,v) as the face pipeline gives them; with `a`'s triangles
/// as they are (the wall's, [`Wall`]). `None` where a carried
/// node cannot be put on `b`'s surface, or the spacing there is not within
/// [`SPACING_TOLERANCE`] of its origin's.
fn carry(
    model: &Model,
    spacing: &dyn Spacing,
    mesh: &Mesh,
    (a, t, map): (usize, V3, HashMap<u32, u32>),
    b: usize,
) -> Option<(FaceOut, Vec<[P3; 3]>)> {
    let (ea, eb) = (EntityRef::new(2, a as u32), EntityRef::new(2, b as u32));
    let surface = model.faces[b].surface.as_ref();
    let uniform = spacing.constant().is_some();
    let mut own: HashMap<u32, u32> = HashMap::new();
    let mut nodes = Vec::new();
    let mut triangles = Vec::new();
    let mut source = Vec::new();
    for tri in mesh.triangles.iter().filter(|e| e.entity == ea) {
        source.push(tri.nodes.map(|k| mesh.nodes[k as usize].pos));
        let mut corners = [0u32; 3];
        for (c, &k) in corners.iter_mut().zip(&tri.nodes) {
            *c = if let Some(&j) = map.get(&k) {
                j
            } else {
                let n = &mesh.nodes[k as usize];
                if n.entity != ea {
                    return None;
                }
                match own.get(&k) {
                    Some(&j) => j,
                    None => {
                        let pos = n.pos + t;
                        let params = surface.inverse(&pos, None)?;
                        if !uniform {
                            let at = |point: P3, entity: EntityRef, params: [f64; 2]| {
                                spacing.spacing(&SpacingQuery {
                                    point,
                                    entity,
                                    params,
                                })
                            };
                            let (d0, d1) = (at(n.pos, ea, n.params), at(pos, eb, params));
                            if !((d1 - d0).abs() <= SPACING_TOLERANCE * d0) {
                                return None;
                            }
                        }
                        let j = FaceOut::OWN + nodes.len() as u32;
                        nodes.push(Node {
                            pos,
                            entity: eb,
                            params,
                        });
                        own.insert(k, j);
                        j
                    }
                }
            };
        }
        triangles.push(corners);
    }
    if triangles.is_empty() {
        return None;
    }
    // counter-clockwise in b's (u,v): the sign of its normal su × sv
    let [u, v] = inside_domain(surface);
    let (_, su, sv) = surface.tangents(u, v);
    let n = su.cross(&sv);
    let pos = |c: u32| {
        if c >= FaceOut::OWN {
            nodes[(c - FaceOut::OWN) as usize].pos
        } else {
            mesh.nodes[c as usize].pos
        }
    };
    for tri in &mut triangles {
        let [p, q, r] = tri.map(pos);
        if (q - p).cross(&(r - p)).dot(&n) < 0.0 {
            tri.swap(1, 2);
        }
    }
    Some((
        FaceOut {
            nodes,
            kept: 0,
            triangles,
        },
        source,
    ))
}

/// A parameter pair in the surface's domain: its centre, or a finite end
/// of an unbounded direction, or 0 (a STEP plane's domain is the whole
/// plane, whose centre is not a number).
fn inside_domain(surface: &dyn crate::geom::Surface) -> [f64; 2] {
    let (du, dv) = surface.domain();
    [du, dv].map(|[lo, hi]| match (lo.is_finite(), hi.is_finite()) {
        (true, true) => 0.5 * (lo + hi),
        (true, false) => lo,
        (false, true) => hi,
        (false, false) => 0.0,
    })
}
