//! Analytic and NURBS surfaces: sphere, cylinder, cone, torus, surfaces of
//! revolution and extrusion of a curve, and tensor-product NURBS patches.
//!
//! Every type implements [`bubblemesh_core::geom::Surface`] with the exact
//! first and second partial derivatives S_u, S_v, S_uu, S_uv, S_vv, the
//! periods of its periodic directions ([`Surface::periods`]) and its
//! singular points ([`Surface::is_singular`]). Constructors validate their
//! input and return a [`SurfaceError`] instead of building a surface that
//! would evaluate to NaN.
//!
//! Units: coordinates, radii and the heights / slant distances used as
//! parameters are in model units; angles are in radians.
//!
//! # Periodic directions
//!
//! A periodic direction has domain `[a, a + T]` and period `T`; evaluation
//! accepts any parameter (it is taken modulo `T`) and
//! [`Surface::inverse`] returns parameters in `[a, a + T)`.
//!
//! # Inverse (closest point)
//!
//! The sphere, cylinder, cone and torus invert in closed form: the answer is
//! the exact closest point for every finite `p`, and the hint only chooses
//! the free parameter where the closest point is not unique in it (the
//! angle of a point on the axis, the angle at a pole or apex).
//!
//! [`Revolution`], [`Extrusion`] and [`NurbsSurface`] minimise
//! |S(u,v) − p|² by a damped Newton iteration (full Hessian when it is
//! positive definite, Gauss–Newton otherwise, monotone back-tracking, bound
//! constraints on non-periodic directions) from the hint, or, without a hint,
//! from the best point of a coarse sampling. With a hint a call costs a
//! handful of evaluations (at most [`NEWTON_MAX_ITERATIONS`] steps); when
//! Newton from the hint fails the sampling start is tried as well. The
//! result is a *local* closest point: the one reached from the start. It is
//! `None` when the iteration does not converge (model-space step below
//! 1e-12 × (surface size + |p|)) or when the distance found exceeds
//! [`INVERSE_MAX_DISTANCE`] × the surface size (the diagonal of its bounding
//! box), where the closest-point problem is no longer the projection of a
//! nearby point the engine asks for.

mod cone;
mod cylinder;
mod extrusion;
mod nurbs;
mod revolution;
mod sphere;
mod torus;

pub use cone::Cone;
pub use cylinder::Cylinder;
pub use extrusion::Extrusion;
pub use nurbs::NurbsSurface;
pub use revolution::Revolution;
pub use sphere::Sphere;
pub use torus::Torus;

use bubblemesh_core::geom::{Surface, SurfaceDerivs, P3, V3};

use crate::curves::GeometryError;

/// Why a surface could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SurfaceError {
    /// A non-finite number, a bad radius, a bad NURBS degree, … (the same
    /// checks as for curves).
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// An axis or direction that is zero, or a reference direction parallel
    /// to the axis.
    #[error("degenerate axis or direction: {0}")]
    BadAxis(&'static str),
    /// A cone half-angle outside (0, π/2).
    #[error("cone half-angle must be in (0, π/2) radians (got {0})")]
    BadHalfAngle(f64),
    /// A parameter range that is empty, NaN, or outside what the surface
    /// allows.
    #[error("bad parameter range [{lo}, {hi}]: {what}")]
    BadRange {
        /// Which range.
        what: &'static str,
        /// Its lower end.
        lo: f64,
        /// Its upper end.
        hi: f64,
    },
    /// Torus radii that do not satisfy major > minor > 0.
    #[error("torus radii must satisfy major > minor > 0 (got major {major}, minor {minor})")]
    BadTorus {
        /// Major radius.
        major: f64,
        /// Minor radius.
        minor: f64,
    },
    /// A NURBS control net or weight net that is not rectangular.
    #[error("bad NURBS control net: {0}")]
    BadNet(String),
    /// A NURBS knot vector, degree or point count rejected in one direction.
    #[error("NURBS surface, {dir} direction: {source}")]
    NurbsDirection {
        /// "u" or "v".
        dir: &'static str,
        /// Why that direction was rejected.
        source: GeometryError,
    },
    /// A profile curve that cannot sweep a surface (on the axis, parallel to
    /// the extrusion direction, infinite interval, …).
    #[error("degenerate profile curve: {0}")]
    DegenerateProfile(&'static str),
}

/// A point is inverted only if its distance to the surface is at most this
/// fraction of the surface size (bounding-box diagonal); see the module
/// documentation. Applies to the Newton-inverted surfaces.
pub const INVERSE_MAX_DISTANCE: f64 = 0.25;

/// Maximum number of Newton steps per start point in [`Surface::inverse`].
pub const NEWTON_MAX_ITERATIONS: usize = 30;

/// Relative threshold for [`Surface::is_singular`]: a point is singular when
/// |S_u × S_v| ≤ `SINGULAR_REL` × (typical |S_u|) × (typical |S_v|), which
/// for the sphere is |cos v| ≤ `SINGULAR_REL`.
pub const SINGULAR_REL: f64 = 1e-10;

/// A right-handed orthonormal frame (origin; x, y, z). Analytic surfaces are
/// written in the local coordinates of a frame, with their axis along z and
/// their angle u measured from x towards y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    origin: P3,
    x: V3,
    y: V3,
    z: V3,
}

impl Frame {
    /// The world axes at the world origin.
    pub fn world() -> Self {
        Self::axis_aligned(P3::origin())
    }

    /// The world axes at `origin` (not checked for finiteness; the surface
    /// constructors check it).
    pub fn axis_aligned(origin: P3) -> Self {
        Frame {
            origin,
            x: V3::x(),
            y: V3::y(),
            z: V3::z(),
        }
    }

    /// The frame at `origin` with z along `axis` (any length). x is the world
    /// +x axis projected on the plane normal to `axis` (the +y axis when
    /// `axis` is nearly along x), y = z × x — the convention of
    /// [`crate::CircleArc::new`].
    pub fn new(origin: P3, axis: V3) -> Result<Self, SurfaceError> {
        finite3(&origin.coords, "frame origin")?;
        finite3(&axis, "axis")?;
        let z = axis
            .try_normalize(0.0)
            .ok_or(SurfaceError::BadAxis("the axis is the zero vector"))?;
        let r = V3::x() - z * z.x;
        let x = if r.norm() > 1e-6 {
            r.normalize()
        } else {
            (V3::y() - z * z.y).normalize()
        };
        Ok(Frame {
            origin,
            x,
            y: z.cross(&x),
            z,
        })
    }

    /// The frame at `origin` with z along `axis` and x along the part of
    /// `reference` normal to the axis (u = 0 direction of the surfaces).
    pub fn with_reference(origin: P3, axis: V3, reference: V3) -> Result<Self, SurfaceError> {
        finite3(&reference, "reference direction")?;
        let f = Self::new(origin, axis)?;
        let x = (reference - f.z * f.z.dot(&reference))
            .try_normalize(1e-12 * reference.norm())
            .ok_or(SurfaceError::BadAxis(
                "the reference direction is zero or parallel to the axis",
            ))?;
        Ok(Frame {
            x,
            y: f.z.cross(&x),
            ..f
        })
    }

    /// Origin.
    pub fn origin(&self) -> P3 {
        self.origin
    }
    /// Unit x axis (u = 0).
    pub fn x(&self) -> V3 {
        self.x
    }
    /// Unit y axis (u = π/2).
    pub fn y(&self) -> V3 {
        self.y
    }
    /// Unit z axis (the surface's axis).
    pub fn z(&self) -> V3 {
        self.z
    }
    /// Local coordinates of `p`.
    pub fn to_local(&self, p: &P3) -> V3 {
        let d = p - self.origin;
        V3::new(d.dot(&self.x), d.dot(&self.y), d.dot(&self.z))
    }
    /// The world vector with local components (a, b, c).
    pub fn vector(&self, a: f64, b: f64, c: f64) -> V3 {
        self.x * a + self.y * b + self.z * c
    }
    /// The world point with local coordinates (a, b, c).
    pub fn point(&self, a: f64, b: f64, c: f64) -> P3 {
        self.origin + self.vector(a, b, c)
    }
}

pub(crate) fn finite3(v: &V3, what: &'static str) -> Result<(), SurfaceError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(GeometryError::NotFinite(what).into())
    }
}

pub(crate) fn check_radius(r: f64) -> Result<(), SurfaceError> {
    if !r.is_finite() {
        return Err(GeometryError::NotFinite("radius").into());
    }
    if !(r > 0.0) {
        return Err(GeometryError::BadRadius(r).into());
    }
    Ok(())
}

/// A parameter range [lo, hi] with lo < hi; infinite ends allowed only when
/// `allow_infinite`.
pub(crate) fn check_range(
    r: [f64; 2],
    allow_infinite: bool,
    what: &'static str,
) -> Result<(), SurfaceError> {
    let [lo, hi] = r;
    let ok_end = |x: f64| x.is_finite() || (allow_infinite && !x.is_nan());
    if !(ok_end(lo) && ok_end(hi) && lo < hi) || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
        return Err(SurfaceError::BadRange { what, lo, hi });
    }
    Ok(())
}

/// `x` taken into `[lo, lo + period)`.
pub(crate) fn wrap(x: f64, lo: f64, period: f64) -> f64 {
    let y = lo + (x - lo).rem_euclid(period);
    if y >= lo + period {
        lo
    } else {
        y
    }
}

/// A finite hint, if any.
pub(crate) fn finite_hint(hint: Option<[f64; 2]>) -> Option<[f64; 2]> {
    hint.filter(|h| h[0].is_finite() && h[1].is_finite())
}

/// The parameter box of a surface and its periodic directions.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ParamBox {
    pub lo: [f64; 2],
    pub hi: [f64; 2],
    pub period: [Option<f64>; 2],
}

impl ParamBox {
    pub fn of(s: &dyn Surface) -> Self {
        let (u, v) = s.domain();
        ParamBox {
            lo: [u[0], v[0]],
            hi: [u[1], v[1]],
            period: s.periods(),
        }
    }

    /// Periodic coordinates wrapped, the others clamped.
    pub fn normalize(&self, x: [f64; 2]) -> [f64; 2] {
        let mut y = x;
        for i in 0..2 {
            y[i] = match self.period[i] {
                Some(t) => wrap(x[i], self.lo[i], t),
                None => x[i].clamp(self.lo[i], self.hi[i]),
            };
        }
        y
    }

    /// The box with infinite ends replaced by finite ones (for sampling):
    /// [lo, lo + 1], [hi − 1, hi] or [−1, 1].
    pub fn finite(&self) -> ([f64; 2], [f64; 2]) {
        let mut lo = self.lo;
        let mut hi = self.hi;
        for i in 0..2 {
            match (lo[i].is_finite(), hi[i].is_finite()) {
                (true, true) => {}
                (true, false) => hi[i] = lo[i] + 1.0,
                (false, true) => lo[i] = hi[i] - 1.0,
                (false, false) => {
                    lo[i] = -1.0;
                    hi[i] = 1.0;
                }
            }
        }
        (lo, hi)
    }

    /// `n` sample values along direction `i` of the finite box: cell centres
    /// for periodic directions, both ends included otherwise.
    pub fn samples(&self, i: usize, n: usize) -> Vec<f64> {
        let (lo, hi) = self.finite();
        let (a, b) = (lo[i], hi[i]);
        if self.period[i].is_some() {
            (0..n)
                .map(|k| a + (k as f64 + 0.5) / n as f64 * (b - a))
                .collect()
        } else {
            (0..n)
                .map(|k| a + k as f64 / (n - 1) as f64 * (b - a))
                .collect()
        }
    }
}

/// Mean |S_u| and |S_v| over an 8 × 8 grid of the (finite) domain: the
/// scales of [`SINGULAR_REL`]. Never zero.
pub(crate) fn typical_partials(s: &dyn Surface) -> [f64; 2] {
    let b = ParamBox::of(s);
    let (us, vs) = (b.samples(0, 8), b.samples(1, 8));
    let (mut a, mut c) = (0.0, 0.0);
    for &u in &us {
        for &v in &vs {
            let d = s.derivs(u, v);
            a += d.su.norm();
            c += d.sv.norm();
        }
    }
    let n = (us.len() * vs.len()) as f64;
    [
        (a / n).max(f64::MIN_POSITIVE),
        (c / n).max(f64::MIN_POSITIVE),
    ]
}

/// The generic singularity test |S_u × S_v| ≤ `SINGULAR_REL` · s_u · s_v.
pub(crate) fn area_singular(d: &SurfaceDerivs, scale: [f64; 2]) -> bool {
    area_singular_of(&d.su, &d.sv, scale)
}

/// [`area_singular`] given the first partials.
pub(crate) fn area_singular_of(su: &V3, sv: &V3, scale: [f64; 2]) -> bool {
    su.cross(sv).norm() <= SINGULAR_REL * scale[0] * scale[1]
}

/// Closest point by Newton from the hint, else from the best of `seeds`
/// (computed lazily; sorted by distance, the three best are tried).
/// `size` is the surface's bounding-box diagonal.
pub(crate) fn newton_inverse(
    s: &dyn Surface,
    p: &P3,
    hint: Option<[f64; 2]>,
    size: f64,
    seeds: impl FnOnce() -> Vec<[f64; 2]>,
) -> Option<[f64; 2]> {
    if !p.iter().all(|x| x.is_finite()) {
        return None;
    }
    let b = ParamBox::of(s);
    let max_dist = INVERSE_MAX_DISTANCE * size;
    if let Some(h) = finite_hint(hint) {
        if let Some((x, d)) = newton(s, p, h, &b, size) {
            if d <= max_dist {
                return Some(x);
            }
        }
    }
    let mut seeds: Vec<([f64; 2], f64)> = seeds()
        .into_iter()
        .map(|x| {
            let x = b.normalize(x);
            (x, (s.point(x[0], x[1]) - p).norm_squared())
        })
        .filter(|(_, d)| d.is_finite())
        .collect();
    seeds.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut best: Option<([f64; 2], f64)> = None;
    for (x0, _) in seeds.into_iter().take(3) {
        if let Some((x, d)) = newton(s, p, x0, &b, size) {
            if best.map_or(true, |(_, bd)| d < bd) {
                best = Some((x, d));
            }
            if d <= 1e-9 * size {
                break;
            }
        }
    }
    best.filter(|&(_, d)| d <= max_dist).map(|(x, _)| x)
}

/// Damped Newton on f(u,v) = ½|S(u,v) − p|² from `start`; returns the
/// parameters and the distance, or `None` when it does not converge.
fn newton(
    s: &dyn Surface,
    p: &P3,
    start: [f64; 2],
    b: &ParamBox,
    size: f64,
) -> Option<([f64; 2], f64)> {
    let tol = 1e-12 * (size + p.coords.norm());
    let mut x = b.normalize(start);
    let mut d = s.derivs(x[0], x[1]);
    let mut r = d.p - p;
    let mut f = r.norm_squared();
    if !f.is_finite() {
        return None;
    }
    for _ in 0..NEWTON_MAX_ITERATIONS {
        let g = [r.dot(&d.su), r.dot(&d.sv)];
        // Bound constraints: a coordinate at its bound whose descent direction
        // points out of the box is held fixed.
        let mut free = [true, true];
        for i in 0..2 {
            if b.period[i].is_none()
                && ((x[i] <= b.lo[i] && g[i] > 0.0) || (x[i] >= b.hi[i] && g[i] < 0.0))
            {
                free[i] = false;
            }
        }
        let mut step = newton_step(&d, &r, g, free);
        let mut lin = (d.su * step[0] + d.sv * step[1]).norm();
        if !lin.is_finite() {
            return None;
        }
        // Keep steps within the surface and within half a period.
        if lin > size {
            step = [step[0] * size / lin, step[1] * size / lin];
            lin = size;
        }
        for i in 0..2 {
            let cap = match b.period[i] {
                Some(t) => 0.5 * t,
                None if (b.hi[i] - b.lo[i]).is_finite() => b.hi[i] - b.lo[i],
                None => f64::INFINITY,
            };
            if step[i].abs() > cap {
                let k = cap / step[i].abs();
                step = [step[0] * k, step[1] * k];
                lin *= k;
            }
        }
        // Back-tracking on f, up to its rounding noise (r = S − p carries an
        // absolute error of a few ulps of |S| and |p|): near the minimum the
        // decrease of f falls below that noise while the gradient is still
        // well resolved, and the full Newton step must be taken.
        let noise = 8.0 * f64::EPSILON * f.sqrt() * (d.p.coords.norm() + p.coords.norm());
        let mut t = 1.0;
        let mut accepted = None;
        for _ in 0..40 {
            let xn = b.normalize([x[0] + t * step[0], x[1] + t * step[1]]);
            let fnew = (s.point(xn[0], xn[1]) - p).norm_squared();
            if fnew <= f + noise {
                accepted = Some(xn);
                break;
            }
            t *= 0.5;
        }
        match accepted {
            Some(xn) => {
                x = xn;
                d = s.derivs(x[0], x[1]);
                r = d.p - p;
                f = r.norm_squared();
                if lin <= tol {
                    return Some((x, f.sqrt()));
                }
            }
            // No decrease at all: at the precision limit of a minimum, or stuck.
            None => return (lin <= 1e-7 * size).then(|| (x, f.sqrt())),
        }
    }
    None
}

/// The Newton step for ½|S − p|² with gradient `g`; coordinates not `free`
/// stay put. Full Hessian when positive definite, else Gauss–Newton with a
/// small Levenberg shift.
fn newton_step(d: &SurfaceDerivs, r: &V3, g: [f64; 2], free: [bool; 2]) -> [f64; 2] {
    let gn = [d.su.norm_squared(), d.su.dot(&d.sv), d.sv.norm_squared()];
    let full = [
        gn[0] + r.dot(&d.suu),
        gn[1] + r.dot(&d.suv),
        gn[2] + r.dot(&d.svv),
    ];
    let lambda = 1e-10 * (gn[0] + gn[2]) + f64::MIN_POSITIVE;
    match free {
        [true, true] => {
            let [a, bb, c] = full;
            let det = a * c - bb * bb;
            let (a, bb, c, det) = if a > 0.0 && c > 0.0 && det > 1e-12 * (a * c + bb * bb) {
                (a, bb, c, det)
            } else {
                let (a, c) = (gn[0] + lambda, gn[2] + lambda);
                (a, gn[1], c, a * c - gn[1] * gn[1])
            };
            if !(det > 0.0) {
                return [0.0, 0.0];
            }
            [(-c * g[0] + bb * g[1]) / det, (bb * g[0] - a * g[1]) / det]
        }
        [true, false] => {
            let h = if full[0] > 0.0 {
                full[0]
            } else {
                gn[0] + lambda
            };
            [-g[0] / h, 0.0]
        }
        [false, true] => {
            let h = if full[2] > 0.0 {
                full[2]
            } else {
                gn[2] + lambda
            };
            [0.0, -g[1] / h]
        }
        [false, false] => [0.0, 0.0],
    }
}
