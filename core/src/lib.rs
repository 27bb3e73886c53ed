//! # bubblemesh-core
//!
//! Physically-based mesh generation by bubble packing (K. Shimada, MIT PhD
//! thesis, 1993). Mesh nodes are bubbles whose diameter follows a node-spacing
//! function d(x); a damped dynamic simulation packs them to a force balance;
//! adaptive population control removes crowded bubbles and splits lonely
//! ones; the bubble centres are joined by constrained Delaunay triangulation.
//!
//! Meshing goes in the order of dimensions (thesis §3.2.3): vertices, then
//! edges, then faces, then volumes, each lower-dimensional result fixed while
//! the next dimension is packed.
//!
//! Modules follow the thesis's concepts:
//! - [`geom`]: what geometry must answer (curves, surfaces, volumes; §5.1.4);
//! - [`model`]: the B-rep topology with stable ids;
//! - [`spacing`]: the node-spacing interface d(x) (§3.2.1, §4.6);
//! - [`bubbles`]: the dimension-independent physics: forces (§4.2),
//!   dynamics (§4.3–4.4), constraints (§4.5), population control (§4.7);
//! - `edge`, [`face`], [`volume`]: stage 1 placement (§4.1), packing and
//!   connection of each dimension; `volume::tet`: the tetrahedral passes;
//! - [`engine`]: [`mesh_model`], meshing in the order of dimensions, with
//!   its [`Options`] (and their [`Event`] observer) and [`Report`];
//! - [`measure`]: the one definition of each element measure;
//! - [`mesh`]: the mesh with source entities; [`quality`]: element quality;
//!   [`verify`]: the last check a mesh passes before it may be written;
//! - [`remesh`]: re-meshing from a saved packing (§4.8).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub(crate) mod bubbles;
pub mod circle_points;
pub mod curvature;
pub(crate) mod edge;
pub mod engine;
pub(crate) mod error;
pub(crate) mod face;
pub mod geom;
pub(crate) mod incidence;
pub mod measure;
pub mod mesh;
pub mod model;
pub(crate) mod options;
pub mod quality;
pub mod remesh;
pub mod spacing;
pub mod verify;
pub(crate) mod volume;

// The API other crates use: meshing, its options, observer and report.
pub use engine::{
    mesh_model, EnergySample, Event, Integrator, ObserverFn, Options, RelaxSettings, RelaxStats,
    Report, Timings, VolumeLattice, DEFAULT_CIRCLE_POINTS, MAX_CIRCLE_POINTS,
};
pub use error::MeshError;
pub use geom::{Curve, Plane, Surface, SurfaceDerivs, P3, V3};
pub use mesh::Mesh;
pub use model::{EntityRef, Model};
pub use spacing::Spacing;
