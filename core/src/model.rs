//! A non-manifold boundary representation: vertices, edges, faces and volumes
//! with stable ids, tied to geometry through the traits of [`crate::geom`].
//!
//! Ids are indices into the model's vectors (0-based) and never change once
//! the model is built; every mesh node and element records the `(dim, id)` of
//! the entity it came from (thesis Fig. 1.12b).

use std::sync::Arc;

use crate::geom::{Curve, Surface, VolumeGeometry, P3};

/// The dimension and id of a model entity: 0 vertex, 1 edge, 2 face, 3 volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EntityRef {
    /// Dimension: 0 vertex, 1 edge, 2 face, 3 volume.
    pub dim: u8,
    /// Index into the model's list of entities of that dimension.
    pub id: u32,
}

impl EntityRef {
    /// The entity `id` of dimension `dim`.
    pub fn new(dim: u8, id: u32) -> Self {
        EntityRef { dim, id }
    }
}

impl std::fmt::Display for EntityRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let kind = ["vertex", "edge", "face", "volume"][self.dim.min(3) as usize];
        write!(f, "{kind} {}", self.id)
    }
}

/// A model vertex: a fixed point (a vertex bubble, thesis §3.2.3 step 1).
#[derive(Clone, Debug)]
pub struct Vertex {
    /// Position, in model units.
    pub point: P3,
    /// The name the input gave it (a STEP product or entity name), if any.
    pub name: Option<String>,
}

/// A model edge: the piece `[t0, t1]` of a curve from vertex `start` to
/// vertex `end`. A closed edge has `start == end`.
///
/// Invariant: `curve.point(t0) == vertices[start].point` and
/// `curve.point(t1) == vertices[end].point` to within the model tolerance.
#[derive(Clone, Debug)]
pub struct Edge {
    /// The carrier curve.
    pub curve: Arc<dyn Curve>,
    /// Curve parameter at the start vertex.
    pub t0: f64,
    /// Curve parameter at the end vertex (`t1 > t0`).
    pub t1: f64,
    /// Index of the start vertex.
    pub start: u32,
    /// Index of the end vertex.
    pub end: u32,
    /// The name the input gave it (a STEP product or entity name), if any.
    pub name: Option<String>,
}

/// One use of an edge in a face loop.
#[derive(Clone, Copy, Debug)]
pub struct EdgeUse {
    /// Index of the edge.
    pub edge: u32,
    /// `true` when the loop runs from the edge's start to its end.
    pub forward: bool,
}

/// A closed chain of edge uses bounding a face. Outer loops run
/// counter-clockwise in (u,v), holes clockwise; the engine does not rely on
/// this orientation (it classifies by winding number), but writers and
/// adapters keep it.
#[derive(Clone, Debug, Default)]
pub struct Loop {
    /// The edge uses in order along the loop.
    pub edges: Vec<EdgeUse>,
}

/// A model face: a trimmed region of a surface.
#[derive(Clone, Debug)]
pub struct Face {
    /// The carrier surface; the face is the part of its (u,v) domain inside
    /// the loops.
    pub surface: Arc<dyn Surface>,
    /// Boundary loops: the first is the outer loop, the others holes.
    pub loops: Vec<Loop>,
    /// Constraint edges inside the face that the mesh must contain
    /// (thesis Fig. 1.14).
    pub embedded_edges: Vec<u32>,
    /// Constraint points inside the face that the mesh must contain.
    pub embedded_vertices: Vec<u32>,
    /// The name the input gave it (a STEP product or entity name), if any.
    pub name: Option<String>,
}

/// A model volume bounded by faces.
#[derive(Clone, Debug)]
pub struct Volume {
    /// Indices of the faces that bound it (its closed shell or shells).
    pub faces: Vec<u32>,
    /// An exact inside/outside answer, where the adapter has one.
    pub geometry: Option<Arc<dyn VolumeGeometry>>,
    /// The name the input gave it (a STEP product or entity name), if any.
    pub name: Option<String>,
}

/// The model handed to the engine.
#[derive(Clone, Debug, Default)]
pub struct Model {
    /// Vertices, indexed by [`EntityRef::id`] with dimension 0.
    pub vertices: Vec<Vertex>,
    /// Edges (dimension 1).
    pub edges: Vec<Edge>,
    /// Faces (dimension 2).
    pub faces: Vec<Face>,
    /// Volumes (dimension 3).
    pub volumes: Vec<Volume>,
    /// Parameter-space curves: for (face, edge), the curve in the face's
    /// (u,v) whose image is the edge (its x, y are u, v), on the edge's own
    /// parameter range. Optional; where absent the engine maps edge nodes
    /// to (u,v) with [`crate::geom::Surface::inverse`].
    pub pcurves: std::collections::HashMap<(u32, u32), Arc<dyn Curve>>,
    /// Where the model came from (a file path), for error messages.
    pub source: Option<String>,
}

impl Model {
    /// The highest dimension with at least one entity (0 for an empty model).
    pub fn dim(&self) -> u8 {
        if !self.volumes.is_empty() {
            3
        } else if !self.faces.is_empty() {
            2
        } else if !self.edges.is_empty() {
            1
        } else {
            0
        }
    }

    /// A human name of an entity for messages: `face 2 ("plate")`.
    pub fn describe(&self, e: EntityRef) -> String {
        let name = match e.dim {
            0 => self
                .vertices
                .get(e.id as usize)
                .and_then(|v| v.name.clone()),
            1 => self.edges.get(e.id as usize).and_then(|v| v.name.clone()),
            2 => self.faces.get(e.id as usize).and_then(|v| v.name.clone()),
            _ => self.volumes.get(e.id as usize).and_then(|v| v.name.clone()),
        };
        match name {
            Some(n) => format!("{e} (\"{n}\")"),
            None => e.to_string(),
        }
    }

    /// Two distinct vertices of face `f`'s loops that lie within `tol` of
    /// each other and are joined by none of its edges: the face's boundary
    /// touches itself there (a hole tangent to the outer loop, written with
    /// a vertex of its own at the touching point). No conforming mesh keeps
    /// two nodes at one point apart, so such a face cannot be meshed as
    /// given.
    pub fn pinch(&self, f: usize, tol: f64) -> Option<(u32, u32)> {
        let face = self.faces.get(f)?;
        let uses = || face.loops.iter().flat_map(|l| &l.edges);
        let mut verts: Vec<u32> = uses()
            .flat_map(|u| {
                let e = &self.edges[u.edge as usize];
                [e.start, e.end]
            })
            .collect();
        verts.sort_unstable();
        verts.dedup();
        let joined = |a: u32, b: u32| {
            uses().any(|u| {
                let e = &self.edges[u.edge as usize];
                (e.start, e.end) == (a, b) || (e.start, e.end) == (b, a)
            })
        };
        // sorted by x, only pairs within `tol` in x are compared
        let x = |v: u32| self.vertices[v as usize].point.x;
        verts.sort_by(|&a, &b| x(a).total_cmp(&x(b)));
        for (k, &a) in verts.iter().enumerate() {
            for &b in &verts[k + 1..] {
                if x(b) - x(a) > tol {
                    break;
                }
                let (pa, pb) = (
                    self.vertices[a as usize].point,
                    self.vertices[b as usize].point,
                );
                if (pa - pb).norm() <= tol && !joined(a, b) {
                    return Some((a.min(b), a.max(b)));
                }
            }
        }
        None
    }

    /// Axis-aligned bounding box of the vertices, sampled edges and sampled
    /// faces (where their parameter domain is finite).
    pub fn bbox(&self) -> Option<(P3, P3)> {
        let mut lo = P3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = P3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        let mut any = false;
        let mut add = |p: P3| {
            any = true;
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        };
        for v in &self.vertices {
            add(v.point);
        }
        for e in &self.edges {
            for k in 0..=32 {
                let t = e.t0 + (e.t1 - e.t0) * k as f64 / 32.0;
                add(e.curve.point(t));
            }
        }
        // closed faces have no edges: sample their surfaces (finite domains)
        for f in &self.faces {
            let (u, v) = f.surface.domain();
            if !(u[0].is_finite() && u[1].is_finite() && v[0].is_finite() && v[1].is_finite()) {
                continue;
            }
            for i in 0..=8 {
                for j in 0..=8 {
                    let p = f.surface.point(
                        u[0] + (u[1] - u[0]) * i as f64 / 8.0,
                        v[0] + (v[1] - v[0]) * j as f64 / 8.0,
                    );
                    if p.iter().all(|x| x.is_finite()) {
                        add(p);
                    }
                }
            }
        }
        any.then_some((lo, hi))
    }

    /// Length of the bounding-box diagonal (0 for an empty model).
    pub fn size(&self) -> f64 {
        self.bbox().map(|(a, b)| (b - a).norm()).unwrap_or(0.0)
    }
}
