//! Small meshes built by hand: a planar grid, an icosphere, a cube of
//! tetrahedra.

#![allow(dead_code)]

use bubblemesh_core::mesh::{Element, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

fn node(p: P3, e: EntityRef) -> Node {
    Node {
        pos: p,
        entity: e,
        params: [p.x, p.y],
    }
}

/// The unit square as an n×n grid of right triangles, the left half on
/// face 0 and the right half on face 1, with the boundary as lines of edge 0.
pub fn grid(n: usize) -> Mesh {
    let mut m = Mesh::default();
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..=n {
        for i in 0..=n {
            let p = P3::new(i as f64 / n as f64, j as f64 / n as f64, 0.0);
            m.nodes.push(node(p, EntityRef::new(2, 0)));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let e = EntityRef::new(2, if 2 * i < n { 0 } else { 1 });
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            m.triangles.push(Element {
                nodes: [a, b, c],
                entity: e,
            });
            m.triangles.push(Element {
                nodes: [a, c, d],
                entity: e,
            });
        }
    }
    let ring: Vec<u32> = (0..n)
        .map(|i| id(i, 0))
        .chain((0..n).map(|j| id(n, j)))
        .chain((0..n).map(|i| id(n - i, n)))
        .chain((0..n).map(|j| id(0, n - j)))
        .collect();
    for k in 0..ring.len() {
        m.lines.push(Element {
            nodes: [ring[k], ring[(k + 1) % ring.len()]],
            entity: EntityRef::new(1, 0),
        });
    }
    m
}

/// A unit sphere: an icosahedron subdivided `levels` times, outward
/// oriented, all on face 0.
pub fn icosphere(levels: usize) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pts: Vec<P3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| P3::from(nalgebra::Vector3::new(x, y, z).normalize()))
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for t in &tris {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[k] = *mid.entry(key).or_insert_with(|| {
                    let p = nalgebra::center(&pts[a as usize], &pts[b as usize]);
                    pts.push(P3::from(p.coords.normalize()));
                    (pts.len() - 1) as u32
                });
            }
            next.push([t[0], m[0], m[2]]);
            next.push([t[1], m[1], m[0]]);
            next.push([t[2], m[2], m[1]]);
            next.push([m[0], m[1], m[2]]);
        }
        tris = next;
    }
    let e = EntityRef::new(2, 0);
    Mesh {
        nodes: pts.into_iter().map(|p| node(p, e)).collect(),
        triangles: tris
            .into_iter()
            .map(|nodes| Element { nodes, entity: e })
            .collect(),
        ..Default::default()
    }
}

/// The unit cube as n³ cells of 6 positively oriented tetrahedra each
/// (Kuhn's subdivision, conforming), on volume 0.
pub fn cube_tets(n: usize) -> Mesh {
    let mut m = Mesh::default();
    let id = |i: usize, j: usize, k: usize| ((k * (n + 1) + j) * (n + 1) + i) as u32;
    let e = EntityRef::new(3, 0);
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                let p = P3::new(i as f64, j as f64, k as f64) / n as f64;
                m.nodes.push(node(p, e));
            }
        }
    }
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                for p in perms {
                    let mut c = [i, j, k];
                    let mut t = [id(c[0], c[1], c[2]); 4];
                    for (s, &axis) in p.iter().enumerate() {
                        c[axis] += 1;
                        t[s + 1] = id(c[0], c[1], c[2]);
                    }
                    let q = t.map(|v| m.nodes[v as usize].pos);
                    let vol = (q[1] - q[0]).dot(&(q[2] - q[0]).cross(&(q[3] - q[0])));
                    if vol < 0.0 {
                        t.swap(2, 3);
                    }
                    m.tetrahedra.push(Element {
                        nodes: t,
                        entity: e,
                    });
                }
            }
        }
    }
    m
}
