//! Improvement passes on a tetrahedral mesh: optimal-Delaunay smoothing,
//! sliver removal with Steiner points, flips and the mean-quality polish.

pub mod flip;
pub mod odt;
pub mod polish;
pub mod sliver;
