//! VTK XML unstructured grid (`.vtu`), ASCII.
//!
//! Written layout (invariants): one piece; cells are the lines (VTK type 3),
//! then the triangles (5), then the tetrahedra (10), each in mesh order;
//! point data and cell data `entity_dim` and `entity_id` (Int32) give every
//! node's and cell's entity; points are Float64 written exactly.
//!
//! Reading accepts ASCII files as written here or by meshio (`binary=False`):
//! cells of types 3, 5 and 10 are kept, other VTK types skipped (with a
//! note, see [`parse_with_notes`]; vertex cells silently), a type that is
//! no VTK type is an error. Entities come from
//! `entity_dim`/`entity_id` when present, else from meshio's Gmsh tags
//! (`gmsh:dim_tags` point data, `gmsh:geometrical` cell data), else they are
//! inferred (see the crate documentation). Binary or appended data is
//! rejected with a message saying so.

use std::io::{self, Write};

use bubblemesh_core::mesh::{Element, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

use crate::text::{as_text, clip};
use crate::{complete_entities, infer_node_entities, NodeField, ParseError, Xyz};

/// Writes `mesh` as ASCII VTU. Element indices must be in range.
pub fn write_to<W: Write>(mesh: &Mesh, w: &mut W) -> io::Result<()> {
    let ncells = mesh.lines.len() + mesh.triangles.len() + mesh.tetrahedra.len();
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    writeln!(w, "<!-- written by bubblemesh -->")?;
    writeln!(w, "<UnstructuredGrid>")?;
    writeln!(
        w,
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
        mesh.nodes.len(),
        ncells
    )?;

    let cell_entities = || {
        mesh.lines
            .iter()
            .map(|e| e.entity)
            .chain(mesh.triangles.iter().map(|e| e.entity))
            .chain(mesh.tetrahedra.iter().map(|e| e.entity))
    };
    writeln!(w, "<PointData>")?;
    int_array(
        w,
        "entity_dim",
        mesh.nodes.iter().map(|n| n.entity.dim as i64),
    )?;
    int_array(
        w,
        "entity_id",
        mesh.nodes.iter().map(|n| n.entity.id as i64),
    )?;
    writeln!(w, "</PointData>")?;
    writeln!(w, "<CellData>")?;
    int_array(w, "entity_dim", cell_entities().map(|e| e.dim as i64))?;
    int_array(w, "entity_id", cell_entities().map(|e| e.id as i64))?;
    writeln!(w, "</CellData>")?;

    writeln!(w, "<Points>")?;
    writeln!(
        w,
        "<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">"
    )?;
    for n in &mesh.nodes {
        writeln!(w, "{}", Xyz(&n.pos))?;
    }
    writeln!(w, "</DataArray>\n</Points>")?;

    writeln!(w, "<Cells>")?;
    writeln!(
        w,
        "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
    )?;
    fn conn<W: Write, const N: usize>(w: &mut W, elems: &[Element<N>]) -> io::Result<()> {
        for e in elems {
            let mut sep = "";
            for v in e.nodes {
                write!(w, "{sep}{v}")?;
                sep = " ";
            }
            writeln!(w)?;
        }
        Ok(())
    }
    conn(w, &mesh.lines)?;
    conn(w, &mesh.triangles)?;
    conn(w, &mesh.tetrahedra)?;
    writeln!(w, "</DataArray>")?;
    writeln!(
        w,
        "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
    )?;
    let mut off = 0u64;
    for (count, k) in [
        (mesh.lines.len(), 2),
        (mesh.triangles.len(), 3),
        (mesh.tetrahedra.len(), 4),
    ] {
        for _ in 0..count {
            off += k;
            writeln!(w, "{off}")?;
        }
    }
    writeln!(w, "</DataArray>")?;
    writeln!(
        w,
        "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
    )?;
    for (count, ty) in [
        (mesh.lines.len(), 3),
        (mesh.triangles.len(), 5),
        (mesh.tetrahedra.len(), 10),
    ] {
        for _ in 0..count {
            writeln!(w, "{ty}")?;
        }
    }
    writeln!(w, "</DataArray>")?;
    writeln!(w, "</Cells>")?;
    writeln!(w, "</Piece>\n</UnstructuredGrid>\n</VTKFile>")?;
    Ok(())
}

fn int_array<W: Write>(w: &mut W, name: &str, values: impl Iterator<Item = i64>) -> io::Result<()> {
    writeln!(
        w,
        "<DataArray type=\"Int32\" Name=\"{name}\" format=\"ascii\">"
    )?;
    for v in values {
        writeln!(w, "{v}")?;
    }
    writeln!(w, "</DataArray>")
}

// ---------------------------------------------------------------------------
// reading

/// An XML start or end tag.
struct Tag<'a> {
    name: &'a str,
    attrs: Vec<(&'a str, &'a str)>,
    closing: bool,
    self_closing: bool,
    /// Byte offsets of `<` and just past `>`.
    start: usize,
    end: usize,
}

impl<'a> Tag<'a> {
    fn attr(&self, name: &str) -> Option<&'a str> {
        self.attrs.iter().find(|a| a.0 == name).map(|a| a.1)
    }
}

/// 1-based line number of a byte offset.
fn line_of(s: &str, at: usize) -> usize {
    1 + s.as_bytes()[..at.min(s.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// At most the first `n` bytes of `s`, cut back to a character boundary
/// (a byte index inside a multi-byte character would panic).
fn head(s: &str, n: usize) -> &str {
    let mut end = s.len().min(n);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s[..end]
}

/// The next tag at or after `from`, skipping comments, processing
/// instructions and declarations; `None` at the end of the text.
fn next_tag(s: &str, mut from: usize) -> Result<Option<Tag<'_>>, ParseError> {
    let b = s.as_bytes();
    loop {
        let Some(lt) = s[from..].find('<').map(|i| from + i) else {
            return Ok(None);
        };
        let rest = &s[lt..];
        let skip_to = |end: &str| {
            rest.find(end).map(|i| lt + i + end.len()).ok_or_else(|| {
                ParseError::at(
                    line_of(s, lt),
                    format!("unterminated '{}'", clip(head(rest, 9))),
                )
            })
        };
        if rest.starts_with("<!--") {
            from = skip_to("-->")?;
            continue;
        }
        if rest.starts_with("<?") {
            from = skip_to("?>")?;
            continue;
        }
        if rest.starts_with("<!") {
            from = skip_to(">")?;
            continue;
        }
        let err = |why: &str| ParseError::at(line_of(s, lt), format!("malformed XML tag: {why}"));
        let mut i = lt + 1;
        let closing = b.get(i) == Some(&b'/');
        if closing {
            i += 1;
        }
        let name_start = i;
        while i < b.len() && !b[i].is_ascii_whitespace() && b[i] != b'>' && b[i] != b'/' {
            i += 1;
        }
        let name = &s[name_start..i];
        if name.is_empty() {
            return Err(err("empty tag name"));
        }
        let mut attrs = Vec::new();
        loop {
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            match b.get(i) {
                None => return Err(err("the file ends inside a tag")),
                Some(b'>') => {
                    return Ok(Some(Tag {
                        name,
                        attrs,
                        closing,
                        self_closing: false,
                        start: lt,
                        end: i + 1,
                    }))
                }
                Some(b'/') if b.get(i + 1) == Some(&b'>') => {
                    return Ok(Some(Tag {
                        name,
                        attrs,
                        closing,
                        self_closing: true,
                        start: lt,
                        end: i + 2,
                    }))
                }
                _ => {}
            }
            let a0 = i;
            while i < b.len() && b[i] != b'=' && !b[i].is_ascii_whitespace() && b[i] != b'>' {
                i += 1;
            }
            let aname = &s[a0..i];
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            if b.get(i) != Some(&b'=') {
                return Err(err(&format!("attribute '{}' has no value", clip(aname))));
            }
            i += 1;
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            let q = match b.get(i) {
                Some(&q @ (b'"' | b'\'')) => q,
                _ => {
                    return Err(err(&format!(
                        "attribute '{}' value is not quoted",
                        clip(aname)
                    )))
                }
            };
            let v0 = i + 1;
            let Some(len) = s[v0..].find(q as char) else {
                return Err(err("unterminated attribute value"));
            };
            attrs.push((aname, &s[v0..v0 + len]));
            i = v0 + len + 1;
        }
    }
}

/// A DataArray as read: its name, components, section and text.
struct Array<'a> {
    name: &'a str,
    ncomp: usize,
    text: &'a str,
    line: usize,
    format: &'a str,
}

impl Array<'_> {
    fn check_ascii(&self) -> Result<(), ParseError> {
        if self.format != "ascii" {
            return Err(ParseError::at(
                self.line,
                format!(
                    "DataArray '{}' is in format '{}'; only ASCII VTU is supported (meshio: binary=False)",
                    self.name, self.format
                ),
            ));
        }
        Ok(())
    }

    fn numbers<T: std::str::FromStr>(&self) -> Result<Vec<T>, ParseError> {
        self.check_ascii()?;
        self.text
            .split_ascii_whitespace()
            .map(|t| {
                t.parse().map_err(|_| {
                    ParseError::at(
                        self.line,
                        format!(
                            "DataArray '{}' holds the non-number '{}'",
                            self.name,
                            clip(t)
                        ),
                    )
                })
            })
            .collect()
    }
}

/// The arrays of the (single) piece, by section.
#[derive(Default)]
struct Piece<'a> {
    points: Option<Array<'a>>,
    cells: Vec<Array<'a>>,
    point_data: Vec<Array<'a>>,
    cell_data: Vec<Array<'a>>,
    n_points: Option<usize>,
    n_cells: Option<usize>,
}

fn collect(s: &str) -> Result<Piece<'_>, ParseError> {
    let mut piece = Piece::default();
    let mut stack: Vec<&str> = Vec::new();
    let mut pieces = 0;
    let mut pos = 0;
    let mut saw_root = false;
    while let Some(tag) = next_tag(s, pos)? {
        pos = tag.end;
        let line = line_of(s, tag.start);
        if tag.closing {
            if stack.pop() != Some(tag.name) {
                return Err(ParseError::at(
                    line,
                    format!("unexpected closing tag '</{}>'", tag.name),
                ));
            }
            continue;
        }
        if !saw_root {
            if tag.name != "VTKFile" {
                return Err(ParseError::at(
                    line,
                    format!("not a VTK XML file: the root is '<{}>'", clip(tag.name)),
                ));
            }
            match tag.attr("type") {
                Some("UnstructuredGrid") => {}
                other => {
                    return Err(ParseError::at(
                        line,
                        format!(
                            "VTK file of type '{}', expected 'UnstructuredGrid'",
                            other.unwrap_or("?")
                        ),
                    ))
                }
            }
            saw_root = true;
        }
        match tag.name {
            "Piece" => {
                pieces += 1;
                if pieces > 1 {
                    return Err(ParseError::at(line, "files with several pieces are not supported"));
                }
                let count = |a: &str| -> Result<Option<usize>, ParseError> {
                    tag.attr(a)
                        .map(|v| {
                            v.trim()
                                .parse()
                                .map_err(|_| ParseError::at(line, format!("bad {a}=\"{}\"", clip(v))))
                        })
                        .transpose()
                };
                piece.n_points = count("NumberOfPoints")?;
                piece.n_cells = count("NumberOfCells")?;
            }
            "AppendedData" => {
                return Err(ParseError::at(
                    line,
                    "appended (raw/binary) data is not supported; only ASCII VTU (meshio: binary=False)",
                ))
            }
            "DataArray" if !tag.self_closing => {
                let close = next_tag(s, tag.end)?.ok_or_else(|| ParseError::at(line, "unterminated DataArray"))?;
                if !(close.closing && close.name == "DataArray") {
                    return Err(ParseError::at(line_of(s, close.start), "expected '</DataArray>'"));
                }
                pos = close.end;
                let ncomp = match tag.attr("NumberOfComponents") {
                    Some(v) => v
                        .trim()
                        .parse()
                        .map_err(|_| ParseError::at(line, format!("bad NumberOfComponents=\"{}\"", clip(v))))?,
                    None => 1,
                };
                let a = Array {
                    name: tag.attr("Name").unwrap_or(""),
                    ncomp,
                    text: &s[tag.end..close.start],
                    line,
                    format: tag.attr("format").unwrap_or("ascii"),
                };
                match stack.last().copied() {
                    Some("Points") if piece.points.is_none() => piece.points = Some(a),
                    Some("Cells") => piece.cells.push(a),
                    Some("PointData") => piece.point_data.push(a),
                    Some("CellData") => piece.cell_data.push(a),
                    _ => {}
                }
                continue;
            }
            _ => {}
        }
        if !tag.self_closing {
            stack.push(tag.name);
        }
    }
    if !saw_root {
        return Err(ParseError::new("not a VTK XML file: no <VTKFile> element"));
    }
    if let Some(open) = stack.last() {
        return Err(ParseError::at(
            line_of(s, s.len()),
            format!("the file ends inside <{open}>"),
        ));
    }
    if pieces == 0 {
        return Err(ParseError::new("the file has no <Piece>"));
    }
    Ok(piece)
}

fn find<'a, 'b>(arrays: &'b [Array<'a>], name: &str) -> Option<&'b Array<'a>> {
    arrays.iter().find(|a| a.name == name)
}

/// An entity from numbers read as f64 (dimension and id must be integers).
fn entity_from(dim: f64, id: f64, line: usize, what: &str) -> Result<EntityRef, ParseError> {
    let ok_dim = (0.0..=3.0).contains(&dim) && dim.fract() == 0.0;
    let ok_id = (0.0..=u32::MAX as f64).contains(&id) && id.fract() == 0.0;
    if !(ok_dim && ok_id) {
        return Err(ParseError::at(
            line,
            format!("{what}: bad entity ({dim}, {id})"),
        ));
    }
    Ok(EntityRef::new(dim as u8, id as u32))
}

/// Entities per item from a pair of (dim, id) arrays, if present with `n`
/// values each.
fn entities_of(arrays: &[Array], n: usize) -> Result<Option<Vec<EntityRef>>, ParseError> {
    let (Some(d), Some(i)) = (find(arrays, "entity_dim"), find(arrays, "entity_id")) else {
        return Ok(None);
    };
    let (dv, iv) = (d.numbers::<f64>()?, i.numbers::<f64>()?);
    if dv.len() != n || iv.len() != n {
        return Err(ParseError::at(
            d.line,
            format!(
                "entity_dim/entity_id hold {}/{} values, expected {n}",
                dv.len(),
                iv.len()
            ),
        ));
    }
    dv.iter()
        .zip(&iv)
        .map(|(&a, &b)| entity_from(a, b, d.line, "entity_dim/entity_id"))
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Parses an ASCII VTU file.
pub fn parse(data: &[u8]) -> Result<Mesh, ParseError> {
    parse_impl(data, false).map(|r| r.0)
}

/// Parses an ASCII VTU file with its `<PointData>` arrays as node fields
/// (every array with one value per component per point).
pub fn parse_with_node_data(data: &[u8]) -> Result<(Mesh, Vec<NodeField>), ParseError> {
    parse_impl(data, true).map(|r| (r.0, r.1))
}

/// Parses an ASCII VTU file, with a note per VTK cell type skipped (a type
/// the reader does not keep: quads, hexahedra, quadratic cells, ...).
pub fn parse_with_notes(data: &[u8]) -> Result<(Mesh, Vec<String>), ParseError> {
    parse_impl(data, false).map(|r| (r.0, r.2))
}

/// VTK cell types are 0..=81 (vtkCellType.h); a type outside is no VTK cell.
const VTK_MAX_TYPE: i64 = 81;

type Parsed = (Mesh, Vec<NodeField>, Vec<String>);

/// Parses a VTU file: points, cells (connectivity, offsets, types) and,
/// with `node_data`, the point data arrays, with notes on what it skipped.
///
/// Longer than 150 lines on purpose: one pass over the XML elements in
/// document order, whose state (the piece's counts, the arrays read so
/// far) every element's branch reads and checks against.
fn parse_impl(data: &[u8], node_data: bool) -> Result<Parsed, ParseError> {
    let s = as_text(data);
    let piece = collect(&s)?;
    let pts_arr = piece
        .points
        .as_ref()
        .ok_or_else(|| ParseError::new("the piece has no <Points> array"))?;
    let xyz: Vec<f64> = pts_arr.numbers()?;
    if pts_arr.ncomp != 3 && pts_arr.ncomp != 2 {
        return Err(ParseError::at(
            pts_arr.line,
            format!("points have {} components, expected 3", pts_arr.ncomp),
        ));
    }
    let nc = pts_arr.ncomp;
    #[allow(clippy::manual_is_multiple_of)] // is_multiple_of needs Rust 1.87
    let ragged = xyz.len() % nc != 0;
    if ragged
        || piece
            .n_points
            .is_some_and(|n| n.checked_mul(nc) != Some(xyz.len()))
    {
        return Err(ParseError::at(
            pts_arr.line,
            format!(
                "{} point coordinates do not make the {} points of NumberOfPoints",
                xyz.len(),
                piece.n_points.map_or("?".to_string(), |n| n.to_string())
            ),
        ));
    }
    if let Some(x) = xyz.iter().find(|x| !x.is_finite()) {
        return Err(ParseError::at(
            pts_arr.line,
            format!("non-finite coordinate {x}"),
        ));
    }
    let np = xyz.len() / nc;
    let mut mesh = Mesh {
        nodes: xyz
            .chunks(nc)
            .map(|c| Node {
                pos: P3::new(c[0], c[1], if nc == 3 { c[2] } else { 0.0 }),
                entity: EntityRef::new(0, 0),
                params: [0.0, 0.0],
            })
            .collect(),
        ..Mesh::default()
    };

    let get = |name: &str| {
        find(&piece.cells, name)
            .ok_or_else(|| ParseError::new(format!("<Cells> has no '{name}' array")))
    };
    let (conn_a, off_a, ty_a) = (get("connectivity")?, get("offsets")?, get("types")?);
    let conn: Vec<i64> = conn_a.numbers()?;
    let offsets: Vec<i64> = off_a.numbers()?;
    let types: Vec<i64> = ty_a.numbers()?;
    let ncells = types.len();
    if offsets.len() != ncells || piece.n_cells.is_some_and(|n| n != ncells) {
        return Err(ParseError::at(
            off_a.line,
            format!(
                "{} offsets and {} types for NumberOfCells={:?}",
                offsets.len(),
                ncells,
                piece.n_cells
            ),
        ));
    }
    let cell_entities = entities_of(&piece.cell_data, ncells)?;
    let geometrical: Option<Vec<f64>> = match find(&piece.cell_data, "gmsh:geometrical") {
        Some(a) => Some(a.numbers()?).filter(|v: &Vec<f64>| v.len() == ncells),
        None => None,
    };
    let mut prev = 0i64;
    let mut skipped: std::collections::BTreeMap<i64, usize> = Default::default();
    for c in 0..ncells {
        let end = offsets[c];
        if end < prev || end as u64 > conn.len() as u64 {
            return Err(ParseError::at(
                off_a.line,
                format!("cell {c}: offset {end} is out of order or past the connectivity"),
            ));
        }
        let ids = &conn[prev as usize..end as usize];
        prev = end;
        let (k, dim) = match types[c] {
            3 => (2, 1u8),
            5 => (3, 2),
            10 => (4, 3),
            // a vertex cell: its point is a node anyway
            1 => continue,
            t if (0..=VTK_MAX_TYPE).contains(&t) => {
                *skipped.entry(t).or_insert(0usize) += 1;
                continue;
            }
            t => {
                return Err(ParseError::at(
                    ty_a.line,
                    format!(
                        "cell {c}: unknown VTK cell type {t} (VTK types are 0 to {VTK_MAX_TYPE})"
                    ),
                ))
            }
        };
        if ids.len() != k {
            return Err(ParseError::at(
                conn_a.line,
                format!(
                    "cell {c} of VTK type {} has {} nodes, expected {k}",
                    types[c],
                    ids.len()
                ),
            ));
        }
        let mut nodes = [0u32; 4];
        for (slot, &v) in nodes.iter_mut().zip(ids) {
            if v < 0 || v as u64 >= np as u64 {
                return Err(ParseError::at(
                    conn_a.line,
                    format!("cell {c} refers to point {v}, but there are {np} points"),
                ));
            }
            *slot = v as u32;
        }
        let entity = match (&cell_entities, &geometrical) {
            (Some(e), _) => e[c],
            (None, Some(g)) => entity_from(
                dim as f64,
                (g[c] - 1.0).max(0.0),
                conn_a.line,
                "gmsh:geometrical",
            )?,
            _ => EntityRef::new(dim, 0),
        };
        match k {
            2 => mesh.lines.push(Element {
                nodes: [nodes[0], nodes[1]],
                entity,
            }),
            3 => mesh.triangles.push(Element {
                nodes: [nodes[0], nodes[1], nodes[2]],
                entity,
            }),
            _ => mesh.tetrahedra.push(Element { nodes, entity }),
        }
    }

    let mut known = vec![false; np];
    if let Some(es) = entities_of(&piece.point_data, np)? {
        for ((n, e), k) in mesh.nodes.iter_mut().zip(es).zip(known.iter_mut()) {
            n.entity = e;
            *k = true;
        }
    } else if let Some(a) = find(&piece.point_data, "gmsh:dim_tags").filter(|a| a.ncomp == 2) {
        let v: Vec<f64> = a.numbers()?;
        if v.len() == 2 * np {
            for (i, n) in mesh.nodes.iter_mut().enumerate() {
                n.entity = entity_from(
                    v[2 * i],
                    (v[2 * i + 1] - 1.0).max(0.0),
                    a.line,
                    "gmsh:dim_tags",
                )?;
                known[i] = true;
            }
        }
    }
    infer_node_entities(&mut mesh, &known);
    complete_entities(&mut mesh);
    let mut fields = Vec::new();
    if node_data {
        for a in &piece.point_data {
            let values: Vec<f64> = a.numbers()?;
            if a.ncomp == 0 || values.len() != np * a.ncomp {
                return Err(ParseError::at(
                    a.line,
                    format!(
                        "PointData '{}' holds {} values for {np} points of {} components",
                        a.name,
                        values.len(),
                        a.ncomp
                    ),
                ));
            }
            fields.push(NodeField {
                name: a.name.to_string(),
                components: a.ncomp,
                values,
            });
        }
    }
    let notes = skipped
        .iter()
        .map(|(&t, &n)| {
            let name = match t {
                9 => "quad (type 9)".to_string(),
                12 => "hexahedron (type 12)".to_string(),
                13 => "wedge (type 13)".to_string(),
                14 => "pyramid (type 14)".to_string(),
                22 => "quadratic triangle (type 22)".to_string(),
                24 => "quadratic tetrahedron (type 24)".to_string(),
                t => format!("VTK cell type {t}"),
            };
            format!(
                "skipped {n} cell(s) of {name}: bubblemesh reads lines, triangles and \
                 tetrahedra only"
            )
        })
        .collect();
    Ok((mesh, fields, notes))
}
