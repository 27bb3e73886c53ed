//! Small geometry for engine tests that do not depend on the adapters.
#![allow(dead_code)]

use std::sync::Arc;

use bubblemesh_core::geom::{Curve, Plane, P3, V3};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex};
use bubblemesh_core::Mesh;

/// The segment a → b, t in [0, 1].
#[derive(Debug)]
pub struct Segment(pub P3, pub P3);

impl Curve for Segment {
    fn interval(&self) -> (f64, f64) {
        (0.0, 1.0)
    }
    fn point(&self, t: f64) -> P3 {
        self.0 + (self.1 - self.0) * t
    }
    fn d1(&self, _t: f64) -> V3 {
        self.1 - self.0
    }
    fn d2(&self, _t: f64) -> V3 {
        V3::zeros()
    }
}

/// The circle of centre c and radius r in the xy plane, t = angle.
#[derive(Debug)]
pub struct Circle(pub P3, pub f64);

impl Curve for Circle {
    fn interval(&self) -> (f64, f64) {
        (0.0, std::f64::consts::TAU)
    }
    fn point(&self, t: f64) -> P3 {
        self.0 + V3::new(t.cos(), t.sin(), 0.0) * self.1
    }
    fn d1(&self, t: f64) -> V3 {
        V3::new(-t.sin(), t.cos(), 0.0) * self.1
    }
    fn d2(&self, t: f64) -> V3 {
        V3::new(-t.cos(), -t.sin(), 0.0) * self.1
    }
}

/// Adds a closed polygon loop (ccw when `ccw`), returning the loop.
pub fn polygon_loop(m: &mut Model, pts: &[[f64; 2]]) -> Loop {
    let first = m.vertices.len() as u32;
    for p in pts {
        m.vertices.push(Vertex {
            point: P3::new(p[0], p[1], 0.0),
            name: None,
        });
    }
    let mut lp = Loop::default();
    for k in 0..pts.len() {
        let a = first + k as u32;
        let b = first + ((k + 1) % pts.len()) as u32;
        let curve = Arc::new(Segment(
            m.vertices[a as usize].point,
            m.vertices[b as usize].point,
        ));
        m.edges.push(Edge {
            curve,
            t0: 0.0,
            t1: 1.0,
            start: a,
            end: b,
            name: None,
        });
        lp.edges.push(EdgeUse {
            edge: m.edges.len() as u32 - 1,
            forward: true,
        });
    }
    lp
}

/// A circle loop run clockwise (a hole).
pub fn circle_hole(m: &mut Model, c: [f64; 2], r: f64) -> Loop {
    let v = m.vertices.len() as u32;
    m.vertices.push(Vertex {
        point: P3::new(c[0] + r, c[1], 0.0),
        name: None,
    });
    m.edges.push(Edge {
        curve: Arc::new(Circle(P3::new(c[0], c[1], 0.0), r)),
        t0: 0.0,
        t1: std::f64::consts::TAU,
        start: v,
        end: v,
        name: None,
    });
    Loop {
        edges: vec![EdgeUse {
            edge: m.edges.len() as u32 - 1,
            forward: false,
        }],
    }
}

pub fn face(m: &mut Model, loops: Vec<Loop>) {
    m.faces.push(Face {
        surface: Arc::new(Plane::xy()),
        loops,
        embedded_edges: vec![],
        embedded_vertices: vec![],
        name: None,
    });
}

pub fn square() -> Model {
    let mut m = Model::default();
    let l = polygon_loop(&mut m, &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    face(&mut m, vec![l]);
    m
}

pub fn hexagon() -> Model {
    let mut m = Model::default();
    let pts: Vec<[f64; 2]> = (0..6)
        .map(|k| {
            let a = k as f64 * std::f64::consts::PI / 3.0;
            [a.cos(), a.sin()]
        })
        .collect();
    let l = polygon_loop(&mut m, &pts);
    face(&mut m, vec![l]);
    m
}

pub fn plate_two_holes() -> Model {
    let mut m = Model::default();
    let l = polygon_loop(&mut m, &[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]);
    let h1 = circle_hole(&mut m, [0.5, 0.5], 0.2);
    let h2 = circle_hole(&mut m, [1.5, 0.5], 0.2);
    face(&mut m, vec![l, h1, h2]);
    m
}

/// Radius ratio 2 r_in / r_circ of every triangle.
pub fn radius_ratios(mesh: &Mesh) -> Vec<f64> {
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
            let a = (p[1] - p[2]).norm();
            let b = (p[0] - p[2]).norm();
            let c = (p[0] - p[1]).norm();
            let area = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
            let s = 0.5 * (a + b + c);
            let r_in = area / s;
            let r_circ = a * b * c / (4.0 * area);
            2.0 * r_in / r_circ
        })
        .collect()
}

/// Fraction of unique edges with L/d(midpoint) in [1/√2, √2], and mean L/d.
pub fn spacing_conformance(mesh: &Mesh, d: impl Fn(&P3) -> f64) -> (f64, f64) {
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t.nodes[k], t.nodes[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let mut inside = 0usize;
    let mut sum = 0.0;
    for (a, b) in &edges {
        let (pa, pb) = (mesh.nodes[*a as usize].pos, mesh.nodes[*b as usize].pos);
        let m = P3::from((pa.coords + pb.coords) * 0.5);
        let r = (pa - pb).norm() / d(&m);
        sum += r;
        if r >= std::f64::consts::FRAC_1_SQRT_2 && r <= std::f64::consts::SQRT_2 {
            inside += 1;
        }
    }
    (inside as f64 / edges.len() as f64, sum / edges.len() as f64)
}
