//! # bubblemesh-viz
//!
//! Seeing the mesh:
//! - [`svg`] and [`png`]: pictures of planar and surface meshes (surfaces
//!   projected along a view direction, painted far to near), elements
//!   coloured by radius ratio or by source entity, optionally the bubbles
//!   as circles (thesis Figs. 5.3–5.6);
//! - [`viewer`]: one self-contained HTML page (no network) with orbit, zoom,
//!   a clipping plane, colour by quality and the quality report;
//! - [`plots`]: the energy history of the relaxation (thesis Fig. 5.7) and
//!   histograms of radius ratio, angles and L/d, as SVG;
//! - [`anim`]: a page animating a sequence of pictures (the bubbles
//!   settling, thesis Fig. 5.6).
//!
//! Everything renders to bytes in memory; the caller writes them (the
//! command line through `bubblemesh_io::output`, whole or not at all).
//!
//! Invariants:
//! - an SVG picture holds exactly one `<polygon>` per drawn face: per
//!   triangle of a triangle mesh, per boundary face of a tetrahedral mesh;
//! - pictures, viewer and legends use the same colour tables ([`color`]);
//! - renderers never panic on a mesh that breaks the [`Mesh`] invariants:
//!   they return [`VizError::InvalidMesh`].

#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::path::Path;

pub use bubblemesh_core::Mesh;

pub mod anim;
pub mod color;
pub mod geometry;
pub mod html;
pub mod picture;
pub mod plots;
pub mod view;

pub use html::{viewer, ViewerOptions};
pub use picture::{png, svg, ColorBy, PictureOptions};

/// A rendering failure.
#[derive(Debug, thiserror::Error)]
pub enum VizError {
    /// Nothing to draw (no elements, no bubbles).
    #[error("the mesh has nothing to draw (no elements)")]
    Empty,
    /// The mesh breaks an invariant the renderer relies on.
    #[error("cannot draw the mesh: {0}")]
    InvalidMesh(String),
    /// The options do not fit the mesh.
    #[error("{0}")]
    Options(String),
}

/// The output kinds this crate writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An SVG picture.
    Svg,
    /// A PNG picture.
    Png,
    /// The viewer page.
    Html,
}

impl Kind {
    /// The kind of a path's extension (case-insensitive), if it is one of
    /// `.svg`, `.png`, `.html` (or `.htm`).
    pub fn from_path(path: &Path) -> Option<Kind> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "svg" => Some(Kind::Svg),
            "png" => Some(Kind::Png),
            "html" | "htm" => Some(Kind::Html),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_follow_the_extension() {
        assert_eq!(Kind::from_path(Path::new("a/B.SVG")), Some(Kind::Svg));
        assert_eq!(Kind::from_path(Path::new("x.png")), Some(Kind::Png));
        assert_eq!(Kind::from_path(Path::new("x.htm")), Some(Kind::Html));
        assert_eq!(Kind::from_path(Path::new("x.msh")), None);
        assert_eq!(Kind::from_path(Path::new("svg")), None);
    }
}
