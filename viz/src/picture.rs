//! Pictures of a mesh: SVG and PNG, drawn from one scene.
//!
//! The scene holds one filled triangle per drawn face (the mesh's triangles,
//! or the boundary faces of its tetrahedra), the mesh's line elements (model
//! edges) as thicker strokes, and optionally one circle per node: the bubble,
//! of diameter the spacing at the node (thesis Figs. 5.3–5.6). On a surface
//! seen obliquely a bubble is drawn as its tangent disc, the ellipse a
//! circle on the surface projects to. Everything is
//! projected along the view direction ([`crate::view`]) and painted far to
//! near (painter's algorithm by mean depth), so closed surfaces hide their
//! back. Faces are shaded by a light over the viewer's left shoulder
//! (two-sided Lambert); flat meshes seen along their normal keep their exact
//! colours.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use bubblemesh_core::mesh::Mesh;
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::{P3, V3};

use crate::color::{self, Rgb};
use crate::geometry::{draw_faces, tet_radius_ratio, triangle_q};
use crate::view::{auto_view, Projection};
use crate::VizError;

/// What colours the elements.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColorBy {
    /// The element's radius ratio ([`color::quality`]).
    #[default]
    Quality,
    /// The model entity the element meshes ([`color::entity`]).
    Entity,
}

/// How to draw a picture.
#[derive(Clone, Debug)]
pub struct PictureOptions {
    /// What colours the elements: quality or model entity.
    pub color: ColorBy,
    /// Direction towards the viewer; `None`: [`auto_view`].
    pub view: Option<V3>,
    /// Bubble diameter at every node (one per node): draws the bubbles.
    pub bubbles: Option<Vec<f64>>,
    /// Picture width in pixels (the height follows the mesh's shape).
    pub width: u32,
    /// Draw element edges; `None`: when they are at least 4 pixels long.
    pub edges: Option<bool>,
    /// Title (SVG `<title>`).
    pub title: Option<String>,
    /// A colour key under the picture (SVG only).
    pub legend: bool,
    /// A line of text drawn in the picture's top-left corner (SVG only).
    pub caption: Option<String>,
    /// Frame this model-space box (plus the bubbles' reach) instead of the
    /// mesh: pictures of one model then share one scale (animations).
    pub fit: Option<(P3, P3)>,
}

impl Default for PictureOptions {
    fn default() -> Self {
        PictureOptions {
            color: ColorBy::Quality,
            view: None,
            bubbles: None,
            width: 1000,
            edges: None,
            title: None,
            legend: true,
            caption: None,
            fit: None,
        }
    }
}

const MARGIN: f64 = 12.0;
const LEGEND_H: f64 = 46.0;
const MAX_ASPECT: f64 = 4.0;
const LINE_COLOR: Rgb = Rgb(20, 20, 20);
const EDGE_COLOR: Rgb = Rgb(45, 45, 45);
const BUBBLE_STROKE: Rgb = Rgb(31, 78, 153);
const BUBBLE_FILL: Rgb = Rgb(70, 130, 220);
const BUBBLE_ALPHA: f64 = 0.16;

#[derive(Clone, Debug)]
enum Prim {
    Face {
        pts: [(f64, f64); 3],
        fill: Rgb,
        q: f64,
        entity: EntityRef,
    },
    Line {
        a: (f64, f64),
        b: (f64, f64),
    },
    /// A bubble: a circle, or for a node on a surface seen obliquely the
    /// ellipse its tangent disc projects to (`rx` along the angle `rot`,
    /// degrees clockwise from the screen's x axis, `ry` across).
    Bubble {
        c: (f64, f64),
        rx: f64,
        ry: f64,
        rot: f64,
    },
}

#[derive(Clone, Debug)]
enum Legend {
    Quality { min: f64, mean: f64, tets: bool },
    Entity(Vec<(String, Rgb)>),
}

/// A projected, sorted scene in pixel coordinates (y down).
#[derive(Clone, Debug)]
struct Scene {
    width: u32,
    height: u32,
    prims: Vec<Prim>,
    edges: bool,
    edge_color: Rgb,
    edge_width: f64,
    line_width: f64,
    faces: usize,
    legend: Legend,
}

fn check_mesh(mesh: &Mesh) -> Result<(), VizError> {
    use bubblemesh_core::measure::{first_missing_node, first_non_finite};
    if let Some(i) = first_non_finite(mesh) {
        return Err(VizError::InvalidMesh(format!(
            "node {i} has a non-finite coordinate"
        )));
    }
    if let Some(v) = first_missing_node(mesh) {
        let n = mesh.nodes.len();
        return Err(VizError::InvalidMesh(format!(
            "an element refers to node {v} but there are {n} nodes"
        )));
    }
    Ok(())
}

/// Entity → palette colour, in the order of the sorted entities drawn.
fn entity_colors(entities: impl Iterator<Item = EntityRef>) -> BTreeMap<EntityRef, Rgb> {
    let mut m: BTreeMap<EntityRef, Rgb> = entities.map(|e| (e, Rgb(0, 0, 0))).collect();
    for (k, v) in m.values_mut().enumerate() {
        *v = color::entity(k);
    }
    m
}

fn entity_name(mesh: &Mesh, e: EntityRef) -> String {
    mesh.entities
        .iter()
        .find(|x| x.entity == e)
        .and_then(|x| x.name.clone())
        .unwrap_or_else(|| e.to_string())
}

/// The scene of a picture: the fit of the model into the image, then the
/// faces, lines and bubbles as primitives sorted back to front, and the
/// legend.
///
/// Longer than 150 lines on purpose: every primitive is placed with the
/// same projection, fit (scale, offsets) and view flags, which the phases
/// would otherwise pass around in long argument lists.
fn build(mesh: &Mesh, o: &PictureOptions) -> Result<Scene, VizError> {
    check_mesh(mesh)?;
    if let Some(b) = &o.bubbles {
        if b.len() != mesh.nodes.len() {
            return Err(VizError::Options(format!(
                "{} bubble diameters for {} nodes",
                b.len(),
                mesh.nodes.len()
            )));
        }
    }
    let faces = draw_faces(mesh);
    if faces.is_empty() && mesh.lines.is_empty() && o.bubbles.is_none() {
        return Err(VizError::Empty);
    }
    let dir = o.view.unwrap_or_else(|| auto_view(mesh).0);
    let proj = Projection::new(dir)
        .ok_or_else(|| VizError::Options("the view direction must be non-zero".into()))?;
    let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
    let screen: Vec<(f64, f64, f64)> = pos.iter().map(|p| proj.project(p)).collect();
    let radius = |i: usize| o.bubbles.as_ref().map_or(0.0, |b| 0.5 * b[i].max(0.0));

    // bounds in projected model units
    let (mut x0, mut x1, mut y0, mut y1) =
        (f64::INFINITY, -f64::INFINITY, f64::INFINITY, -f64::INFINITY);
    let mut grow = |x: f64, y: f64, r: f64| {
        x0 = x0.min(x - r);
        x1 = x1.max(x + r);
        y0 = y0.min(y - r);
        y1 = y1.max(y + r);
    };
    let rmax = (0..pos.len()).map(radius).fold(0.0, f64::max);
    match o.fit {
        Some((lo, hi)) => {
            for k in 0..8 {
                let c = P3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                let (x, y, _) = proj.project(&c);
                grow(x, y, rmax);
            }
        }
        None => {
            let used = used_nodes(mesh, o.bubbles.is_some());
            for (i, s) in screen.iter().enumerate() {
                if used[i] {
                    grow(s.0, s.1, radius(i));
                }
            }
        }
    }
    if !(x0.is_finite() && y0.is_finite()) {
        return Err(VizError::Empty);
    }
    let (wx, wy) = (x1 - x0, y1 - y0);
    let width = o.width.clamp(16, 20_000) as f64;
    let inner = width - 2.0 * MARGIN;
    let scale = if wx > 0.0 {
        (inner / wx).min(if wy > 0.0 {
            MAX_ASPECT * inner / wy
        } else {
            f64::INFINITY
        })
    } else if wy > 0.0 {
        inner / wy
    } else {
        1.0
    };
    let height = (wy * scale + 2.0 * MARGIN).ceil().max(16.0);
    let xoff = MARGIN + 0.5 * (inner - wx * scale);
    let to_px = |x: f64, y: f64| (xoff + (x - x0) * scale, MARGIN + (y1 - y) * scale);

    // faces with their colour and depth
    let elem_q: Vec<f64> = if mesh.triangles.is_empty() {
        mesh.tetrahedra
            .iter()
            .map(|t| tet_radius_ratio(&t.nodes.map(|i| pos[i as usize])))
            .collect()
    } else {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.nodes.map(|i| pos[i as usize]);
                triangle_q(&a, &b, &c)
            })
            .collect()
    };
    let elem_entity = |e: u32| {
        if mesh.triangles.is_empty() {
            mesh.tetrahedra[e as usize].entity
        } else {
            mesh.triangles[e as usize].entity
        }
    };
    let ecolors = entity_colors(faces.iter().map(|f| elem_entity(f.element)));
    let diag = {
        let (lo, hi) = mesh.bbox().unwrap_or((P3::origin(), P3::origin()));
        (hi - lo).norm().max(f64::MIN_POSITIVE)
    };
    // (depth, rank, prim); rank orders coincident depths: faces, lines, bubbles
    let mut items: Vec<(f64, u8, Prim)> = Vec::with_capacity(faces.len() + mesh.lines.len());
    let flat_view = {
        let (n, flat) = auto_view(mesh);
        flat && n.cross(&proj.dir).norm() < 1e-9
    };
    // a light over the viewer's left shoulder: faces of different
    // orientation differ even when they make equal angles with the view
    let light = (proj.dir + 0.45 * proj.up - 0.3 * proj.right).normalize();
    let mut edge_px = 0.0;
    let mut edge_n = 0usize;
    for f in &faces {
        let p = f.nodes.map(|i| pos[i as usize]);
        let s = f.nodes.map(|i| screen[i as usize]);
        let q = elem_q[f.element as usize];
        let entity = elem_entity(f.element);
        let base = match o.color {
            ColorBy::Quality => color::quality(q),
            ColorBy::Entity => ecolors[&entity],
        };
        let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
        let shade = if flat_view || n.norm() == 0.0 {
            1.0
        } else {
            0.4 + 0.6 * (n.normalize().dot(&light)).abs()
        };
        let fill = base.shade(shade);
        // under the bubbles the mesh steps back
        let fill = if o.bubbles.is_some() {
            fill.mix(Rgb(255, 255, 255), 0.55)
        } else {
            fill
        };
        let pts = [0, 1, 2].map(|k| to_px(s[k].0, s[k].1));
        for k in 0..3 {
            let (a, b) = (pts[k], pts[(k + 1) % 3]);
            edge_px += ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
            edge_n += 1;
        }
        let depth = if flat_view {
            0.0
        } else {
            (s[0].2 + s[1].2 + s[2].2) / 3.0
        };
        items.push((
            depth,
            0,
            Prim::Face {
                pts,
                fill,
                q,
                entity,
            },
        ));
    }
    let bias = 1e-3 * diag;
    for l in &mesh.lines {
        let [a, b] = l.nodes.map(|i| screen[i as usize]);
        let depth = if flat_view {
            0.0
        } else {
            0.5 * (a.2 + b.2) + bias
        };
        items.push((
            depth,
            1,
            Prim::Line {
                a: to_px(a.0, a.1),
                b: to_px(b.0, b.1),
            },
        ));
    }
    if o.bubbles.is_some() {
        let used = used_nodes(mesh, true);
        // node normals (area-weighted) from the drawn faces; nodes on none
        // (inside a volume, on lines only) get none and draw as spheres
        let mut normal = vec![V3::zeros(); pos.len()];
        for f in &faces {
            let p = f.nodes.map(|i| pos[i as usize]);
            let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
            for &v in &f.nodes {
                normal[v as usize] += n;
            }
        }
        for (i, s) in screen.iter().enumerate() {
            let r = radius(i);
            if !(used[i] && r > 0.0) {
                continue;
            }
            let c = to_px(s.0, s.1);
            let n = normal[i];
            let prim = if flat_view || n.norm() == 0.0 {
                Prim::Bubble {
                    c,
                    rx: r * scale,
                    ry: r * scale,
                    rot: 0.0,
                }
            } else {
                let n = n.normalize();
                let facing = n.dot(&proj.dir).abs().max(0.08);
                // the projected normal (screen y points down) is the short axis
                let (nx, ny) = (n.dot(&proj.right), -n.dot(&proj.up));
                Prim::Bubble {
                    c,
                    rx: facing * r * scale,
                    ry: r * scale,
                    rot: ny.atan2(nx).to_degrees(),
                }
            };
            // a tangent disc reaches r towards the viewer at most: drawn
            // after the faces around its node
            let depth = if flat_view { 0.0 } else { s.2 + r };
            items.push((depth, 2, prim));
        }
    }
    items.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mean_edge = if edge_n > 0 {
        edge_px / edge_n as f64
    } else {
        10.0
    };
    let edges = o.edges.unwrap_or(mean_edge >= 4.0);
    let edge_width = (mean_edge / 25.0).clamp(0.3, 1.2);
    let legend = match o.color {
        ColorBy::Quality => Legend::Quality {
            min: elem_q.iter().cloned().fold(f64::INFINITY, f64::min),
            mean: elem_q.iter().sum::<f64>() / elem_q.len().max(1) as f64,
            tets: mesh.triangles.is_empty() && !mesh.tetrahedra.is_empty(),
        },
        ColorBy::Entity => Legend::Entity(
            ecolors
                .iter()
                .map(|(e, c)| (entity_name(mesh, *e), *c))
                .collect(),
        ),
    };
    Ok(Scene {
        width: width as u32,
        height: height as u32,
        prims: items.into_iter().map(|(_, _, p)| p).collect(),
        edges,
        edge_color: if o.bubbles.is_some() {
            Rgb(150, 150, 150)
        } else {
            EDGE_COLOR
        },
        edge_width,
        line_width: (2.2 * edge_width).max(1.0),
        faces: faces.len(),
        legend,
    })
}

/// Nodes a picture shows: those of elements, and every node when bubbles
/// are drawn.
fn used_nodes(mesh: &Mesh, all: bool) -> Vec<bool> {
    let mut used = vec![all; mesh.nodes.len()];
    if !all {
        let ids = mesh
            .lines
            .iter()
            .flat_map(|e| e.nodes.iter())
            .chain(mesh.triangles.iter().flat_map(|e| e.nodes.iter()))
            .chain(mesh.tetrahedra.iter().flat_map(|e| e.nodes.iter()));
        for &v in ids {
            used[v as usize] = true;
        }
    }
    used
}

struct Num(f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = (self.0 * 100.0).round() / 100.0;
        if r == r.trunc() {
            write!(f, "{}", r as i64)
        } else {
            write!(f, "{r}")
        }
    }
}

/// Escapes text for XML content and attributes.
pub fn xml_escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            c if (c as u32) < 0x20 && c != '\n' && c != '\t' => o.push(' '),
            c => o.push(c),
        }
    }
    o
}

/// The mesh as an SVG document: one `<polygon>` per drawn face (per
/// triangle; per boundary face of a tetrahedral mesh), with its radius
/// ratio in `data-q` and its entity in `data-entity`; line elements as
/// `<line>`, bubbles as `<circle>`, then the colour key.
pub fn svg(mesh: &Mesh, o: &PictureOptions) -> Result<String, VizError> {
    let sc = build(mesh, o)?;
    let legend_h = if o.legend { LEGEND_H } else { 0.0 };
    let (w, h) = (sc.width, sc.height as f64 + legend_h);
    let mut s = String::with_capacity(100 * sc.prims.len() + 2000);
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#,
        h = Num(h)
    );
    if let Some(t) = &o.title {
        let _ = writeln!(s, "<title>{}</title>", xml_escape(t));
    }
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
    let stroke = if sc.edges {
        format!(
            r#" stroke="{}" stroke-width="{}" stroke-linejoin="round""#,
            sc.edge_color.hex(),
            Num(sc.edge_width.max(0.01))
        )
    } else {
        String::new()
    };
    let _ = writeln!(s, r#"<g id="mesh"{stroke} data-elements="{}">"#, sc.faces);
    for p in &sc.prims {
        match p {
            Prim::Face {
                pts,
                fill,
                q,
                entity,
            } => {
                let _ = writeln!(
                    s,
                    r#"<polygon points="{},{} {},{} {},{}" fill="{}"{} data-q="{:.3}" data-entity="{}:{}"/>"#,
                    Num(pts[0].0),
                    Num(pts[0].1),
                    Num(pts[1].0),
                    Num(pts[1].1),
                    Num(pts[2].0),
                    Num(pts[2].1),
                    fill.hex(),
                    if sc.edges {
                        String::new()
                    } else {
                        // hide the anti-aliasing seams between faces
                        format!(r#" stroke="{}" stroke-width="0.4""#, fill.hex())
                    },
                    q,
                    entity.dim,
                    entity.id
                );
            }
            Prim::Line { a, b } => {
                let _ = writeln!(
                    s,
                    r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{}" stroke-width="{}" stroke-linecap="round"/>"#,
                    Num(a.0),
                    Num(a.1),
                    Num(b.0),
                    Num(b.1),
                    LINE_COLOR.hex(),
                    Num(sc.line_width)
                );
            }
            Prim::Bubble { c, rx, ry, rot } => {
                let style = format!(
                    r#"fill="{}" fill-opacity="{}" stroke="{}" stroke-width="{}""#,
                    BUBBLE_FILL.hex(),
                    BUBBLE_ALPHA,
                    BUBBLE_STROKE.hex(),
                    Num((1.2 * sc.edge_width).max(0.5))
                );
                if (rx - ry).abs() <= 1e-3 * ry {
                    let _ = writeln!(
                        s,
                        r#"<circle cx="{}" cy="{}" r="{}" {style}/>"#,
                        Num(c.0),
                        Num(c.1),
                        Num(*ry)
                    );
                } else {
                    let _ = writeln!(
                        s,
                        r#"<ellipse cx="{}" cy="{}" rx="{}" ry="{}" transform="rotate({} {} {})" {style}/>"#,
                        Num(c.0),
                        Num(c.1),
                        Num(*rx),
                        Num(*ry),
                        Num(*rot),
                        Num(c.0),
                        Num(c.1)
                    );
                }
            }
        }
    }
    let _ = writeln!(s, "</g>");
    if let Some(c) = &o.caption {
        let _ = writeln!(
            s,
            r##"<text x="{m}" y="{y}" font-size="15" fill="#111" stroke="#fff" stroke-width="3" paint-order="stroke">{}</text>"##,
            xml_escape(c),
            m = MARGIN + 2.0,
            y = MARGIN + 14.0
        );
    }
    if o.legend {
        legend_svg(&mut s, &sc.legend, sc.height as f64, w as f64);
    }
    let _ = writeln!(s, "</svg>");
    Ok(s)
}

fn legend_svg(s: &mut String, legend: &Legend, top: f64, width: f64) {
    let y = top + 6.0;
    let _ = writeln!(s, r#"<g id="legend">"#);
    match legend {
        Legend::Quality { min, mean, tets } => {
            let bar_w = (width - 2.0 * MARGIN).min(360.0);
            let _ = writeln!(
                s,
                r#"<defs><linearGradient id="qmap" x1="0" x2="1" y1="0" y2="0">"#
            );
            for (q, c) in color::QUALITY_STOPS {
                let _ = writeln!(
                    s,
                    r#"<stop offset="{q}" stop-color="{}"/>"#,
                    Rgb((c >> 16) as u8, (c >> 8) as u8, c as u8).hex()
                );
            }
            let _ = writeln!(s, "</linearGradient></defs>");
            let _ = writeln!(
                s,
                r##"<rect x="{MARGIN}" y="{y}" width="{}" height="12" fill="url(#qmap)" stroke="#444" stroke-width="0.5"/>"##,
                Num(bar_w)
            );
            for q in [0.0, 0.5, 0.75, 1.0] {
                let x = MARGIN + q * bar_w;
                let _ = writeln!(
                    s,
                    r##"<text x="{}" y="{}" text-anchor="middle" fill="#222">{q}</text>"##,
                    Num(x),
                    Num(y + 26.0)
                );
            }
            let what = if *tets {
                "3 r_in / r_circ"
            } else {
                "2 r_in / r_circ"
            };
            if min.is_finite() {
                let _ = writeln!(
                    s,
                    r##"<text x="{}" y="{}" fill="#222">radius ratio q = {what}: min {min:.3}, mean {mean:.3}</text>"##,
                    Num(MARGIN + bar_w + 14.0),
                    Num(y + 11.0)
                );
            }
        }
        Legend::Entity(list) => {
            let mut x = MARGIN;
            for (k, (name, c)) in list.iter().enumerate() {
                if k >= 12 || x > width - 80.0 {
                    let _ = writeln!(
                        s,
                        r##"<text x="{}" y="{}" fill="#222">… {} more</text>"##,
                        Num(x),
                        Num(y + 11.0),
                        list.len() - k
                    );
                    break;
                }
                let _ = writeln!(
                    s,
                    r##"<rect x="{}" y="{y}" width="14" height="12" fill="{}" stroke="#444" stroke-width="0.5"/>"##,
                    Num(x),
                    c.hex()
                );
                let label = xml_escape(name);
                let _ = writeln!(
                    s,
                    r##"<text x="{}" y="{}" fill="#222">{label}</text>"##,
                    Num(x + 18.0),
                    Num(y + 11.0)
                );
                x += 18.0 + 7.0 * name.chars().count() as f64 + 16.0;
            }
        }
    }
    let _ = writeln!(s, "</g>");
}

/// The mesh as a PNG image (the SVG's scene without the colour key and
/// caption, anti-aliased).
pub fn png(mesh: &Mesh, o: &PictureOptions) -> Result<Vec<u8>, VizError> {
    use tiny_skia::{
        Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, Transform,
    };
    let sc = build(mesh, o)?;
    let mut pm = Pixmap::new(sc.width, sc.height)
        .ok_or_else(|| VizError::Options(format!("bad image size {}×{}", sc.width, sc.height)))?;
    pm.fill(Color::WHITE);
    let paint_of = |c: Rgb, alpha: f64| {
        let mut p = Paint::default();
        p.set_color_rgba8(c.0, c.1, c.2, (alpha * 255.0).round() as u8);
        p.anti_alias = true;
        p
    };
    let stroke_of = |w: f64| Stroke {
        width: w as f32,
        line_join: LineJoin::Round,
        line_cap: LineCap::Round,
        ..Stroke::default()
    };
    let edge_paint = paint_of(sc.edge_color, 1.0);
    let edge_stroke = stroke_of(sc.edge_width);
    let seam_stroke = stroke_of(0.6);
    let line_paint = paint_of(LINE_COLOR, 1.0);
    let line_stroke = stroke_of(sc.line_width);
    let bubble_fill = paint_of(BUBBLE_FILL, BUBBLE_ALPHA);
    let bubble_paint = paint_of(BUBBLE_STROKE, 1.0);
    let bubble_stroke = stroke_of((1.2 * sc.edge_width).max(0.5));
    let id = Transform::identity();
    for p in &sc.prims {
        match p {
            Prim::Face { pts, fill, .. } => {
                let mut pb = PathBuilder::new();
                pb.move_to(pts[0].0 as f32, pts[0].1 as f32);
                pb.line_to(pts[1].0 as f32, pts[1].1 as f32);
                pb.line_to(pts[2].0 as f32, pts[2].1 as f32);
                pb.close();
                if let Some(path) = pb.finish() {
                    let paint = paint_of(*fill, 1.0);
                    pm.fill_path(&path, &paint, FillRule::Winding, id, None);
                    if sc.edges {
                        pm.stroke_path(&path, &edge_paint, &edge_stroke, id, None);
                    } else {
                        pm.stroke_path(&path, &paint, &seam_stroke, id, None);
                    }
                }
            }
            Prim::Line { a, b } => {
                let mut pb = PathBuilder::new();
                pb.move_to(a.0 as f32, a.1 as f32);
                pb.line_to(b.0 as f32, b.1 as f32);
                if let Some(path) = pb.finish() {
                    pm.stroke_path(&path, &line_paint, &line_stroke, id, None);
                }
            }
            Prim::Bubble { c, rx, ry, rot } => {
                let oval =
                    tiny_skia::Rect::from_ltrb(-*rx as f32, -*ry as f32, *rx as f32, *ry as f32)
                        .and_then(PathBuilder::from_oval)
                        .and_then(|p| {
                            p.transform(
                                Transform::from_rotate(*rot as f32)
                                    .post_translate(c.0 as f32, c.1 as f32),
                            )
                        });
                if let Some(path) = oval {
                    pm.fill_path(&path, &bubble_fill, FillRule::Winding, id, None);
                    pm.stroke_path(&path, &bubble_paint, &bubble_stroke, id, None);
                }
            }
        }
    }
    encode_rgb_png(&pm).map_err(|e| VizError::Options(format!("cannot encode the PNG: {e}")))
}

/// The opaque pixmap as an 8-bit RGB PNG (a third smaller than RGBA, and
/// adaptive filtering with strong compression suits flat-coloured pictures).
fn encode_rgb_png(pm: &tiny_skia::Pixmap) -> Result<Vec<u8>, png::EncodingError> {
    let rgb: Vec<u8> = pm
        .pixels()
        .iter()
        .flat_map(|p| {
            let c = p.demultiply();
            [c.red(), c.green(), c.blue()]
        })
        .collect();
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, pm.width(), pm.height());
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Best);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut w = enc.write_header()?;
        w.write_image_data(&rgb)?;
    }
    Ok(out)
}
