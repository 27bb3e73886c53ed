//! Twin faces: the two sides of a wall thinner than the spacing get one
//! mesh, the second the first's carried across.
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
//! the same triangles, the same quality. Two curved faces are twins when
//! the later is the earlier's offset surface at a distance t shorter than
//! the spacing (a bent sheet's two sides: coaxial cylinders, concentric
//! spheres): each point p carried to p + t·n(p), n the earlier face's unit
//! normal there, lands on the later face, and the boundary nodes and
//! segments match as for planes. The carried triangulation is then the
//! later face's, stretched by (r + t)/r across a radius of curvature r.
//! Either is taken unless the spacing at a carried node differs by more
//! than [`SPACING_TOLERANCE`] from the spacing at the node it comes from
//! (a spacing that changes across the wall keeps each side its own mesh).
//!
//! The later face's boundary nodes are then put exactly where the earlier
//! face's are carried (they matched within [`MATCH`]·d): four nodes of two
//! segments across a planar wall must be coplanar to the last bit, or the
//! Delaunay tetrahedralization makes a flat tetrahedron of them. Across a
//! curved wall those four nodes are not coplanar at all (the segments
//! across are skew): the volume stage splits the prisms of every wall
//! itself ([`Wall`], `volume::wall`).

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

/// A face's boundary as twinning compares it.
#[derive(Clone, Debug)]
struct Outline {
    /// Whether the surface is a plane (twins by a translation) or curved
    /// (twins by an offset along the normal).
    planar: bool,
    /// The unit normal at `origin` (the sign is the parametrization's);
    /// a plane's everywhere.
    normal: V3,
    /// The boundary nodes, each once, ascending.
    nodes: Vec<u32>,
    /// The boundary segments, each with its lower node first, sorted.
    segments: Vec<[u32; 2]>,
    /// The mean of the boundary nodes' positions.
    centroid: P3,
    /// A point of the surface from the surface alone (at
    /// [`inside_domain`]), not from the mesh.
    origin: P3,
    /// The least spacing at the boundary nodes.
    d: f64,
    /// The median spacing at the boundary nodes: the spacing the face's
    /// bubbles have, which a wall must be thinner than for no bubble to
    /// fit across it (the least is a short edge's or a small hole's, which
    /// grade the spacing down around them: a plate 1 thick whose corner
    /// edges are 1 long has a least spacing of 1 at any d).
    typical: f64,
}

/// The outline of every face that may have a twin: with no embedded edge
/// or vertex, its boundary meshed (`edge_nodes`, the nodes
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
            if !f.embedded_edges.is_empty() || !f.embedded_vertices.is_empty() || f.loops.is_empty()
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
            let mut ds: Vec<f64> = nodes
                .iter()
                .map(|&k| node_d.get(k as usize).copied().unwrap_or(f64::NAN))
                .collect();
            let d = ds.iter().copied().fold(f64::INFINITY, f64::min);
            let typical = *ds.select_nth_unstable_by(nodes.len() / 2, f64::total_cmp).1;
            (d.is_finite() && d > 0.0 && typical.is_finite()).then_some(Outline {
                planar: f.surface.is_planar(),
                normal,
                nodes,
                segments,
                centroid,
                origin,
                d,
                typical,
            })
        })
        .collect()
}

/// The space between two twin faces, as the volume stage asks of it: the
/// prisms between each of the earlier face's triangles (corners 0–2) and
/// its carried copy (corners 3–5, in the same order), and their corners'
/// node ids in the mesh.
#[derive(Clone, Debug)]
pub(crate) struct Wall {
    pub(crate) prisms: Vec<[P3; 6]>,
    pub(crate) ids: Vec<[u32; 6]>,
    shape: Shape,
}

/// What [`Wall::holds`] asks of a wall besides its prisms.
#[derive(Clone, Debug)]
enum Shape {
    /// Between two planes.
    Slab {
        /// The unit normal of the two planes.
        normal: V3,
        /// Where the earlier face's plane is along `normal` (p·normal).
        from: f64,
        /// How far the later face's plane is from it along `normal` (signed).
        across: f64,
    },
    /// Between a curved face and its offset, within the box `lo`–`hi`.
    Shell { lo: P3, hi: P3 },
}

impl Wall {
    /// Whether `p` lies between the two faces: strictly between them (by
    /// more than 1e-9 of the thickness) and, seen across, inside the face.
    pub(crate) fn holds(&self, p: &P3) -> bool {
        let base = |w: &[P3; 6]| [w[0], w[1], w[2]];
        match &self.shape {
            Shape::Slab {
                normal,
                from,
                across,
            } => {
                let s = (p.coords.dot(normal) - from) / across;
                if !(s > 1e-9 && s < 1.0 - 1e-9) {
                    return false;
                }
                // p's shadow on the earlier face's plane, in one of its triangles
                let q = p - normal * (s * across);
                self.prisms.iter().any(|w| in_triangle(&base(w), &q))
            }
            Shape::Shell { lo, hi } => {
                if (0..3).any(|i| p[i] < lo[i] || p[i] > hi[i]) {
                    return false;
                }
                self.prisms.iter().any(|w| {
                    // across the prism by its corners' mean offset
                    let o = ((w[3] - w[0]) + (w[4] - w[1]) + (w[5] - w[2])) / 3.0;
                    let n = (w[1] - w[0]).cross(&(w[2] - w[0]));
                    let s = (p - w[0]).dot(&n) / o.dot(&n);
                    s > 1e-9 && s < 1.0 - 1e-9 && in_triangle(&base(w), &(p - o * s))
                })
            }
        }
    }
}

/// Whether `q`, a point of the triangle's plane, is inside it (or on its
/// sides).
fn in_triangle([a, b, c]: &[P3; 3], q: &P3) -> bool {
    let n = (b - a).cross(&(c - a));
    let side = |u: &P3, v: &P3| (v - u).cross(&(q - u)).dot(&n) >= 0.0;
    side(a, b) && side(b, c) && side(c, a)
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
        let Some((a, offset, map)) = find(model, &self.outlines, &self.meshed, mesh, b) else {
            return;
        };
        // b's boundary nodes put exactly where a's are carried (module
        // docs; on as_0086 they were 1e-14 apart, and 24 flat tetrahedra
        // sent the volume to a refinement round), those a twin has not
        // pinned already
        let sa = model.faces[a].surface.as_ref();
        // a's boundary nodes carried across, once (the prisms take them too)
        let Some(across) = map
            .keys()
            .map(|&ka| Some((ka, offset.carry(sa, &mesh.nodes[ka as usize].pos, None)?)))
            .collect::<Option<HashMap<u32, P3>>>()
        else {
            return;
        };
        let snapped: Vec<(u32, P3)> = map
            .iter()
            .filter(|(_, kb)| !self.pinned.contains(kb))
            .map(|(ka, &kb)| (kb, across[ka]))
            .collect();
        let pinned: Vec<u32> = map.iter().flat_map(|(&ka, &kb)| [ka, kb]).collect();
        let d = [a, b]
            .iter()
            .filter_map(|&f| self.outlines[f].as_ref().map(|o| o.d))
            .fold(f64::INFINITY, f64::min);
        let Some((carried, (prisms, mut ids))) =
            carry(model, spacing, mesh, (a, offset, map, across), b, d)
        else {
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
        let Some(first) = prisms.first() else {
            return;
        };
        // b's own nodes numbered as `append_to` will number them
        let next = mesh.nodes.len() as u32;
        for c in ids.iter_mut().flat_map(|w| &mut w[3..]) {
            if *c >= FaceOut::OWN {
                *c = next + (*c - FaceOut::OWN);
            }
        }
        let shape = match offset {
            Offset::Translate(t) => {
                let Some(normal) = t.try_normalize(0.0) else {
                    return;
                };
                Shape::Slab {
                    from: first[0].coords.dot(&normal),
                    normal,
                    across: t.norm(),
                }
            }
            Offset::Normal(_) => {
                let (lo, hi) = crate::geom::bounds(prisms.iter().flatten());
                Shape::Shell { lo, hi }
            }
        };
        self.walls.push(Wall { prisms, ids, shape });
    }
}

/// How a twin's points are carried onto the other face.
#[derive(Clone, Copy, Debug)]
enum Offset {
    /// Planes: by this translation (along their normal).
    Translate(V3),
    /// Curved faces: by this signed distance along the earlier face's unit
    /// normal at the point (the later face is the earlier one's offset
    /// surface, as the two sides of a bent sheet: coaxial cylinders,
    /// concentric spheres).
    Normal(f64),
}

impl Offset {
    /// `p`, a point of `surface` at `params` (found by
    /// [`Surface::inverse`](crate::geom::Surface::inverse) when `None`),
    /// carried across. `None` where the normal is not defined there.
    fn carry(
        &self,
        surface: &dyn crate::geom::Surface,
        p: &P3,
        params: Option<[f64; 2]>,
    ) -> Option<P3> {
        match *self {
            Offset::Translate(t) => Some(p + t),
            Offset::Normal(t) => {
                let [u, v] = params.or_else(|| surface.inverse(p, None))?;
                let (_, su, sv) = surface.tangents(u, v);
                Some(p + su.cross(&sv).try_normalize(0.0)? * t)
            }
        }
    }
}

/// The earlier face whose mesh face `b` takes, carried across (see the
/// module docs): `(a, offset, boundary node of a → boundary node of b)`.
/// `meshed[a]` says which faces are in `mesh` now.
fn find(
    model: &Model,
    outlines: &[Option<Outline>],
    meshed: &[bool],
    mesh: &Mesh,
    b: usize,
) -> Option<(usize, Offset, HashMap<u32, u32>)> {
    let ob = outlines.get(b)?.as_ref()?;
    (0..b).find_map(|a| {
        let oa = outlines[a].as_ref()?;
        if !meshed[a]
            || oa.planar != ob.planar
            || oa.nodes.len() != ob.nodes.len()
            || oa.segments.len() != ob.segments.len()
        {
            return None;
        }
        let (d, typical) = (oa.d.min(ob.d), oa.typical.min(ob.typical));
        // `probe` carries a's boundary nodes to find their partners,
        // `offset` carries the mesh
        let (probe, offset) = if oa.planar {
            if oa.normal.cross(&ob.normal).norm() > 1e-9 {
                return None;
            }
            let t = ob.centroid - oa.centroid;
            let across = t.dot(&ob.normal);
            // along the normal, shorter than the spacing, not zero
            if (t - ob.normal * across).norm() > MATCH * d
                || !(across.abs() < typical)
                || across == 0.0
            {
                return None;
            }
            // the translation along the normal, from the two planes alone:
            // where the plane is normal to an axis, the carried nodes then
            // differ from theirs in that coordinate alone; and it does not
            // depend on where b's nodes are, so that snapping them twice (a
            // re-meshing of a twinned mesh) puts them where it put them once
            let across = (ob.origin - oa.origin).dot(&ob.normal);
            if !across.is_finite() {
                return None;
            }
            (Offset::Translate(t), Offset::Translate(ob.normal * across))
        } else {
            // each node moves by less than the spacing, so the centroids do
            if !((ob.centroid - oa.centroid).norm() < typical) {
                return None;
            }
            // the distance from a's origin to b's surface along a's normal
            // there, from the two surfaces alone (as for planes)
            let sb = model.faces[b].surface.as_ref();
            let q = sb.inverse(&oa.origin, None).map(|[u, v]| sb.point(u, v))?;
            let across = (q - oa.origin).dot(&oa.normal);
            if (q - oa.origin - oa.normal * across).norm() > MATCH * d
                || !(across.abs() < typical)
                || across == 0.0
            {
                return None;
            }
            (Offset::Normal(across), Offset::Normal(across))
        };
        let sa = model.faces[a].surface.as_ref();
        let carried: Vec<(u32, P3)> = oa
            .nodes
            .iter()
            .map(|&k| Some((k, probe.carry(sa, &mesh.nodes[k as usize].pos, None)?)))
            .collect::<Option<_>>()?;
        let map = match_nodes(mesh, &carried, &ob.nodes, MATCH * d)?;
        let mut segments: Vec<[u32; 2]> = oa
            .segments
            .iter()
            .map(|s| {
                let (p, q) = (map[&s[0]], map[&s[1]]);
                [p.min(q), p.max(q)]
            })
            .collect();
        segments.sort_unstable();
        (segments == ob.segments).then_some((a, offset, map))
    })
}

/// Each node of `from`, carried to its point, to the node of `to` within
/// `tol` of it, one to one; `None` where any has no partner.
fn match_nodes(mesh: &Mesh, from: &[(u32, P3)], to: &[u32], tol: f64) -> Option<HashMap<u32, u32>> {
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
    for &(k, p) in from {
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

/// The prisms between a face's triangles and their carried copies: their
/// corners (0–2 the triangle's, 3–5 their copies, in the same order) and
/// the corners' node ids (a carried node's as [`FaceOut`] numbers it).
type Prisms = (Vec<[P3; 6]>, Vec<[u32; 6]>);

/// Face `a`'s mesh (its triangles and own nodes in `mesh`) carried by
/// `offset` onto face `b`, boundary nodes through `map` (and carried to
/// `across`, where each node is kept once carried); triangles
/// counter-clockwise in `b`'s (u,v) as the face pipeline gives them; with
/// the prisms between `a`'s triangles as they are and carried (the wall's,
/// [`Wall`]). `None` where a carried node is not on `b`'s surface (within
/// [`MATCH`]·d), or the spacing there is not within [`SPACING_TOLERANCE`]
/// of its origin's.
fn carry(
    model: &Model,
    spacing: &dyn Spacing,
    mesh: &Mesh,
    (a, offset, map, mut across): (usize, Offset, HashMap<u32, u32>, HashMap<u32, P3>),
    b: usize,
    d: f64,
) -> Option<(FaceOut, Prisms)> {
    let (ea, eb) = (EntityRef::new(2, a as u32), EntityRef::new(2, b as u32));
    let (sa, surface) = (
        model.faces[a].surface.as_ref(),
        model.faces[b].surface.as_ref(),
    );
    let uniform = spacing.constant().is_some();
    let mut own: HashMap<u32, u32> = HashMap::new();
    let mut nodes = Vec::new();
    let mut triangles = Vec::new();
    let mut prisms = Vec::new();
    let mut ids = Vec::new();
    for tri in mesh.triangles.iter().filter(|e| e.entity == ea) {
        let mut prism = [P3::origin(); 6];
        for (i, &k) in tri.nodes.iter().enumerate() {
            let n = &mesh.nodes[k as usize];
            prism[i] = n.pos;
            prism[i + 3] = match across.get(&k) {
                Some(&p) => p,
                None => {
                    let p = offset.carry(sa, &n.pos, (n.entity == ea).then_some(n.params))?;
                    across.insert(k, p);
                    p
                }
            };
        }
        prisms.push(prism);
        let mut corners = [0u32; 3];
        for ((c, &k), pos) in corners.iter_mut().zip(&tri.nodes).zip(&prism[3..]) {
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
                        let pos = *pos;
                        let params = surface.inverse(&pos, None)?;
                        let [u, v] = params;
                        if !((surface.point(u, v) - pos).norm() <= MATCH * d) {
                            return None;
                        }
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
        ids.push([
            tri.nodes[0],
            tri.nodes[1],
            tri.nodes[2],
            corners[0],
            corners[1],
            corners[2],
        ]);
        triangles.push(corners);
    }
    if triangles.is_empty() {
        return None;
    }
    // counter-clockwise in b's (u,v): the sign of its normal su × sv (a
    // plane's anywhere, a curved face's at the triangle)
    let normal_at = |[u, v]: [f64; 2]| {
        let (_, su, sv) = surface.tangents(u, v);
        su.cross(&sv)
    };
    let plane = surface
        .is_planar()
        .then(|| normal_at(inside_domain(surface)));
    let pos = |c: u32| {
        if c >= FaceOut::OWN {
            nodes[(c - FaceOut::OWN) as usize].pos
        } else {
            mesh.nodes[c as usize].pos
        }
    };
    for tri in &mut triangles {
        let [p, q, r] = tri.map(pos);
        let n = match plane {
            Some(n) => n,
            None => {
                normal_at(surface.inverse(&P3::from((p.coords + q.coords + r.coords) / 3.0), None)?)
            }
        };
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
        (prisms, ids),
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
