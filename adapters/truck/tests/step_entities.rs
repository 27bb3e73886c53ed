//! STEP entities written here one by one (issue 21): PARABOLA,
//! OFFSET_CURVE_3D, COMPOSITE_CURVE, PCURVE, FACETED_BREP,
//! CURVE_BOUNDED_SURFACE, wireframe-only content, and the reader's unit
//! conversion (also on the ../shared/realstep files that are not in
//! millimetres).

use bubblemesh_core::geom::{Curve, P3};
use bubblemesh_core::spacing::Constant;
use bubblemesh_core::{mesh_model, Mesh, Options};
use bubblemesh_truck::{parse_step, parse_step_with, read_step, read_step_with};
use bubblemesh_truck::{LengthUnit, StepModel, StepOptions};

/// STEP text being written: entities numbered in order.
struct Writer {
    lines: Vec<String>,
}

impl Writer {
    fn new() -> Self {
        Writer { lines: Vec::new() }
    }
    fn add(&mut self, body: impl Into<String>) -> usize {
        self.lines.push(body.into());
        self.lines.len()
    }
    fn point(&mut self, p: [f64; 3]) -> usize {
        self.add(format!(
            "CARTESIAN_POINT('',({:?},{:?},{:?}))",
            p[0], p[1], p[2]
        ))
    }
    fn point2(&mut self, p: [f64; 2]) -> usize {
        self.add(format!("CARTESIAN_POINT('',({:?},{:?}))", p[0], p[1]))
    }
    fn dir(&mut self, d: [f64; 3]) -> usize {
        self.add(format!("DIRECTION('',({:?},{:?},{:?}))", d[0], d[1], d[2]))
    }
    fn axis(&mut self, o: [f64; 3], z: [f64; 3], x: [f64; 3]) -> usize {
        let (o, z, x) = (self.point(o), self.dir(z), self.dir(x));
        self.add(format!("AXIS2_PLACEMENT_3D('',#{o},#{z},#{x})"))
    }
    fn vertex(&mut self, p: [f64; 3]) -> usize {
        let q = self.point(p);
        self.add(format!("VERTEX_POINT('',#{q})"))
    }
    fn line(&mut self, a: [f64; 3], b: [f64; 3]) -> usize {
        let p = self.point(a);
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let dd = self.dir(d);
        let v = self.add(format!("VECTOR('',#{dd},{l:?})"));
        self.add(format!("LINE('',#{p},#{v})"))
    }
    fn edge(&mut self, v1: usize, v2: usize, curve: usize) -> usize {
        self.add(format!("EDGE_CURVE('',#{v1},#{v2},#{curve},.T.)"))
    }
    /// A face on `surface` with one outer loop of (edge, orientation).
    fn face(&mut self, surface: usize, uses: &[(usize, bool)]) -> usize {
        let oes: Vec<String> = uses
            .iter()
            .map(|&(e, o)| {
                let o = if o { ".T." } else { ".F." };
                format!("#{}", self.add(format!("ORIENTED_EDGE('',*,*,#{e},{o})")))
            })
            .collect();
        let lp = self.add(format!("EDGE_LOOP('',({}))", oes.join(",")));
        let b = self.add(format!("FACE_OUTER_BOUND('',#{lp},.T.)"));
        self.add(format!("ADVANCED_FACE('',(#{b}),#{surface},.T.)"))
    }
    /// The plane z = h (normal +z).
    fn plane_z(&mut self, h: f64) -> usize {
        let ax = self.axis([0.0, 0.0, h], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
        self.add(format!("PLANE('',#{ax})"))
    }
    /// An open shell of `faces`.
    fn shell(&mut self, faces: &[usize]) -> usize {
        let f: Vec<String> = faces.iter().map(|f| format!("#{f}")).collect();
        self.add(format!("OPEN_SHELL('',({}))", f.join(",")))
    }
    /// A context whose length unit is `unit` (an SI prefix such as
    /// `.MILLI.` or `$`, or `inch`).
    fn context(&mut self, unit: &str) -> usize {
        let lu = if unit == "inch" {
            let mm = self.add("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )");
            let m = self.add(format!(
                "LENGTH_MEASURE_WITH_UNIT(LENGTH_MEASURE(25.4),#{mm})"
            ));
            let d = self.add("DIMENSIONAL_EXPONENTS(1.,0.,0.,0.,0.,0.,0.)");
            self.add(format!(
                "( CONVERSION_BASED_UNIT('INCH',#{m}) LENGTH_UNIT() NAMED_UNIT(#{d}) )"
            ))
        } else {
            self.add(format!(
                "( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT({unit},.METRE.) )"
            ))
        };
        self.add(format!(
            "( GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNIT_ASSIGNED_CONTEXT((#{lu})) \
             REPRESENTATION_CONTEXT('','') )"
        ))
    }
    fn text(&self) -> String {
        let mut s = String::from(
            "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\n\
             FILE_NAME('','',(''),(''),'','','');\n\
             FILE_SCHEMA(('AUTOMOTIVE_DESIGN'));\nENDSEC;\nDATA;\n",
        );
        for (k, l) in self.lines.iter().enumerate() {
            s.push_str(&format!("#{} = {l};\n", k + 1));
        }
        s.push_str("ENDSEC;\nEND-ISO-10303-21;\n");
        s
    }
}

fn read(w: &Writer, what: &str) -> StepModel {
    parse_step(&w.text(), what).unwrap_or_else(|e| panic!("{what}: {e}"))
}

/// The faces (dim 2) meshed at a uniform size.
fn mesh_faces(s: &StepModel, size: f64) -> Mesh {
    let opts = Options {
        dim: Some(2),
        ..Default::default()
    };
    mesh_model(&s.model, &Constant(size), &opts)
        .unwrap_or_else(|e| panic!("meshing: {e}"))
        .0
}

/// Total triangle area, whether every triangle edge is shared by two
/// triangles, and the signed enclosed volume.
fn area_closed_volume(mesh: &Mesh) -> (f64, bool, f64) {
    let mut count = std::collections::HashMap::<(u32, u32), i32>::new();
    let (mut area, mut vol) = (0.0, 0.0);
    for t in &mesh.triangles {
        let [a, b, c] = t.nodes;
        for (u, v) in [(a, b), (b, c), (c, a)] {
            *count.entry((u.min(v), u.max(v))).or_default() += 1;
        }
        let p = |i: u32| mesh.nodes[i as usize].pos.coords;
        area += 0.5 * (p(b) - p(a)).cross(&(p(c) - p(a))).norm();
        vol += p(a).dot(&p(b).cross(&p(c))) / 6.0;
    }
    (area, count.values().all(|&c| c == 2), vol)
}

/// First and second derivatives against central differences, at interior
/// parameters.
fn check_derivatives(c: &dyn Curve, what: &str) {
    let (a, b) = c.interval();
    let h = 1e-5 * (b - a);
    for k in 1..40 {
        let t = a + (b - a) * k as f64 / 40.0;
        let scale = c.d1(t).norm().max(1e-3);
        let fd1 = (c.point(t + h) - c.point(t - h)) / (2.0 * h);
        let e1 = (fd1 - c.d1(t)).norm() / scale;
        assert!(e1 < 1e-6, "{what}: d1 at t = {t} off by {e1} (relative)");
        let fd2 = (c.d1(t + h) - c.d1(t - h)) / (2.0 * h);
        let e2 = (fd2 - c.d2(t)).norm() / c.d2(t).norm().max(scale);
        assert!(e2 < 1e-5, "{what}: d2 at t = {t} off by {e2} (relative)");
    }
}

fn close(a: P3, b: [f64; 3], tol: f64) -> bool {
    (a - P3::new(b[0], b[1], b[2])).norm() <= tol
}

/// A PARABOLA edge runs between its vertices (exactly: the parameters are
/// found in closed form), through the apex, with the derivatives of its
/// point map; the face it bounds with a line has the area between x = y²
/// and x = 1, 4/3.
#[test]
fn parabola_edge_ends_at_its_vertices() {
    let mut w = Writer::new();
    let vm = w.vertex([1.0, -1.0, 0.0]);
    let vp = w.vertex([1.0, 1.0, 0.0]);
    // C(t) = (t²/4, t/2, 0): x = y²
    let ax = w.axis([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let par = w.add(format!("PARABOLA('',#{ax},0.25)"));
    let ep = w.edge(vm, vp, par);
    let ln = w.line([1.0, -1.0, 0.0], [1.0, 1.0, 0.0]);
    let el = w.edge(vm, vp, ln);
    let pl = w.plane_z(0.0);
    let f = w.face(pl, &[(el, true), (ep, false)]);
    w.shell(&[f]);
    let s = read(&w, "parabola");
    assert_eq!((s.model.edges.len(), s.model.faces.len()), (2, 1));
    let k = s
        .info
        .edge_ids
        .iter()
        .position(|&e| e == ep as u64)
        .unwrap();
    let e = &s.model.edges[k];
    assert!(close(e.curve.point(e.t0), [1.0, -1.0, 0.0], 1e-12));
    assert!(close(e.curve.point(e.t1), [1.0, 1.0, 0.0], 1e-12));
    assert!(close(
        e.curve.point(0.5 * (e.t0 + e.t1)),
        [0.0, 0.0, 0.0],
        1e-12
    ));
    check_derivatives(e.curve.as_ref(), "parabola edge");
    let (area, _, _) = area_closed_volume(&mesh_faces(&s, 0.05));
    assert!((area - 4.0 / 3.0).abs() < 0.01, "area {area}");
}

/// OFFSET_CURVE_3D: of a line a line, of a circle in its plane a circle
/// (exact), of an ellipse an evaluated curve 0.5 from the ellipse whose
/// derivatives are right; the disc bounded by the offset ellipse has the
/// area of a parallel body, πab + L d + πd².
#[test]
fn offset_curves_read_exactly_or_with_derivatives() {
    // an offset line: LINE y = 0 offset by 0.5 with V = +z lies at y = 0.5
    // (V × C' = z × x = y, ISO 10303-42 as OpenCascade reads it)
    {
        let mut w = Writer::new();
        let va = w.vertex([0.0, 0.5, 0.0]);
        let vb = w.vertex([2.0, 0.5, 0.0]);
        let ln = w.line([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        let z = w.dir([0.0, 0.0, 1.0]);
        let off = w.add(format!("OFFSET_CURVE_3D('',#{ln},0.5,.F.,#{z})"));
        w.edge(va, vb, off);
        let s = read(&w, "offset line");
        let e = &s.model.edges[0];
        for k in 0..=4 {
            let p = e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 4.0);
            assert!((p.y - 0.5).abs() < 1e-12 && p.z.abs() < 1e-12, "{p:?}");
        }
    }
    // circle r = 1 offset by 0.5 with V = −z (outward: V × C' points away
    // from the centre): r = 1.5; ellipse 2 × 1 likewise
    let ell_perimeter = 9.688_448_220_547_675;
    for (basis, want_area, what) in [
        ("circle", std::f64::consts::PI * 1.5 * 1.5, "offset circle"),
        (
            "ellipse",
            std::f64::consts::PI * 2.0 + ell_perimeter * 0.5 + std::f64::consts::PI * 0.25,
            "offset ellipse",
        ),
    ] {
        let mut w = Writer::new();
        let ax = w.axis([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
        let (c, start) = if basis == "circle" {
            (w.add(format!("CIRCLE('',#{ax},1.)")), [1.5, 0.0, 0.0])
        } else {
            (w.add(format!("ELLIPSE('',#{ax},2.,1.)")), [2.5, 0.0, 0.0])
        };
        let z = w.dir([0.0, 0.0, -1.0]);
        let off = w.add(format!("OFFSET_CURVE_3D('',#{c},0.5,.F.,#{z})"));
        let v = w.vertex(start);
        let e = w.edge(v, v, off);
        let pl = w.plane_z(0.0);
        let f = w.face(pl, &[(e, true)]);
        w.shell(&[f]);
        let s = read(&w, what);
        let e = &s.model.edges[0];
        if basis == "ellipse" {
            check_derivatives(e.curve.as_ref(), what);
            // every point 0.5 from the ellipse (nearest of dense samples)
            for k in 0..50 {
                let p = e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 50.0);
                let d = (0..20000)
                    .map(|i| {
                        let t = std::f64::consts::TAU * i as f64 / 20000.0;
                        (p - P3::new(2.0 * t.cos(), t.sin(), 0.0)).norm()
                    })
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    (d - 0.5).abs() < 1e-6,
                    "{what}: {p:?} is {d} from the ellipse"
                );
            }
        } else {
            for k in 0..8 {
                let p = e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 8.0);
                assert!((p.coords.norm() - 1.5).abs() < 1e-12);
            }
        }
        let (area, _, _) = area_closed_volume(&mesh_faces(&s, 0.1));
        assert!(
            (area / want_area - 1.0).abs() < 0.01,
            "{what}: area {area}, expected {want_area}"
        );
    }
}

/// A COMPOSITE_CURVE of trimmed lines (by parameter, one against its sense)
/// and a trimmed circle (by points, in degrees), closed into a stadium
/// half: two edges on it (the second across the curve's start), inside a
/// SURFACE_CURVE and a TRIMMED_CURVE; the face has area 4 + π/2.
#[test]
fn composite_curve_edges_follow_their_segments() {
    let mut w = Writer::new();
    // degrees, so the circle's trims by PARAMETER_VALUE would be degrees
    let _ = w.add("( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) )");
    let rad = 1usize;
    let pam = w.add(format!(
        "PLANE_ANGLE_MEASURE_WITH_UNIT(PLANE_ANGLE_MEASURE(0.0174532925199433),#{rad})"
    ));
    let dims = w.add("DIMENSIONAL_EXPONENTS(0.,0.,0.,0.,0.,0.,0.)");
    let _deg = w.add(format!(
        "( CONVERSION_BASED_UNIT('DEGREE',#{pam}) NAMED_UNIT(#{dims}) PLANE_ANGLE_UNIT() )"
    ));
    // bottom: LINE through (−1, −1) along +x, t from 0 to 2
    let l1 = w.line([-1.0, -1.0, 0.0], [0.0, -1.0, 0.0]);
    let t1 = w.add(format!(
        "TRIMMED_CURVE('',#{l1},(PARAMETER_VALUE(0.)),(PARAMETER_VALUE(2.)),.T.,.PARAMETER.)"
    ));
    // right: the circle about (1, 0) from −90° to 90°, trimmed by points
    let ax = w.axis([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let ci = w.add(format!("CIRCLE('',#{ax},1.)"));
    let (pa, pb) = (w.point([1.0, -1.0, 0.0]), w.point([1.0, 1.0, 0.0]));
    let t2 = w.add(format!(
        "TRIMMED_CURVE('',#{ci},(#{pa},PARAMETER_VALUE(-80.)),(#{pb}),.T.,.CARTESIAN.)"
    ));
    // top: LINE through (−1, 1) along +x, from t = 2 back to t = 0
    let l3 = w.line([-1.0, 1.0, 0.0], [0.0, 1.0, 0.0]);
    let t3 = w.add(format!(
        "TRIMMED_CURVE('',#{l3},(PARAMETER_VALUE(2.)),(PARAMETER_VALUE(0.)),.F.,.PARAMETER.)"
    ));
    // left: a polyline run backwards (−1, −1) → (−1, 1), same_sense .F.
    let (q0, q1) = (w.point([-1.0, -1.0, 0.0]), w.point([-1.0, 1.0, 0.0]));
    let pl4 = w.add(format!("POLYLINE('',(#{q0},#{q1}))"));
    let mut segs = Vec::new();
    for (c, same) in [(t1, true), (t2, true), (t3, true), (pl4, false)] {
        let same = if same { ".T." } else { ".F." };
        segs.push(format!(
            "#{}",
            w.add(format!("COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,{same},#{c})"))
        ));
    }
    let comp = w.add(format!("COMPOSITE_CURVE('',({}),.F.)", segs.join(",")));
    let pl = w.plane_z(0.0);
    let sc = w.add(format!("SURFACE_CURVE('',#{comp},(#{pl}),.CURVE_3D.)"));
    let va = w.vertex([-1.0, -1.0, 0.0]);
    let vb = w.vertex([1.0, 1.0, 0.0]);
    let e1 = w.edge(va, vb, sc);
    // the second edge on a TRIMMED_CURVE of the composite (by its points)
    let (ta, tb) = (w.point([1.0, 1.0, 0.0]), w.point([-1.0, -1.0, 0.0]));
    let tc = w.add(format!(
        "TRIMMED_CURVE('',#{comp},(#{ta}),(#{tb}),.T.,.CARTESIAN.)"
    ));
    let e2 = w.edge(vb, va, tc);
    let f = w.face(pl, &[(e1, true), (e2, true)]);
    w.shell(&[f]);
    // the composite's parameter is the file's (ISO 10303-42): the bottom
    // over [0, 2], the half circle over [2, 182] degrees; a TRIMMED_CURVE
    // of it from 2 to 92 is the quarter circle from (1, −1) to (2, 0)
    let tq = w.add(format!(
        "TRIMMED_CURVE('',#{comp},(PARAMETER_VALUE(2.)),(PARAMETER_VALUE(92.)),.T.,.PARAMETER.)"
    ));
    let (q0, q1) = (w.vertex([1.0, -1.0, 0.0]), w.vertex([2.0, 0.0, 0.0]));
    let eq = w.edge(q0, q1, tq);
    let s = read(&w, "composite");
    assert_eq!((s.model.edges.len(), s.model.faces.len()), (3, 1));
    let k = s
        .info
        .edge_ids
        .iter()
        .position(|&x| x == eq as u64)
        .unwrap();
    let q = &s.model.edges[k];
    assert!(close(q.curve.point(q.t0), [1.0, -1.0, 0.0], 1e-9));
    assert!(close(q.curve.point(q.t1), [2.0, 0.0, 0.0], 1e-9));
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let m = q.curve.point(0.5 * (q.t0 + q.t1));
    assert!(close(m, [1.0 + h, -h, 0.0], 1e-9), "{m:?}");
    assert!((q.t0 - 2.0).abs() < 1e-9 && (q.t1 - 92.0).abs() < 1e-9);
    let e = &s.model.edges[0];
    assert!(close(e.curve.point(e.t0), [-1.0, -1.0, 0.0], 1e-9));
    assert!(close(e.curve.point(e.t1), [1.0, 1.0, 0.0], 1e-9));
    // through the circle's rightmost point
    let mid = (0..=200)
        .map(|k| e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 200.0).x)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!((mid - 2.0).abs() < 1e-4, "reaches x = {mid}");
    let e = &s.model.edges[1];
    assert!(close(e.curve.point(e.t0), [1.0, 1.0, 0.0], 1e-9));
    assert!(close(e.curve.point(e.t1), [-1.0, -1.0, 0.0], 1e-9));
    // along the top, then down the left side through (−1, 0)
    let near = (0..=400)
        .map(|k| {
            let p = e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 400.0);
            (p - P3::new(-1.0, 0.0, 0.0)).norm()
        })
        .fold(f64::INFINITY, f64::min);
    assert!(near < 0.02, "passes {near} from (-1, 0)");
    let top = e.curve.point(e.t0 + 0.25 * (e.t1 - e.t0));
    assert!((top.y - 1.0).abs() < 1e-9, "{top:?}");
    let (area, _, _) = area_closed_volume(&mesh_faces(&s, 0.1));
    let want = 4.0 + std::f64::consts::FRAC_PI_2;
    assert!(
        (area / want - 1.0).abs() < 0.01,
        "area {area}, expected {want}"
    );
}

/// Edges given only through a PCURVE (as the edge's geometry, and as a
/// SURFACE_CURVE's associated geometry when its 3D curve is unreadable):
/// a 2D circle on a raised plane is a 3D circle at that height; a 2D line
/// v = 0.5 on a cylinder of radius 2 is its circle at height 0.5, with the
/// derivatives of the composed map.
#[test]
fn pcurve_edges_are_their_2d_curves_on_the_surface() {
    let mut w = Writer::new();
    let ax = w.axis([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let pl = w.add(format!("PLANE('',#{ax})"));
    let c2o = w.point2([0.0, 0.0]);
    let c2x = w.add("DIRECTION('',(1.,0.))");
    let a2 = w.add(format!("AXIS2_PLACEMENT_2D('',#{c2o},#{c2x})"));
    let c2 = w.add(format!("CIRCLE('',#{a2},1.)"));
    let ctx2 = w.add("( GEOMETRIC_REPRESENTATION_CONTEXT(2) PARAMETRIC_REPRESENTATION_CONTEXT() REPRESENTATION_CONTEXT('2D','') )");
    let dr = w.add(format!("DEFINITIONAL_REPRESENTATION('',(#{c2}),#{ctx2})"));
    let pc = w.add(format!("PCURVE('',#{pl},#{dr})"));
    let v = w.vertex([1.0, 0.0, 1.0]);
    let e = w.edge(v, v, pc);
    let f = w.face(pl, &[(e, true)]);
    // the cylinder: a SURFACE_CURVE whose 3D curve is of no known type
    let cax = w.axis([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let cyl = w.add(format!("CYLINDRICAL_SURFACE('',#{cax},2.)"));
    let lo = w.point2([0.0, 0.5]);
    let ld = w.add("DIRECTION('',(1.,0.))");
    let lv = w.add(format!("VECTOR('',#{ld},1.)"));
    let l2 = w.add(format!("LINE('',#{lo},#{lv})"));
    let dr2 = w.add(format!("DEFINITIONAL_REPRESENTATION('',(#{l2}),#{ctx2})"));
    let pc2 = w.add(format!("PCURVE('',#{cyl},#{dr2})"));
    let unknown = w.add("CLOTHOID('',$,1.,$)");
    let sc = w.add(format!("SURFACE_CURVE('',#{unknown},(#{pc2}),.PCURVE_S1.)"));
    let va = w.vertex([2.0, 0.0, 0.5]);
    let vb = w.vertex([0.0, 2.0, 0.5]);
    let e2 = w.edge(va, vb, sc);
    w.shell(&[f]);
    let s = read(&w, "pcurve");
    let k = s.info.edge_ids.iter().position(|&x| x == e as u64).unwrap();
    let c = &s.model.edges[k];
    for i in 0..=8 {
        let p = c.curve.point(c.t0 + (c.t1 - c.t0) * i as f64 / 8.0);
        assert!((p.coords.xy().norm() - 1.0).abs() < 1e-12 && (p.z - 1.0).abs() < 1e-12);
    }
    check_derivatives(c.curve.as_ref(), "pcurve circle");
    let k = s
        .info
        .edge_ids
        .iter()
        .position(|&x| x == e2 as u64)
        .unwrap();
    let c = &s.model.edges[k];
    assert!(close(c.curve.point(c.t0), [2.0, 0.0, 0.5], 1e-9));
    assert!(close(c.curve.point(c.t1), [0.0, 2.0, 0.5], 1e-9));
    let m = c.curve.point(0.5 * (c.t0 + c.t1));
    let r = std::f64::consts::SQRT_2;
    assert!(close(m, [r, r, 0.5], 1e-9), "{m:?}");
    check_derivatives(c.curve.as_ref(), "pcurve line on a cylinder");
    let (area, _, _) = area_closed_volume(&mesh_faces(&s, 0.1));
    assert!(
        (area / std::f64::consts::PI - 1.0).abs() < 0.01,
        "area {area}"
    );
}

/// A pcurve in a file whose angles are degrees: its u on a cylinder or a
/// cone is in degrees (2D lines of constant v from u = 0° to 90°; the
/// cone's v is the height above its placement), on a torus both parameters
/// are; evaluated as the same 3D curves as in radians.
#[test]
fn pcurves_in_degrees_on_a_cylinder_and_a_torus() {
    let mut w = Writer::new();
    let rad = w.add("( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) )");
    let pam = w.add(format!(
        "PLANE_ANGLE_MEASURE_WITH_UNIT(PLANE_ANGLE_MEASURE(0.0174532925199433),#{rad})"
    ));
    let dims = w.add("DIMENSIONAL_EXPONENTS(0.,0.,0.,0.,0.,0.,0.)");
    w.add(format!(
        "( CONVERSION_BASED_UNIT('DEGREE',#{pam}) NAMED_UNIT(#{dims}) PLANE_ANGLE_UNIT() )"
    ));
    let ctx2 = w.add("( GEOMETRIC_REPRESENTATION_CONTEXT(2) PARAMETRIC_REPRESENTATION_CONTEXT() REPRESENTATION_CONTEXT('2D','') )");
    let cax = w.axis([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let cyl = w.add(format!("CYLINDRICAL_SURFACE('',#{cax},2.)"));
    let tor = w.add(format!("TOROIDAL_SURFACE('',#{cax},3.,1.)"));
    // radius 1 at the placement, 45°: ρ = 1 + h
    let cone = w.add(format!("CONICAL_SURFACE('',#{cax},1.,45.)"));
    let mut edges = Vec::new();
    // (surface, 2D start, 2D direction, vertices)
    let cases = [
        (
            cyl,
            [0.0, 0.5],
            [1.0, 0.0],
            [2.0, 0.0, 0.5],
            [0.0, 2.0, 0.5],
        ),
        // the torus's outer equator (v = 0) from u = 0° to 90°
        (
            tor,
            [0.0, 0.0],
            [1.0, 0.0],
            [4.0, 0.0, 0.0],
            [0.0, 4.0, 0.0],
        ),
        // a tube circle (u = 0) from v = 0° to 90°
        (
            tor,
            [0.0, 0.0],
            [0.0, 1.0],
            [4.0, 0.0, 0.0],
            [3.0, 0.0, 1.0],
        ),
        // the cone's circle at height 1 (ρ = 2), u from 0° to 90°
        (
            cone,
            [0.0, 1.0],
            [1.0, 0.0],
            [2.0, 0.0, 1.0],
            [0.0, 2.0, 1.0],
        ),
    ];
    for (surf, p, d, a, b) in cases {
        let lo = w.point2(p);
        let ld = w.add(format!("DIRECTION('',({:?},{:?}))", d[0], d[1]));
        let lv = w.add(format!("VECTOR('',#{ld},1.)"));
        let l2 = w.add(format!("LINE('',#{lo},#{lv})"));
        let dr = w.add(format!("DEFINITIONAL_REPRESENTATION('',(#{l2}),#{ctx2})"));
        let pc = w.add(format!("PCURVE('',#{surf},#{dr})"));
        let (va, vb) = (w.vertex(a), w.vertex(b));
        edges.push((w.edge(va, vb, pc), a, b));
    }
    let s = read(&w, "degrees");
    for (k, (id, a, b)) in edges.into_iter().enumerate() {
        let m = s
            .info
            .edge_ids
            .iter()
            .position(|&x| x == id as u64)
            .unwrap();
        let c = &s.model.edges[m];
        assert!(close(c.curve.point(c.t0), a, 1e-9), "case {k}");
        assert!(close(c.curve.point(c.t1), b, 1e-9), "case {k}");
        let mid = c.curve.point(0.5 * (c.t0 + c.t1));
        let want = match k {
            0 => [2.0f64.sqrt(), 2.0f64.sqrt(), 0.5],
            1 => [8.0f64.sqrt(), 8.0f64.sqrt(), 0.0],
            2 => [3.0 + 0.5f64.sqrt(), 0.0, 0.5f64.sqrt()],
            _ => [2.0f64.sqrt(), 2.0f64.sqrt(), 1.0],
        };
        assert!(close(mid, want, 1e-9), "case {k}: {mid:?}");
        check_derivatives(c.curve.as_ref(), "pcurve in degrees");
    }
}

/// Writes the cube [0, 2]³ as a FACETED_BREP of POLY_LOOPs: its faces as
/// FACE_SURFACEs on planes, or (`bare`) as FACEs without geometry.
fn faceted_cube(bare: bool) -> String {
    let mut w = Writer::new();
    faceted_cube_into(&mut w, bare);
    w.text()
}

/// Adds the FACETED_BREP cube of [`faceted_cube`] to `w`: returns its id.
fn faceted_cube_into(w: &mut Writer, bare: bool) -> usize {
    let corner = |i: usize| [0, 1, 2].map(|k| if i >> k & 1 == 1 { 2.0 } else { 0.0 });
    let pts: Vec<usize> = (0..8).map(|i| w.point(corner(i))).collect();
    let mut faces = Vec::new();
    for k in 0..3 {
        for side in 0..2 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let mut cyc: Vec<usize> = [(0, 0), (1, 0), (1, 1), (0, 1)]
                .iter()
                .map(|&(x, y)| side << k | x << a | y << b)
                .collect();
            if side == 0 {
                cyc.reverse();
            }
            let ids: Vec<String> = cyc.iter().map(|&i| format!("#{}", pts[i])).collect();
            let pl = w.add(format!("POLY_LOOP('',({}))", ids.join(",")));
            let bd = w.add(format!("FACE_OUTER_BOUND('',#{pl},.T.)"));
            let face = if bare {
                w.add(format!("FACE('',(#{bd}))"))
            } else {
                let mut n = [0.0; 3];
                n[k] = if side == 1 { 1.0 } else { -1.0 };
                let mut x = [0.0; 3];
                x[a] = 1.0;
                let ax = w.axis(corner(side << k), n, x);
                let plane = w.add(format!("PLANE('',#{ax})"));
                w.add(format!("FACE_SURFACE('',(#{bd}),#{plane},.T.)"))
            };
            faces.push(format!("#{face}"));
        }
    }
    let sh = w.add(format!("CLOSED_SHELL('',({}))", faces.join(",")));
    w.add(format!("FACETED_BREP('cube',#{sh})"))
}

/// A FACETED_BREP as a product's shape (FACETED_BREP_SHAPE_REPRESENTATION)
/// is its volume, named after the product.
#[test]
fn faceted_brep_of_a_product_is_its_named_volume() {
    let mut w = Writer::new();
    let app = w.add("APPLICATION_CONTEXT('')");
    let ctx = w.context(".MILLI.");
    let origin = w.axis([0.0; 3], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let brep = faceted_cube_into(&mut w, true);
    let pc = w.add(format!("PRODUCT_CONTEXT('',#{app},'mechanical')"));
    let p = w.add(format!("PRODUCT('dice','dice','',(#{pc}))"));
    let f = w.add(format!("PRODUCT_DEFINITION_FORMATION('','',#{p})"));
    let c = w.add(format!(
        "PRODUCT_DEFINITION_CONTEXT('part definition',#{app},'design')"
    ));
    let pd = w.add(format!("PRODUCT_DEFINITION('design','',#{f},#{c})"));
    let rep = w.add(format!(
        "FACETED_BREP_SHAPE_REPRESENTATION('',(#{brep},#{origin}),#{ctx})"
    ));
    let pds = w.add(format!("PRODUCT_DEFINITION_SHAPE('','',#{pd})"));
    w.add(format!("SHAPE_DEFINITION_REPRESENTATION(#{pds},#{rep})"));
    let s = read(&w, "dice");
    assert_eq!((s.model.faces.len(), s.model.volumes.len()), (6, 1));
    assert_eq!(s.model.volumes[0].name.as_deref(), Some("dice"));
    assert_eq!(s.model.volumes[0].faces.len(), 6);
}

/// A FACETED_BREP cube (faces on planes, or bare FACEs whose plane is
/// their polygon's) is one closed solid: 8 vertices, 12 edges each shared
/// by two faces in opposite directions, 6 faces meshing closed with area
/// 24 and volume 8.
#[test]
fn faceted_brep_cube_is_a_closed_solid() {
    for bare in [false, true] {
        let what = if bare { "bare faces" } else { "face surfaces" };
        let s = parse_step(&faceted_cube(bare), what).unwrap_or_else(|e| panic!("{what}: {e}"));
        let m = &s.model;
        assert_eq!(
            (
                m.vertices.len(),
                m.edges.len(),
                m.faces.len(),
                m.volumes.len()
            ),
            (8, 12, 6, 1),
            "{what}"
        );
        let mut uses = vec![(0, 0); m.edges.len()];
        for f in &m.faces {
            assert_eq!(f.loops.len(), 1);
            for u in &f.loops[0].edges {
                let c = &mut uses[u.edge as usize];
                if u.forward {
                    c.0 += 1
                } else {
                    c.1 += 1
                }
            }
        }
        assert!(uses.iter().all(|&c| c == (1, 1)), "{what}: {uses:?}");
        let (area, closed, vol) = area_closed_volume(&mesh_faces(&s, 0.4));
        assert!(closed, "{what}: not closed");
        assert!((area - 24.0).abs() < 1e-9, "{what}: area {area}");
        assert!((vol.abs() - 8.0).abs() < 1e-9, "{what}: volume {vol}");
        // outward as read: the faces' sense says so
        let (lo, hi) = m.bbox().unwrap();
        assert!(close(lo, [0.0; 3], 1e-12) && close(hi, [2.0; 3], 1e-12));
    }
}

/// A CURVE_BOUNDED_SURFACE alone is read as a face of its basis surface
/// inside its OUTER_BOUNDARY_CURVE (here a pcurve polygon on a plane at
/// z = 3): one face of area 2 × 1.
#[test]
fn curve_bounded_surface_is_a_face() {
    let mut w = Writer::new();
    let ax = w.axis([0.0, 0.0, 3.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let pl = w.add(format!("PLANE('',#{ax})"));
    let q: Vec<String> = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0], [0.0, 0.0]]
        .iter()
        .map(|&p| format!("#{}", w.point2(p)))
        .collect();
    let poly = w.add(format!("POLYLINE('',({}))", q.join(",")));
    let ctx2 = w.add("( GEOMETRIC_REPRESENTATION_CONTEXT(2) PARAMETRIC_REPRESENTATION_CONTEXT() REPRESENTATION_CONTEXT('2D','') )");
    let dr = w.add(format!("DEFINITIONAL_REPRESENTATION('',(#{poly}),#{ctx2})"));
    let pc = w.add(format!("PCURVE('',#{pl},#{dr})"));
    let seg = w.add(format!("COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.T.,#{pc})"));
    let ob = w.add(format!("OUTER_BOUNDARY_CURVE('',(#{seg}),.F.)"));
    let cbs = w.add(format!("CURVE_BOUNDED_SURFACE('',#{pl},(#{ob}),.F.)"));
    let ctx = w.context(".MILLI.");
    w.add(format!(
        "GEOMETRICALLY_BOUNDED_SURFACE_SHAPE_REPRESENTATION('',(#{cbs}),#{ctx})"
    ));
    let s = read(&w, "curve bounded");
    assert_eq!((s.model.faces.len(), s.model.edges.len()), (1, 1));
    let (lo, hi) = s.model.bbox().unwrap();
    assert!(close(lo, [0.0, 0.0, 3.0], 1e-9) && close(hi, [2.0, 1.0, 3.0], 1e-9));
    let (area, _, _) = area_closed_volume(&mesh_faces(&s, 0.1));
    assert!((area - 2.0).abs() < 1e-3, "area {area}");
}

/// A CURVE_BOUNDED_SURFACE that cannot be read as a face (here bounded by
/// its basis's own edges, `implicit_outer`) is skipped with a note beside
/// a B-rep, and an error naming it alone.
#[test]
fn unreadable_curve_bounded_surface_is_noted_beside_a_brep() {
    let add = |w: &mut Writer| {
        let ax = w.axis([0.0, 0.0, 3.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
        let pl = w.add(format!("PLANE('',#{ax})"));
        w.add(format!("CURVE_BOUNDED_SURFACE('',#{pl},(),.T.)"))
    };
    let mut w = Writer::new();
    let cbs = add(&mut w);
    let err = parse_step(&w.text(), "cbs.stp").unwrap_err().to_string();
    assert!(
        err.contains(&format!("#{cbs} CURVE_BOUNDED_SURFACE")) && err.contains("implicit_outer"),
        "{err}"
    );
    let mut w = Writer::new();
    faceted_cube_into(&mut w, false);
    let cbs = add(&mut w);
    let s = read(&w, "cube+cbs");
    assert_eq!(s.model.faces.len(), 6);
    assert!(
        s.info
            .notes
            .iter()
            .any(|n| n.starts_with(&format!("#{cbs} CURVE_BOUNDED_SURFACE: skipped"))),
        "{:?}",
        s.info.notes
    );
}

/// Wireframe content is no B-rep: beside one it is noted and skipped; alone
/// it is an error naming the file and the entity.
#[test]
fn wireframe_is_noted_beside_a_brep_and_an_error_alone() {
    let wire = |w: &mut Writer| {
        let ln = w.line([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        let tc = w.add(format!(
            "TRIMMED_CURVE('',#{ln},(PARAMETER_VALUE(0.)),(PARAMETER_VALUE(1.)),.T.,.PARAMETER.)"
        ));
        w.add(format!("GEOMETRIC_CURVE_SET('',(#{tc}))"))
    };
    let mut w = Writer::new();
    let gcs = wire(&mut w);
    let err = parse_step(&w.text(), "wire.stp").unwrap_err().to_string();
    assert!(
        err.contains("wire.stp") && err.contains(&format!("#{gcs} GEOMETRIC_CURVE_SET")),
        "{err}"
    );
    assert!(err.contains("wireframe"), "{err}");
    // beside a faceted cube
    let cube = faceted_cube(false);
    let body_end = cube.find("ENDSEC;\nEND-ISO").unwrap();
    let n = cube.matches(" = ").count();
    let text = format!(
        "{}#{} = CARTESIAN_POINT('',(5.,5.,5.));\n#{} = CARTESIAN_POINT('',(6.,5.,5.));\n\
         #{} = POLYLINE('',(#{},#{}));\n#{} = GEOMETRIC_CURVE_SET('',(#{}));\n{}",
        &cube[..body_end],
        n + 1,
        n + 2,
        n + 3,
        n + 1,
        n + 2,
        n + 4,
        n + 3,
        &cube[body_end..]
    );
    let s = parse_step(&text, "cube+wire").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.model.faces.len(), 6);
    assert_eq!(s.info.notes.len(), 1, "{:?}", s.info.notes);
    assert!(s.info.notes[0].contains(&format!("#{} GEOMETRIC_CURVE_SET", n + 4)));
}

/// A part in inches read in millimetres: every length × 25.4 (vertices,
/// radii); the unit reported is the one asked for, the file's is kept. A
/// file that names no unit cannot be converted.
#[test]
fn inch_file_read_in_millimetres_is_scaled() {
    let build = |with_unit: bool| {
        let mut w = Writer::new();
        if with_unit {
            w.context("inch");
        }
        let ax = w.axis([1.0, 2.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
        let c = w.add(format!("CIRCLE('',#{ax},0.5)"));
        let v = w.vertex([1.5, 2.0, 0.0]);
        let e = w.edge(v, v, c);
        let pl = w.plane_z(0.0);
        let f = w.face(pl, &[(e, true)]);
        w.shell(&[f]);
        w.text()
    };
    let mm = StepOptions {
        unit: Some(LengthUnit::millimetre()),
    };
    let plain = parse_step(&build(true), "inch").unwrap();
    let s = parse_step_with(&build(true), "inch", &mm).unwrap();
    assert_eq!(plain.info.length_unit.as_ref().unwrap().name, "inch");
    assert_eq!(s.info.length_unit.as_ref().unwrap().name, "millimetre");
    assert_eq!(s.info.file_length_unit.as_ref().unwrap().name, "inch");
    let e = &s.model.edges[0];
    for k in 0..8 {
        let p = e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 8.0);
        let r = (p - P3::new(25.4, 50.8, 0.0)).norm();
        assert!((r - 12.7).abs() < 1e-9, "radius {r}");
    }
    let (a, b) = (plain.model.bbox().unwrap(), s.model.bbox().unwrap());
    assert!((a.0 * 25.4 - b.0).norm() < 1e-9 && (a.1 * 25.4 - b.1).norm() < 1e-9);
    let err = parse_step_with(&build(false), "nounit", &mm).unwrap_err();
    assert!(err.to_string().contains("names no length unit"), "{err}");
    assert_eq!(
        LengthUnit::inch().factor_to(&LengthUnit::millimetre()),
        25.4
    );
    assert_eq!(LengthUnit::parse("ft"), Some(LengthUnit::foot()));
}

/// `../shared/realstep` beside the repository, or `$BUBBLEMESH_REALSTEP`.
fn realstep_dir() -> String {
    let dir = std::env::var("BUBBLEMESH_REALSTEP").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/realstep").to_string()
    });
    if std::env::var_os("CI").is_some() && !std::path::Path::new(&dir).is_dir() {
        panic!("CI is set but the realstep files are not at {dir}");
    }
    dir
}

/// Every realstep file not in millimetres, read in millimetres, has its
/// bounding box multiplied by the unit's size in millimetres (25.4 for
/// inch files, 1000 for metre, 10 for centimetre) and the same entities;
/// read in its own unit it is unchanged.
#[test]
fn realstep_files_convert_to_millimetres() {
    let dir = realstep_dir();
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!("skipped: {dir} not found");
        return;
    };
    let mut names: Vec<_> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.extension()
                .and_then(|x| x.to_str())
                .is_some_and(|x| matches!(x.to_ascii_lowercase().as_str(), "stp" | "step"))
        })
        .collect();
    names.sort();
    let mm = StepOptions {
        unit: Some(LengthUnit::millimetre()),
    };
    let mut converted = Vec::new();
    for path in names {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let plain = read_step(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let unit = plain.info.length_unit.clone().unwrap();
        if unit.name == "millimetre" {
            continue;
        }
        let f = unit.factor_to(&LengthUnit::millimetre());
        let s = read_step_with(&path, &mm).unwrap_or_else(|e| panic!("{name} in mm: {e}"));
        assert_eq!(s.model.faces.len(), plain.model.faces.len(), "{name}");
        assert_eq!(s.model.edges.len(), plain.model.edges.len(), "{name}");
        let ((a0, a1), (b0, b1)) = (plain.model.bbox().unwrap(), s.model.bbox().unwrap());
        let tol = 1e-9 * f * (a1 - a0).norm();
        assert!(
            (a0 * f - b0).norm() <= tol && (a1 * f - b1).norm() <= tol,
            "{name}: {a0:?}–{a1:?} × {f} is not {b0:?}–{b1:?}"
        );
        let same = read_step_with(
            &path,
            &StepOptions {
                unit: Some(unit.clone()),
            },
        )
        .unwrap();
        assert_eq!(same.model.bbox(), plain.model.bbox(), "{name}");
        converted.push(format!("{name}: {} × {f}", unit.name));
    }
    eprintln!("{}", converted.join("\n"));
    assert!(converted.len() >= 6, "{converted:?}");
}

/// The realstep files with a GEOMETRIC_CURVE_SET beside their B-rep read,
/// the set noted as skipped wireframe.
#[test]
fn realstep_wireframe_sets_are_noted() {
    let dir = realstep_dir();
    if !std::path::Path::new(&dir).is_dir() {
        eprintln!("skipped: {dir} not found");
        return;
    }
    for f in [
        "as_0051_flipping_joystick_assembly.stp",
        "pyocc_face_recognition_sample_part.stp",
        "pyocc_splinecage.stp",
    ] {
        let s =
            read_step(&std::path::Path::new(&dir).join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert!(!s.model.faces.is_empty(), "{f}");
        assert!(
            s.info
                .notes
                .iter()
                .any(|n| n.contains("GEOMETRIC_CURVE_SET") && n.contains("skipped")),
            "{f}: {:?}",
            s.info.notes
        );
    }
}
