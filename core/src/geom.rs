//! The geometric queries the bubble method needs (thesis §5.1.4).
//!
//! These traits say *what* a geometry must answer, not how an adapter stores
//! it. Every length is in model units (whatever the input file uses); every
//! parameter is the adapter's own parameter, which need not be arc length.
//!
//! Invariants an implementation must keep:
//! - evaluation at a parameter inside the interval/domain returns finite values;
//! - derivatives are the exact derivatives of the point map (tests in the
//!   adapters compare them with finite differences);
//! - implementations are `Send + Sync` so the engine may evaluate from several
//!   threads.

use nalgebra::{Point3, Vector3};

/// A point in model space.
pub type P3 = Point3<f64>;
/// A vector in model space.
pub type V3 = Vector3<f64>;

/// A parametric curve C(t), t in `interval()`.
pub trait Curve: Send + Sync + std::fmt::Debug {
    /// Parameter interval `[t0, t1]`, `t0 < t1`.
    fn interval(&self) -> (f64, f64);
    /// C(t).
    fn point(&self, t: f64) -> P3;
    /// C'(t) = dC/dt.
    fn d1(&self, t: f64) -> V3;
    /// C''(t) = d²C/dt².
    fn d2(&self, t: f64) -> V3;
    /// (C(t), C'(t), C''(t)): the values of [`Curve::point`],
    /// [`Curve::d1`] and [`Curve::d2`], bit for bit. Surfaces swept from a
    /// curve ask all three at once; an adapter that computes them together
    /// (NURBS: one basis evaluation instead of three) answers it directly.
    fn derivs(&self, t: f64) -> (P3, V3, V3) {
        (self.point(t), self.d1(t), self.d2(t))
    }
    /// (C(t), C'(t)) for stage 2's steps on surfaces swept from this curve:
    /// [`Curve::derivs`]'s first two by default; an adapter with a faster
    /// form of the first derivative (NURBS: power-form spans) answers it
    /// directly, equal to [`Curve::point`] and [`Curve::d1`] to rounding.
    fn tangent(&self, t: f64) -> (P3, V3) {
        let (p, d1, _) = self.derivs(t);
        (p, d1)
    }
    /// Whether C(t0) == C(t1) (a circle, a closed spline).
    fn is_closed(&self) -> bool {
        let (a, b) = self.interval();
        let (pa, pb) = (self.point(a), self.point(b));
        let scale = self.approx_length().max(f64::MIN_POSITIVE);
        (pa - pb).norm() <= 1e-9 * scale
    }
    /// Arc length by Gauss–Legendre quadrature on 64 panels; adapters with a
    /// closed form may override it.
    fn approx_length(&self) -> f64 {
        length_between(self, self.interval().0, self.interval().1)
    }
}

/// The axis-aligned bounding box of `pts`, (lowest, highest) corner
/// (inverted, +∞ to −∞, when there are none).
pub fn bounds<Q: std::borrow::Borrow<P3>>(pts: impl IntoIterator<Item = Q>) -> (P3, P3) {
    let mut lo = P3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let mut hi = P3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for p in pts {
        let p = p.borrow();
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    (lo, hi)
}

/// Arc length of `c` between `a` and `b` (a ≤ b or a > b) by 5-point
/// Gauss–Legendre quadrature on 64 panels.
pub fn length_between<C: Curve + ?Sized>(c: &C, a: f64, b: f64) -> f64 {
    const X: [f64; 5] = [
        0.0,
        -0.538_469_310_105_683_1,
        0.538_469_310_105_683_1,
        -0.906_179_845_938_664,
        0.906_179_845_938_664,
    ];
    const W: [f64; 5] = [
        0.568_888_888_888_888_9,
        0.478_628_670_499_366_5,
        0.478_628_670_499_366_5,
        0.236_926_885_056_189_1,
        0.236_926_885_056_189_1,
    ];
    let n = 64;
    let h = (b - a) / n as f64;
    let mut s = 0.0;
    for k in 0..n {
        let m = a + (k as f64 + 0.5) * h;
        for (x, w) in X.iter().zip(W) {
            s += w * c.d1(m + 0.5 * h * x).norm();
        }
    }
    (s * 0.5 * h).abs()
}

/// Value and partial derivatives of a surface at one (u,v).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceDerivs {
    /// S(u,v).
    pub p: P3,
    /// ∂S/∂u.
    pub su: V3,
    /// ∂S/∂v.
    pub sv: V3,
    /// ∂²S/∂u².
    pub suu: V3,
    /// ∂²S/∂u∂v.
    pub suv: V3,
    /// ∂²S/∂v².
    pub svv: V3,
}

/// A parametric surface S(u,v) over a rectangular parameter domain.
///
/// Trimming (which part of the domain a face uses) belongs to the face's
/// boundary loops in the [`crate::model::Model`]; a surface may additionally
/// answer in/out itself through [`Surface::trim`].
pub trait Surface: Send + Sync + std::fmt::Debug {
    /// `([u0, u1], [v0, v1])`.
    fn domain(&self) -> ([f64; 2], [f64; 2]);
    /// S(u,v).
    fn point(&self, u: f64, v: f64) -> P3;
    /// S and its first and second partials at (u,v).
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs;
    /// S, ∂S/∂u and ∂S/∂v at (u,v): the values [`Surface::derivs`] gives,
    /// bit for bit. Stage 2 asks this a few times per bubble and step; an
    /// adapter whose second partials cost (NURBS) answers it without them.
    fn tangents(&self, u: f64, v: f64) -> (P3, V3, V3) {
        let d = self.derivs(u, v);
        (d.p, d.su, d.sv)
    }
    /// (u,v) of the point of the surface nearest to `p`, searched from `hint`
    /// when given. `None` when the adapter cannot invert its map.
    fn inverse(&self, p: &P3, hint: Option<[f64; 2]>) -> Option<[f64; 2]>;
    /// Period in u and in v of a periodic surface (a sphere's or cylinder's
    /// u: 2π; both for a torus), `None` for an open direction. Bubbles cross
    /// a periodic seam freely; their parameter is kept in
    /// `[domain.0, domain.0 + period)`.
    fn periods(&self) -> [Option<f64>; 2] {
        [None, None]
    }
    /// Whether S_u × S_v vanishes at (u,v) (a sphere's poles, a cone's
    /// apex). Near such points the engine moves bubbles by projection
    /// ([`Surface::inverse`]) instead of the first fundamental form.
    fn is_singular(&self, _u: f64, _v: f64) -> bool {
        false
    }
    /// [`Surface::is_singular`] for a caller that has just asked
    /// [`Surface::tangents`] at (u,v) and passes `su`, `sv`: the same
    /// answer, without evaluating them again where the adapter decides by
    /// them (NURBS).
    fn is_singular_with(&self, u: f64, v: f64, _su: &V3, _sv: &V3) -> bool {
        self.is_singular(u, v)
    }
    /// The model-space points where the parametrization is singular (a
    /// sphere's poles, a cone's apex). Bubbles near them are connected in
    /// their tangent plane instead of in (u,v).
    fn singular_points(&self) -> Vec<P3> {
        Vec::new()
    }
    /// Whether the surface is a plane (lets the engine use exact 2D
    /// predicates in (u,v) and a lattice aligned with the parameters).
    fn is_planar(&self) -> bool {
        false
    }
    /// Whether the adapter itself knows that (u,v) is inside (`Some(true)`) or
    /// outside (`Some(false)`) the trimmed region; `None` (the default) lets
    /// the engine decide from the face's boundary loops.
    fn trim(&self, _u: f64, _v: f64) -> Option<bool> {
        None
    }
}

/// A region of space bounded by faces. Volume meshing asks only in/out.
pub trait VolumeGeometry: Send + Sync + std::fmt::Debug {
    /// `Some(inside)` where the adapter can answer exactly; `None` lets the
    /// engine decide from the watertight boundary mesh.
    fn contains(&self, _p: &P3) -> Option<bool> {
        None
    }
}

/// The straight segment from `.0` to `.1`, t in [0, 1] (a host's line
/// through the C ABI, and the test models' edges).
#[derive(Clone, Copy, Debug)]
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
    fn approx_length(&self) -> f64 {
        (self.1 - self.0).norm()
    }
}

/// The plane S(u,v) = origin + u·e1 + v·e2 with orthonormal e1, e2.
///
/// 2D domains use the plane z = 0 with (u,v) = (x,y).
#[derive(Clone, Copy, Debug)]
pub struct Plane {
    /// S(0, 0).
    pub origin: P3,
    /// The u direction (unit length).
    pub e1: V3,
    /// The v direction (unit length, orthogonal to `e1`).
    pub e2: V3,
}

impl Plane {
    /// The plane z = 0, (u,v) = (x,y).
    pub fn xy() -> Self {
        Plane {
            origin: P3::origin(),
            e1: V3::x(),
            e2: V3::y(),
        }
    }
}

impl Surface for Plane {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (
            [f64::NEG_INFINITY, f64::INFINITY],
            [f64::NEG_INFINITY, f64::INFINITY],
        )
    }
    fn point(&self, u: f64, v: f64) -> P3 {
        self.origin + self.e1 * u + self.e2 * v
    }
    fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        SurfaceDerivs {
            p: self.point(u, v),
            su: self.e1,
            sv: self.e2,
            suu: V3::zeros(),
            suv: V3::zeros(),
            svv: V3::zeros(),
        }
    }
    fn inverse(&self, p: &P3, _hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
        let d = p - self.origin;
        Some([d.dot(&self.e1), d.dot(&self.e2)])
    }
    fn is_planar(&self) -> bool {
        true
    }
}

/// The difference `d` of a periodic coordinate taken the shorter way
/// round, in [−period/2, period/2]: how boundary nodes are joined across a
/// seam.
#[inline]
pub fn nearest_turn(d: f64, period: f64) -> f64 {
    d - period * (d / period).round()
}

/// Bisects the steps of a curve sampled in (u,v), `samples` (curve
/// parameter, (u,v)) in order, until no step `too_far` says is too long
/// remains, a step is under 10⁻⁹ of the parameter (a curve through a pole
/// turns u at once there) or there are `max_len` samples; `at(s, hint)` is
/// the (u,v) of the curve at `s`, `hint` the sample before it. Used to tell
/// which way a loop runs round a periodic surface near a pole, where u
/// turns by nearly half a period within a short arc.
pub fn bisect_steps<E>(
    samples: &mut Vec<(f64, [f64; 2])>,
    max_len: usize,
    too_far: impl Fn([f64; 2], [f64; 2]) -> bool,
    mut at: impl FnMut(f64, [f64; 2]) -> Result<[f64; 2], E>,
) -> Result<(), E> {
    let mut j = 0;
    while j + 1 < samples.len() && samples.len() < max_len {
        let ((s0, p0), (s1, p1)) = (samples[j], samples[j + 1]);
        if s1 - s0 > 1e-9 && too_far(p0, p1) {
            let sm = 0.5 * (s0 + s1);
            let q = at(sm, p0)?;
            samples.insert(j + 1, (sm, q));
        } else {
            j += 1;
        }
    }
    Ok(())
}

/// Parameter `x` moved into one period `[origin, origin + period)` of a
/// periodic direction (unchanged when `period` is `None`).
pub fn wrap_coordinate(x: f64, period: Option<f64>, origin: f64) -> f64 {
    match period {
        Some(p) => origin + (x - origin).rem_euclid(p),
        None => x,
    }
}

/// `(u,v)` moved into the fundamental domain of a surface's periodic
/// directions ([`Surface::periods`]), `origin` the domain's lower corner
/// (see [`wrap_coordinate`]).
pub fn wrap_periodic(uv: [f64; 2], periods: [Option<f64>; 2], origin: [f64; 2]) -> [f64; 2] {
    [
        wrap_coordinate(uv[0], periods[0], origin[0]),
        wrap_coordinate(uv[1], periods[1], origin[1]),
    ]
}

/// The point of the segment [a, b] nearest to `p`, in the plane (a
/// degenerate segment gives `a`).
pub fn closest_on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [a[0] + t * d[0], a[1] + t * d[1]]
}
