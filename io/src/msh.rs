//! Gmsh MSH: writes 4.1 ASCII; reads 4.1 ASCII and 2.2 ASCII.
//!
//! Written layout (invariants):
//! - `$PhysicalNames` (after `$MeshFormat`, before `$Entities`; left out
//!   when no entity has elements): one physical group per entity of
//!   [`entity_table`] that has elements (a node on a vertex is a point
//!   element), of the entity's dimension, its tag the entity tag, named
//!   [`physical_name`]: the entity's model name (a STEP product, a domain
//!   face) or, unnamed, [`default_name`] (`volume 3`, `face 12`, `edge 7`,
//!   `point 1`), quoted, with `"` and `\` replaced so that Gmsh and meshio
//!   read it. Names are not made unique: two entities may share one;
//! - `$Entities` holds every entity of [`entity_table`]: tags are `id + 1`
//!   per dimension; points carry the coordinates of their node (else the
//!   centre of their bounding box, else the origin); curves, surfaces and
//!   volumes carry the bounding box of their nodes, their elements' nodes and
//!   their boundary entities, and their signed boundary tags restricted to
//!   entities present in the table; an entity with elements lists its
//!   physical group (`1 tag`), one without lists none (`0`);
//! - `$Nodes` has one block per entity owning nodes (parametric = 0); every
//!   node is in exactly one block, the block of `node.entity`; node tags are
//!   `index + 1`, so the tags are 1..N (in blocks they need not be
//!   contiguous, which MSH 4.1 allows);
//! - `$Elements` has blocks per (element type, entity): type 15 (point) for
//!   every node on a vertex, then 1 (2-node line), 2 (3-node triangle), 4
//!   (4-node tetrahedron); element tags are 1..M in file order; within a
//!   block elements keep their order in the mesh.
//!
//! Reading: `$Entities` and `$PhysicalNames` are parsed loosely (tags,
//! boundaries and physical tags; a bad name line is skipped),
//! `$Nodes`/`$Elements` strictly. An entity is named after the first named
//! physical group it belongs to (in MSH 2.2: its first element's physical
//! tag), unless that name is its own [`default_name`] — so a written mesh
//! reads back with the names it had, and a Gmsh group over several
//! entities names each of them. Other Gmsh element types
//! than 1, 2, 4 and 15 are skipped (with a note, see [`parse_with_notes`]),
//! a type that is no Gmsh type is an error; unknown sections are skipped. Nodes are ordered by
//! tag, so a file written here reads back with the same node indices. In MSH
//! 2.2, where nodes carry no entity, a node on a point element is on that
//! vertex and the others are inferred (see the crate documentation).

use std::collections::{HashMap, HashSet};
use std::io::{self, Write};

use bubblemesh_core::mesh::{Element, EntityInfo, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

use crate::text::{as_text, cap, clip, coord, parse_at, Text};
use crate::{complete_entities, entity_table, infer_node_entities, NodeField, ParseError, Xyz};

/// Writes `mesh` as MSH 4.1 ASCII. The mesh must satisfy the [`Mesh`]
/// invariants (element indices in range; [`crate::write`] checks this).
///
/// Longer than 150 lines on purpose: it writes the sections in file order
/// ($MeshFormat, $PhysicalNames, $Entities, $Nodes, $Elements) from tables
/// built once at
/// the top (entity tags, physical groups and bounding boxes, nodes per
/// entity), which every
/// section reads; split, the pieces would pass those tables around.
pub fn write_to<W: Write>(mesh: &Mesh, w: &mut W) -> io::Result<()> {
    let table = entity_table(mesh);
    let index: HashMap<EntityRef, usize> = table
        .iter()
        .enumerate()
        .map(|(i, e)| (e.entity, i))
        .collect();
    let tag = |e: EntityRef| e.id as u64 + 1;
    let pos = |i: u32| mesh.nodes[i as usize].pos;

    // Bounding boxes: own nodes, element nodes, then boundary entities in
    // increasing dimension (so the boundary's boxes are complete).
    let mut bbox: Vec<Option<(P3, P3)>> = vec![None; table.len()];
    let grow = |b: &mut Option<(P3, P3)>, p: &P3| match b {
        None => *b = Some((*p, *p)),
        Some((lo, hi)) => {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    };
    for n in &mesh.nodes {
        grow(&mut bbox[index[&n.entity]], &n.pos);
    }
    for e in &mesh.lines {
        e.nodes
            .iter()
            .for_each(|&v| grow(&mut bbox[index[&e.entity]], &pos(v)));
    }
    for e in &mesh.triangles {
        e.nodes
            .iter()
            .for_each(|&v| grow(&mut bbox[index[&e.entity]], &pos(v)));
    }
    for e in &mesh.tetrahedra {
        e.nodes
            .iter()
            .for_each(|&v| grow(&mut bbox[index[&e.entity]], &pos(v)));
    }
    // Boundary tags that name entities of the table.
    let boundary: Vec<Vec<i64>> = table
        .iter()
        .map(|e| {
            e.boundary
                .iter()
                .map(|&b| b as i64)
                .filter(|&b| {
                    e.entity.dim > 0
                        && b != 0
                        && index.contains_key(&EntityRef::new(
                            e.entity.dim - 1,
                            (b.unsigned_abs() - 1) as u32,
                        ))
                })
                .collect()
        })
        .collect();
    for dim in 1..=3u8 {
        for (i, e) in table.iter().enumerate() {
            if e.entity.dim != dim {
                continue;
            }
            for &b in &boundary[i] {
                let j = index[&EntityRef::new(dim - 1, (b.unsigned_abs() - 1) as u32)];
                if let Some((lo, hi)) = bbox[j] {
                    grow(&mut bbox[i], &lo);
                    grow(&mut bbox[i], &hi);
                }
            }
        }
    }
    let mut point_at: HashMap<EntityRef, P3> = HashMap::new();
    for n in mesh.nodes.iter().filter(|n| n.entity.dim == 0) {
        point_at.entry(n.entity).or_insert(n.pos);
    }
    // Entities with elements (a node on a vertex is a point element): each
    // is its own physical group, tag = entity tag.
    let mut with_elements: HashSet<EntityRef> = point_at.keys().copied().collect();
    with_elements.extend(mesh.lines.iter().map(|e| e.entity));
    with_elements.extend(mesh.triangles.iter().map(|e| e.entity));
    with_elements.extend(mesh.tetrahedra.iter().map(|e| e.entity));
    let physical: Vec<bool> = table
        .iter()
        .map(|e| with_elements.contains(&e.entity))
        .collect();
    let phys = |i: usize| {
        if physical[i] {
            format!("1 {}", tag(table[i].entity))
        } else {
            "0".to_string()
        }
    };

    writeln!(w, "$MeshFormat\n4.1 0 8\n$EndMeshFormat")?;
    let ngroups = physical.iter().filter(|&&p| p).count();
    if ngroups > 0 {
        writeln!(w, "$PhysicalNames\n{ngroups}")?;
        for (_, e) in table.iter().enumerate().filter(|(i, _)| physical[*i]) {
            writeln!(
                w,
                "{} {} \"{}\"",
                e.entity.dim,
                tag(e.entity),
                physical_name(e)
            )?;
        }
        writeln!(w, "$EndPhysicalNames")?;
    }
    writeln!(w, "$Entities")?;
    let count = |d: u8| table.iter().filter(|e| e.entity.dim == d).count();
    writeln!(w, "{} {} {} {}", count(0), count(1), count(2), count(3))?;
    for (i, e) in table.iter().enumerate() {
        let (lo, hi) = bbox[i].unwrap_or((P3::origin(), P3::origin()));
        if e.entity.dim == 0 {
            let p = point_at
                .get(&e.entity)
                .copied()
                .unwrap_or_else(|| P3::from((lo.coords + hi.coords) * 0.5));
            writeln!(w, "{} {} {}", tag(e.entity), Xyz(&p), phys(i))?;
        } else {
            write!(
                w,
                "{} {} {} {} {}",
                tag(e.entity),
                Xyz(&lo),
                Xyz(&hi),
                phys(i),
                boundary[i].len()
            )?;
            for b in &boundary[i] {
                write!(w, " {b}")?;
            }
            writeln!(w)?;
        }
    }
    writeln!(w, "$EndEntities")?;

    // Nodes grouped by entity (stable: index order within a block).
    let n = mesh.nodes.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by_key(|&i| mesh.nodes[i as usize].entity);
    let node_blocks: Vec<&[u32]> = order
        .chunk_by(|&a, &b| mesh.nodes[a as usize].entity == mesh.nodes[b as usize].entity)
        .collect();
    writeln!(w, "$Nodes")?;
    writeln!(w, "{} {} {} {}", node_blocks.len(), n, n.min(1), n)?;
    for block in &node_blocks {
        let e = mesh.nodes[block[0] as usize].entity;
        writeln!(w, "{} {} 0 {}", e.dim, tag(e), block.len())?;
        for &i in *block {
            writeln!(w, "{}", i as u64 + 1)?;
        }
        for &i in *block {
            writeln!(w, "{}", Xyz(&mesh.nodes[i as usize].pos))?;
        }
    }
    writeln!(w, "$EndNodes")?;

    // Element blocks: (entity, type, element node lists).
    fn grouped<const N: usize>(elems: &[Element<N>]) -> Vec<(EntityRef, Vec<[u32; N]>)> {
        let mut idx: Vec<usize> = (0..elems.len()).collect();
        idx.sort_by_key(|&i| elems[i].entity);
        idx.chunk_by(|&a, &b| elems[a].entity == elems[b].entity)
            .map(|run| {
                (
                    elems[run[0]].entity,
                    run.iter().map(|&i| elems[i].nodes).collect(),
                )
            })
            .collect()
    }
    let points: Vec<(EntityRef, Vec<[u32; 1]>)> = node_blocks
        .iter()
        .filter(|b| mesh.nodes[b[0] as usize].entity.dim == 0)
        .map(|b| {
            (
                mesh.nodes[b[0] as usize].entity,
                b.iter().map(|&i| [i]).collect(),
            )
        })
        .collect();
    let lines = grouped(&mesh.lines);
    let tris = grouped(&mesh.triangles);
    let tets = grouped(&mesh.tetrahedra);
    let nblocks = points.len() + lines.len() + tris.len() + tets.len();
    let nelem = points.iter().map(|b| b.1.len()).sum::<usize>()
        + mesh.lines.len()
        + mesh.triangles.len()
        + mesh.tetrahedra.len();
    writeln!(w, "$Elements")?;
    writeln!(w, "{} {} {} {}", nblocks, nelem, nelem.min(1), nelem)?;
    let mut next_tag = 1u64;
    fn blocks<W: Write, const N: usize>(
        w: &mut W,
        groups: &[(EntityRef, Vec<[u32; N]>)],
        ty: u32,
        next_tag: &mut u64,
    ) -> io::Result<()> {
        for (e, elems) in groups {
            writeln!(w, "{} {} {} {}", e.dim, e.id as u64 + 1, ty, elems.len())?;
            // itoa instead of `write!`: the element lines are most of a
            // volume mesh's file (case K: 2.75 M lines of 5 integers) and
            // the formatting machinery was about 1 s of its writing
            let mut buf = itoa::Buffer::new();
            for nodes in elems {
                w.write_all(buf.format(*next_tag).as_bytes())?;
                *next_tag += 1;
                for &v in nodes {
                    w.write_all(b" ")?;
                    w.write_all(buf.format(v as u64 + 1).as_bytes())?;
                }
                w.write_all(b"\n")?;
            }
        }
        Ok(())
    }
    blocks(w, &points, 15, &mut next_tag)?;
    blocks(w, &lines, 1, &mut next_tag)?;
    blocks(w, &tris, 2, &mut next_tag)?;
    blocks(w, &tets, 4, &mut next_tag)?;
    writeln!(w, "$EndElements")?;
    Ok(())
}

/// The physical-group name of an entity without a model name: `point N`,
/// `edge N`, `face N` or `volume N`, N its (1-based) entity tag.
pub fn default_name(e: EntityRef) -> String {
    let kind = ["point", "edge", "face", "volume"][e.dim.min(3) as usize];
    format!("{kind} {}", e.id as u64 + 1)
}

/// Longest physical name written, in bytes: Gmsh reads a `$PhysicalNames`
/// line into a 256-byte buffer.
const MAX_NAME: usize = 200;

/// The physical-group name written for an entity: its model name, else
/// [`default_name`]. Made safe for the quoted field of `$PhysicalNames` as
/// Gmsh (which ends the name at the next `"`) and meshio (which splits the
/// line like a POSIX shell) read it: `"` becomes `'`, `\` becomes `/`,
/// control characters become spaces, and it is cut to [`MAX_NAME`] bytes
/// (at a character boundary).
pub fn physical_name(e: &EntityInfo) -> String {
    let raw = match e.name.as_deref().map(str::trim) {
        Some(n) if !n.is_empty() => n.to_string(),
        _ => return default_name(e.entity),
    };
    let mut out = String::with_capacity(raw.len());
    for c in raw.chars() {
        let c = match c {
            '"' => '\'',
            '\\' => '/',
            c if c.is_control() => ' ',
            c => c,
        };
        if out.len() + c.len_utf8() > MAX_NAME {
            break;
        }
        out.push(c);
    }
    out
}

/// Parses MSH 4.1 or 2.2 ASCII.
pub fn parse(data: &[u8]) -> Result<Mesh, ParseError> {
    parse_impl(data, false).map(|r| r.0)
}

/// Parses MSH 4.1 or 2.2 ASCII with the per-node fields of its `$NodeData`
/// sections (in the order of the file; a name may repeat, e.g. time steps).
pub fn parse_with_node_data(data: &[u8]) -> Result<(Mesh, Vec<NodeField>), ParseError> {
    parse_impl(data, true).map(|r| (r.0, r.1))
}

/// Parses MSH 4.1 or 2.2 ASCII, with a note per kind of element skipped
/// (a Gmsh type the reader does not keep: quadrangles, hexahedra,
/// second-order elements, ...).
pub fn parse_with_notes(data: &[u8]) -> Result<(Mesh, Vec<String>), ParseError> {
    parse_impl(data, false).map(|r| (r.0, r.2))
}

/// Gmsh element types 1..=140 are defined (GmshDefines.h); a type outside
/// is not a Gmsh element.
const GMSH_MAX_TYPE: i64 = 140;

/// A readable name of the Gmsh element types commonly met.
fn gmsh_type_name(ty: i64) -> String {
    let name = match ty {
        3 => "4-node quadrangle",
        5 => "8-node hexahedron",
        6 => "6-node prism",
        7 => "5-node pyramid",
        8 => "3-node second-order line",
        9 => "6-node second-order triangle",
        10 => "9-node second-order quadrangle",
        11 => "10-node second-order tetrahedron",
        16 => "8-node second-order quadrangle",
        _ => return format!("Gmsh element type {ty}"),
    };
    format!("{name} (type {ty})")
}

/// Checks an element type the reader does not keep: an error if it is no
/// Gmsh type, else counted as skipped.
fn skip_type(
    skipped: &mut std::collections::BTreeMap<i64, usize>,
    ty: i64,
    count: usize,
    line: usize,
) -> Result<(), ParseError> {
    if !(1..=GMSH_MAX_TYPE).contains(&ty) {
        return Err(ParseError::at(
            line,
            format!("unknown element type {ty} (Gmsh types are 1 to {GMSH_MAX_TYPE})"),
        ));
    }
    *skipped.entry(ty).or_insert(0) += count;
    Ok(())
}

type Parsed = (Mesh, Vec<NodeField>, Vec<String>);

fn parse_impl(data: &[u8], node_data: bool) -> Result<Parsed, ParseError> {
    let s = as_text(data);
    let mut t = Text::new(&s, None);
    let first = t.line("$MeshFormat")?;
    if first != "$MeshFormat" {
        return Err(t.err(format!(
            "not a Gmsh MSH file: expected '$MeshFormat', found '{}'",
            clip(first)
        )));
    }
    let hdr = t.line_tokens("the version line of $MeshFormat")?;
    let version = hdr[0];
    let file_type: i64 = match hdr.get(1) {
        Some(tok) => parse_at(tok, "the file type (0 = ASCII)", t.lineno())?,
        None => return Err(t.err("the version line of $MeshFormat has no file type")),
    };
    if file_type != 0 {
        return Err(t.err("binary MSH files are not supported; save as ASCII"));
    }
    let v4 = match version {
        "4.1" => true,
        v if v == "2" || v.starts_with("2.") => false,
        v => {
            return Err(t.err(format!(
                "unsupported MSH version {} (supported: 4.1 and 2.2 ASCII)",
                clip(v)
            )))
        }
    };
    end_section(&mut t, "MeshFormat")?;

    let mut r = Reader::default();
    while let Some(l) = t.next_line() {
        let Some(name) = l.strip_prefix('$') else {
            return Err(t.err(format!(
                "expected a section name like '$Nodes', found '{}'",
                clip(l)
            )));
        };
        match (name, v4) {
            ("Entities", true) => r.entities_41(&mut t)?,
            ("Nodes", true) => r.nodes_41(&mut t)?,
            ("Elements", true) => r.elements_41(&mut t)?,
            ("Nodes", false) => r.nodes_22(&mut t)?,
            ("Elements", false) => r.elements_22(&mut t)?,
            ("PhysicalNames", _) => r.physical_names(&mut t)?,
            ("NodeData", _) if node_data => r.node_data(&mut t)?,
            _ => skip_section(&mut t, name)?,
        }
    }
    let fields = std::mem::take(&mut r.fields);
    let notes: Vec<String> = r
        .skipped
        .iter()
        .map(|(&ty, &n)| {
            format!(
                "skipped {n} element(s) of {}: bubblemesh reads points, 2-node lines, \
                 3-node triangles and 4-node tetrahedra only",
                gmsh_type_name(ty)
            )
        })
        .collect();
    let mesh = r.finish()?;
    Ok((mesh, fields, notes))
}

/// Reads the line closing a section, which must be `$End<name>`.
fn end_section(t: &mut Text, name: &str) -> Result<(), ParseError> {
    let want = format!("$End{name}");
    let l = t.line(&want)?;
    if l != want {
        return Err(t.err(format!("expected '{want}', found '{}'", clip(l))));
    }
    Ok(())
}

/// Skips to the line `$End<name>`.
fn skip_section(t: &mut Text, name: &str) -> Result<(), ParseError> {
    let want = format!("$End{name}");
    while let Some(l) = t.next_line() {
        if l == want {
            return Ok(());
        }
    }
    Err(t.eof(&want))
}

/// An entity from its dimension and (1-based, 0 tolerated) tag.
fn entity(t: &Text, dim: i64, tag: i64) -> Result<EntityRef, ParseError> {
    if !(0..=3).contains(&dim) {
        return Err(t.err(format!("entity dimension {dim} is not 0..3")));
    }
    if !(0..=u32::MAX as i64).contains(&tag) {
        return Err(t.err(format!("entity tag {tag} is out of range")));
    }
    Ok(EntityRef::new(dim as u8, (tag.max(1) - 1) as u32))
}

/// Gmsh element type → (number of nodes, dimension) for the types we keep.
fn element_kind(ty: i64) -> Option<(usize, u8)> {
    match ty {
        15 => Some((1, 0)),
        1 => Some((2, 1)),
        2 => Some((3, 2)),
        4 => Some((4, 3)),
        _ => None,
    }
}

#[derive(Default)]
struct Reader {
    entities: Vec<EntityInfo>,
    /// (tag, node, entity known from the file).
    nodes: Vec<(u64, Node, bool)>,
    /// Node tag → index, once `$Nodes` is read.
    map: Option<TagMap>,
    mesh: Mesh,
    /// `$NodeData` fields (only when asked for).
    fields: Vec<NodeField>,
    /// Element type → number of elements skipped.
    skipped: std::collections::BTreeMap<i64, usize>,
    /// `$PhysicalNames`: (dimension, physical tag) → name.
    physical_names: HashMap<(u8, i64), String>,
    /// Entity → its physical tags (MSH 4.1 `$Entities`; in MSH 2.2 the
    /// physical tag of its first element).
    physical_tags: HashMap<EntityRef, Vec<i64>>,
}

enum TagMap {
    /// Tags are exactly 1..=N.
    Dense(usize),
    Sparse(HashMap<u64, u32>),
}

impl Reader {
    fn entities_41(&mut self, t: &mut Text) -> Result<(), ParseError> {
        let h = t.line_tokens("the $Entities counts")?;
        if h.len() < 4 {
            return Err(t.err("the $Entities counts line needs 4 numbers"));
        }
        let mut counts = [0usize; 4];
        for (k, c) in counts.iter_mut().enumerate() {
            *c = parse_at(h[k], "an entity count", t.lineno())?;
        }
        for (dim, &count) in counts.iter().enumerate() {
            for _ in 0..count {
                let tok = t.line_tokens("an entity line")?;
                let tag: i64 = parse_at(tok[0], "an entity tag", t.lineno())?;
                let e = entity(t, dim as i64, tag)?;
                // Loose: a malformed boundary list leaves the boundary empty.
                let boundary = if dim == 0 {
                    vec![]
                } else {
                    boundary_tags(&tok[1..]).unwrap_or_default()
                };
                let phys = entity_physical_tags(&tok[1..], dim == 0).unwrap_or_default();
                if !phys.is_empty() {
                    self.physical_tags.entry(e).or_insert(phys);
                }
                self.entities.push(EntityInfo {
                    entity: e,
                    boundary,
                    name: None,
                });
            }
        }
        skip_section(t, "Entities")
    }

    fn nodes_41(&mut self, t: &mut Text) -> Result<(), ParseError> {
        self.check_once("Nodes", t)?;
        let h = t.line_tokens("the $Nodes header")?;
        if h.len() < 2 {
            return Err(t.err("the $Nodes header needs 4 numbers"));
        }
        let nblocks: usize = parse_at(h[0], "the number of node blocks", t.lineno())?;
        let total: usize = parse_at(h[1], "the number of nodes", t.lineno())?;
        self.nodes.reserve(cap(total));
        for _ in 0..nblocks {
            let b = t.line_tokens("a node block header")?;
            if b.len() < 4 {
                return Err(t.err("a node block header needs 4 numbers"));
            }
            let ln = t.lineno();
            let dim: i64 = parse_at(b[0], "an entity dimension", ln)?;
            let etag: i64 = parse_at(b[1], "an entity tag", ln)?;
            let parametric: i64 = parse_at(b[2], "the parametric flag", ln)?;
            let count: usize = parse_at(b[3], "the number of nodes in the block", ln)?;
            let e = entity(t, dim, etag)?;
            let start = self.nodes.len();
            for _ in 0..count {
                let tag: u64 = t.num("a node tag")?;
                self.nodes.push((tag, node(P3::origin(), e), true));
            }
            for k in 0..count {
                let l = t.line_tokens("node coordinates")?;
                if l.len() < 3 {
                    return Err(t.err("node coordinates need x y z"));
                }
                let ln = t.lineno();
                let p = P3::new(coord(l[0], ln)?, coord(l[1], ln)?, coord(l[2], ln)?);
                let n = &mut self.nodes[start + k].1;
                n.pos = p;
                if parametric != 0 {
                    for (j, tok) in l[3..].iter().take(2).enumerate() {
                        n.params[j] = parse_at(tok, "a node parameter", ln)?;
                    }
                }
            }
        }
        if self.nodes.len() != total {
            return Err(t.err(format!(
                "the $Nodes header announces {total} nodes but the blocks hold {}",
                self.nodes.len()
            )));
        }
        end_section(t, "Nodes")?;
        self.build_map(t)
    }

    fn nodes_22(&mut self, t: &mut Text) -> Result<(), ParseError> {
        self.check_once("Nodes", t)?;
        let total: usize = t.num("the number of nodes")?;
        self.nodes.reserve(cap(total));
        for _ in 0..total {
            let l = t.line_tokens("a node line")?;
            if l.len() < 4 {
                return Err(t.err("a node line needs: tag x y z"));
            }
            let ln = t.lineno();
            let tag: u64 = parse_at(l[0], "a node tag", ln)?;
            let p = P3::new(coord(l[1], ln)?, coord(l[2], ln)?, coord(l[3], ln)?);
            self.nodes.push((tag, node(p, EntityRef::new(0, 0)), false));
        }
        end_section(t, "Nodes")?;
        self.build_map(t)
    }

    fn check_once(&self, what: &str, t: &Text) -> Result<(), ParseError> {
        if self.map.is_some() {
            return Err(t.err(format!("a second ${what} section")));
        }
        Ok(())
    }

    /// Orders nodes by tag and builds the tag → index map.
    fn build_map(&mut self, t: &Text) -> Result<(), ParseError> {
        self.nodes.sort_by_key(|n| n.0);
        if let Some(w) = self.nodes.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(t.err(format!("node tag {} appears twice in $Nodes", w[0].0)));
        }
        if self.nodes.len() > u32::MAX as usize {
            return Err(t.err("too many nodes"));
        }
        let dense = self
            .nodes
            .iter()
            .enumerate()
            .all(|(i, n)| n.0 == i as u64 + 1);
        self.map = Some(if dense {
            TagMap::Dense(self.nodes.len())
        } else {
            TagMap::Sparse(
                self.nodes
                    .iter()
                    .enumerate()
                    .map(|(i, n)| (n.0, i as u32))
                    .collect(),
            )
        });
        Ok(())
    }

    /// The index of a node tag token.
    fn node_index(&self, tok: &str, t: &Text) -> Result<u32, ParseError> {
        let tag: u64 = parse_at(tok, "a node tag", t.lineno())?;
        let i = match self.map.as_ref() {
            Some(TagMap::Dense(n)) => (tag >= 1 && tag <= *n as u64).then(|| (tag - 1) as u32),
            Some(TagMap::Sparse(m)) => m.get(&tag).copied(),
            None => return Err(t.err("$Elements comes before $Nodes")),
        };
        i.ok_or_else(|| {
            t.err(format!(
                "element refers to node tag {tag}, which $Nodes does not define"
            ))
        })
    }

    /// Stores one element of a kept type.
    fn push(&mut self, nodes: &[u32], e: EntityRef, from_22: bool) {
        match nodes.len() {
            1 => {
                // A point element: in MSH 2.2 it gives the node its vertex.
                if from_22 {
                    let n = &mut self.nodes[nodes[0] as usize];
                    if !n.2 {
                        n.1.entity = e;
                        n.2 = true;
                    }
                }
            }
            2 => self.mesh.lines.push(Element {
                nodes: [nodes[0], nodes[1]],
                entity: e,
            }),
            3 => self.mesh.triangles.push(Element {
                nodes: [nodes[0], nodes[1], nodes[2]],
                entity: e,
            }),
            _ => self.mesh.tetrahedra.push(Element {
                nodes: [nodes[0], nodes[1], nodes[2], nodes[3]],
                entity: e,
            }),
        }
    }

    fn elements_41(&mut self, t: &mut Text) -> Result<(), ParseError> {
        let h = t.line_tokens("the $Elements header")?;
        let nblocks: usize = parse_at(h[0], "the number of element blocks", t.lineno())?;
        let mut idx = Vec::with_capacity(4);
        for _ in 0..nblocks {
            let b = t.line_tokens("an element block header")?;
            if b.len() < 4 {
                return Err(t.err("an element block header needs 4 numbers"));
            }
            let ln = t.lineno();
            let dim: i64 = parse_at(b[0], "an entity dimension", ln)?;
            let etag: i64 = parse_at(b[1], "an entity tag", ln)?;
            let ty: i64 = parse_at(b[2], "an element type", ln)?;
            let count: usize = parse_at(b[3], "the number of elements in the block", ln)?;
            let e = entity(t, dim, etag)?;
            let Some((k, _)) = element_kind(ty) else {
                skip_type(&mut self.skipped, ty, count, ln)?;
                for _ in 0..count {
                    t.line("an element line")?;
                }
                continue;
            };
            for _ in 0..count {
                let l = t.line_tokens("an element line")?;
                if l.len() < 1 + k {
                    return Err(t.err(format!(
                        "an element of type {ty} needs a tag and {k} node tags, found {} numbers",
                        l.len()
                    )));
                }
                idx.clear();
                for tok in &l[1..1 + k] {
                    idx.push(self.node_index(tok, t)?);
                }
                self.push(&idx, e, false);
            }
        }
        end_section(t, "Elements")
    }

    fn elements_22(&mut self, t: &mut Text) -> Result<(), ParseError> {
        let total: usize = t.num("the number of elements")?;
        let mut idx = Vec::with_capacity(4);
        for _ in 0..total {
            let l = t.line_tokens("an element line")?;
            let ln = t.lineno();
            if l.len() < 3 {
                return Err(t.err("an element line needs: tag type ntags tags... nodes..."));
            }
            let ty: i64 = parse_at(l[1], "an element type", ln)?;
            let ntags: usize = parse_at(l[2], "the number of tags", ln)?;
            let Some((k, dim)) = element_kind(ty) else {
                skip_type(&mut self.skipped, ty, 1, ln)?;
                continue;
            };
            if l.len() < 3 + ntags + k {
                return Err(t.err(format!(
                    "an element of type {ty} with {ntags} tags needs {} numbers, found {}",
                    3 + ntags + k,
                    l.len()
                )));
            }
            // Elementary (geometrical) tag: the second tag; else the first.
            let etag: i64 = match ntags {
                0 => 1,
                1 => parse_at(l[3], "a physical tag", ln)?,
                _ => parse_at(l[4], "an elementary tag", ln)?,
            };
            let e = entity(t, dim as i64, etag)?;
            if ntags >= 2 && !self.physical_tags.contains_key(&e) {
                let p: i64 = parse_at(l[3], "a physical tag", ln)?;
                self.physical_tags.insert(e, vec![p]);
            }
            idx.clear();
            for tok in &l[3 + ntags..3 + ntags + k] {
                idx.push(self.node_index(tok, t)?);
            }
            self.push(&idx, e, true);
        }
        end_section(t, "Elements")
    }

    /// `$PhysicalNames`, read loosely (names only label entities): a
    /// count, then `dim tag "name"` lines, the name being what lies between
    /// the first and the last `"` of the line (Gmsh's names hold no `"`); a
    /// line that does not read so is skipped.
    fn physical_names(&mut self, t: &mut Text) -> Result<(), ParseError> {
        while let Some(l) = t.next_line() {
            if l == "$EndPhysicalNames" {
                return Ok(());
            }
            let mut tok = l.split_whitespace();
            let dim = tok.next().and_then(|s| s.parse::<u8>().ok());
            let tag = tok.next().and_then(|s| s.parse::<i64>().ok());
            let (Some(dim), Some(tag), Some(a), Some(b)) = (dim, tag, l.find('"'), l.rfind('"'))
            else {
                continue;
            };
            if dim <= 3 && b > a {
                self.physical_names
                    .insert((dim, tag), l[a + 1..b].to_string());
            }
        }
        Err(t.eof("$EndPhysicalNames"))
    }

    /// One `$NodeData` section: string tags (the first is the name), real
    /// tags, integer tags (the second is the number of components, the
    /// third the number of values), then `node-tag value...` lines. Nodes
    /// the section does not list get NaN.
    fn node_data(&mut self, t: &mut Text) -> Result<(), ParseError> {
        let n_str: usize = t.num("the number of string tags of $NodeData")?;
        let mut name = String::new();
        for k in 0..n_str {
            let l = t.line("a string tag of $NodeData")?;
            if k == 0 {
                name = l.trim().trim_matches('"').to_string();
            }
        }
        let n_real: usize = t.num("the number of real tags of $NodeData")?;
        for _ in 0..n_real {
            t.line("a real tag of $NodeData")?;
        }
        let n_int: usize = t.num("the number of integer tags of $NodeData")?;
        let mut ints = Vec::new();
        for _ in 0..n_int {
            ints.push(t.num::<i64>("an integer tag of $NodeData")?);
        }
        let (Some(&ncomp), Some(&count)) = (ints.get(1), ints.get(2)) else {
            return Err(t.err(format!(
                "$NodeData '{name}' needs 3 integer tags (step, components, count)"
            )));
        };
        if !(1..=9).contains(&ncomp) || count < 0 {
            return Err(t.err(format!(
                "$NodeData '{name}': {ncomp} components or {count} values is not valid"
            )));
        }
        let nn = self.nodes.len();
        if self.map.is_none() {
            return Err(t.err("$NodeData comes before $Nodes"));
        }
        let ncomp = ncomp as usize;
        let mut values = vec![f64::NAN; nn * ncomp];
        for _ in 0..count {
            let l = t.line_tokens("a $NodeData line")?;
            if l.len() < 1 + ncomp {
                return Err(t.err(format!(
                    "a $NodeData line needs a node tag and {ncomp} values"
                )));
            }
            let i = self.node_index(l[0], t)? as usize;
            for c in 0..ncomp {
                values[i * ncomp + c] = parse_at(l[1 + c], "a $NodeData value", t.lineno())?;
            }
        }
        end_section(t, "NodeData")?;
        self.fields.push(NodeField {
            name,
            components: ncomp,
            values,
        });
        Ok(())
    }

    fn finish(self) -> Result<Mesh, ParseError> {
        if self.map.is_none() {
            return Err(ParseError::new("the file has no $Nodes section"));
        }
        let mut mesh = self.mesh;
        let known: Vec<bool> = self.nodes.iter().map(|n| n.2).collect();
        mesh.nodes = self.nodes.into_iter().map(|n| n.1).collect();
        infer_node_entities(&mut mesh, &known);
        mesh.entities = self.entities;
        complete_entities(&mut mesh);
        // Names: the first named physical group of each entity, except the
        // default name of the entity itself (what the writer gives an
        // unnamed entity), so a written mesh reads back as it was.
        for e in &mut mesh.entities {
            let Some(tags) = self.physical_tags.get(&e.entity) else {
                continue;
            };
            let name = tags
                .iter()
                .find_map(|&p| self.physical_names.get(&(e.entity.dim, p)))
                .filter(|n| !n.is_empty() && **n != default_name(e.entity));
            if let Some(n) = name {
                e.name = Some(n.clone());
            }
        }
        Ok(mesh)
    }
}

fn node(pos: P3, entity: EntityRef) -> Node {
    Node {
        pos,
        entity,
        params: [0.0, 0.0],
    }
}

/// Boundary tags from the tokens after an entity tag in MSH 4.1 `$Entities`:
/// 6 bounding-box numbers, physical tags, then bounding entities.
fn boundary_tags(tok: &[&str]) -> Option<Vec<i32>> {
    let nphys: usize = tok.get(6)?.parse().ok()?;
    let nb: usize = tok.get(7 + nphys)?.parse().ok()?;
    tok.get(8 + nphys..8 + nphys + nb)?
        .iter()
        .map(|s| s.parse().ok())
        .collect()
}

/// Physical tags from the tokens after an entity tag in MSH 4.1
/// `$Entities`: after 3 coordinates (a point) or 6 bounding-box numbers.
fn entity_physical_tags(tok: &[&str], point: bool) -> Option<Vec<i64>> {
    let at = if point { 3 } else { 6 };
    let n: usize = tok.get(at)?.parse().ok()?;
    tok.get(at + 1..at + 1 + n)?
        .iter()
        .map(|s| s.parse().ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn physical_names_are_safe_in_quotes() {
        let info = |name: Option<&str>| EntityInfo {
            entity: EntityRef::new(3, 2),
            boundary: vec![],
            name: name.map(str::to_string),
        };
        assert_eq!(physical_name(&info(None)), "volume 3");
        assert_eq!(physical_name(&info(Some("  "))), "volume 3");
        assert_eq!(physical_name(&info(Some("a \"b\"\\c\td"))), "a 'b'/c d");
        let long = "é".repeat(300);
        let n = physical_name(&info(Some(&long)));
        assert!(n.len() <= MAX_NAME && n.chars().all(|c| c == 'é'), "{n}");
        assert_eq!(default_name(EntityRef::new(0, 0)), "point 1");
        assert_eq!(default_name(EntityRef::new(1, 6)), "edge 7");
        assert_eq!(default_name(EntityRef::new(2, 11)), "face 12");
    }

    #[test]
    fn physical_tags_of_points_and_others() {
        let pt: Vec<&str> = "0 0 0 2 5 6".split(' ').collect();
        assert_eq!(entity_physical_tags(&pt, true), Some(vec![5, 6]));
        let c: Vec<&str> = "0 0 0 1 1 1 1 7 2 1 -2".split(' ').collect();
        assert_eq!(entity_physical_tags(&c, false), Some(vec![7]));
        assert_eq!(entity_physical_tags(&c[..3], false), None);
    }

    #[test]
    fn boundary_tags_are_found_after_physical_tags() {
        let tok: Vec<&str> = "0 0 0 1 1 1 2 7 8 3 1 -2 3".split(' ').collect();
        assert_eq!(boundary_tags(&tok), Some(vec![1, -2, 3]));
        assert_eq!(boundary_tags(&tok[..8]), None);
    }
}
