//! Helpers shared by the viz tests.

pub mod chromium;
pub mod meshes;
