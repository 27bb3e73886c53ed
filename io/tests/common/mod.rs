//! A small mesh with lines, triangles and tetrahedra on distinct entities.
#![allow(dead_code)]

use bubblemesh_core::mesh::{Element, EntityInfo, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

/// Corner `i` of a unit cube scaled and shifted so coordinates are not
/// round numbers: bits of i give x, y, z.
pub fn corner(i: u32) -> P3 {
    let b = |k: u32| ((i >> k) & 1) as f64;
    P3::new(1.0 / 3.0 + 0.7 * b(0), -2.5 + 0.7 * b(1), 0.1 + 0.7 * b(2))
}

fn e(dim: u8, id: u32) -> EntityRef {
    EntityRef::new(dim, id)
}

/// The cube split into the 6 Kuhn tetrahedra (positively oriented), with:
/// - the bottom face (z = min, nodes 0 1 3 2) as 2 triangles on face 0;
/// - its 4 edges as lines on edges 0..3;
/// - bottom corners on vertices 0..3, the top ones in volume 0;
/// - entities with boundaries and a name.
pub fn sample_mesh() -> Mesh {
    let vertex_of = [Some(0), Some(1), Some(3), Some(2)];
    let nodes: Vec<Node> = (0..8)
        .map(|i| Node {
            pos: corner(i),
            entity: match vertex_of.get(i as usize) {
                Some(Some(v)) => e(0, *v),
                _ => e(3, 0),
            },
            params: [0.0, 0.0],
        })
        .collect();
    let mut tets = Vec::new();
    for perm in [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ] {
        let mut v = vec![0u32];
        let mut cur = 0u32;
        for ax in perm {
            cur |= 1 << ax;
            v.push(cur);
        }
        let mut t = [v[0], v[1], v[2], v[3]];
        if signed_volume(&nodes, t) < 0.0 {
            t.swap(0, 1);
        }
        tets.push(Element {
            nodes: t,
            entity: e(3, 0),
        });
    }
    let lines = [[0, 1], [1, 3], [3, 2], [2, 0]]
        .iter()
        .enumerate()
        .map(|(k, &nodes)| Element {
            nodes,
            entity: e(1, k as u32),
        })
        .collect();
    let triangles = vec![
        Element {
            nodes: [0, 1, 3],
            entity: e(2, 0),
        },
        Element {
            nodes: [0, 3, 2],
            entity: e(2, 0),
        },
    ];
    let mut entities: Vec<EntityInfo> = (0..4)
        .map(|k| EntityInfo {
            entity: e(0, k),
            boundary: vec![],
            name: None,
        })
        .collect();
    // Edge k runs from vertex k to vertex k+1 (mod 4).
    for k in 0..4i32 {
        entities.push(EntityInfo {
            entity: e(1, k as u32),
            boundary: vec![k + 1, -((k + 1) % 4 + 1)],
            name: None,
        });
    }
    entities.push(EntityInfo {
        entity: e(2, 0),
        boundary: vec![1, 2, 3, 4],
        name: Some("bottom".into()),
    });
    entities.push(EntityInfo {
        entity: e(3, 0),
        boundary: vec![1],
        name: None,
    });
    Mesh {
        nodes,
        lines,
        triangles,
        tetrahedra: tets,
        entities,
    }
}

/// The sample mesh without lines and triangles.
pub fn tet_only() -> Mesh {
    let mut m = sample_mesh();
    m.lines.clear();
    m.triangles.clear();
    m.entities.clear();
    for n in &mut m.nodes {
        n.entity = EntityRef::new(3, 0);
    }
    m
}

pub fn signed_volume(nodes: &[Node], t: [u32; 4]) -> f64 {
    let p = t.map(|i| nodes[i as usize].pos);
    (p[1] - p[0]).dot(&(p[2] - p[0]).cross(&(p[3] - p[0]))) / 6.0
}

/// Volume enclosed by a closed triangle surface (divergence theorem):
/// positive when the triangles are oriented outward.
pub fn enclosed_volume(m: &Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.nodes.map(|i| m.nodes[i as usize].pos.coords);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum()
}

/// Whether python3 can import all the modules.
pub fn python_has(modules: &str) -> bool {
    std::process::Command::new("python3")
        .arg("-c")
        .arg(format!("import {modules}"))
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}
