//! The mesh model: nodes and elements, each tagged with the model entity it
//! came from (thesis Fig. 1.12b).
//!
//! Invariants:
//! - every element index is `< nodes.len()`;
//! - triangles of a face are oriented counter-clockwise with respect to the
//!   face's (u,v) parameters (for 2D domains: counter-clockwise in x, y);
//! - tetrahedra have positive volume (right-handed);
//! - `entities` lists every entity that owns a node or an element, with its
//!   boundary (the signed, 1-based tags Gmsh's MSH 4.1 `$Entities` wants).

use crate::geom::P3;
use crate::model::{EntityRef, Model};

/// A mesh node.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    /// Position, in model units.
    pub pos: P3,
    /// The entity the node lies on (a vertex, an edge, a face or a volume).
    pub entity: EntityRef,
    /// Parameters on that entity: `[t, 0]`, `[u, v]`, unused otherwise.
    pub params: [f64; 2],
}

/// An element: node indices and the entity it meshes.
#[derive(Clone, Copy, Debug)]
pub struct Element<const N: usize> {
    /// Indices into [`Mesh::nodes`]; triangles counter-clockwise seen from
    /// outside their volume, tetrahedra positively oriented.
    pub nodes: [u32; N],
    /// The model entity the element meshes.
    pub entity: EntityRef,
}

/// A model entity as the writers need it.
#[derive(Clone, Debug)]
pub struct EntityInfo {
    /// Which entity.
    pub entity: EntityRef,
    /// Signed 1-based tags of the bounding entities of dimension `dim - 1`
    /// (negative: used reversed).
    pub boundary: Vec<i32>,
    /// The entity's name in the model, if any.
    pub name: Option<String>,
}

/// A simplicial mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Every node, once.
    pub nodes: Vec<Node>,
    /// Line segments on edges.
    pub lines: Vec<Element<2>>,
    /// Triangles on faces.
    pub triangles: Vec<Element<3>>,
    /// Tetrahedra in volumes.
    pub tetrahedra: Vec<Element<4>>,
    /// The model's entities with their boundaries, for the writers.
    pub entities: Vec<EntityInfo>,
}

impl Mesh {
    /// The highest element dimension present.
    pub fn dim(&self) -> u8 {
        if !self.tetrahedra.is_empty() {
            3
        } else if !self.triangles.is_empty() {
            2
        } else if !self.lines.is_empty() {
            1
        } else {
            0
        }
    }

    /// Fills `entities` from the model's topology (every entity of the model,
    /// with its boundary).
    pub fn set_entities_from(&mut self, model: &Model) {
        let mut out = Vec::new();
        for (i, v) in model.vertices.iter().enumerate() {
            out.push(EntityInfo {
                entity: EntityRef::new(0, i as u32),
                boundary: vec![],
                name: v.name.clone(),
            });
        }
        for (i, e) in model.edges.iter().enumerate() {
            let mut b = vec![e.start as i32 + 1];
            if e.end != e.start {
                b.push(-(e.end as i32 + 1));
            }
            out.push(EntityInfo {
                entity: EntityRef::new(1, i as u32),
                boundary: b,
                name: e.name.clone(),
            });
        }
        for (i, f) in model.faces.iter().enumerate() {
            let b = f
                .loops
                .iter()
                .flat_map(|l| l.edges.iter())
                .map(|u| {
                    let t = u.edge as i32 + 1;
                    if u.forward {
                        t
                    } else {
                        -t
                    }
                })
                .collect();
            out.push(EntityInfo {
                entity: EntityRef::new(2, i as u32),
                boundary: b,
                name: f.name.clone(),
            });
        }
        for (i, v) in model.volumes.iter().enumerate() {
            out.push(EntityInfo {
                entity: EntityRef::new(3, i as u32),
                boundary: v.faces.iter().map(|f| *f as i32 + 1).collect(),
                name: v.name.clone(),
            });
        }
        self.entities = out;
    }

    /// Axis-aligned bounding box of the nodes.
    pub fn bbox(&self) -> Option<(P3, P3)> {
        let first = self.nodes.first()?.pos;
        let (mut lo, mut hi) = (first, first);
        for n in &self.nodes {
            for k in 0..3 {
                lo[k] = lo[k].min(n.pos[k]);
                hi[k] = hi[k].max(n.pos[k]);
            }
        }
        Some((lo, hi))
    }
}
