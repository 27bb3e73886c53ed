//! Medit (INRIA) ASCII `.mesh`.
//!
//! Written layout (invariants): `MeshVersionFormatted 2`, `Dimension 3`,
//! `Vertices` with ref = node entity id + 1, `Corners` (1-based indices of
//! the nodes on model vertices, when there are any), then `Edges`,
//! `Triangles`, `Tetrahedra` with ref = element entity id + 1 (only the
//! non-empty sections), `End`. Each section's count is on its own line (as
//! meshio expects).
//!
//! Read: the sections above (2D files too, with z = 0); `Quadrilaterals`,
//! `Hexahedra`, `Prisms`, `Pyramids` (with a note, see [`parse_with_notes`]),
//! normals, tangents, ridges and required entities are skipped. Elements are on entity (element dim, ref − 1); nodes
//! listed in `Corners` on vertex (0, ref − 1), the others inferred (see the
//! crate documentation).

use std::io::{self, Write};

use bubblemesh_core::mesh::{Element, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

use crate::text::as_text;
use crate::text::{cap, clip, coord, Text};
use crate::{complete_entities, infer_node_entities, ParseError, Xyz};

/// Writes `mesh` as Medit ASCII. Element indices must be in range.
pub fn write_to<W: Write>(mesh: &Mesh, w: &mut W) -> io::Result<()> {
    let r = |e: EntityRef| e.id as u64 + 1;
    writeln!(w, "MeshVersionFormatted 2\n\nDimension 3\n")?;
    writeln!(w, "Vertices\n{}", mesh.nodes.len())?;
    for n in &mesh.nodes {
        writeln!(w, "{} {}", Xyz(&n.pos), r(n.entity))?;
    }
    let corners: Vec<usize> = (0..mesh.nodes.len())
        .filter(|&i| mesh.nodes[i].entity.dim == 0)
        .collect();
    if !corners.is_empty() {
        writeln!(w, "\nCorners\n{}", corners.len())?;
        for i in corners {
            writeln!(w, "{}", i + 1)?;
        }
    }
    fn section<W: Write, const N: usize>(
        w: &mut W,
        name: &str,
        elems: &[Element<N>],
    ) -> io::Result<()> {
        if elems.is_empty() {
            return Ok(());
        }
        writeln!(w, "\n{name}\n{}", elems.len())?;
        for e in elems {
            for v in e.nodes {
                write!(w, "{} ", v as u64 + 1)?;
            }
            writeln!(w, "{}", e.entity.id as u64 + 1)?;
        }
        Ok(())
    }
    section(w, "Edges", &mesh.lines)?;
    section(w, "Triangles", &mesh.triangles)?;
    section(w, "Tetrahedra", &mesh.tetrahedra)?;
    writeln!(w, "\nEnd")
}

/// Reads `count` then `count` records of `per` numbers, giving each record
/// to `f` with the line it ended on.
fn records<T: std::str::FromStr + Copy + Default>(
    t: &mut Text,
    what: &str,
    per: usize,
    mut f: impl FnMut(&[T], usize) -> Result<(), ParseError>,
) -> Result<(), ParseError> {
    let count: usize = t.num(&format!("the number of {what}"))?;
    let mut rec = vec![T::default(); per];
    for _ in 0..count {
        for slot in rec.iter_mut() {
            *slot = t.num(&format!("a number of the {what}"))?;
        }
        f(&rec, t.lineno())?;
    }
    Ok(())
}

/// A 1-based reference → entity id (0 and negative refs → 0).
fn id_of(r: i64) -> u32 {
    (r - 1).clamp(0, u32::MAX as i64) as u32
}

/// Parses Medit ASCII.
pub fn parse(data: &[u8]) -> Result<Mesh, ParseError> {
    parse_with_notes(data).map(|r| r.0)
}

/// Parses Medit ASCII, with a note per kind of element skipped
/// (quadrilaterals, pyramids, prisms, hexahedra).
///
/// Just over 150 lines: one pass over the keywords in file order with the
/// reader state they share (vertex count, the keyword's block), one short
/// branch per keyword.
pub fn parse_with_notes(data: &[u8]) -> Result<(Mesh, Vec<String>), ParseError> {
    let mut notes: Vec<String> = Vec::new();
    let s = as_text(data);
    let mut t = Text::new(&s, Some('#'));
    let mut dim: Option<usize> = None;
    let mut saw_version = false;
    let mut refs: Vec<i64> = Vec::new();
    let mut corners: Vec<(i64, usize)> = Vec::new();
    let mut mesh = Mesh::default();
    // (element node indices, 1-based, unchecked) with the line they ended on.
    let mut lines: Vec<([i64; 2], i64, usize)> = Vec::new();
    let mut tris: Vec<([i64; 3], i64, usize)> = Vec::new();
    let mut tets: Vec<([i64; 4], i64, usize)> = Vec::new();
    loop {
        let kw = match t.token("a keyword") {
            Ok(k) => k,
            Err(_) if saw_version => break,
            Err(e) => return Err(e),
        };
        if !saw_version && kw != "MeshVersionFormatted" {
            return Err(t.err(format!(
                "not a Medit mesh: expected 'MeshVersionFormatted', found '{}'",
                clip(kw)
            )));
        }
        match kw {
            "MeshVersionFormatted" => {
                let v: i64 = t.num("the mesh version")?;
                if !(1..=4).contains(&v) {
                    return Err(t.err(format!("unsupported MeshVersionFormatted {v}")));
                }
                saw_version = true;
            }
            "Dimension" => {
                let d: usize = t.num("the dimension")?;
                if d != 2 && d != 3 {
                    return Err(t.err(format!("Dimension {d}, expected 2 or 3")));
                }
                dim = Some(d);
            }
            "Vertices" => {
                let d = dim.ok_or_else(|| t.err("'Vertices' before 'Dimension'"))?;
                let count: usize = t.num("the number of vertices")?;
                mesh.nodes.reserve(cap(count));
                refs.reserve(cap(count));
                for _ in 0..count {
                    let mut p = [0.0; 3];
                    for x in p.iter_mut().take(d) {
                        let tok = t.token("a vertex coordinate")?;
                        *x = coord(tok, t.lineno())?;
                    }
                    refs.push(t.num("a vertex reference")?);
                    mesh.nodes.push(Node {
                        pos: P3::new(p[0], p[1], p[2]),
                        entity: EntityRef::new(0, 0),
                        params: [0.0, 0.0],
                    });
                }
            }
            "Edges" => records::<i64>(&mut t, "edges", 3, |r, l| {
                lines.push(([r[0], r[1]], r[2], l));
                Ok(())
            })?,
            "Triangles" => records::<i64>(&mut t, "triangles", 4, |r, l| {
                tris.push(([r[0], r[1], r[2]], r[3], l));
                Ok(())
            })?,
            "Tetrahedra" => records::<i64>(&mut t, "tetrahedra", 5, |r, l| {
                tets.push(([r[0], r[1], r[2], r[3]], r[4], l));
                Ok(())
            })?,
            "Corners" => records::<i64>(&mut t, "corners", 1, |r, l| {
                corners.push((r[0], l));
                Ok(())
            })?,
            "RequiredVertices" | "Ridges" | "RequiredEdges" | "RequiredTriangles"
            | "RequiredTetrahedra" => records::<i64>(&mut t, kw, 1, |_, _| Ok(()))?,
            "NormalAtVertices" | "TangentAtVertices" => {
                records::<i64>(&mut t, kw, 2, |_, _| Ok(()))?
            }
            "Normals" | "Tangents" => {
                let d = dim.ok_or_else(|| t.err(format!("'{kw}' before 'Dimension'")))?;
                records::<f64>(&mut t, kw, d, |_, _| Ok(()))?
            }
            "Quadrilaterals" | "Pyramids" | "Prisms" | "Hexahedra" | "Hexaedra" => {
                let per = match kw {
                    "Quadrilaterals" => 5,
                    "Pyramids" => 6,
                    "Prisms" => 7,
                    _ => 9,
                };
                let mut n = 0usize;
                records::<i64>(&mut t, kw, per, |_, _| {
                    n += 1;
                    Ok(())
                })?;
                if n > 0 {
                    notes.push(format!(
                        "skipped {n} element(s) of '{kw}': bubblemesh reads edges, triangles \
                         and tetrahedra only"
                    ));
                }
            }
            "End" => break,
            other => {
                return Err(t.err(format!("unknown Medit keyword '{}'", clip(other))));
            }
        }
    }
    if dim.is_none() {
        return Err(t.err("no 'Dimension' in the file"));
    }
    let n = mesh.nodes.len();
    let index = |v: i64, line: usize| -> Result<u32, ParseError> {
        if v < 1 || v as u64 > n as u64 {
            return Err(ParseError::at(
                line,
                format!("vertex index {v} is out of range 1..{n}"),
            ));
        }
        Ok((v - 1) as u32)
    };
    fn convert<const N: usize>(
        raw: &[([i64; N], i64, usize)],
        dim: u8,
        index: &dyn Fn(i64, usize) -> Result<u32, ParseError>,
    ) -> Result<Vec<Element<N>>, ParseError> {
        raw.iter()
            .map(|(v, r, line)| {
                let mut nodes = [0u32; N];
                for (slot, &x) in nodes.iter_mut().zip(v) {
                    *slot = index(x, *line)?;
                }
                Ok(Element {
                    nodes,
                    entity: EntityRef::new(dim, id_of(*r)),
                })
            })
            .collect()
    }
    mesh.lines = convert(&lines, 1, &index)?;
    mesh.triangles = convert(&tris, 2, &index)?;
    mesh.tetrahedra = convert(&tets, 3, &index)?;
    let mut known = vec![false; n];
    for &(c, line) in &corners {
        let i = index(c, line)? as usize;
        mesh.nodes[i].entity = EntityRef::new(0, id_of(refs[i]));
        known[i] = true;
    }
    infer_node_entities(&mut mesh, &known);
    complete_entities(&mut mesh);
    Ok((mesh, notes))
}
