//! STL: writes binary; reads binary and ASCII.
//!
//! Written: the triangles of [`surface_triangles`] (the mesh's triangles, or
//! the outward boundary faces of a tetrahedral mesh) in single precision,
//! each with its unit normal (zero for a degenerate triangle). STL keeps no
//! entities and no lines.
//!
//! Read: a file is binary when its size is exactly 84 + 50·n bytes for the
//! count n in its header, ASCII when it starts with `solid`. Vertices with
//! exactly equal coordinates are merged into one node. Triangles are on face
//! 0, or in ASCII files with several `solid`s, on face k for the k-th solid.

use std::collections::HashMap;
use std::io::{self, Write};

use bubblemesh_core::mesh::{Element, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::P3;

use crate::text::{as_text, clip, coord, Text};
use crate::{complete_entities, infer_node_entities, surface_triangles, ParseError};

/// Writes the surface triangles of `mesh` as binary STL. Element indices
/// must be in range.
pub fn write_to<W: Write>(mesh: &Mesh, w: &mut W) -> io::Result<()> {
    let tris = surface_triangles(mesh);
    let count = u32::try_from(tris.len())
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "too many triangles for STL"))?;
    let mut header = [b' '; 80];
    let title = b"bubblemesh binary STL";
    header[..title.len()].copy_from_slice(title);
    w.write_all(&header)?;
    w.write_all(&count.to_le_bytes())?;
    let mut rec = [0u8; 50];
    for t in &tris {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
        let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
        let n = if n.norm() > 0.0 { n.normalize() } else { n };
        let vals = [n, p[0].coords, p[1].coords, p[2].coords];
        for (k, v) in vals.iter().enumerate() {
            for c in 0..3 {
                let at = 4 * (3 * k + c);
                rec[at..at + 4].copy_from_slice(&(v[c] as f32).to_le_bytes());
            }
        }
        w.write_all(&rec)?;
    }
    Ok(())
}

/// Parses binary or ASCII STL.
pub fn parse(data: &[u8]) -> Result<Mesh, ParseError> {
    if data.len() >= 84 {
        let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as u64;
        if 84 + 50 * n == data.len() as u64 {
            return parse_binary(data, n as usize);
        }
    }
    let head = data
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(data.len());
    if data[head..].starts_with(b"solid") {
        return parse_ascii(data);
    }
    if data.len() >= 84 {
        let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as u64;
        Err(ParseError::new(format!(
            "not ASCII STL (no 'solid'), and as binary STL the header announces {n} triangles \
             ({} bytes) but the file has {} bytes (truncated or not STL)",
            84 + 50 * n,
            data.len()
        )))
    } else {
        Err(ParseError::new(format!(
            "not ASCII STL (no 'solid') and too short for binary STL ({} bytes)",
            data.len()
        )))
    }
}

/// Merges vertices with exactly equal coordinates.
#[derive(Default)]
struct Builder {
    mesh: Mesh,
    index: HashMap<[u64; 3], u32>,
}

impl Builder {
    fn vertex(&mut self, p: [f64; 3]) -> u32 {
        // +0.0 turns -0.0 into 0.0 so both merge.
        let key = p.map(|x| (x + 0.0).to_bits());
        let nodes = &mut self.mesh.nodes;
        *self.index.entry(key).or_insert_with(|| {
            nodes.push(Node {
                pos: P3::new(p[0], p[1], p[2]),
                entity: EntityRef::new(2, 0),
                params: [0.0, 0.0],
            });
            (nodes.len() - 1) as u32
        })
    }

    fn triangle(&mut self, p: [[f64; 3]; 3], face: u32) {
        let nodes = p.map(|q| self.vertex(q));
        self.mesh.triangles.push(Element {
            nodes,
            entity: EntityRef::new(2, face),
        });
    }

    fn finish(mut self) -> Mesh {
        let known = vec![false; self.mesh.nodes.len()];
        infer_node_entities(&mut self.mesh, &known);
        complete_entities(&mut self.mesh);
        self.mesh
    }
}

fn parse_binary(data: &[u8], n: usize) -> Result<Mesh, ParseError> {
    let mut b = Builder::default();
    b.mesh.triangles.reserve(n);
    for t in 0..n {
        let rec = &data[84 + 50 * t..84 + 50 * (t + 1)];
        let f = |k: usize| {
            f32::from_le_bytes([rec[4 * k], rec[4 * k + 1], rec[4 * k + 2], rec[4 * k + 3]]) as f64
        };
        let mut p = [[0.0; 3]; 3];
        for (v, q) in p.iter_mut().enumerate() {
            for (c, x) in q.iter_mut().enumerate() {
                *x = f(3 + 3 * v + c);
                if !x.is_finite() {
                    return Err(ParseError::new(format!(
                        "triangle {t} has a non-finite coordinate"
                    )));
                }
            }
        }
        b.triangle(p, 0);
    }
    Ok(b.finish())
}

fn parse_ascii(data: &[u8]) -> Result<Mesh, ParseError> {
    let s = as_text(data);
    let mut t = Text::new(&s, None);
    let mut b = Builder::default();
    let mut solids = 0u32;
    let mut in_solid = false;
    let mut in_facet = false;
    let mut loop_pts: Vec<[f64; 3]> = Vec::with_capacity(3);
    while let Some(l) = t.next_line() {
        let mut tok = l.split_ascii_whitespace();
        let key = tok.next().unwrap_or("");
        let ln = t.lineno();
        match key {
            "solid" if !in_solid => {
                in_solid = true;
                solids += 1;
            }
            "endsolid" if in_solid && !in_facet => in_solid = false,
            "facet" if in_solid && !in_facet => {
                in_facet = true;
                loop_pts.clear();
            }
            "outer" | "endloop" if in_facet => {}
            "vertex" if in_facet => {
                let c: Vec<&str> = tok.collect();
                if c.len() != 3 {
                    return Err(t.err("a vertex line needs 3 coordinates"));
                }
                loop_pts.push([coord(c[0], ln)?, coord(c[1], ln)?, coord(c[2], ln)?]);
            }
            "endfacet" if in_facet => {
                if loop_pts.len() < 3 {
                    return Err(t.err(format!("a facet with {} vertices", loop_pts.len())));
                }
                // Polygons (non-standard) are fan-triangulated.
                for k in 1..loop_pts.len() - 1 {
                    b.triangle([loop_pts[0], loop_pts[k], loop_pts[k + 1]], solids - 1);
                }
                in_facet = false;
            }
            _ => return Err(t.err(format!("unexpected '{}' in ASCII STL", clip(l)))),
        }
    }
    if in_solid || solids == 0 {
        return Err(t.eof("'endsolid' (the file is truncated)"));
    }
    Ok(b.finish())
}
