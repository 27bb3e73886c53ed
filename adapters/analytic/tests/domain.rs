//! The TOML domain format: the example domains, topology guarantees and one
//! test per validation rule.

use std::path::PathBuf;

use bubblemesh_analytic::{parse_domain, read_domain, DomainError};
use bubblemesh_core::geom::P3;
use bubblemesh_core::model::{Loop, Model};

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
}

fn load(name: &str) -> Model {
    read_domain(&example(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// Signed area of a loop sampled at 64 points per edge.
fn loop_area(m: &Model, l: &Loop) -> f64 {
    let mut pts: Vec<P3> = Vec::new();
    for u in &l.edges {
        let e = &m.edges[u.edge as usize];
        for k in 0..64 {
            let f = k as f64 / 64.0;
            let f = if u.forward { f } else { 1.0 - f };
            pts.push(e.curve.point(e.t0 + f * (e.t1 - e.t0)));
        }
    }
    let n = pts.len();
    0.5 * (0..n)
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            a.x * b.y - a.y * b.x
        })
        .sum::<f64>()
}

/// Structural invariants every parsed model must satisfy.
fn check_invariants(m: &Model) {
    let tol = 1e-9 * m.size();
    for (i, e) in m.edges.iter().enumerate() {
        assert!(e.t0 < e.t1, "edge {i}");
        assert!(
            (e.curve.point(e.t0) - m.vertices[e.start as usize].point).norm() <= tol,
            "edge {i} start"
        );
        assert!(
            (e.curve.point(e.t1) - m.vertices[e.end as usize].point).norm() <= tol,
            "edge {i} end"
        );
    }
    for (fi, f) in m.faces.iter().enumerate() {
        for (li, l) in f.loops.iter().enumerate() {
            // Consecutive uses connect and the loop closes.
            let ends: Vec<(u32, u32)> = l
                .edges
                .iter()
                .map(|u| {
                    let e = &m.edges[u.edge as usize];
                    if u.forward {
                        (e.start, e.end)
                    } else {
                        (e.end, e.start)
                    }
                })
                .collect();
            for k in 0..ends.len() {
                assert_eq!(
                    ends[k].1,
                    ends[(k + 1) % ends.len()].0,
                    "face {fi} loop {li} use {k}"
                );
            }
            let a = loop_area(m, l);
            if li == 0 {
                assert!(
                    a > 0.0,
                    "face {fi}: outer loop must be counter-clockwise (area {a})"
                );
            } else {
                assert!(a < 0.0, "face {fi}: hole {li} must be clockwise (area {a})");
            }
        }
        // Faces lie in z = 0.
        for u in f.loops.iter().flat_map(|l| &l.edges) {
            let e = &m.edges[u.edge as usize];
            for k in 0..=8 {
                assert!(e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 8.0).z.abs() <= tol);
            }
        }
    }
}

struct Counts {
    vertices: usize,
    edges: usize,
    faces: usize,
    loops: usize,
    embedded_edges: usize,
    embedded_vertices: usize,
}

fn counts(m: &Model) -> Counts {
    Counts {
        vertices: m.vertices.len(),
        edges: m.edges.len(),
        faces: m.faces.len(),
        loops: m.faces.iter().map(|f| f.loops.len()).sum(),
        embedded_edges: m.faces.iter().map(|f| f.embedded_edges.len()).sum(),
        embedded_vertices: m.faces.iter().map(|f| f.embedded_vertices.len()).sum(),
    }
}

fn assert_counts(
    name: &str,
    v: usize,
    e: usize,
    f: usize,
    l: usize,
    ee: usize,
    ev: usize,
) -> Model {
    let m = load(name);
    let c = counts(&m);
    assert_eq!(
        (
            c.vertices,
            c.edges,
            c.faces,
            c.loops,
            c.embedded_edges,
            c.embedded_vertices
        ),
        (v, e, f, l, ee, ev),
        "{name}: (vertices, edges, faces, loops, embedded edges, embedded vertices)"
    );
    check_invariants(&m);
    assert!(m.source.as_deref().is_some_and(|s| s.ends_with(name)));
    m
}

#[test]
fn square() {
    let m = assert_counts("square.toml", 4, 4, 1, 1, 0, 0);
    assert_eq!(m.dim(), 2);
    assert!((loop_area(&m, &m.faces[0].loops[0]) - 1.0).abs() < 1e-12);
    assert_eq!(m.faces[0].name.as_deref(), Some("square"));
}

#[test]
fn plate_two_holes() {
    let m = assert_counts("plate_two_holes.toml", 6, 6, 1, 3, 0, 0);
    let f = &m.faces[0];
    // Each hole is one closed circle edge whose vertex is at angle 0.
    for (l, cx) in f.loops[1..].iter().zip([0.5, 1.5]) {
        assert_eq!(l.edges.len(), 1);
        let e = &m.edges[l.edges[0].edge as usize];
        assert_eq!(e.start, e.end);
        assert!((m.vertices[e.start as usize].point - P3::new(cx + 0.2, 0.5, 0.0)).norm() < 1e-15);
        assert!((e.curve.approx_length() - std::f64::consts::TAU * 0.2).abs() < 1e-12);
        assert!(e.curve.is_closed());
    }
    // Area of the plate minus the disks (sampled polygons).
    let area: f64 = f.loops.iter().map(|l| loop_area(&m, l)).sum();
    assert!((area - (2.0 - 2.0 * std::f64::consts::PI * 0.04)).abs() < 1e-3);
}

#[test]
fn hexagon() {
    let m = assert_counts("hexagon.toml", 6, 6, 1, 1, 0, 0);
    for (k, v) in m.vertices.iter().enumerate() {
        let a = k as f64 * std::f64::consts::PI / 3.0;
        assert!((v.point - P3::new(a.cos(), a.sin(), 0.0)).norm() < 1e-15);
    }
    for e in &m.edges {
        assert!((e.curve.approx_length() - 1.0).abs() < 1e-15);
    }
}

#[test]
fn constrained() {
    // 4 outer corners + 3 hole joints + 3 polyline nodes + 2 points;
    // 4 sides + (line, arc, nurbs) + 2 polyline segments.
    let m = assert_counts("constrained.toml", 12, 9, 1, 2, 2, 2);
    let f = &m.faces[0];
    assert_eq!(f.loops[1].edges.len(), 3);
    for &e in &f.embedded_edges {
        assert_eq!(m.edges[e as usize].name.as_deref(), Some("crack"));
    }
    let pts: Vec<P3> = f
        .embedded_vertices
        .iter()
        .map(|&v| m.vertices[v as usize].point)
        .collect();
    assert_eq!(pts, vec![P3::new(0.5, 2.5, 0.0), P3::new(3.5, 0.5, 0.0)]);
}

#[test]
fn two_faces_share_an_edge() {
    let m = assert_counts("two_faces.toml", 6, 7, 2, 2, 0, 0);
    let uses = |fi: usize| m.faces[fi].loops[0].edges.clone();
    let (a, b) = (uses(0), uses(1));
    let shared: Vec<(bool, bool)> = a
        .iter()
        .flat_map(|ua| {
            b.iter()
                .filter(move |ub| ub.edge == ua.edge)
                .map(move |ub| (ua.forward, ub.forward))
        })
        .collect();
    assert_eq!(shared.len(), 1, "exactly one shared edge");
    let (fa, fb) = shared[0];
    assert_ne!(
        fa, fb,
        "the faces use the shared edge in opposite directions"
    );
    let e = a
        .iter()
        .find(|u| b.iter().any(|v| v.edge == u.edge))
        .unwrap()
        .edge;
    let e = &m.edges[e as usize];
    let (p, q) = (
        m.vertices[e.start as usize].point,
        m.vertices[e.end as usize].point,
    );
    assert_eq!(p.x, 1.0);
    assert_eq!(q.x, 1.0);
}

fn parse(text: &str) -> Result<Model, DomainError> {
    parse_domain(text, "test-domain.toml")
}

const HEAD: &str = "format = \"bubblemesh-domain 1\"\n";

/// Parses `HEAD + body`, expects an error, checks that its message names
/// the file and contains every `needle`, and returns it.
fn fails(body: &str, needles: &[&str]) -> String {
    let text = format!("{HEAD}{body}");
    let msg = match parse(&text) {
        Ok(m) => panic!(
            "expected an error for:\n{text}\ngot a model with {} edges",
            m.edges.len()
        ),
        Err(e) => e.to_string(),
    };
    assert!(
        msg.starts_with("test-domain.toml: "),
        "message does not name the file: {msg}"
    );
    for n in needles {
        assert!(msg.contains(n), "message {msg:?} does not contain {n:?}");
    }
    msg
}

#[test]
fn shared_circle_between_a_hole_and_a_disk() {
    // A non-manifold mix: the plate's hole and the disk filling it share the
    // circle edge, used clockwise by the plate and counter-clockwise by the
    // disk.
    let m = parse(&format!(
        "{HEAD}
[[face]]
name = \"plate\"
outer = {{ polygon = [[0, 0], [2, 0], [2, 1], [0, 1]] }}
holes = [ {{ circle = {{ center = [0.5, 0.5], radius = 0.2 }} }} ]
[[face]]
name = \"disk\"
outer = {{ circle = {{ center = [0.5, 0.5], radius = 0.2 }} }}
"
    ))
    .unwrap();
    check_invariants(&m);
    assert_eq!(m.edges.len(), 5);
    let hole = m.faces[0].loops[1].edges[0];
    let disk = m.faces[1].loops[0].edges[0];
    assert_eq!(hole.edge, disk.edge);
    assert_ne!(hole.forward, disk.forward);
}

#[test]
fn loops_are_reoriented_and_arcs_merge_with_arc3() {
    // Outer given clockwise, hole counter-clockwise; the hole is a chain of
    // two half circles, one given as `arc` (clockwise, start > end) and one
    // as `arc3`; a constraint repeats the first half circle as arc3 — it
    // must not merge with the boundary (different face role) but is outside
    // anyway, so use another face for it.
    let m = parse(&format!(
        "{HEAD}
[[face]]
outer = {{ polygon = [[0, 0], [0, 4], [4, 4], [4, 0]] }}
holes = [ {{ chain = [
  {{ arc = {{ center = [2, 2], radius = 1, start = 180, end = 0 }} }},
  {{ arc3 = [[3, 2], [2, 1], [1, 2]] }},
] }} ]
[[face]]
outer = {{ chain = [ {{ line = [[1, 2], [3, 2]] }}, {{ arc3 = [[3, 2], [2, 3], [1, 2]] }} ] }}
"
    ))
    .unwrap();
    check_invariants(&m);
    // The upper half circle (arc from 180° to 0° clockwise, and arc3 through
    // (2, 3)) is one edge.
    assert_eq!(m.edges.len(), 4 + 2 + 1);
    let upper = m.faces[0].loops[1].edges[0].edge;
    assert!(m.faces[1].loops[0].edges.iter().any(|u| u.edge == upper));
}

#[test]
fn stand_alone_curves() {
    let m = parse(&format!(
        "{HEAD}
[[curve]]
name = \"diagonal\"
line = [[0, 0, 0], [1, 1, 1]]
[[curve]]
arc = {{ center = [0, 0, 1], radius = 2, start = 0, end = 90, normal = [1, 0, 0] }}
[[curve]]
nurbs = {{ degree = 2, points = [[0, 0], [1, 1], [2, 0]], weights = [1, 2, 1], knots = [0, 0, 0, 1, 1, 1] }}
[[curve]]
polyline = [[2, 0], [3, 0], [3, 1]]
"
    ))
    .unwrap();
    assert_eq!(m.dim(), 1);
    assert_eq!(m.edges.len(), 5);
    assert_eq!(m.edges[0].name.as_deref(), Some("diagonal"));
    // The NURBS starts at the line's start (0, 0, 0) and ends at the
    // polyline's start (2, 0): those are shared vertices.
    assert_eq!(m.vertices.len(), 7);
    // The 3D arc lies in the plane x = 0 at radius 2 around (0, 0, 1).
    let a = &m.edges[1];
    for k in 0..=10 {
        let q = a.curve.point(a.t0 + (a.t1 - a.t0) * k as f64 / 10.0);
        assert!(q.x.abs() < 1e-15 && ((q - P3::new(0.0, 0.0, 1.0)).norm() - 2.0).abs() < 1e-14);
    }
}

#[test]
fn polygon_may_repeat_its_first_point() {
    let m = parse(&format!(
        "{HEAD}[[face]]\nouter = {{ polygon = [[0,0],[1,0],[1,1],[0,0]] }}\n"
    ))
    .unwrap();
    assert_eq!(m.edges.len(), 3);
    check_invariants(&m);
}

#[test]
fn tolerance_key_merges_nearby_points() {
    let body = "[[face]]\nouter = { chain = [ { line = [[0,0],[1,0]] }, { line = [[1.001,0],[0,1]] }, { line = [[0,1],[0,0]] } ] }\n";
    fails(body, &["gap"]);
    let m = parse(&format!("{HEAD}tolerance = 0.01\n{body}")).unwrap();
    assert_eq!(m.vertices.len(), 3);
    fails(
        "tolerance = -1\n[[face]]\nouter = { polygon = [[0,0],[1,0],[0,1]] }",
        &["tolerance", "positive"],
    );
}

// ------------------------------------------------------ malformed input

#[test]
fn error_not_toml() {
    let e = parse("format = \"bubblemesh-domain 1\"\n[[face]\nouter = 3").unwrap_err();
    assert!(matches!(e, DomainError::Toml { .. }));
    let msg = e.to_string();
    assert!(msg.starts_with("test-domain.toml: not valid TOML"), "{msg}");
    assert!(msg.contains("line 2"), "{msg}");
}

#[test]
fn error_missing_format() {
    let e = parse("[[face]]\nouter = { polygon = [[0,0],[1,0],[0,1]] }\n").unwrap_err();
    assert!(matches!(e, DomainError::Format { .. }));
    let msg = e.to_string();
    assert!(
        msg.contains("test-domain.toml") && msg.contains("missing the required key `format`"),
        "{msg}"
    );
}

#[test]
fn error_unknown_format_or_version() {
    let msg = parse("format = \"gmsh 4\"\n").unwrap_err().to_string();
    assert!(
        msg.contains("test-domain.toml") && msg.contains("unknown format \"gmsh 4\""),
        "{msg}"
    );
    let msg = parse("format = \"bubblemesh-domain 2\"\n")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("unsupported format version \"2\""), "{msg}");
    let msg = parse("format = 1\n").unwrap_err().to_string();
    assert!(msg.contains("must be a string"), "{msg}");
}

#[test]
fn error_unknown_keys() {
    let msg = fails(
        "[[face]]\nouter = { polygon = [[0,0],[1,0],[0,1]] }\nhole = []\n",
        &["unknown field `hole`", "line 4"],
    );
    assert!(msg.contains("holes"), "lists the expected keys: {msg}");
    fails(
        "[[face]]\nouter = { circle = { centre = [0,0], radius = 1 } }\n",
        &["unknown field `centre`"],
    );
    fails("colour = \"red\"\n", &["unknown field `colour`"]);
    fails(
        "[[face]]\nouter = { chain = [ { circle = { center = [0,0], radius = 1 } } ] }\n",
        &["unknown field `circle`"],
    );
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[1,0],[0,1]] }\nname = 3\n",
        &["invalid type"],
    );
}

#[test]
fn error_no_or_two_geometry_keys() {
    fails(
        "[[face]]\nouter = { name = \"x\" }\n",
        &["face #1, outer loop", "exactly one", "found none"],
    );
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[1,0],[0,1]], circle = { center = [0,0], radius = 1 } }\n",
        &["found `polygon` and `circle`"],
    );
    fails(
        "[[face]]\nouter = { chain = [ {} ] }\n",
        &["piece 1", "found none"],
    );
    fails(
        "[[face]]\nouter = { chain = [] }\n",
        &["at least one piece"],
    );
    fails("format = \"bubblemesh-domain 1\"\n", &[]);
}

#[test]
fn error_empty_domain() {
    let msg = fails("", &["nothing to mesh"]);
    assert!(
        msg.starts_with("test-domain.toml: the file defines"),
        "{msg}"
    );
}

#[test]
fn error_polygon_too_few_points() {
    fails(
        "[[face]]\nname = \"tri\"\nouter = { polygon = [[0,0],[1,0]] }\n",
        &["face 'tri' (face #1), outer loop", "at least 3", "got 2"],
    );
}

#[test]
fn error_repeated_consecutive_points() {
    fails(
        "[[face]]\nname = \"p\"\nouter = { polygon = [[0,0],[1,0],[1,0],[0,1]] }\n",
        &[
            "face 'p' (face #1), outer loop, side 2",
            "repeated consecutive points",
            "points 2 and 3",
        ],
    );
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[1,0],[0,1]] }\nconstraints = [ { polyline = [[0.1,0.1],[0.2,0.2],[0.2,0.2]] } ]\n",
        &["constraint 1, segment 2", "repeated consecutive points"],
    );
}

#[test]
fn error_chain_gap() {
    fails(
        "[[face]]\nname = \"plate\"\nouter = { polygon = [[0,0],[4,0],[4,4],[0,4]] }\n\
         holes = [ { chain = [ { line = [[1,1],[2,1]] }, { line = [[2,1.25],[1.5,2]] }, { line = [[1.5,2],[1,1]] } ] } ]\n",
        &["face 'plate' (face #1), hole 1", "do not connect", "piece 2 (line)", "piece 1 (line)", "gap of 0.25"],
    );
    // A reversed piece gets a hint.
    fails(
        "[[face]]\nouter = { chain = [ { line = [[0,0],[1,0]] }, { line = [[0,1],[1,0]] }, { line = [[0,1],[0,0]] } ] }\n",
        &["piece 2 (line)", "reversed"],
    );
}

#[test]
fn error_loop_not_closed() {
    fails(
        "[[face]]\nouter = { chain = [ { line = [[0,0],[1,0]] }, { arc = { center = [1,0.5], radius = 0.5, start = -90, end = 90 } }, { line = [[1,1],[0,0.1]] } ] }\n",
        &["face #1, outer loop", "not closed", "gap of 0.1"],
    );
    fails(
        "[[face]]\nouter = { line = [[0,0],[1,0]] }\n",
        &["not closed"],
    );
    fails(
        "[[face]]\nouter = { polyline = [[0,0],[1,0],[1,1]] }\n",
        &["not closed"],
    );
}

#[test]
fn error_bad_radius() {
    fails(
        "[[face]]\nname = \"plate\"\nouter = { polygon = [[0,0],[2,0],[2,1],[0,1]] }\n\
         holes = [ { circle = { center = [0.5,0.5], radius = 0.2 } }, { circle = { center = [1.5,0.5], radius = 0 } } ]\n",
        &["face 'plate' (face #1), hole 2", "radius must be a positive", "got 0"],
    );
    fails(
        "[[face]]\nouter = { chain = [ { line = [[0,0],[1,0]] }, { arc = { center = [1,0.5], radius = -0.5, start = -90, end = 90 } } ] }\n",
        &["outer loop, piece 2 (arc)", "got -0.5"],
    );
    fails(
        "[[curve]]\narc = { center = [0,0], radius = 1, start = 10, end = 10 }\n",
        &["curve #1", "angles are equal"],
    );
    fails(
        "[[curve]]\narc = { center = [0,0], radius = 1, start = 0, end = 400 }\n",
        &["at most 360"],
    );
    fails("[[curve]]\narc3 = [[0,0],[1,1],[2,2]]\n", &["collinear"]);
    fails("[[curve]]\narc3 = [[0,0],[1,1]]\n", &["exactly 3 points"]);
}

#[test]
fn error_non_finite_coordinates() {
    fails(
        "[[face]]\nname = \"q\"\nouter = { polygon = [[0,0],[1,nan],[1,1],[0,1]] }\n",
        &[
            "face 'q' (face #1), outer loop",
            "point 2",
            "not a finite number",
        ],
    );
    fails(
        "[[face]]\nouter = { circle = { center = [inf, 0], radius = 1 } }\n",
        &["centre", "not a finite number"],
    );
    fails(
        "[[face]]\nouter = { circle = { center = [0, 0], radius = inf } }\n",
        &["radius"],
    );
    fails(
        "[[curve]]\nline = [[0,0],[1,2,3,4]]\n",
        &["[x, y] or [x, y, z]", "got 4"],
    );
    fails(
        "[[curve]]\narc = { center = [0,0], radius = 1, start = 0, end = nan }\n",
        &["finite"],
    );
    let msg = fails(
        "[[curve]]\nline = [[0,0],[1e308,1e308]]\n[[curve]]\nline = [[0,0],[-1e308,-1e308]]\n",
        &[],
    );
    assert!(msg.contains("too large"), "{msg}");
}

#[test]
fn error_bad_nurbs() {
    fails(
        "[[curve]]\nname = \"s\"\nnurbs = { degree = 2, points = [[0,0],[1,1],[2,0]], knots = [0,0,1,0.5,1,1] }\n",
        &["curve 's' (curve #1)", "knot vector", "non-decreasing"],
    );
    fails(
        "[[curve]]\nnurbs = { degree = 2, points = [[0,0],[1,1],[2,0]], knots = [0,0,0,1,1] }\n",
        &["knot vector", "n + p + 1 = 6"],
    );
    fails(
        "[[curve]]\nnurbs = { degree = 2, points = [[0,0],[1,1],[2,0]], weights = [1, 0, 1] }\n",
        &["weights", "weight 2"],
    );
    fails(
        "[[curve]]\nnurbs = { degree = 2, points = [[0,0],[1,1],[2,0]], weights = [1, 1] }\n",
        &["2 weights for 3 control points"],
    );
    fails(
        "[[curve]]\nnurbs = { degree = 4, points = [[0,0],[1,1],[2,0]] }\n",
        &["at least 5 control points"],
    );
    fails(
        "[[curve]]\nnurbs = { degree = 0, points = [[0,0],[1,1],[2,0]] }\n",
        &["degree"],
    );
    fails(
        "[[curve]]\nnurbs = { degree = 1000000000, points = [[0,0],[1,1]] }\n",
        &["degree"],
    );
    fails(
        "[[curve]]\nnurbs = { degree = -1, points = [[0,0],[1,1]] }\n",
        &["not a valid bubblemesh domain"],
    );
}

#[test]
fn error_face_off_the_plane() {
    fails(
        "[[face]]\nname = \"tilted\"\nouter = { polygon = [[0,0,0],[1,0,0],[1,1,0.5],[0,1,0]] }\n",
        &["face 'tilted' (face #1), outer loop", "z = 0", "z = 0.5"],
    );
    fails(
        "[[face]]\nouter = { circle = { center = [0,0], radius = 1, normal = [0, 1, 1] } }\n",
        &["outer loop", "plane z = 0"],
    );
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[1,0],[0,1]] }\npoints = [[0.2, 0.2, 1]]\n",
        &["point 1", "z = 1"],
    );
    // A circle with normal −z is fine (reoriented).
    let m = parse(&format!("{HEAD}[[face]]\nouter = {{ circle = {{ center = [0,0], radius = 1, normal = [0,0,-1] }} }}\n")).unwrap();
    check_invariants(&m);
}

#[test]
fn error_hole_outside_outer() {
    fails(
        "[[face]]\nname = \"plate\"\nouter = { polygon = [[0,0],[2,0],[2,1],[0,1]] }\nholes = [ { circle = { center = [3,0.5], radius = 0.2 } } ]\n",
        &["face 'plate' (face #1), hole 1", "outside the outer loop"],
    );
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[4,0],[4,4],[0,4]] }\n\
         holes = [ { circle = { center = [2,2], radius = 1 } }, { circle = { center = [2,2], radius = 0.5 } } ]\n",
        &["hole 2", "inside hole 1"],
    );
}

#[test]
fn error_loops_cross() {
    fails(
        "[[face]]\nname = \"plate\"\nouter = { polygon = [[0,0],[2,0],[2,1],[0,1]] }\nholes = [ { circle = { center = [1.9,0.5], radius = 0.2 } } ]\n",
        &["face 'plate' (face #1)", "the outer loop and hole 1 cross or touch"],
    );
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[4,0],[4,4],[0,4]] }\n\
         holes = [ { circle = { center = [1.5,2], radius = 0.6 } }, { circle = { center = [2.5,2], radius = 0.6 } } ]\n",
        &["hole 1 and hole 2 cross or touch"],
    );
    // Bow tie: the outer loop crosses itself.
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[1,1],[1,0],[0,1]] }\n",
        &["the outer loop crosses or touches itself", "(0.5, 0.5)"],
    );
    // A hole touching the outer loop at a corner.
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[2,0],[2,2],[0,2]] }\nholes = [ { polygon = [[0,0],[1,0.5],[0.5,1]] } ]\n",
        &["cross or touch"],
    );
    // A loop that runs back over itself.
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[2,0],[1,0],[1,1]] }\n",
        &["runs back over itself"],
    );
    // Collinear points: the loop has no area.
    fails(
        "[[face]]\nouter = { polygon = [[0,0],[1,0],[2,0]] }\n",
        &["runs back over itself"],
    );
}

#[test]
fn error_constraint_outside_face() {
    let face = "[[face]]\nname = \"plate\"\nouter = { polygon = [[0,0],[2,0],[2,1],[0,1]] }\nholes = [ { circle = { center = [0.5,0.5], radius = 0.2 } } ]\n";
    fails(
        &format!("{face}points = [[1.0, 0.5], [3.0, 0.5]]\n"),
        &[
            "face 'plate' (face #1), point 2",
            "(3, 0.5)",
            "outside the face",
        ],
    );
    fails(
        &format!("{face}points = [[0.5, 0.5]]\n"),
        &["point 1", "inside hole 1"],
    );
    fails(
        &format!("{face}points = [[1.0, 0.0]]\n"),
        &["point 1", "on the face boundary"],
    );
    fails(
        &format!("{face}constraints = [ {{ line = [[1.5,0.5],[2.5,0.5]] }} ]\n"),
        &[
            "constraint 1",
            "crosses or touches the outer loop near (2, 0.5)",
        ],
    );
    fails(
        &format!("{face}constraints = [ {{ line = [[1.5,0.5],[2,0.5]] }} ]\n"),
        &[
            "constraint 1",
            "touches the outer loop near (2, 0.5)",
            "only at a vertex",
        ],
    );
    // Within the tolerance of the boundary counts as touching it.
    fails(
        &format!(
            "tolerance = 1e-6\n{face}constraints = [ {{ line = [[1.5,0.5],[1.9999999,0.5]] }} ]\n"
        ),
        &["constraint 1", "touches the face boundary"],
    );
    // Running along the boundary, and duplicating a boundary side.
    fails(
        &format!("{face}constraints = [ {{ polyline = [[1,0.5],[2,1],[2,0.5]] }} ]\n"),
        &["constraint 1", "runs along the outer loop"],
    );
    fails(
        &format!("{face}constraints = [ {{ line = [[2,0],[2,1]] }} ]\n"),
        &[
            "constraint 1",
            "coincides with an edge of the face boundary",
        ],
    );
    fails(
        &format!("{face}constraints = [ {{ line = [[2.5,0.5],[3,0.5]] }} ]\n"),
        &["constraint 1", "outside the outer loop"],
    );
    fails(
        &format!("{face}constraints = [ {{ line = [[0.1,0.5],[0.9,0.5]] }} ]\n"),
        &["constraint 1", "crosses or touches hole 1"],
    );
    fails(
        &format!("{face}constraints = [ {{ line = [[1.1,0.1],[1.9,0.9]] }}, {{ line = [[1.1,0.9],[1.9,0.1]] }} ]\n"),
        &["constraint 2", "crosses or touches constraint 1", "(1.5, 0.5)"],
    );
    // A constraint ending at a boundary corner and one inside are fine.
    let m = parse(&format!(
        "{HEAD}{face}constraints = [ {{ line = [[2,1],[1.5,0.5]] }}, {{ circle = {{ center = [1.0, 0.5], radius = 0.2 }} }} ]\npoints = [[1.0, 0.2]]\n"
    ))
    .unwrap();
    check_invariants(&m);
    assert_eq!(m.faces[0].embedded_edges.len(), 2);
    // The constraint's end is the corner vertex (2, 1).
    let e = &m.edges[m.faces[0].embedded_edges[0] as usize];
    assert!(m.faces[0].loops[0].edges.iter().any(|u| {
        let b = &m.edges[u.edge as usize];
        b.start == e.start || b.end == e.start
    }));
}

#[test]
fn error_io_names_the_file() {
    let e = read_domain(std::path::Path::new("/nonexistent/dir/missing.toml")).unwrap_err();
    assert!(matches!(e, DomainError::Io { .. }));
    assert_eq!(e.file(), "/nonexistent/dir/missing.toml");
    assert!(e
        .to_string()
        .starts_with("/nonexistent/dir/missing.toml: cannot read"));
}

/// Mutations of the example files never make the reader panic.
#[test]
fn never_panics_on_mutated_input() {
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut rnd = move |n: usize| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed % n as u64) as usize
    };
    let tokens = [
        "0", "-1", "1e308", "nan", "inf", "-inf", "[]", "[[0,0]]", "{}", "\"x\"", "0.5", "[0,0,1]",
        "1e-300", ",", "]",
    ];
    for name in [
        "square.toml",
        "plate_two_holes.toml",
        "hexagon.toml",
        "constrained.toml",
        "two_faces.toml",
    ] {
        let text = std::fs::read_to_string(example(name)).unwrap();
        // Every prefix.
        for cut in (0..text.len()).step_by(7) {
            if text.is_char_boundary(cut) {
                let _ = parse(&text[..cut]);
            }
        }
        // Replace a number-like token by something nasty.
        for _ in 0..300 {
            let bytes: Vec<char> = text.chars().collect();
            let starts: Vec<usize> = (0..bytes.len())
                .filter(|&i| {
                    bytes[i].is_ascii_digit()
                        && (i == 0 || !bytes[i - 1].is_ascii_digit() && bytes[i - 1] != '.')
                })
                .collect();
            let s = starts[rnd(starts.len())];
            let mut e = s;
            while e < bytes.len() && (bytes[e].is_ascii_digit() || bytes[e] == '.') {
                e += 1;
            }
            let mut out: String = bytes[..s].iter().collect();
            out.push_str(tokens[rnd(tokens.len())]);
            out.extend(&bytes[e..]);
            let _ = parse(&out);
        }
    }
}

#[test]
fn single_piece_closed_loops() {
    // A closed polyline, a 360° arc, a closed NURBS (the 9-point circle)
    // and a chain of one full arc are all valid loops; each closed curve is
    // one edge whose start and end are one vertex.
    let m = parse(&format!(
        "{HEAD}
[[face]]
outer = {{ polyline = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]] }}
holes = [
  {{ arc = {{ center = [2, 2], radius = 1, start = 90, end = 450 }} }},
  {{ nurbs = {{ degree = 2, points = [[9, 2], [9, 3], [8, 3], [7, 3], [7, 2], [7, 1], [8, 1], [9, 1], [9, 2]], weights = [1, 0.7071067811865476, 1, 0.7071067811865476, 1, 0.7071067811865476, 1, 0.7071067811865476, 1], knots = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1] }} }},
  {{ chain = [ {{ arc = {{ center = [5, 8], radius = 1, start = 0, end = -360 }} }} ] }},
]
"
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    check_invariants(&m);
    assert_eq!(m.edges.len(), 4 + 3);
    for l in &m.faces[0].loops[1..] {
        assert_eq!(l.edges.len(), 1);
        let e = &m.edges[l.edges[0].edge as usize];
        assert_eq!(e.start, e.end);
    }
}

#[test]
fn sub_table_syntax() {
    // Long paths may be written as sub-tables instead of inline tables.
    let m = parse(&format!(
        "{HEAD}
[[face]]
name = \"plate\"

[face.outer]
polygon = [[0, 0], [2, 0], [2, 1], [0, 1]]

[[face.holes]]
circle = {{ center = [0.5, 0.5], radius = 0.2 }}

[[face.holes]]
name = \"spline-hole\"
[face.holes.nurbs]
degree = 2
points = [[1.4, 0.5], [1.5, 0.7], [1.6, 0.5], [1.5, 0.3], [1.4, 0.5]]
knots = [0, 0, 0, 0.3, 0.6, 1, 1, 1]

[[face.constraints]]
line = [[0.9, 0.2], [1.1, 0.8]]
"
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    check_invariants(&m);
    assert_eq!(m.faces[0].loops.len(), 3);
    assert_eq!(m.faces[0].embedded_edges.len(), 1);
    let spline = m.faces[0].loops[2].edges[0].edge;
    assert_eq!(
        m.edges[spline as usize].name.as_deref(),
        Some("spline-hole")
    );
}
