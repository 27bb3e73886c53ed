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
//! - [`engine`]: stage 1 placement (§4.1), forces (§4.2), dynamics (§4.3–4.4),
//!   constraints (§4.5), population control (§4.7);
//! - [`connect`]: constrained Delaunay connection of bubble centres;
//!   [`connect3d`]: the boundary-conforming Delaunay tetrahedralization of a
//!   volume's bubbles;
//! - [`mesh`]: the mesh with source entities; [`quality`]: element quality;
//!   [`verify`]: the last check a mesh passes before it may be written.

pub mod connect;
pub mod connect3d;
pub mod curvature;
pub mod engine;
pub mod geom;
pub mod mesh;
pub mod model;
pub mod quality;
pub mod spacing;
pub mod verify;

pub use engine::{mesh_model, MeshError, Options, Report};
pub use geom::{Curve, Plane, Surface, SurfaceDerivs, P3, V3};
pub use mesh::Mesh;
pub use model::{EntityRef, Model};
pub use spacing::Spacing;
