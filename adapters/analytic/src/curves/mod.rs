//! Analytic curves: straight segments, circular arcs and NURBS curves.
//!
//! Every type implements [`bubblemesh_core::geom::Curve`] with exact first
//! and second derivatives. Constructors validate their input and return a
//! [`GeometryError`] instead of building a curve that would evaluate to NaN;
//! once built, a curve evaluates to finite values everywhere on its
//! parameter interval.
//!
//! Units: coordinates and radii are in model units; arc parameters are
//! angles in radians.

mod arc;
mod ellipse;
mod hyperbola;
mod line;
mod nurbs;
mod on_surface;

pub use arc::CircleArc;
pub use ellipse::EllipseArc;
pub use hyperbola::HyperbolaArc;
pub use line::Line;
pub(crate) use nurbs::{basis_derivs, clamped_uniform_knots, find_span, MAXP};
pub use nurbs::{Nurbs, MAX_NURBS_DEGREE};
pub use on_surface::CurveOnSurface;

use bubblemesh_core::geom::{P3, V3};

/// Why a curve could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    /// A coordinate, radius, angle, weight or knot is NaN or infinite.
    #[error("{0} is not a finite number")]
    NotFinite(&'static str),
    /// A circle or arc with radius ≤ 0.
    #[error("radius must be positive (got {0})")]
    BadRadius(f64),
    /// An arc whose end angle is not after its start angle, or which turns
    /// more than a full circle.
    #[error(
        "arc angles must satisfy start < end ≤ start + 2π (got start {start} rad, end {end} rad)"
    )]
    BadAngles {
        /// Start angle, radians.
        start: f64,
        /// End angle, radians.
        end: f64,
    },
    /// A zero normal, or a plane basis whose vectors are zero or parallel.
    #[error("degenerate plane: {0}")]
    BadPlane(&'static str),
    /// Three points given for an arc are (nearly) on one line.
    #[error("the three points are collinear (or two coincide), so no circle passes through them")]
    Collinear,
    /// A NURBS degree outside `1..=MAX_NURBS_DEGREE`.
    #[error("NURBS degree must be between 1 and {max} (got {got})")]
    BadDegree {
        /// The degree given.
        got: usize,
        /// The largest degree supported.
        max: usize,
    },
    /// Too few control points for the degree.
    #[error("a NURBS of degree {degree} needs at least {} control points (got {got})", degree + 1)]
    TooFewControlPoints {
        /// The degree.
        degree: usize,
        /// The number of control points given.
        got: usize,
    },
    /// Weight vector of the wrong length or with a non-positive entry.
    #[error("bad NURBS weights: {0}")]
    BadWeights(String),
    /// Knot vector of the wrong length, decreasing, or with an empty domain.
    #[error("bad NURBS knot vector: {0}")]
    BadKnots(String),
}

/// Checks that every coordinate of `p` is finite.
pub(crate) fn finite_point(p: &P3, what: &'static str) -> Result<(), GeometryError> {
    if p.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(GeometryError::NotFinite(what))
    }
}

/// Checks that every component of `v` is finite.
pub(crate) fn finite_vector(v: &V3, what: &'static str) -> Result<(), GeometryError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(GeometryError::NotFinite(what))
    }
}
