//! Small geometry for engine tests that do not depend on the adapters.
#![allow(dead_code)]

use std::sync::Arc;

use bubblemesh_core::geom::{Curve, Plane, P3, V3};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex};
use bubblemesh_core::Mesh;

pub use bubblemesh_core::geom::Segment;

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
        if (std::f64::consts::FRAC_1_SQRT_2..=std::f64::consts::SQRT_2).contains(&r) {
            inside += 1;
        }
    }
    (inside as f64 / edges.len() as f64, sum / edges.len() as f64)
}

/// Unit-frame sphere: S = c + r (cos v cos u, cos v sin u, sin v).
#[derive(Debug)]
pub struct Sphere(pub f64);

impl bubblemesh_core::geom::Surface for Sphere {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        let h = std::f64::consts::FRAC_PI_2;
        ([0.0, std::f64::consts::TAU], [-h, h])
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        P3::new(v.cos() * u.cos(), v.cos() * u.sin(), v.sin()) * self.0
    }
    fn derivs(&self, u: f64, v: f64) -> bubblemesh_core::geom::SurfaceDerivs {
        let r = self.0;
        let (cu, su, cv, sv) = (u.cos(), u.sin(), v.cos(), v.sin());
        bubblemesh_core::geom::SurfaceDerivs {
            p: self.point(u, v),
            su: V3::new(-cv * su, cv * cu, 0.0) * r,
            sv: V3::new(-sv * cu, -sv * su, cv) * r,
            suu: V3::new(-cv * cu, -cv * su, 0.0) * r,
            suv: V3::new(sv * su, -sv * cu, 0.0) * r,
            svv: V3::new(-cv * cu, -cv * su, -sv) * r,
        }
    }
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        let n = p.coords.norm();
        if n == 0.0 {
            return None;
        }
        let v = (p.z / n).clamp(-1.0, 1.0).asin();
        let u = if p.x.hypot(p.y) < 1e-14 * n {
            hint.map(|h| h[0]).unwrap_or(0.0)
        } else {
            p.y.atan2(p.x)
        };
        Some([u.rem_euclid(std::f64::consts::TAU), v])
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [Some(std::f64::consts::TAU), None]
    }
    fn is_singular(&self, _u: f64, v: f64) -> bool {
        v.abs() >= std::f64::consts::FRAC_PI_2 - 1e-12
    }
    fn singular_points(&self) -> Vec<P3> {
        vec![P3::new(0.0, 0.0, self.0), P3::new(0.0, 0.0, -self.0)]
    }
}

/// Torus about z: S = ((R + r cos v) cos u, (R + r cos v) sin u, r sin v).
#[derive(Debug)]
pub struct Torus(pub f64, pub f64);

impl bubblemesh_core::geom::Surface for Torus {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        ([0.0, std::f64::consts::TAU], [0.0, std::f64::consts::TAU])
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        let w = self.0 + self.1 * v.cos();
        P3::new(w * u.cos(), w * u.sin(), self.1 * v.sin())
    }
    fn derivs(&self, u: f64, v: f64) -> bubblemesh_core::geom::SurfaceDerivs {
        let (big, r) = (self.0, self.1);
        let (cu, su, cv, sv) = (u.cos(), u.sin(), v.cos(), v.sin());
        let w = big + r * cv;
        bubblemesh_core::geom::SurfaceDerivs {
            p: self.point(u, v),
            su: V3::new(-w * su, w * cu, 0.0),
            sv: V3::new(-r * sv * cu, -r * sv * su, r * cv),
            suu: V3::new(-w * cu, -w * su, 0.0),
            suv: V3::new(r * sv * su, -r * sv * cu, 0.0),
            svv: V3::new(-r * cv * cu, -r * cv * su, -r * sv),
        }
    }
    fn inverse(&self, p: &P3, _hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        let u = p.y.atan2(p.x);
        let rho = p.x.hypot(p.y) - self.0;
        let v = p.z.atan2(rho);
        Some([
            u.rem_euclid(std::f64::consts::TAU),
            v.rem_euclid(std::f64::consts::TAU),
        ])
    }
    fn periods(&self) -> [Option<f64>; 2] {
        [Some(std::f64::consts::TAU), Some(std::f64::consts::TAU)]
    }
}

pub fn closed_surface(s: Arc<dyn bubblemesh_core::geom::Surface>) -> Model {
    let mut m = Model::default();
    m.faces.push(Face {
        surface: s,
        loops: vec![],
        embedded_edges: vec![],
        embedded_vertices: vec![],
        name: None,
    });
    m
}
