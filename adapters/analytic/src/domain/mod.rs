//! The bubblemesh TOML domain format, version 1.
//!
//! A domain file describes planar 2D domains (faces in the plane z = 0) and
//! stand-alone curves; [`parse_domain`] and [`read_domain`] turn it into a
//! [`Model`] whose faces lie on [`bubblemesh_core::geom::Plane::xy`], so a
//! face's (u, v) is (x, y). The user documentation with examples is
//! `docs/domain-format.md`; in short:
//!
//! ```toml
//! format = "bubblemesh-domain 1"
//!
//! [[face]]
//! name = "plate"
//! outer = { polygon = [[0, 0], [2, 0], [2, 1], [0, 1]] }
//! holes = [ { circle = { center = [0.5, 0.5], radius = 0.2 } } ]
//! constraints = [ { line = [[1.2, 0.2], [1.6, 0.4]] } ]
//! points = [[1.0, 0.8]]
//! ```
//!
//! Guarantees of the returned model:
//! - vertices closer than the tolerance (default 1e-9 × the bounding-box
//!   diagonal, or the file's `tolerance`) are one vertex, file-wide;
//! - edges with the same end vertices and the same geometry are one edge,
//!   so faces that share a side share the edge (used in opposite
//!   directions by two faces on either side);
//! - each face's first loop is its outer loop, counter-clockwise in (x, y),
//!   the others are holes, clockwise; consecutive edge uses connect;
//! - loops are closed, simple, pairwise disjoint, holes lie inside the outer
//!   loop and not inside one another (checked on sampled loops);
//! - constraint curves (`Face::embedded_edges`) and points
//!   (`Face::embedded_vertices`) lie inside their face; a constraint may
//!   meet the boundary only at a boundary vertex;
//! - no input makes the reader panic; every problem is a [`DomainError`]
//!   naming the file, the entity and the reason.

mod build;
mod error;
mod planar;
mod solid;
mod spec;
mod surface;

use std::path::Path;

use bubblemesh_core::model::Model;

pub use build::RELATIVE_TOLERANCE;
pub use error::DomainError;

/// The value of the required `format` key for this version of the format.
pub const FORMAT: &str = "bubblemesh-domain 1";

/// Reads and parses the domain file at `path`; errors name the file as
/// `path` is displayed. Sets `model.source` to that name.
pub fn read_domain(path: &Path) -> Result<Model, DomainError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| DomainError::Io {
        file: file.clone(),
        source,
    })?;
    parse_domain(&text, &file)
}

/// Parses domain-format `text`; `source_name` (usually the file name) is
/// used in error messages and stored in `model.source`.
pub fn parse_domain(text: &str, source_name: &str) -> Result<Model, DomainError> {
    let file = || source_name.to_string();
    let table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| DomainError::Toml {
            file: file(),
            message: e.to_string().trim_end().to_string(),
        })?;
    check_format(table.get("format")).map_err(|reason| DomainError::Format {
        file: file(),
        reason,
    })?;
    let spec: spec::DomainSpec = toml::from_str(text).map_err(|e| DomainError::Schema {
        file: file(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let mut model = build::build(&spec).map_err(|e| e.with_file(source_name))?;
    model.source = Some(source_name.to_string());
    Ok(model)
}

fn check_format(v: Option<&toml::Value>) -> Result<(), String> {
    let example = format!("format = \"{FORMAT}\"");
    match v {
        None => Err(format!(
            "missing the required key `format`; a domain file starts with the line: {example}"
        )),
        Some(toml::Value::String(s)) => {
            let s = s.trim();
            if s == FORMAT {
                Ok(())
            } else if let Some(version) = s.strip_prefix("bubblemesh-domain") {
                Err(format!(
                    "unsupported format version \"{}\": this reader understands {example}",
                    version.trim()
                ))
            } else {
                Err(format!("unknown format \"{s}\": expected {example}"))
            }
        }
        Some(other) => Err(format!(
            "the key `format` must be a string (got a {}): {example}",
            other.type_str()
        )),
    }
}
