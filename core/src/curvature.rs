//! Curvature-based node spacing (thesis §4.6, eq. 4.6.1, 5.1.1–5.1.2) and
//! view-based spacing (eq. 4.6.2).
//!
//! A chord of length d on a circle of radius ρ deviates from the arc by the
//! sagitta ε = ρ − √(ρ² − d²/4); solved for d,
//!
//! d = 2 √(2 ε ρ − ε²)   (eq. 5.1.1),
//!
//! so a mesh whose edges follow this d stays within ε of the geometry. On a
//! surface ρ is the *minimum* radius of curvature, 1/max(|κ1|, |κ2|) from
//! the principal curvatures (eq. 5.1.2); on a curve, 1/κ. Where ρ ≤ ε/2
//! the formula has no solution and d = d_min; flat places get d_max.
//!
//! Triangles, not segments: eq. 4.6.1 bounds the sagitta of an *edge*, but
//! a triangle's interior lies farther from the sphere than its edges — an
//! equilateral triangle of side L deviates by about R_c²/(2ρ) at its
//! circumcentre, R_c = L/√3, which is 4/3 of the edge's L²/(8ρ). Spacing
//! from [`Curvature`] therefore solves the sagitta equation for the
//! circumradius and takes L = √3·√(2ερ − ε²) = (√3/2)·d_c, so the distance
//! from every triangle to the surface is ε (not 4ε/3) for a near-equilateral
//! mesh.
//!
//! Units: ε, d_min, d_max in model units. Invariant: the returned spacing is
//! in [d_min, d_max].

use std::sync::Arc;

use crate::geom::{SurfaceDerivs, P3};
use crate::model::Model;
use crate::spacing::{Spacing, SpacingQuery};

/// Curvature of a surface point: the larger principal curvature in absolute
/// value, from the first and second fundamental forms. `None` at a singular
/// point (S_u × S_v = 0).
pub fn max_principal_curvature(s: &SurfaceDerivs) -> Option<f64> {
    let n = s.su.cross(&s.sv);
    let nn = n.norm();
    if !(nn > 0.0) {
        return None;
    }
    let n = n / nn;
    let (e, f, g) = (s.su.dot(&s.su), s.su.dot(&s.sv), s.sv.dot(&s.sv));
    let (l, m, nn2) = (s.suu.dot(&n), s.suv.dot(&n), s.svv.dot(&n));
    let det = e * g - f * f;
    if !(det > 0.0) {
        return None;
    }
    let h = (e * nn2 - 2.0 * f * m + g * l) / (2.0 * det);
    let k = (l * nn2 - m * m) / det;
    let disc = (h * h - k).max(0.0).sqrt();
    Some((h + disc).abs().max((h - disc).abs()))
}

/// Spacing of eq. 5.1.1 for curvature κ, clamped to [d_min, d_max].
pub fn chord_spacing(kappa: f64, eps: f64, d_min: f64, d_max: f64) -> f64 {
    if !(kappa > 0.0) {
        return d_max;
    }
    let rho = 1.0 / kappa;
    if rho <= 0.5 * eps {
        return d_min;
    }
    (2.0 * (2.0 * eps * rho - eps * eps).sqrt()).clamp(d_min, d_max)
}

/// The packing's edges spread around d (L/d up to about 1.2 on curved
/// faces, `bench/`), and the deviation grows as L², so the spacing asked
/// for is this fraction of the ideal edge.
pub const SPREAD_MARGIN: f64 = 1.0 / 1.2;

/// Edge length whose equilateral triangles stay within ε of a sphere of
/// curvature κ (see the module docs): (√3/2)·eq. 5.1.1 with the margin
/// [`SPREAD_MARGIN`] for the spread of edge lengths, clamped.
pub fn triangle_spacing(kappa: f64, eps: f64, d_min: f64, d_max: f64) -> f64 {
    if !(kappa > 0.0) {
        return d_max;
    }
    (SPREAD_MARGIN * 0.5 * 3f64.sqrt() * chord_spacing(kappa, eps, 0.0, f64::INFINITY))
        .clamp(d_min, d_max)
}

/// d from the curvature of the entity a point lies on.
pub struct Curvature {
    pub model: Arc<Model>,
    /// Allowed distance from the mesh to the geometry (ε).
    pub eps: f64,
    pub d_min: f64,
    pub d_max: f64,
    /// Spacing at each model vertex: the smallest over the edges that end
    /// there (a vertex bubble sits on all of them).
    vertex_d: Vec<f64>,
    /// Faces each edge bounds: an edge bubble also sits on them, so its
    /// spacing is the smallest of the curve's and those surfaces'.
    edge_faces: Vec<Vec<u32>>,
}

impl Curvature {
    pub fn new(model: Arc<Model>, eps: f64, d_min: f64, d_max: f64) -> Self {
        let mut edge_faces = vec![Vec::new(); model.edges.len()];
        for (fi, f) in model.faces.iter().enumerate() {
            for u in f.loops.iter().flat_map(|l| l.edges.iter()) {
                if let Some(v) = edge_faces.get_mut(u.edge as usize) {
                    if !v.contains(&(fi as u32)) {
                        v.push(fi as u32);
                    }
                }
            }
            for &e in &f.embedded_edges {
                if let Some(v) = edge_faces.get_mut(e as usize) {
                    v.push(fi as u32);
                }
            }
        }
        let mut c = Curvature {
            model: model.clone(),
            eps,
            d_min,
            d_max,
            vertex_d: vec![d_max; model.vertices.len()],
            edge_faces,
        };
        for (ei, e) in model.edges.iter().enumerate() {
            for (v, t) in [(e.start, e.t0), (e.end, e.t1)] {
                let d = c.edge_spacing(ei, t);
                let slot = &mut c.vertex_d[v as usize];
                *slot = slot.min(d);
            }
        }
        c
    }

    /// Spacing on a face at (u,v) from the surface's largest curvature.
    fn face_spacing(&self, fi: usize, uv: [f64; 2]) -> f64 {
        let Some(f) = self.model.faces.get(fi) else {
            return self.d_max;
        };
        let s = f.surface.derivs(uv[0], uv[1]);
        match max_principal_curvature(&s) {
            Some(k) => triangle_spacing(k, self.eps, self.d_min, self.d_max),
            // a pole or an apex: the curvature of a point a hair away (the
            // limit of the surrounding values)
            None => {
                let (u, v) = f.surface.domain();
                let mid = [0.5 * (u[0] + u[1]), 0.5 * (v[0] + v[1])];
                let p = [
                    uv[0] + 1e-6 * (mid[0] - uv[0]),
                    uv[1] + 1e-6 * (mid[1] - uv[1]),
                ];
                let s = f.surface.derivs(p[0], p[1]);
                max_principal_curvature(&s)
                    .map(|k| triangle_spacing(k, self.eps, self.d_min, self.d_max))
                    .unwrap_or(self.d_min)
            }
        }
    }

    /// Spacing on an edge at parameter t: the curve's, and that of every
    /// face the edge bounds (its (u,v) from the pcurve or by inversion).
    fn edge_spacing(&self, ei: usize, t: f64) -> f64 {
        let Some(e) = self.model.edges.get(ei) else {
            return self.d_max;
        };
        let mut d = triangle_spacing(
            curve_curvature(e.curve.as_ref(), t),
            self.eps,
            self.d_min,
            self.d_max,
        );
        let p = e.curve.point(t);
        for &fi in &self.edge_faces[ei] {
            let uv = match self.model.pcurves.get(&(fi, ei as u32)) {
                Some(pc) => {
                    let q = pc.point(t);
                    Some([q.x, q.y])
                }
                None => self.model.faces[fi as usize].surface.inverse(&p, None),
            };
            if let Some(uv) = uv {
                d = d.min(self.face_spacing(fi as usize, uv));
            }
        }
        d
    }
}

fn curve_curvature(c: &dyn crate::geom::Curve, t: f64) -> f64 {
    let d1 = c.d1(t);
    let n = d1.norm();
    if !(n > 0.0) {
        return 0.0;
    }
    d1.cross(&c.d2(t)).norm() / (n * n * n)
}

impl Spacing for Curvature {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        let id = q.entity.id as usize;
        match q.entity.dim {
            0 => self.vertex_d.get(id).copied().unwrap_or(self.d_max),
            1 => self.edge_spacing(id, q.params[0]),
            2 => self.face_spacing(id, q.params),
            _ => self.d_max,
        }
    }
}

/// View-based spacing d = a·|V0 − x| (eq. 4.6.2), clamped to [d_min, d_max]:
/// small elements near the viewpoint V0, large far away.
pub struct View {
    pub viewpoint: P3,
    pub factor: f64,
    pub d_min: f64,
    pub d_max: f64,
}

impl Spacing for View {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        (self.factor * (q.point - self.viewpoint).norm()).clamp(self.d_min, self.d_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::V3;

    #[test]
    fn sagitta_of_the_chord_is_eps() {
        // on a circle of radius 2, a chord of length d has sagitta eps
        let (rho, eps) = (2.0, 0.01);
        let d = chord_spacing(1.0 / rho, eps, 1e-6, 1e6);
        let sagitta = rho - (rho * rho - d * d / 4.0).sqrt();
        assert!((sagitta - eps).abs() < 1e-12);
    }

    #[test]
    fn sphere_curvature_is_one_over_radius() {
        // sphere of radius 3 at (u, v) = (0.3, 0.4)
        let r = 3.0;
        let (u, v) = (0.3f64, 0.4f64);
        let (cu, su, cv, sv) = (u.cos(), u.sin(), v.cos(), v.sin());
        let s = SurfaceDerivs {
            p: P3::new(r * cv * cu, r * cv * su, r * sv),
            su: V3::new(-r * cv * su, r * cv * cu, 0.0),
            sv: V3::new(-r * sv * cu, -r * sv * su, r * cv),
            suu: V3::new(-r * cv * cu, -r * cv * su, 0.0),
            suv: V3::new(r * sv * su, -r * sv * cu, 0.0),
            svv: V3::new(-r * cv * cu, -r * cv * su, -r * sv),
        };
        let k = max_principal_curvature(&s).unwrap();
        assert!((k - 1.0 / r).abs() < 1e-7, "{k}");
    }

    #[test]
    fn flat_gets_d_max_and_sharp_gets_d_min() {
        assert_eq!(chord_spacing(0.0, 0.01, 0.1, 1.0), 1.0);
        assert_eq!(chord_spacing(1000.0, 0.01, 0.1, 1.0), 0.1);
    }
}
