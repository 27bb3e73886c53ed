//! The circular arc (and full circle) in 3D.

use std::f64::consts::TAU;

use bubblemesh_core::geom::{Curve, P3, V3};

use super::{finite_point, finite_vector, GeometryError};

/// Relative slack allowed when checking that an arc turns at most 2π.
const FULL_TURN_SLACK: f64 = 1e-12;

/// The arc C(θ) = c + r·(cos θ·e1 + sin θ·e2), θ ∈ [start, end].
///
/// The parameter is the angle in radians, measured from `e1` towards `e2`,
/// so the arc runs counter-clockwise seen from the tip of the normal
/// n = e1 × e2. Arc length is r·(end − start).
///
/// Invariants: `e1`, `e2` are orthonormal; `radius > 0`;
/// `start < end ≤ start + 2π` (a full circle has `end = start + 2π`); all
/// values are finite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircleArc {
    center: P3,
    radius: f64,
    e1: V3,
    e2: V3,
    start: f64,
    end: f64,
}

impl CircleArc {
    /// An arc in the plane z = 0, counter-clockwise seen from +z, angles
    /// measured from the +x axis (e1 = x, e2 = y).
    pub fn xy(center: [f64; 2], radius: f64, start: f64, end: f64) -> Result<Self, GeometryError> {
        Self::with_basis(
            P3::new(center[0], center[1], 0.0),
            V3::x(),
            V3::y(),
            radius,
            start,
            end,
        )
    }

    /// The full circle in the plane z = 0, counter-clockwise, θ ∈ [0, 2π];
    /// its start (and end) point is at angle 0, `center + (radius, 0)`.
    pub fn circle_xy(center: [f64; 2], radius: f64) -> Result<Self, GeometryError> {
        Self::xy(center, radius, 0.0, TAU)
    }

    /// An arc in the plane through `center` with normal `normal` (any
    /// length), counter-clockwise seen from the tip of the normal.
    ///
    /// Angles are measured from the reference direction e1 = the +x axis
    /// projected onto the plane (the +y axis when the normal is along x);
    /// e2 = n × e1. For the normal +z this is the usual (x, y) angle; for −z
    /// angles run clockwise in (x, y).
    pub fn new(
        center: P3,
        normal: V3,
        radius: f64,
        start: f64,
        end: f64,
    ) -> Result<Self, GeometryError> {
        finite_vector(&normal, "arc normal")?;
        let n = normal
            .try_normalize(0.0)
            .ok_or(GeometryError::BadPlane("the normal is the zero vector"))?;
        let (e1, e2) = plane_basis(&n);
        Self::with_basis(center, e1, e2, radius, start, end)
    }

    /// An arc with an explicit plane basis. `e1` is normalised and `e2` is
    /// made orthogonal to it (Gram–Schmidt) and normalised, so any two
    /// non-parallel vectors spanning the plane are accepted.
    pub fn with_basis(
        center: P3,
        e1: V3,
        e2: V3,
        radius: f64,
        start: f64,
        end: f64,
    ) -> Result<Self, GeometryError> {
        finite_point(&center, "arc centre")?;
        finite_vector(&e1, "arc basis vector e1")?;
        finite_vector(&e2, "arc basis vector e2")?;
        if !radius.is_finite() {
            return Err(GeometryError::NotFinite("radius"));
        }
        if radius <= 0.0 {
            return Err(GeometryError::BadRadius(radius));
        }
        if !start.is_finite() || !end.is_finite() {
            return Err(GeometryError::NotFinite("arc angle"));
        }
        if !(start < end) || end - start > TAU * (1.0 + FULL_TURN_SLACK) {
            return Err(GeometryError::BadAngles { start, end });
        }
        let e1 = e1
            .try_normalize(0.0)
            .ok_or(GeometryError::BadPlane("basis vector e1 is zero"))?;
        let e2 = (e2 - e1 * e1.dot(&e2))
            .try_normalize(1e-12 * e2.norm())
            .ok_or(GeometryError::BadPlane(
                "basis vectors are zero or parallel",
            ))?;
        Ok(CircleArc {
            center,
            radius,
            e1,
            e2,
            start,
            end,
        })
    }

    /// The arc from `a` through `b` to `c` (any three non-collinear points
    /// in 3D). The plane normal is (b − a) × (c − a), so the arc runs
    /// counter-clockwise about it, from angle 0 at `a` to its end angle at
    /// `c`, passing `b`.
    pub fn through(a: P3, b: P3, c: P3) -> Result<Self, GeometryError> {
        finite_point(&a, "arc point")?;
        finite_point(&b, "arc point")?;
        finite_point(&c, "arc point")?;
        let u = b - a;
        let v = c - a;
        let w = u.cross(&v);
        let w2 = w.norm_squared();
        // Relative collinearity test: |u × v| ≤ 1e-10 |u||v| (angle < 1e-10 rad).
        if !(w2 > 1e-20 * u.norm_squared() * v.norm_squared()) || !w2.is_finite() {
            return Err(GeometryError::Collinear);
        }
        // Circumcentre of the triangle (a, b, c).
        let center =
            a + (v.cross(&w) * u.norm_squared() + w.cross(&u) * v.norm_squared()) / (2.0 * w2);
        let radius = (a - center).norm();
        let e1 = (a - center) / radius;
        let n = w / w2.sqrt();
        let e2 = n.cross(&e1);
        let cv = c - center;
        let mut end = cv.dot(&e2).atan2(cv.dot(&e1));
        if end <= 0.0 {
            end += TAU;
        }
        Self::with_basis(center, e1, e2, radius, 0.0, end)
    }

    /// Centre (model units).
    pub fn center(&self) -> P3 {
        self.center
    }
    /// Radius (model units), > 0.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Unit vector towards angle 0.
    pub fn e1(&self) -> V3 {
        self.e1
    }
    /// Unit vector towards angle π/2.
    pub fn e2(&self) -> V3 {
        self.e2
    }
    /// Unit normal e1 × e2.
    pub fn normal(&self) -> V3 {
        self.e1.cross(&self.e2)
    }
    /// Start angle (radians).
    pub fn start_angle(&self) -> f64 {
        self.start
    }
    /// End angle (radians), in `(start, start + 2π]`.
    pub fn end_angle(&self) -> f64 {
        self.end
    }
    /// The swept angle `end − start` in radians.
    pub fn sweep(&self) -> f64 {
        self.end - self.start
    }
}

/// An orthonormal basis (e1, e2) of the plane with unit normal `n`, with
/// e1 × e2 = n; e1 is +x projected on the plane, or +y if n is nearly ±x.
fn plane_basis(n: &V3) -> (V3, V3) {
    let x = V3::x();
    let r = x - n * n.dot(&x);
    let e1 = if r.norm() > 1e-6 {
        r.normalize()
    } else {
        let y = V3::y();
        (y - n * n.dot(&y)).normalize()
    };
    (e1, n.cross(&e1))
}

impl Curve for CircleArc {
    fn interval(&self) -> (f64, f64) {
        (self.start, self.end)
    }
    fn point(&self, t: f64) -> P3 {
        let (s, c) = t.sin_cos();
        self.center + (self.e1 * c + self.e2 * s) * self.radius
    }
    fn d1(&self, t: f64) -> V3 {
        let (s, c) = t.sin_cos();
        (self.e2 * c - self.e1 * s) * self.radius
    }
    fn d2(&self, t: f64) -> V3 {
        let (s, c) = t.sin_cos();
        -(self.e1 * c + self.e2 * s) * self.radius
    }
    fn is_closed(&self) -> bool {
        self.end - self.start >= TAU * (1.0 - FULL_TURN_SLACK)
    }
    fn approx_length(&self) -> f64 {
        self.radius * (self.end - self.start)
    }
}
