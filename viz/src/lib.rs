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
//! Everything renders to bytes in memory; [`write_atomic`] then puts a file
//! in place whole or not at all.
//!
//! Invariants:
//! - an SVG picture holds exactly one `<polygon>` per drawn face: per
//!   triangle of a triangle mesh, per boundary face of a tetrahedral mesh;
//! - pictures, viewer and legends use the same colour tables ([`color`]);
//! - renderers never panic on a mesh that breaks the [`Mesh`] invariants:
//!   they return [`VizError::InvalidMesh`].

use std::fs::{self, OpenOptions};
use std::io::{self, Write};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

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
    Svg,
    Png,
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

/// Writes `bytes` to `path` whole or not at all: a temporary file in the
/// same directory, synced, then renamed over `path`; on failure the
/// temporary is removed and an existing `path` is left as it was.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "not a file name"))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let tmp = dir.join(format!(
        ".{}.{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut f = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
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

    #[test]
    fn atomic_write_replaces_whole_and_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.svg");
        fs::write(&p, "old").unwrap();
        write_atomic(&p, b"new").unwrap();
        assert_eq!(fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
        // a missing directory: an error, nothing written
        let q = dir.path().join("missing/b.svg");
        assert!(write_atomic(&q, b"x").is_err());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
