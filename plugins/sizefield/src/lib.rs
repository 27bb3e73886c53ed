//! A size field from a previous mesh (thesis §4.6, the analysis-error
//! refinement loop): read a mesh carrying a value per node, interpolate it
//! linearly over the mesh's elements, and use it as the spacing.
//!
//! The file is a Gmsh MSH (ASCII 2.2 or 4.1) with a `$NodeData` section or
//! an ASCII VTU with a `<PointData>` array (`bubblemesh_io`'s readers).
//! The value is either
//! - `kind=size`: the target spacing itself (model units), times `scale`;
//! - `kind=error`: an error indicator e ≥ 0 per node; the new spacing is
//!   h · clamp((target / e)^(1/order), 1/max_refine, max_coarsen), with h the
//!   node's current spacing (the mean length of the mesh edges at the node)
//!   — the usual a-priori estimate e ∝ h^order (order 2 for the error of
//!   linear interpolation).
//!
//! Interpolation: at the point of the background mesh nearest to the query
//! (inside an element, or its projection onto the nearest one), by the
//! barycentric coordinates of that element (tetrahedra if the mesh has any,
//! else triangles, else segments). Found with an R*-tree (`rstar`).
//!
//! Arguments:
//! - `mesh` (required): the file (relative to the working directory);
//! - `field` (default: the value of `kind`, i.e. "size" or "error"): the
//!   name of the node field;
//! - `kind` (default `size`): `size` or `error`;
//! - `scale` (default 1, `kind=size`): factor on the sizes;
//! - `target` (required for `kind=error`, > 0): the error wanted;
//! - `order` (default 2, `kind=error`): the convergence order;
//! - `max_refine` (default 4), `max_coarsen` (default 2): bounds on the
//!   change of spacing per round (`kind=error`);
//! - `d_min`, `d_max` (optional): bounds on the result.

use bubblemesh_core::mesh::Mesh;
use bubblemesh_plugin_api::{export_plugin, Args, BmQuery, InitInfo, SpacingPlugin};
use rstar::{PointDistance, RTree, RTreeObject, AABB};

type P = [f64; 3];

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: P, b: P) -> P {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn lerp3(p: &[P], w: &[f64]) -> P {
    let mut q = [0.0; 3];
    for (pi, wi) in p.iter().zip(w) {
        for k in 0..3 {
            q[k] += pi[k] * wi;
        }
    }
    q
}

/// One element of the background mesh: its corners and node indices.
struct Simplex {
    nodes: [u32; 4],
    n: usize,
    corners: [P; 4],
}

impl Simplex {
    /// The nearest point of the element to `p` as barycentric weights.
    fn nearest(&self, p: P) -> [f64; 4] {
        let c = &self.corners;
        match self.n {
            2 => {
                let w = seg(p, c[0], c[1]);
                [w[0], w[1], 0.0, 0.0]
            }
            3 => {
                let w = tri(p, c[0], c[1], c[2]);
                [w[0], w[1], w[2], 0.0]
            }
            _ => tet(p, c),
        }
    }

    fn dist2(&self, p: P) -> f64 {
        let w = self.nearest(p);
        let q = lerp3(&self.corners[..self.n], &w[..self.n]);
        let d = sub(p, q);
        dot(d, d)
    }
}

/// Closest point of a segment, as weights.
fn seg(p: P, a: P, b: P) -> [f64; 2] {
    let ab = sub(b, a);
    let l = dot(ab, ab);
    let t = if l > 0.0 {
        (dot(sub(p, a), ab) / l).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [1.0 - t, t]
}

/// Closest point of a triangle, as weights (Ericson, Real-Time Collision
/// Detection §5.1.5: Voronoi regions of the corners and edges). Written
/// here: a dozen lines, no crate offers it on plain arrays.
fn tri(p: P, a: P, b: P, c: P) -> [f64; 3] {
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = va + vb + vc;
    if !(denom.abs() > 0.0) {
        return [1.0, 0.0, 0.0]; // degenerate triangle
    }
    let (v, w) = (vb / denom, vc / denom);
    [1.0 - v - w, v, w]
}

/// Barycentric weights of the nearest point of a tetrahedron: of `p`
/// itself when inside, else of the nearest point of its nearest face.
fn tet(p: P, c: &[P; 4]) -> [f64; 4] {
    let (e1, e2, e3, ep) = (
        sub(c[1], c[0]),
        sub(c[2], c[0]),
        sub(c[3], c[0]),
        sub(p, c[0]),
    );
    let det = dot(e1, cross(e2, e3));
    if det.abs() > 0.0 {
        let l1 = dot(ep, cross(e2, e3)) / det;
        let l2 = dot(e1, cross(ep, e3)) / det;
        let l3 = dot(e1, cross(e2, ep)) / det;
        let l0 = 1.0 - l1 - l2 - l3;
        if l0 >= 0.0 && l1 >= 0.0 && l2 >= 0.0 && l3 >= 0.0 {
            return [l0, l1, l2, l3];
        }
    }
    let mut best = ([1.0, 0.0, 0.0, 0.0], f64::INFINITY);
    for f in [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
        let w = tri(p, c[f[0]], c[f[1]], c[f[2]]);
        let q = lerp3(&[c[f[0]], c[f[1]], c[f[2]]], &w);
        let d = sub(p, q);
        let d2 = dot(d, d);
        if d2 < best.1 {
            let mut full = [0.0; 4];
            for k in 0..3 {
                full[f[k]] = w[k];
            }
            best = (full, d2);
        }
    }
    best.0
}

impl RTreeObject for Simplex {
    type Envelope = AABB<P>;
    fn envelope(&self) -> AABB<P> {
        let mut lo = self.corners[0];
        let mut hi = lo;
        for c in &self.corners[1..self.n] {
            for k in 0..3 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
        AABB::from_corners(lo, hi)
    }
}

impl PointDistance for Simplex {
    fn distance_2(&self, p: &P) -> f64 {
        self.dist2(*p)
    }
}

/// The interpolated field.
pub struct SizeField {
    tree: RTree<Simplex>,
    /// The spacing at each node of the background mesh.
    size: Vec<f64>,
    d_min: f64,
    d_max: f64,
}

/// Mean length of the edges of `elems` at each node (NaN where none).
fn node_edge_length(mesh: &Mesh, elems: &[Simplex]) -> Vec<f64> {
    let mut sum = vec![0.0; mesh.nodes.len()];
    let mut cnt = vec![0u32; mesh.nodes.len()];
    for s in elems {
        for i in 0..s.n {
            for j in i + 1..s.n {
                let d = sub(s.corners[i], s.corners[j]);
                let l = dot(d, d).sqrt();
                for k in [s.nodes[i], s.nodes[j]] {
                    sum[k as usize] += l;
                    cnt[k as usize] += 1;
                }
            }
        }
    }
    sum.iter()
        .zip(&cnt)
        .map(|(s, &c)| if c > 0 { s / c as f64 } else { f64::NAN })
        .collect()
}

impl SizeField {
    /// Builds the field from the mesh file and the arguments (see the
    /// crate docs).
    pub fn from_args(args: &Args) -> Result<SizeField, String> {
        args.check_known(&[
            "mesh",
            "field",
            "kind",
            "scale",
            "target",
            "order",
            "max_refine",
            "max_coarsen",
            "d_min",
            "d_max",
        ])?;
        let path = args.str("mesh").ok_or("argument mesh=FILE is required")?;
        let kind = args.str("kind").unwrap_or("size");
        if kind != "size" && kind != "error" {
            return Err(format!("argument kind={kind}: expected size or error"));
        }
        let name = args.str("field").unwrap_or(kind);
        let (mesh, fields) = bubblemesh_io::read_with_node_data(std::path::Path::new(path))
            .map_err(|e| e.to_string())?;
        let field = fields
            .iter()
            .rev()
            .find(|f| f.name == name)
            .ok_or_else(|| {
                let names: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
                format!(
                    "{path}: no node field '{name}' (the file has: {})",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                )
            })?;
        if field.components != 1 {
            return Err(format!(
                "{path}: node field '{name}' has {} components; a scalar is needed",
                field.components
            ));
        }
        let pos: Vec<P> = mesh.nodes.iter().map(|n| n.pos.coords.into()).collect();
        let mut elems: Vec<Simplex> = Vec::new();
        let mut push = |nodes: &[u32]| {
            let mut s = Simplex {
                nodes: [0; 4],
                n: nodes.len(),
                corners: [[0.0; 3]; 4],
            };
            for (k, &i) in nodes.iter().enumerate() {
                s.nodes[k] = i;
                s.corners[k] = pos[i as usize];
            }
            elems.push(s);
        };
        if !mesh.tetrahedra.is_empty() {
            mesh.tetrahedra.iter().for_each(|e| push(&e.nodes));
        } else if !mesh.triangles.is_empty() {
            mesh.triangles.iter().for_each(|e| push(&e.nodes));
        } else {
            mesh.lines.iter().for_each(|e| push(&e.nodes));
        }
        if elems.is_empty() {
            return Err(format!(
                "{path}: the mesh has no elements to interpolate on"
            ));
        }
        let mut used = vec![false; mesh.nodes.len()];
        for s in &elems {
            for &i in &s.nodes[..s.n] {
                used[i as usize] = true;
            }
        }
        let values = &field.values;
        if let Some(i) = (0..values.len()).find(|&i| used[i] && !values[i].is_finite()) {
            return Err(format!(
                "{path}: node field '{name}' has no finite value at node {} ({:?})",
                i + 1,
                pos[i]
            ));
        }
        let size: Vec<f64> = if kind == "size" {
            let scale = args.positive("scale")?.unwrap_or(1.0);
            if let Some(i) = (0..values.len()).find(|&i| used[i] && !(values[i] > 0.0)) {
                return Err(format!(
                    "{path}: size {} at node {} is not > 0",
                    values[i],
                    i + 1
                ));
            }
            values.iter().map(|v| v * scale).collect()
        } else {
            let target = args
                .positive("target")?
                .ok_or("argument target (> 0) is required for kind=error")?;
            let order = args.positive("order")?.unwrap_or(2.0);
            let refine = args.positive("max_refine")?.unwrap_or(4.0).max(1.0);
            let coarsen = args.positive("max_coarsen")?.unwrap_or(2.0).max(1.0);
            if let Some(i) = (0..values.len()).find(|&i| used[i] && values[i] < 0.0) {
                return Err(format!(
                    "{path}: error indicator {} at node {} is negative",
                    values[i],
                    i + 1
                ));
            }
            let h = node_edge_length(&mesh, &elems);
            values
                .iter()
                .zip(&h)
                .map(|(&e, &h)| {
                    let f = if e > 0.0 {
                        (target / e).powf(1.0 / order)
                    } else {
                        coarsen
                    };
                    h * f.clamp(1.0 / refine, coarsen)
                })
                .collect()
        };
        let d_min = args.positive("d_min")?.unwrap_or(0.0);
        let d_max = args.positive("d_max")?.unwrap_or(f64::INFINITY);
        if d_min > d_max {
            return Err(format!("d_min {d_min} is larger than d_max {d_max}"));
        }
        Ok(SizeField {
            tree: RTree::bulk_load(elems),
            size,
            d_min,
            d_max,
        })
    }

    /// The interpolated spacing at `p`.
    pub fn at(&self, p: P) -> f64 {
        let s = self
            .tree
            .nearest_neighbor(&p)
            .expect("the tree is not empty (checked in from_args)");
        let w = s.nearest(p);
        let d: f64 = (0..s.n)
            .map(|k| w[k] * self.size[s.nodes[k] as usize])
            .sum();
        d.clamp(self.d_min.max(f64::MIN_POSITIVE), self.d_max)
    }
}

impl SpacingPlugin for SizeField {
    fn init(_info: &InitInfo, args: &Args) -> Result<Self, String> {
        SizeField::from_args(args)
    }

    fn spacing(&self, queries: &[BmQuery], out: &mut [f64]) -> Result<(), String> {
        for (q, o) in queries.iter().zip(out.iter_mut()) {
            *o = self.at(q.point);
        }
        Ok(())
    }
}

export_plugin!(
    SizeField,
    "sizefield",
    "spacing interpolated from a mesh's node field (MSH $NodeData / VTU PointData); args: mesh, field, kind=size|error, scale, target, order, max_refine, max_coarsen, d_min, d_max"
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_weights_inside_and_outside() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let w = tri([0.25, 0.25, 0.3], a, b, c);
        assert!((w[0] - 0.5).abs() < 1e-12 && (w[1] - 0.25).abs() < 1e-12);
        assert_eq!(tri([-1.0, -1.0, 0.0], a, b, c), [1.0, 0.0, 0.0]);
        let w = tri([0.5, -1.0, 0.0], a, b, c);
        assert!((w[1] - 0.5).abs() < 1e-12 && w[2] == 0.0);
    }

    #[test]
    fn tet_weights_inside() {
        let c = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let w = tet([0.1, 0.2, 0.3, 0.0][..3].try_into().unwrap(), &c);
        assert!((w[1] - 0.1).abs() < 1e-12 && (w[3] - 0.3).abs() < 1e-12);
        let w = tet([2.0, 0.0, 0.0], &c);
        assert_eq!(w, [0.0, 1.0, 0.0, 0.0]);
    }
}
