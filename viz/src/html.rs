//! A self-contained HTML viewer: one file, no network (the data and the
//! script are inline; no library, no CDN).
//!
//! The page draws the mesh on a 2D canvas with the painter's algorithm
//! (orthographic, orbit about the z axis and the screen's horizontal axis,
//! zoom, pan), colours the elements by radius ratio or by entity, and cuts
//! the mesh with an axis-aligned clipping plane: the elements whose centroid
//! lies on the kept side stay, and for tetrahedra the boundary of the kept
//! set is drawn, so the cut shows the tetrahedra it passes through. The
//! quality report is a table in the page (it needs no script); the element
//! count in `#element-count` is written by the script once it has read the
//! mesh data, and `#drawn-count` holds the faces of the last drawing.
//!
//! The initial state can be set in the address's fragment, e.g.
//! `mesh.html#clip=z:0.5&flip=1&color=entity&edges=0&yaw=30&pitch=20`
//! (angles in degrees; the clip position is a fraction of the box).

use std::fmt::Write as _;

use bubblemesh_core::mesh::Mesh;
use bubblemesh_core::quality::QualityReport;
use bubblemesh_core::{P3, V3};

use crate::color;
use crate::geometry::{tet_radius_ratio, triangle_q};
use crate::picture::{xml_escape, ColorBy};
use crate::view::auto_view;
use crate::VizError;

/// What the viewer page shows besides the mesh.
#[derive(Clone, Debug, Default)]
pub struct ViewerOptions<'a> {
    /// Page title (e.g. the input file).
    pub title: String,
    /// Initial colouring.
    pub color: ColorBy,
    /// Initial view direction (towards the viewer); `None`: [`auto_view`].
    pub view: Option<V3>,
    /// The quality report, shown as a table.
    pub quality: Option<&'a QualityReport>,
    /// Extra figures (title, SVG document), e.g. histograms.
    pub figures: Vec<(String, String)>,
    /// Free text lines shown under the title (e.g. the command).
    pub notes: Vec<String>,
}

/// A number with `prec` decimals, trailing zeros removed.
fn push_num(s: &mut String, v: f64, prec: usize) {
    let start = s.len();
    let _ = write!(s, "{v:.prec$}");
    if s[start..].contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if &s[start..] == "-0" {
        s.truncate(start);
        s.push('0');
    }
}

/// Writes `"key":[v,v,...]`.
fn push_array<T: Copy>(s: &mut String, key: &str, vals: &[T], f: impl Fn(&mut String, T)) {
    let _ = write!(s, "\"{key}\":[");
    for (k, &v) in vals.iter().enumerate() {
        if k > 0 {
            s.push(',');
        }
        f(s, v);
    }
    s.push(']');
}

/// The mesh data the page's script reads (JSON).
fn mesh_json(mesh: &Mesh, color: ColorBy, view: V3, flat: bool) -> String {
    let pos: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
    let (lo, hi) = mesh.bbox().unwrap_or((P3::origin(), P3::origin()));
    let diag = (hi - lo).norm();
    // about 1e-7 of the model size
    let prec = if diag > 0.0 {
        (7.0 - diag.log10().floor()).clamp(0.0, 15.0) as usize
    } else {
        6
    };
    // entities in use, in sorted order (the pictures' palette order)
    let mut ents: Vec<_> = mesh
        .triangles
        .iter()
        .map(|t| t.entity)
        .chain(mesh.tetrahedra.iter().map(|t| t.entity))
        .collect();
    ents.sort_unstable();
    ents.dedup();
    let ent_index = |e| ents.binary_search(&e).unwrap_or(0) as u32;
    let mut s = String::with_capacity(40 * pos.len() + 30 * mesh.triangles.len());
    s.push('{');
    let coords: Vec<f64> = pos.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    push_array(&mut s, "nodes", &coords, |s, v| push_num(s, v, prec));
    s.push(',');
    let tris: Vec<u32> = mesh.triangles.iter().flat_map(|t| t.nodes).collect();
    push_array(&mut s, "tris", &tris, |s, v| {
        let _ = write!(s, "{v}");
    });
    s.push(',');
    let tq: Vec<f64> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.nodes.map(|i| pos[i as usize]);
            triangle_q(&a, &b, &c)
        })
        .collect();
    push_array(&mut s, "triQ", &tq, |s, v| push_num(s, v, 4));
    s.push(',');
    let te: Vec<u32> = mesh.triangles.iter().map(|t| ent_index(t.entity)).collect();
    push_array(&mut s, "triEnt", &te, |s, v| {
        let _ = write!(s, "{v}");
    });
    s.push(',');
    let tets: Vec<u32> = mesh.tetrahedra.iter().flat_map(|t| t.nodes).collect();
    push_array(&mut s, "tets", &tets, |s, v| {
        let _ = write!(s, "{v}");
    });
    s.push(',');
    let kq: Vec<f64> = mesh
        .tetrahedra
        .iter()
        .map(|t| tet_radius_ratio(&t.nodes.map(|i| pos[i as usize])))
        .collect();
    push_array(&mut s, "tetQ", &kq, |s, v| push_num(s, v, 4));
    s.push(',');
    let ke: Vec<u32> = mesh
        .tetrahedra
        .iter()
        .map(|t| ent_index(t.entity))
        .collect();
    push_array(&mut s, "tetEnt", &ke, |s, v| {
        let _ = write!(s, "{v}");
    });
    let names: Vec<serde_json::Value> = ents
        .iter()
        .enumerate()
        .map(|(k, e)| {
            let name = mesh
                .entities
                .iter()
                .find(|x| x.entity == *e)
                .and_then(|x| x.name.clone())
                .unwrap_or_else(|| e.to_string());
            serde_json::json!({"name": name, "color": color::entity(k).hex()})
        })
        .collect();
    let stops: Vec<serde_json::Value> = color::QUALITY_STOPS
        .iter()
        .map(|&(q, c)| {
            serde_json::json!([
                q,
                color::Rgb((c >> 16) as u8, (c >> 8) as u8, c as u8).hex()
            ])
        })
        .collect();
    let _ = write!(
        s,
        ",\"entities\":{},\"stops\":{},\"view\":[{},{},{}],\"flat\":{flat},\"color\":\"{}\"}}",
        serde_json::Value::Array(names),
        serde_json::Value::Array(stops),
        view.x,
        view.y,
        view.z,
        match color {
            ColorBy::Quality => "quality",
            ColorBy::Entity => "entity",
        }
    );
    // safe inside <script>: no "</" can close the element
    s.replace("</", "<\\/")
}

fn fmt_value(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Null => "–".into(),
        serde_json::Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.to_string()
            } else {
                let x = n.as_f64().unwrap_or(f64::NAN);
                let a = x.abs();
                if a != 0.0 && !(1e-3..1e6).contains(&a) {
                    format!("{x:.4e}")
                } else {
                    format!("{x:.4}")
                }
            }
        }
        serde_json::Value::Object(m) => m
            .iter()
            .map(|(k, v)| format!("{k}: {}", fmt_value(v)))
            .collect::<Vec<_>>()
            .join(", "),
        other => other.to_string(),
    }
}

/// The quality report as an HTML table: one group of rows per section.
pub fn quality_table(q: &QualityReport) -> String {
    let v = serde_json::to_value(q).unwrap_or(serde_json::Value::Null);
    let mut s = String::from("<table id=\"quality\">\n");
    if let serde_json::Value::Object(mut sections) = v {
        // the report's order, then anything newer
        let mut names: Vec<String> = ["counts", "triangles", "tets", "edges", "spacing"]
            .iter()
            .map(|s| s.to_string())
            .filter(|k| sections.contains_key(k))
            .collect();
        names.extend(
            sections
                .keys()
                .filter(|k| !names.contains(k))
                .cloned()
                .collect::<Vec<_>>(),
        );
        for name in names {
            let section = sections.remove(&name).unwrap_or_default();
            match section {
                serde_json::Value::Object(rows) => {
                    let _ = writeln!(s, "<tr><th colspan=\"2\">{}</th></tr>", xml_escape(&name));
                    for (k, x) in rows {
                        let _ = writeln!(
                            s,
                            "<tr><td>{}</td><td class=\"n\">{}</td></tr>",
                            xml_escape(&k),
                            xml_escape(&fmt_value(&x))
                        );
                    }
                }
                serde_json::Value::Null => {}
                other => {
                    let _ = writeln!(
                        s,
                        "<tr><th>{}</th><td class=\"n\">{}</td></tr>",
                        xml_escape(&name),
                        xml_escape(&fmt_value(&other))
                    );
                }
            }
        }
    }
    s.push_str("</table>\n");
    s
}

/// Strips the XML declaration of an SVG document for inlining in HTML.
pub fn inline_svg(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(k) => &svg[k..],
        None => svg,
    }
}

/// The viewer page for `mesh`.
pub fn viewer(mesh: &Mesh, o: &ViewerOptions) -> Result<String, VizError> {
    if mesh.triangles.is_empty() && mesh.tetrahedra.is_empty() {
        return Err(VizError::Options(
            "the HTML viewer shows triangles and tetrahedra; this mesh has neither (mesh with --dim 2 or more)".into(),
        ));
    }
    let n = mesh.nodes.len();
    let bad = mesh
        .triangles
        .iter()
        .flat_map(|t| t.nodes.iter())
        .chain(mesh.tetrahedra.iter().flat_map(|t| t.nodes.iter()))
        .any(|&v| v as usize >= n);
    if bad || bubblemesh_core::measure::first_non_finite(mesh).is_some() {
        return Err(VizError::InvalidMesh(
            "an element refers to a missing node or a node is not finite".into(),
        ));
    }
    let (auto, flat) = auto_view(mesh);
    let view = o.view.unwrap_or(auto);
    let data = mesh_json(mesh, o.color, view, flat);
    let title = xml_escape(&o.title);
    let mut side = String::new();
    for note in &o.notes {
        let _ = writeln!(side, "<p class=\"note\">{}</p>", xml_escape(note));
    }
    if let Some(q) = o.quality {
        let _ = writeln!(side, "<h2>Quality</h2>\n{}", quality_table(q));
    }
    for (t, svg) in &o.figures {
        let _ = writeln!(
            side,
            "<details class=\"fig\"><summary>{}</summary>\n{}\n</details>",
            xml_escape(t),
            inline_svg(svg)
        );
    }
    Ok(PAGE
        .replace("{{TITLE}}", &title)
        .replace("{{SIDE}}", &side)
        .replace("{{NODES}}", &n.to_string())
        .replace("{{SCRIPT}}", SCRIPT)
        .replace("{{DATA}}", &data))
}

const PAGE: &str = r##"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{{TITLE}} · bubblemesh</title>
<style>
html,body{margin:0;height:100%}
body{font:13px/1.35 system-ui,-apple-system,"Segoe UI",sans-serif;color:#222;display:flex}
#view{flex:1;position:relative;min-width:0;background:#fff}
#c{position:absolute;inset:0;width:100%;height:100%;display:block;touch-action:none;cursor:grab}
#c.dragging{cursor:grabbing}
#side{width:330px;flex:none;overflow:auto;padding:8px 12px;border-left:1px solid #ccc;background:#f8f8f8;box-sizing:border-box}
h1{font-size:15px;margin:4px 0 6px;word-break:break-all}
h2{font-size:13px;margin:12px 0 4px}
.note{margin:2px 0;color:#555;font-size:12px;word-break:break-all}
fieldset{border:1px solid #ddd;margin:6px 0;padding:4px 8px}
legend{font-weight:600}
label{margin-right:8px;white-space:nowrap}
input[type=range]{width:100%}
table{border-collapse:collapse;font-size:12px;width:100%}
th{text-align:left;background:#e9e9e9;padding:2px 6px}
td{padding:1px 6px;border-bottom:1px solid #e6e6e6}
td.n{text-align:right;font-variant-numeric:tabular-nums}
#qbar{height:12px;border:1px solid #777;margin-top:4px}
#qlab{display:flex;justify-content:space-between;font-size:11px}
.sw{display:inline-block;width:12px;height:10px;border:1px solid #555;margin-right:4px;vertical-align:middle}
.fig svg{max-width:100%;height:auto}
.help{color:#666;font-size:11px}
#stats{font-size:12px}
@media (max-width:700px){body{flex-direction:column}#view{height:65vh;flex:none}#side{width:auto;border-left:0}}
</style>
</head>
<body>
<div id="view"><canvas id="c"></canvas></div>
<div id="side">
<h1>{{TITLE}}</h1>
<p id="stats"><b id="element-count">?</b> elements (<span id="kinds">no script</span>), {{NODES}} nodes; drawn faces: <span id="drawn-count">0</span></p>
<fieldset><legend>Colour</legend>
<label><select id="color"><option value="quality">radius ratio</option><option value="entity">entity</option></select></label>
<label><input type="checkbox" id="edges"> edges</label>
<div id="key"></div>
</fieldset>
<fieldset><legend>Clipping plane</legend>
<label><input type="checkbox" id="clip"> clip</label>
<label>normal <select id="axis"><option value="0">x</option><option value="1">y</option><option value="2">z</option></select></label>
<label><input type="checkbox" id="flip"> flip</label>
<input type="range" id="pos" min="0" max="1000" value="500">
</fieldset>
<p class="help">drag: orbit · shift-drag or right-drag: pan · wheel: zoom · double-click: reset view</p>
{{SIDE}}
</div>
<script type="application/json" id="mesh-data">{{DATA}}</script>
<script>
{{SCRIPT}}
</script>
</body>
</html>
"##;

const SCRIPT: &str = r###"(function () {
"use strict";
var $ = function (id) { return document.getElementById(id); };
var D = JSON.parse($("mesh-data").textContent);
var P = D.nodes, nN = P.length / 3;
var T = D.tris, nT = T.length / 3;
var K = D.tets, nK = K.length / 4;
$("element-count").textContent = String(nT + nK);
$("kinds").textContent = nT + " triangles, " + nK + " tetrahedra";
var canvas = $("c"), ctx = canvas.getContext("2d");

var lo = [0, 0, 0], hi = [0, 0, 0];
if (nN > 0) {
  lo = [Infinity, Infinity, Infinity]; hi = [-Infinity, -Infinity, -Infinity];
  for (var i = 0; i < nN; i++) for (var k = 0; k < 3; k++) {
    var v = P[3 * i + k]; if (v < lo[k]) lo[k] = v; if (v > hi[k]) hi[k] = v;
  }
}
var C = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
var R = 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;

function hex(h) { return [parseInt(h.substr(1, 2), 16), parseInt(h.substr(3, 2), 16), parseInt(h.substr(5, 2), 16)]; }
var STOPS = D.stops.map(function (s) { return [s[0], hex(s[1])]; });
var ENT = D.entities.map(function (e) { return hex(e.color); });
function qcolor(q) {
  if (!(q >= 0)) q = 0; if (q > 1) q = 1;
  for (var i = 1; i < STOPS.length; i++) {
    var a = STOPS[i - 1], b = STOPS[i];
    if (q <= b[0]) {
      var t = b[0] > a[0] ? (q - a[0]) / (b[0] - a[0]) : 0;
      return [0, 1, 2].map(function (k) { return Math.round(a[1][k] + (b[1][k] - a[1][k]) * t); });
    }
  }
  return STOPS[STOPS.length - 1][1];
}

// the initial view: D.view points towards the viewer
var ev = D.view, el = Math.hypot(ev[0], ev[1], ev[2]) || 1;
var PITCH0 = Math.asin(Math.max(-1, Math.min(1, ev[2] / el)));
var YAW0 = Math.abs(ev[2] / el) > 1 - 1e-9 ? 0 : Math.atan2(ev[0], -ev[1]);
var st = { yaw: YAW0, pitch: PITCH0, zoom: 1, panx: 0, pany: 0, color: D.color,
  edges: nT + nK <= 60000, clip: false, axis: nK > 0 ? 0 : 2, pos: 0.5, flip: false };
(function parseHash() {
  var h = location.hash.replace(/^#/, "");
  if (!h) return;
  h.split("&").forEach(function (kv) {
    var p = kv.split("="), k = p[0], v = decodeURIComponent(p[1] || "");
    if (k === "clip") {
      st.clip = true; var a = v.split(":");
      var ax = "xyz".indexOf(a[0]); if (ax >= 0) st.axis = ax;
      if (a.length > 1 && isFinite(parseFloat(a[1]))) st.pos = Math.max(0, Math.min(1, parseFloat(a[1])));
    } else if (k === "flip") st.flip = v !== "0";
    else if (k === "color" && (v === "quality" || v === "entity")) st.color = v;
    else if (k === "edges") st.edges = v !== "0";
    else if (k === "yaw" && isFinite(parseFloat(v))) st.yaw = parseFloat(v) * Math.PI / 180;
    else if (k === "pitch" && isFinite(parseFloat(v))) st.pitch = parseFloat(v) * Math.PI / 180;
    else if (k === "zoom" && parseFloat(v) > 0) st.zoom = parseFloat(v);
  });
})();

var F = new Int32Array(0), FE = new Int32Array(0), FN = new Float32Array(0), FC = new Uint8Array(0), NF = 0;
var TF = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];
function kept(ids) {
  if (!st.clip) return true;
  var a = st.axis, c = 0;
  for (var i = 0; i < ids.length; i++) c += P[3 * ids[i] + a];
  c /= ids.length;
  var cut = lo[a] + st.pos * (hi[a] - lo[a]);
  return st.flip ? c >= cut : c <= cut;
}
function buildFaces() {
  var faces = [], elems = [], t, k;
  if (nK > 0) {
    var seen = new Map();
    for (t = 0; t < nK; t++) {
      var q = [K[4 * t], K[4 * t + 1], K[4 * t + 2], K[4 * t + 3]];
      if (!kept(q)) continue;
      for (k = 0; k < 4; k++) {
        var f = [q[TF[k][0]], q[TF[k][1]], q[TF[k][2]]];
        var s = f.slice().sort(function (x, y) { return x - y; });
        var key = s[0] + "," + s[1] + "," + s[2];
        if (seen.has(key)) seen.set(key, -1); else seen.set(key, 4 * t + k);
      }
    }
    seen.forEach(function (v) {
      if (v < 0) return;
      var t = Math.floor(v / 4), k = v % 4;
      faces.push(K[4 * t + TF[k][0]], K[4 * t + TF[k][1]], K[4 * t + TF[k][2]]);
      elems.push(t);
    });
  } else {
    for (t = 0; t < nT; t++) {
      var tri = [T[3 * t], T[3 * t + 1], T[3 * t + 2]];
      if (!kept(tri)) continue;
      faces.push(tri[0], tri[1], tri[2]);
      elems.push(t);
    }
  }
  F = Int32Array.from(faces); FE = Int32Array.from(elems); NF = elems.length;
  FN = new Float32Array(3 * NF);
  for (var i = 0; i < NF; i++) {
    var a = 3 * F[3 * i], b = 3 * F[3 * i + 1], c = 3 * F[3 * i + 2];
    var ux = P[b] - P[a], uy = P[b + 1] - P[a + 1], uz = P[b + 2] - P[a + 2];
    var vx = P[c] - P[a], vy = P[c + 1] - P[a + 1], vz = P[c + 2] - P[a + 2];
    var nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    var nl = Math.hypot(nx, ny, nz) || 1;
    FN[3 * i] = nx / nl; FN[3 * i + 1] = ny / nl; FN[3 * i + 2] = nz / nl;
  }
  colourFaces();
}
function colourFaces() {
  FC = new Uint8Array(3 * NF);
  var Q = nK > 0 ? D.tetQ : D.triQ, E = nK > 0 ? D.tetEnt : D.triEnt;
  for (var i = 0; i < NF; i++) {
    var c = st.color === "entity" ? ENT[E[FE[i]] % ENT.length] : qcolor(Q[FE[i]]);
    FC[3 * i] = c[0]; FC[3 * i + 1] = c[1]; FC[3 * i + 2] = c[2];
  }
  key();
}
function key() {
  var k = $("key"), h = "";
  if (st.color === "quality") {
    var g = STOPS.map(function (s) { return "rgb(" + s[1].join(",") + ") " + (100 * s[0]) + "%"; }).join(",");
    h = '<div id="qbar" style="background:linear-gradient(to right,' + g + ')"></div>' +
      '<div id="qlab"><span>0</span><span>radius ratio q</span><span>1</span></div>';
  } else {
    D.entities.forEach(function (e) {
      h += '<div><span class="sw" style="background:' + e.color + '"></span>' +
        e.name.replace(/[&<>"]/g, function (c) { return "&#" + c.charCodeAt(0) + ";"; }) + "</div>";
    });
  }
  k.innerHTML = h;
}

var X = new Float32Array(nN), Y = new Float32Array(nN), Z = new Float32Array(nN);
function draw() {
  pending = false;
  var dpr = window.devicePixelRatio || 1;
  var W = canvas.clientWidth || 300, H = canvas.clientHeight || 300;
  var bw = Math.round(W * dpr), bh = Math.round(H * dpr);
  if (canvas.width !== bw || canvas.height !== bh) { canvas.width = bw; canvas.height = bh; }
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.fillStyle = "#ffffff"; ctx.fillRect(0, 0, W, H);
  var cp = Math.cos(st.pitch), sp = Math.sin(st.pitch), cy = Math.cos(st.yaw), sy = Math.sin(st.yaw);
  var e0 = cp * sy, e1 = -cp * cy, e2 = sp;
  var r0 = cy, r1 = sy, r2 = 0;
  var u0 = e1 * r2 - e2 * r1, u1 = e2 * r0 - e0 * r2, u2 = e0 * r1 - e1 * r0;
  var s = st.zoom * 0.92 * Math.min(W / (2 * HX), H / (2 * HY));
  var ox = 0.5 * W + st.panx, oy = 0.5 * H + st.pany;
  for (var i = 0; i < nN; i++) {
    var dx = P[3 * i] - C[0], dy = P[3 * i + 1] - C[1], dz = P[3 * i + 2] - C[2];
    X[i] = ox + s * (dx * r0 + dy * r1 + dz * r2);
    Y[i] = oy - s * (dx * u0 + dy * u1 + dz * u2);
    Z[i] = dx * e0 + dy * e1 + dz * e2;
  }
  var order = new Uint32Array(NF), depth = new Float32Array(NF);
  for (var f = 0; f < NF; f++) {
    depth[f] = Z[F[3 * f]] + Z[F[3 * f + 1]] + Z[F[3 * f + 2]];
    order[f] = f;
  }
  order.sort(function (a, b) { return depth[a] - depth[b]; });
  // a light over the viewer's left shoulder; flat meshes keep their colours
  var l0 = e0 + 0.45 * u0 - 0.3 * r0, l1 = e1 + 0.45 * u1 - 0.3 * r1, l2 = e2 + 0.45 * u2 - 0.3 * r2;
  var ll = Math.hypot(l0, l1, l2); l0 /= ll; l1 /= ll; l2 /= ll;
  ctx.lineJoin = "round";
  var edge = "rgba(35,35,35,0.75)";
  ctx.lineWidth = st.edges ? 0.7 : 0.6;
  for (var n = 0; n < NF; n++) {
    var f = order[n], a = F[3 * f], b = F[3 * f + 1], c = F[3 * f + 2];
    var sh = D.flat ? 1 : 0.4 + 0.6 * Math.abs(FN[3 * f] * l0 + FN[3 * f + 1] * l1 + FN[3 * f + 2] * l2);
    var col = "rgb(" + Math.round(FC[3 * f] * sh) + "," + Math.round(FC[3 * f + 1] * sh) + "," + Math.round(FC[3 * f + 2] * sh) + ")";
    ctx.beginPath();
    ctx.moveTo(X[a], Y[a]); ctx.lineTo(X[b], Y[b]); ctx.lineTo(X[c], Y[c]); ctx.closePath();
    ctx.fillStyle = col; ctx.fill();
    ctx.strokeStyle = st.edges ? edge : col; ctx.stroke();
  }
  $("drawn-count").textContent = String(NF);
  document.body.setAttribute("data-rendered", String(NF));
}
// half extents of the mesh in the initial view: zoom 1 fits them to the canvas
var HX = R, HY = R;
(function () {
  var cp = Math.cos(st.pitch), sp = Math.sin(st.pitch), cy = Math.cos(st.yaw), sy = Math.sin(st.yaw);
  var e0 = cp * sy, e1 = -cp * cy, e2 = sp, r0 = cy, r1 = sy;
  var u0 = -e2 * r1, u1 = e2 * r0, u2 = e0 * r1 - e1 * r0;
  var wx = 0, wy = 0;
  for (var i = 0; i < nN; i++) {
    var dx = P[3 * i] - C[0], dy = P[3 * i + 1] - C[1], dz = P[3 * i + 2] - C[2];
    wx = Math.max(wx, Math.abs(dx * r0 + dy * r1));
    wy = Math.max(wy, Math.abs(dx * u0 + dy * u1 + dz * u2));
  }
  if (wx > 1e-9 * R) HX = wx;
  if (wy > 1e-9 * R) HY = wy;
})();
var pending = false;
function schedule() {
  if (pending) return;
  pending = true;
  window.requestAnimationFrame(draw);
}

function sync() {
  $("color").value = st.color; $("edges").checked = st.edges; $("clip").checked = st.clip;
  $("axis").value = String(st.axis); $("flip").checked = st.flip; $("pos").value = String(Math.round(st.pos * 1000));
}
$("color").addEventListener("change", function () { st.color = this.value; colourFaces(); schedule(); });
$("edges").addEventListener("change", function () { st.edges = this.checked; schedule(); });
$("clip").addEventListener("change", function () { st.clip = this.checked; buildFaces(); schedule(); });
$("axis").addEventListener("change", function () { st.axis = +this.value; buildFaces(); schedule(); });
$("flip").addEventListener("change", function () { st.flip = this.checked; buildFaces(); schedule(); });
$("pos").addEventListener("input", function () { st.pos = this.value / 1000; if (st.clip) { buildFaces(); schedule(); } });

var drag = null;
canvas.addEventListener("pointerdown", function (e) {
  canvas.setPointerCapture(e.pointerId); canvas.classList.add("dragging");
  drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button !== 0 };
});
canvas.addEventListener("pointermove", function (e) {
  if (!drag) return;
  var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  drag.x = e.clientX; drag.y = e.clientY;
  if (drag.pan) { st.panx += dx; st.pany += dy; }
  else {
    st.yaw -= 0.01 * dx;
    st.pitch = Math.max(-Math.PI / 2, Math.min(Math.PI / 2, st.pitch + 0.01 * dy));
  }
  schedule();
});
function up() { drag = null; canvas.classList.remove("dragging"); }
canvas.addEventListener("pointerup", up);
canvas.addEventListener("pointercancel", up);
canvas.addEventListener("contextmenu", function (e) { e.preventDefault(); });
canvas.addEventListener("wheel", function (e) {
  e.preventDefault();
  st.zoom = Math.max(0.05, Math.min(500, st.zoom * Math.exp(-0.0015 * e.deltaY)));
  schedule();
}, { passive: false });
canvas.addEventListener("dblclick", function () {
  st.yaw = YAW0; st.pitch = PITCH0; st.zoom = 1; st.panx = 0; st.pany = 0; schedule();
});
window.addEventListener("resize", schedule);

sync();
buildFaces();
draw();
})();"###;

#[cfg(test)]
mod tests {
    /// The viewer's JavaScript keeps its own tetrahedron face table; it
    /// must be the engine's ([`bubblemesh_core::measure::TET_FACES`]), or
    /// the viewer would draw inward faces.
    #[test]
    fn the_viewer_face_table_is_the_engines() {
        let start = super::SCRIPT.find("var TF = ").expect("TF in the script") + 9;
        let end = start + super::SCRIPT[start..].find(';').expect("TF ends");
        let digits: Vec<usize> = super::SCRIPT[start..end]
            .chars()
            .filter_map(|c| c.to_digit(10))
            .map(|d| d as usize)
            .collect();
        let want: Vec<usize> = bubblemesh_core::measure::TET_FACES
            .iter()
            .flatten()
            .copied()
            .collect();
        assert_eq!(digits, want);
    }
}
