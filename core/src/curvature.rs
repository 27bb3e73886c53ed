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

use crate::geom::{Surface, SurfaceDerivs, P3, V3};
use crate::model::Model;
use crate::spacing::{Spacing, SpacingQuery};

/// Principal curvatures and directions at a surface point (thesis eq.
/// 5.1.2 uses ρ = 1/max(|κ1|, |κ2|)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principal {
    /// Unit normal S_u × S_v / |S_u × S_v|.
    pub normal: V3,
    /// Principal curvatures (sign relative to `normal`), |k1| ≥ |k2|, in
    /// 1/model units.
    pub k1: f64,
    /// The other principal curvature, |k2| ≤ |k1|.
    pub k2: f64,
    /// Unit principal directions of k1 and k2; `dir2 = normal × dir1`. At
    /// an umbilic (k1 = k2) dir1 is along S_u.
    pub dir1: V3,
    /// Unit principal direction of k2.
    pub dir2: V3,
}

/// Principal curvatures and directions from the first and second
/// fundamental forms. `None` at a singular point (S_u × S_v = 0).
pub fn principal_curvatures(s: &SurfaceDerivs) -> Option<Principal> {
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
    let (k1, k2) = if (h + disc).abs() >= (h - disc).abs() {
        (h + disc, h - disc)
    } else {
        (h - disc, h + disc)
    };
    // eigenvector (a, b) of (II − k1 I): the longer of the two rows' normals
    let r1 = (m - k1 * f, -(l - k1 * e));
    let r2 = (nn2 - k1 * g, -(m - k1 * f));
    let (a, b) = if r1.0.hypot(r1.1) >= r2.0.hypot(r2.1) {
        r1
    } else {
        r2
    };
    let mut dir1 = s.su * a + s.sv * b;
    let scale = (e + g).sqrt() * (l.abs() + m.abs() + nn2.abs() + k1.abs() * (e + g));
    if !(dir1.norm() > 1e-12 * scale.max(f64::MIN_POSITIVE)) {
        dir1 = s.su; // umbilic: every direction is principal
    }
    let dir1 = dir1.normalize();
    Some(Principal {
        normal: n,
        k1,
        k2,
        dir1,
        dir2: n.cross(&dir1),
    })
}

/// The larger normal curvature |II(w, w)| / I(w, w) = |S_ww · N| / |S_w|²
/// along the parameter lines flagged in `along` (w = u for index 0, v for
/// 1), in 1/model units: the curvature of a u or v line as the surface
/// bends it. 0 where a flagged partial or the normal vanishes.
pub fn parameter_line_curvature(s: &SurfaceDerivs, along: [bool; 2]) -> f64 {
    let n = s.su.cross(&s.sv);
    let nn = n.norm();
    if !(nn > 0.0) {
        return 0.0;
    }
    let n = n / nn;
    let mut k: f64 = 0.0;
    for (w, sw, sww) in [(0, s.su, s.suu), (1, s.sv, s.svv)] {
        let l2 = sw.norm_squared();
        if along[w] && l2 > 0.0 {
            k = k.max((sww.dot(&n) / l2).abs());
        }
    }
    k
}

/// Curvature of a surface point: the larger principal curvature in absolute
/// value, from the first and second fundamental forms. `None` at a singular
/// point (S_u × S_v = 0).
pub fn max_principal_curvature(s: &SurfaceDerivs) -> Option<f64> {
    principal_curvatures(s).map(|p| p.k1.abs())
}

/// Principal curvatures of `surface` at (u,v); at a pole or an apex, those
/// of a point a hair away towards the middle of the domain (the limit of
/// the surrounding values). `None` when that is singular too.
pub fn surface_principal(surface: &dyn Surface, uv: [f64; 2]) -> Option<Principal> {
    let s = surface.derivs(uv[0], uv[1]);
    principal_curvatures(&s).or_else(|| {
        let (u, v) = surface.domain();
        let mid = [0.5 * (u[0] + u[1]), 0.5 * (v[0] + v[1])];
        let p = [
            uv[0] + 1e-6 * (mid[0] - uv[0]),
            uv[1] + 1e-6 * (mid[1] - uv[1]),
        ];
        principal_curvatures(&surface.derivs(p[0], p[1]))
    })
}

/// For each edge of the model, the faces it bounds or is embedded in (a
/// bubble on the edge also sits on them).
pub fn edge_faces(model: &Model) -> Vec<Vec<u32>> {
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
    edge_faces
}

/// (u,v) on face `fi` of the point at parameter `t` of edge `ei`: from the
/// pcurve when the model has one, else by inverting the surface.
pub fn edge_point_uv(model: &Model, fi: u32, ei: u32, t: f64) -> Option<[f64; 2]> {
    edge_point_uv_near(model, fi, ei, t, None)
}

/// [`edge_point_uv`], the surface inverted from `hint` (the (u,v) of a
/// nearby point of the edge, when walking along it: a NURBS face's
/// inversion from nothing is most of the cost where a file has no
/// pcurves).
pub fn edge_point_uv_near(
    model: &Model,
    fi: u32,
    ei: u32,
    t: f64,
    hint: Option<[f64; 2]>,
) -> Option<[f64; 2]> {
    match model.pcurves.get(&(fi, ei)) {
        Some(pc) => {
            let q = pc.point(t);
            Some([q.x, q.y])
        }
        None => {
            let p = model.edges.get(ei as usize)?.curve.point(t);
            model.faces.get(fi as usize)?.surface.inverse(&p, hint)
        }
    }
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
    /// The model whose curvature sets the spacing.
    pub model: Arc<Model>,
    /// Allowed distance from the mesh to the geometry (ε).
    pub eps: f64,
    /// Smallest spacing, in model units.
    pub d_min: f64,
    /// Largest spacing (where the entity is flat), in model units.
    pub d_max: f64,
    /// Spacing at each model vertex: the smallest over the edges that end
    /// there (a vertex bubble sits on all of them).
    vertex_d: Vec<f64>,
    /// Faces each edge bounds: an edge bubble also sits on them, so its
    /// spacing is the smallest of the curve's and those surfaces'.
    edge_faces: Vec<Vec<u32>>,
}

impl Curvature {
    /// The curvature spacing of `model` for the chord tolerance `eps`,
    /// clamped to `[d_min, d_max]`.
    pub fn new(model: Arc<Model>, eps: f64, d_min: f64, d_max: f64) -> Self {
        let edge_faces = edge_faces(&model);
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
        surface_principal(f.surface.as_ref(), uv)
            .map(|p| triangle_spacing(p.k1.abs(), self.eps, self.d_min, self.d_max))
            .unwrap_or(self.d_min)
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
        for &fi in &self.edge_faces[ei] {
            if let Some(uv) = edge_point_uv(&self.model, fi, ei as u32, t) {
                d = d.min(self.face_spacing(fi as usize, uv));
            }
        }
        d
    }
}

/// Curvature κ = |C' × C''| / |C'|³ of a curve at t (0 where C' = 0).
pub fn curve_curvature(c: &dyn crate::geom::Curve, t: f64) -> f64 {
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
    /// The viewpoint V0.
    pub viewpoint: P3,
    /// The factor a (spacing per unit of distance).
    pub factor: f64,
    /// Smallest spacing, in model units.
    pub d_min: f64,
    /// Largest spacing, in model units.
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
    fn cylinder_principal_directions() {
        // cylinder of radius 2 about z: S(u, v) = (2 cos u, 2 sin u, v);
        // |k1| = 1/2 around the axis, k2 = 0 along it
        let (r, u) = (2.0, 0.7f64);
        let (c, s) = (u.cos(), u.sin());
        let d = SurfaceDerivs {
            p: P3::new(r * c, r * s, 0.3),
            su: V3::new(-r * s, r * c, 0.0),
            sv: V3::z(),
            suu: V3::new(-r * c, -r * s, 0.0),
            suv: V3::zeros(),
            svv: V3::zeros(),
        };
        let p = principal_curvatures(&d).unwrap();
        assert!(
            (p.k1.abs() - 0.5).abs() < 1e-12 && p.k2.abs() < 1e-12,
            "{p:?}"
        );
        assert!((p.dir1.dot(&V3::new(-s, c, 0.0)).abs() - 1.0).abs() < 1e-12);
        assert!((p.dir2.z.abs() - 1.0).abs() < 1e-12);
        assert!(p.normal.dot(&p.dir1).abs() < 1e-12);
    }

    #[test]
    fn flat_gets_d_max_and_sharp_gets_d_min() {
        assert_eq!(chord_spacing(0.0, 0.01, 0.1, 1.0), 1.0);
        assert_eq!(chord_spacing(1000.0, 0.01, 0.1, 1.0), 0.1);
    }
}
