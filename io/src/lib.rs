//! # bubblemesh-io
//!
//! Mesh writers and readers: Gmsh MSH 4.1 ASCII (read also MSH 2.2), VTK XML
//! `.vtu` (ASCII), STL (binary written; ASCII and binary read), Wavefront
//! OBJ and Medit `.mesh`.
//! A written `.msh` carries one physical group per entity with elements,
//! tagged like the entity and named after it (the part or face; see
//! [`msh`]), so FEM tools (Gmsh, meshio, dolfinx) tell the parts apart.
//!
//! [`write`] and [`read`] choose the format from the file extension. Each
//! format module also offers `write_to` (to any [`std::io::Write`]) and
//! `parse` (from bytes), which know nothing about files.
//!
//! Invariants:
//! - writing is atomic: the output goes to a temporary file in the target's
//!   directory which is renamed over the target only once complete; on any
//!   error the temporary is removed and an existing target is left untouched
//!   ([`output::OutputSet`] does this for several files at once; an existing
//!   device or FIFO is written in place, never renamed over);
//! - every [`IoError`] names the file it is about;
//! - readers never panic on bad input: truncated, empty or garbage files give
//!   [`IoError::Parse`] with the reason and, where it makes sense, the line;
//! - a read [`Mesh`] keeps the [`Mesh`] invariants that do not depend on the
//!   file's geometry: element indices are in range, every node has an entity
//!   (the file's own where it has one, else inferred: the entity of the
//!   lowest-dimensional element using the node), and `entities` lists every
//!   entity used by a node or element.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::collections::{BTreeMap, HashSet};
use std::fmt;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use bubblemesh_core::mesh::{Element, EntityInfo, Mesh};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

pub mod medit;
pub mod msh;
pub mod obj;
pub mod output;
pub mod stl;
pub mod vtu;

mod text;

/// An error reading or writing a mesh file. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused (missing directory, permissions, ...).
    #[error("{}: {source}", .path.display())]
    Io {
        /// The file (or directory) the failed operation was on.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: io::Error,
    },
    /// The extension names no supported format.
    #[error(
        "{}: unsupported mesh file extension '{ext}' (supported: {})",
        .path.display(),
        Format::supported_list()
    )]
    UnsupportedExtension {
        /// The path whose extension was not recognised.
        path: PathBuf,
        /// The extension as given, with its dot (`.txt`), or `(none)` when
        /// the path has no extension.
        ext: String,
    },
    /// The file's content is not a valid mesh of its format.
    #[error("{}{}: {reason}", .path.display(), line_suffix(*.line))]
    Parse {
        /// The file that failed to parse.
        path: PathBuf,
        /// 1-based line number, when the format is line-oriented.
        line: Option<usize>,
        /// What is wrong with the content (a missing section, a malformed
        /// number, a node index out of range, ...).
        reason: String,
    },
    /// The mesh cannot be written (an element refers to a missing node, a
    /// coordinate is not finite, ...).
    #[error("{}: cannot write the mesh: {reason}", .path.display())]
    InvalidMesh {
        /// The file that was to be written; it is left untouched.
        path: PathBuf,
        /// The first defect found (too many nodes, a non-finite node, an
        /// element naming a missing node, an entity dimension above 3).
        reason: String,
    },
    /// An output path that cannot be used (it is an input, a directory,
    /// another output, ...): see [`output::check_outputs`].
    #[error("{}: {reason}", .path.display())]
    Output {
        /// The refused output path.
        path: PathBuf,
        /// Why it is refused; [`output::check_outputs`] names the output by
        /// its command-line label (`-o`, `--report`).
        reason: String,
    },
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|l| format!(":{l}")).unwrap_or_default()
}

/// A parse failure, without the file name (the format modules work on
/// bytes; [`read`] adds the path).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    /// 1-based line number, when it makes sense.
    pub line: Option<usize>,
    /// What is wrong with the content (a missing section, a malformed number,
    /// a node index out of range, ...).
    pub reason: String,
}

impl ParseError {
    /// A parse error not tied to a line (a missing section, a truncated
    /// binary file, ...).
    pub fn new(reason: impl Into<String>) -> Self {
        ParseError {
            line: None,
            reason: reason.into(),
        }
    }
    /// A parse error at the 1-based `line`.
    pub fn at(line: usize, reason: impl Into<String>) -> Self {
        ParseError {
            line: Some(line),
            reason: reason.into(),
        }
    }
    fn with_path(self, path: &Path) -> IoError {
        IoError::Parse {
            path: path.to_path_buf(),
            line: self.line,
            reason: self.reason,
        }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "line {l}: {}", self.reason),
            None => f.write_str(&self.reason),
        }
    }
}

impl std::error::Error for ParseError {}

/// The supported file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Gmsh MSH 4.1 ASCII (reads MSH 2.2 ASCII too), `.msh`.
    Msh,
    /// VTK XML unstructured grid, ASCII, `.vtu`.
    Vtu,
    /// STL (binary written; ASCII and binary read), `.stl`.
    Stl,
    /// Wavefront OBJ, `.obj`.
    Obj,
    /// Medit (INRIA) ASCII mesh, `.mesh`.
    Medit,
}

impl Format {
    /// Every supported format, in the order they are listed in messages
    /// (MSH, VTU, STL, OBJ, Medit).
    pub const ALL: [Format; 5] = [
        Format::Msh,
        Format::Vtu,
        Format::Stl,
        Format::Obj,
        Format::Medit,
    ];

    /// The extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Msh => "msh",
            Format::Vtu => "vtu",
            Format::Stl => "stl",
            Format::Obj => "obj",
            Format::Medit => "mesh",
        }
    }

    /// The format of a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format, IoError> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_string())
            .unwrap_or_default();
        let lower = ext.to_ascii_lowercase();
        Format::ALL
            .into_iter()
            .find(|f| f.extension() == lower)
            .ok_or_else(|| IoError::UnsupportedExtension {
                path: path.to_path_buf(),
                ext: if ext.is_empty() {
                    "(none)".to_string()
                } else {
                    format!(".{ext}")
                },
            })
    }

    fn supported_list() -> String {
        Format::ALL
            .iter()
            .map(|f| format!(".{}", f.extension()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Writes `mesh` to `path` in the format of its extension, atomically.
pub fn write(mesh: &Mesh, path: &Path) -> Result<(), IoError> {
    write_as(mesh, path, Format::from_path(path)?)
}

/// Writes `mesh` to `path` in `format`, atomically (see the crate invariants).
pub fn write_as(mesh: &Mesh, path: &Path, format: Format) -> Result<(), IoError> {
    let mut out = output::OutputSet::new();
    stage_as(&mut out, mesh, path, format)?;
    out.commit()
}

/// Stages `mesh` as the file `path` (format of its extension) in `out`,
/// written when `out` commits.
pub fn stage(out: &mut output::OutputSet, mesh: &Mesh, path: &Path) -> Result<(), IoError> {
    stage_as(out, mesh, path, Format::from_path(path)?)
}

/// Stages `mesh` as the file `path` in `format` in `out`.
pub fn stage_as(
    out: &mut output::OutputSet,
    mesh: &Mesh,
    path: &Path,
    format: Format,
) -> Result<(), IoError> {
    validate(mesh).map_err(|reason| IoError::InvalidMesh {
        path: path.to_path_buf(),
        reason,
    })?;
    out.file(path, |mut w| match format {
        Format::Msh => msh::write_to(mesh, &mut w),
        Format::Vtu => vtu::write_to(mesh, &mut w),
        Format::Stl => stl::write_to(mesh, &mut w),
        Format::Obj => obj::write_to(mesh, &mut w),
        Format::Medit => medit::write_to(mesh, &mut w),
    })
}

/// Reads the mesh at `path` in the format of its extension.
pub fn read(path: &Path) -> Result<Mesh, IoError> {
    read_as(path, Format::from_path(path)?)
}

/// Values given per node of a mesh file (MSH `$NodeData`, VTU
/// `<PointData>`): a target size, an error indicator, a solution.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeField {
    /// The field's name: the first string tag of a MSH `$NodeData`, the
    /// `Name` attribute of a VTU `<DataArray>`.
    pub name: String,
    /// Values per node (1 for a scalar).
    pub components: usize,
    /// `components` values per node, in the order of [`Mesh::nodes`]; NaN
    /// for a node the file gives no value.
    pub values: Vec<f64>,
}

/// Reads the mesh at `path` with its per-node fields: `$NodeData` of a MSH
/// file, `<PointData>` of a VTU file (other formats carry none and give an
/// empty list).
pub fn read_with_node_data(path: &Path) -> Result<(Mesh, Vec<NodeField>), IoError> {
    let format = Format::from_path(path)?;
    type Parser = fn(&[u8]) -> Result<(Mesh, Vec<NodeField>), ParseError>;
    let parse: Parser = match format {
        Format::Msh => msh::parse_with_node_data,
        Format::Vtu => vtu::parse_with_node_data,
        _ => return read_as(path, format).map(|m| (m, Vec::new())),
    };
    let data = read_bytes(path)?;
    parse(&data).map_err(|e| e.with_path(path))
}

/// Reads the mesh at `path` in the format of its extension, with a note
/// per kind of element the reader skipped (quadrangles, hexahedra,
/// second-order elements: element types it does not keep). The caller
/// shows them: a skipped element is never silent.
pub fn read_with_notes(path: &Path) -> Result<(Mesh, Vec<String>), IoError> {
    let format = Format::from_path(path)?;
    type Parse = fn(&[u8]) -> Result<(Mesh, Vec<String>), ParseError>;
    let parse: Parse = match format {
        Format::Msh => msh::parse_with_notes,
        Format::Vtu => vtu::parse_with_notes,
        Format::Medit => medit::parse_with_notes,
        // STL holds triangles only; OBJ polygons are triangulated
        Format::Stl | Format::Obj => return read_as(path, format).map(|m| (m, Vec::new())),
    };
    let data = read_bytes(path)?;
    parse(&data).map_err(|e| e.with_path(path))
}

/// The bytes of the mesh file at `path`; an empty (or all-blank) file is
/// an error.
fn read_bytes(path: &Path) -> Result<Vec<u8>, IoError> {
    let data = fs::read(path).map_err(|source| IoError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if data.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(ParseError::new("the file is empty").with_path(path));
    }
    Ok(data)
}

/// Reads the mesh at `path` in `format`.
pub fn read_as(path: &Path, format: Format) -> Result<Mesh, IoError> {
    let data = read_bytes(path)?;
    let parsed = match format {
        Format::Msh => msh::parse(&data),
        Format::Vtu => vtu::parse(&data),
        Format::Stl => stl::parse(&data),
        Format::Obj => obj::parse(&data),
        Format::Medit => medit::parse(&data),
    };
    parsed.map_err(|e| e.with_path(path))
}

/// Checks what the writers rely on: element indices in range, entity
/// dimensions ≤ 3, finite coordinates ([`bubblemesh_core::measure::check_indices`]).
fn validate(mesh: &Mesh) -> Result<(), String> {
    bubblemesh_core::measure::check_indices(mesh).map_err(|e| e.to_string())
}

// ---------------------------------------------------------------------------
// helpers shared by the formats

/// The triangles a surface format (STL, OBJ) writes: the mesh's triangles if
/// it has any, else the boundary faces of its tetrahedra (faces in exactly
/// one tetrahedron), oriented outward (for either orientation of the tet),
/// with the tetrahedron's entity. Empty for meshes with neither.
pub fn surface_triangles(mesh: &Mesh) -> Vec<Element<3>> {
    if !mesh.triangles.is_empty() || mesh.tetrahedra.is_empty() {
        return mesh.triangles.clone();
    }
    // Face k is opposite vertex k; outward for a positively oriented tet.
    use bubblemesh_core::measure::{boundary_faces, TET_FACES as FACES};
    let mut boundary = boundary_faces(mesh.tetrahedra.iter().map(|t| t.nodes));
    boundary.sort_unstable();
    boundary
        .into_iter()
        .map(|(t, k)| {
            let tet = &mesh.tetrahedra[t as usize];
            let p = tet.nodes.map(|i| mesh.nodes[i as usize].pos);
            let six_v = (p[1] - p[0]).dot(&(p[2] - p[0]).cross(&(p[3] - p[0])));
            let mut nodes = FACES[k as usize].map(|i| tet.nodes[i]);
            if six_v < 0.0 {
                nodes.swap(1, 2);
            }
            Element {
                nodes,
                entity: tet.entity,
            }
        })
        .collect()
}

/// Fills the entity of every node with `known[i] == false`: the entity of
/// the lowest-dimensional element using it (first such element in the order
/// lines, triangles, tetrahedra), or `EntityRef{dim: mesh dim (2 for a mesh
/// without elements), id: 0}` for a node no element uses.
pub(crate) fn infer_node_entities(mesh: &mut Mesh, known: &[bool]) {
    let n = mesh.nodes.len();
    let mut set: Vec<bool> = (0..n)
        .map(|i| known.get(i).copied().unwrap_or(false))
        .collect();
    let Mesh {
        nodes,
        lines,
        triangles,
        tetrahedra,
        ..
    } = mesh;
    let mut visit = |ids: &[u32], entity: EntityRef| {
        for &v in ids {
            let v = v as usize;
            if !set[v] {
                set[v] = true;
                nodes[v].entity = entity;
            }
        }
    };
    for e in lines.iter() {
        visit(&e.nodes, e.entity);
    }
    for e in triangles.iter() {
        visit(&e.nodes, e.entity);
    }
    for e in tetrahedra.iter() {
        visit(&e.nodes, e.entity);
    }
    let default = EntityRef::new(
        match mesh.dim() {
            0 => 2,
            d => d,
        },
        0,
    );
    for (node, s) in mesh.nodes.iter_mut().zip(set) {
        if !s {
            node.entity = default;
        }
    }
}

/// The entity table a writer uses: `mesh.entities` (first listing wins)
/// plus, with an empty boundary, every entity a node or element uses that is
/// not listed; sorted by (dim, id).
pub fn entity_table(mesh: &Mesh) -> Vec<EntityInfo> {
    let mut table: BTreeMap<EntityRef, EntityInfo> = BTreeMap::new();
    for e in &mesh.entities {
        table.entry(e.entity).or_insert_with(|| e.clone());
    }
    let mut used: HashSet<EntityRef> = HashSet::new();
    used.extend(mesh.nodes.iter().map(|n| n.entity));
    used.extend(mesh.lines.iter().map(|e| e.entity));
    used.extend(mesh.triangles.iter().map(|e| e.entity));
    used.extend(mesh.tetrahedra.iter().map(|e| e.entity));
    for e in used {
        table.entry(e).or_insert_with(|| EntityInfo {
            entity: e,
            boundary: vec![],
            name: None,
        });
    }
    table.into_values().collect()
}

/// Sets `mesh.entities` to [`entity_table`] (readers call this last).
pub(crate) fn complete_entities(mesh: &mut Mesh) {
    mesh.entities = entity_table(mesh);
}

/// A float in the shortest form that reads back exactly, in exponent form
/// only for very large or small magnitudes (Rust's `{}` never uses one).
pub(crate) struct F(pub f64);

impl fmt::Display for F {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a == 0.0 {
            f.write_str("0")
        } else if (1e-5..1e16).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// A node position written as `x y z`.
pub(crate) struct Xyz<'a>(pub &'a P3);

impl fmt::Display for Xyz<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {}", F(self.0.x), F(self.0.y), F(self.0.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_read_back_exactly() {
        for x in [
            0.1,
            -1.0 / 3.0,
            1e-300,
            6.02e23,
            1e15,
            12345.678,
            -0.0,
            5e-324,
        ] {
            let s = F(x).to_string();
            assert_eq!(s.parse::<f64>().unwrap(), x, "{s}");
            assert!(s.len() < 30, "{s}");
        }
    }

    #[test]
    fn a_body_failing_midway_leaves_the_target_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("x.msh");
        fs::write(&target, "old").unwrap();
        let mut out = output::OutputSet::new();
        let err = out
            .file(&target, |w| {
                w.write_all(&[b'a'; 200_000])?;
                Err(io::Error::other("boom"))
            })
            .unwrap_err();
        drop(out);
        let msg = err.to_string();
        assert!(msg.contains("x.msh") && msg.contains("boom"), "{msg}");
        assert_eq!(fs::read_to_string(&target).unwrap(), "old");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn unknown_extension_lists_the_supported_ones() {
        let e = Format::from_path(Path::new("out/a.xyz"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.xyz") && e.contains(".xyz"), "{e}");
        assert!(e.contains(".msh, .vtu, .stl, .obj, .mesh"), "{e}");
        let e = Format::from_path(Path::new("noext"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("noext") && e.contains("(none)"), "{e}");
        assert_eq!(Format::from_path(Path::new("A.MSH")).unwrap(), Format::Msh);
    }
}
