//! Wavefront OBJ: `v` and `f` statements (and `l` when reading).
//!
//! Written: the triangles of [`surface_triangles`] (the mesh's triangles, or
//! the outward boundary faces of a tetrahedral mesh) as 1-based `f` lines,
//! over the nodes they use only (`v` lines in increasing node index, so a
//! mesh whose nodes are all on triangles keeps its node order). OBJ keeps no
//! entities.
//!
//! Read: `v x y z [w]`; `f` with `a`, `a/b`, `a//c`, `a/b/c` corners and
//! negative (relative) indices, polygons fan-triangulated; `l` polylines as
//! line segments. Other standard statements (`vt`, `vn`, `g`, `o`, `s`,
//! `usemtl`, ...) are ignored; anything else is an error. Triangles are on
//! face 0, lines on edge 0.

use std::io::{self, Write};

use bubblemesh_core::mesh::{Element, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

use crate::text::{as_text, clip, coord, parse_at, Text};
use crate::{complete_entities, infer_node_entities, surface_triangles, ParseError, Xyz};

/// Writes the surface triangles of `mesh` as OBJ. Element indices must be
/// in range.
pub fn write_to<W: Write>(mesh: &Mesh, w: &mut W) -> io::Result<()> {
    let tris = surface_triangles(mesh);
    let mut new_index = vec![0u32; mesh.nodes.len()];
    for t in &tris {
        for &v in &t.nodes {
            new_index[v as usize] = 1;
        }
    }
    writeln!(w, "# written by bubblemesh")?;
    let mut next = 0u32;
    for (i, n) in mesh.nodes.iter().enumerate() {
        if new_index[i] != 0 {
            next += 1;
            new_index[i] = next; // 1-based
            writeln!(w, "v {}", Xyz(&n.pos))?;
        }
    }
    for t in &tris {
        let [a, b, c] = t.nodes.map(|v| new_index[v as usize]);
        writeln!(w, "f {a} {b} {c}")?;
    }
    Ok(())
}

/// Statements that are valid OBJ but carry nothing we read.
const IGNORED: &[&str] = &[
    "vt",
    "vn",
    "vp",
    "g",
    "o",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "p",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "call",
    "csh",
    "maplib",
    "usemap",
    "lod",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "bevel",
    "c_interp",
    "d_interp",
];

/// Parses an OBJ file.
pub fn parse(data: &[u8]) -> Result<Mesh, ParseError> {
    let s = as_text(data);
    let mut t = Text::new(&s, Some('#'));
    let mut mesh = Mesh::default();
    let mut corners: Vec<u32> = Vec::with_capacity(8);
    while let Some(l) = t.next_line() {
        let ln = t.lineno();
        let mut tok = l.split_ascii_whitespace();
        let key = tok.next().unwrap_or("");
        match key {
            "v" => {
                let c: Vec<&str> = tok.collect();
                if c.len() < 3 {
                    return Err(t.err("a 'v' line needs x y z"));
                }
                mesh.nodes.push(Node {
                    pos: P3::new(coord(c[0], ln)?, coord(c[1], ln)?, coord(c[2], ln)?),
                    entity: EntityRef::new(2, 0),
                    params: [0.0, 0.0],
                });
            }
            "f" | "l" => {
                corners.clear();
                for c in tok {
                    let first = c.split('/').next().unwrap_or("");
                    let i: i64 = parse_at(first, "a vertex index", ln)?;
                    let n = mesh.nodes.len() as i64;
                    let idx = if i < 0 { n + i } else { i - 1 };
                    if i == 0 || idx < 0 || idx >= n {
                        return Err(t.err(format!(
                            "vertex index {i} is out of range ({n} vertices so far)"
                        )));
                    }
                    corners.push(idx as u32);
                }
                if key == "f" {
                    if corners.len() < 3 {
                        return Err(t.err("a face needs at least 3 vertices"));
                    }
                    for k in 1..corners.len() - 1 {
                        mesh.triangles.push(Element {
                            nodes: [corners[0], corners[k], corners[k + 1]],
                            entity: EntityRef::new(2, 0),
                        });
                    }
                } else {
                    if corners.len() < 2 {
                        return Err(t.err("a line needs at least 2 vertices"));
                    }
                    for k in 0..corners.len() - 1 {
                        mesh.lines.push(Element {
                            nodes: [corners[k], corners[k + 1]],
                            entity: EntityRef::new(1, 0),
                        });
                    }
                }
            }
            k if IGNORED.contains(&k) => {}
            _ => return Err(t.err(format!("unknown OBJ statement '{}'", clip(key)))),
        }
    }
    if mesh.nodes.is_empty() {
        return Err(ParseError::new("no vertices ('v' lines) in the file"));
    }
    let known = vec![false; mesh.nodes.len()];
    infer_node_entities(&mut mesh, &known);
    complete_entities(&mut mesh);
    Ok(mesh)
}
