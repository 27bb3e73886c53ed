//! # bubblemesh-analytic
//!
//! Analytic geometry for bubblemesh and its TOML domain format.
//!
//! - [`curves`]: [`Line`], [`CircleArc`] and [`Nurbs`], each implementing
//!   [`bubblemesh_core::geom::Curve`] with exact first and second
//!   derivatives;
//! - [`surfaces`]: [`Sphere`], [`Cylinder`], [`Cone`], [`Torus`],
//!   [`Revolution`], [`Extrusion`] and [`NurbsSurface`], each implementing
//!   [`bubblemesh_core::geom::Surface`] with exact first and second
//!   partials, periods, singular points and a closest-point inverse;
//! - [`domain`]: the versioned TOML format for planar domains and curve
//!   sets (`docs/domain-format.md`), read into a
//!   [`bubblemesh_core::model::Model`] by [`read_domain`] / [`parse_domain`].

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it is also
// true for NaN, which is how invalid input is rejected without a panic.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod curves;
pub mod domain;
mod power_form;
pub mod surfaces;

pub use curves::{
    CircleArc, EllipseArc, GeometryError, HyperbolaArc, Line, Nurbs, MAX_NURBS_DEGREE,
};
pub use domain::{parse_domain, read_domain, DomainError, FORMAT};
pub use surfaces::{
    Cone, Cylinder, Extrusion, Frame, NurbsSurface, Revolution, Sphere, SurfaceError, Torus,
};

/// What the unit tests share.
#[cfg(test)]
pub(crate) mod testing {
    /// Deterministic numbers in [−0.5, 0.5) from `seed` (`fastrand`'s
    /// seeded generator): random nets and parameters, the same on every run.
    pub(crate) fn unit(seed: u64) -> impl FnMut() -> f64 {
        let mut rng = fastrand::Rng::with_seed(seed);
        move || rng.f64() - 0.5
    }
}
