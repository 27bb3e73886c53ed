//! # bubblemesh-truck
//!
//! Real CAD parts as bubblemesh [`Model`](bubblemesh_core::model::Model)s:
//!
//! - [`read_step`] / [`parse_step`]: a STEP (ISO 10303-21, AP203/AP214/AP242
//!   B-rep) file. The file is parsed by our own ISO 10303-21 parser
//!   ([`step::part21`]) into ruststep's AST; every geometric and topological
//!   entity is then converted here into bubblemesh-analytic geometry. Every `ADVANCED_FACE`,
//!   `EDGE_CURVE` and `VERTEX_POINT` of the file ends up in the model, or the
//!   read fails with an error naming the entity (`#id TYPE`) and the reason.
//!
//! - [`read_step_with`] / [`parse_step_with`]: the same, with
//!   [`StepOptions`]: `unit: Some(`[`LengthUnit`]`)` converts every
//!   coordinate and length from the file's length unit (millimetre,
//!   centimetre, metre, inch, foot, …: [`StepInfo::file_length_unit`]) to the
//!   one asked for, exactly as the geometry is read (points, control points,
//!   radii, offsets and tolerances scaled; angles, weights and knots kept).
//!   [`LengthUnit::parse`] reads `mm`, `cm`, `m`, `in`, `ft` (for a CLI
//!   `--unit` flag). Without it coordinates stay in the file's unit.
//!
//! - [`from_truck_solid`] / [`from_truck_shell`]: B-reps built in code with
//!   truck-modeling, their geometry converted the same way (see [`modeling`]).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod curve_tools;
mod face_build;
mod face_view;
pub mod modeling;
pub mod step;

pub use face_view::FaceView;
pub use modeling::{from_truck_shell, from_truck_solid, TruckError};
pub use step::{
    parse_step, parse_step_with, read_step, read_step_with, LengthUnit, StepError, StepInfo,
    StepModel, StepOptions,
};
