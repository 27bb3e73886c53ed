//! STEP text written here, entity by entity: assemblies (every part
//! instance is placed by its transformation, nested assemblies compose, a
//! part used twice gives two volumes named after the product and instance
//! path), degenerate edges, boundaries off their surfaces.

use bubblemesh_core::geom::P3;
use bubblemesh_truck::{parse_step, read_step, step::volume_bbox};

/// STEP text being written: entities numbered in order.
struct Writer {
    lines: Vec<String>,
}

impl Writer {
    fn new() -> Self {
        Writer { lines: Vec::new() }
    }
    /// Adds `#id = body;` and returns the id.
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
    fn dir(&mut self, d: [f64; 3]) -> usize {
        self.add(format!("DIRECTION('',({:?},{:?},{:?}))", d[0], d[1], d[2]))
    }
    fn axis(&mut self, o: [f64; 3], z: [f64; 3], x: [f64; 3]) -> usize {
        let (o, z, x) = (self.point(o), self.dir(z), self.dir(x));
        self.add(format!("AXIS2_PLACEMENT_3D('',#{o},#{z},#{x})"))
    }
    /// The box [0, s0] × [0, s1] × [0, s2] as a MANIFOLD_SOLID_BREP whose
    /// vertices are `off` away from its planes (0 for an exact box): returns
    /// the solid's id. `degenerate`: the first face's loop also has a
    /// zero-length edge (a LINE from a vertex to itself) at its first corner.
    fn box_solid(&mut self, s: [f64; 3], off: f64, degenerate: bool) -> usize {
        let corner = |i: usize| [0, 1, 2].map(|k| if i >> k & 1 == 1 { s[k] } else { 0.0 });
        let mut v = [0usize; 8];
        for (i, vi) in v.iter_mut().enumerate() {
            let c = corner(i);
            // pushed off along (1, 1, 1) so no face contains its vertices exactly
            let p = self.point([c[0] + off, c[1] + off, c[2] + off]);
            *vi = self.add(format!("VERTEX_POINT('',#{p})"));
        }
        // the 12 edges: corners differing in one bit, from the lower one
        let mut edges = std::collections::HashMap::new();
        for i in 0..8usize {
            for k in 0..3 {
                let j = i | 1 << k;
                if j == i {
                    continue;
                }
                let (a, b) = (corner(i), corner(j));
                let p = self.point(a);
                let mut d = [0.0; 3];
                d[k] = 1.0;
                let dd = self.dir(d);
                let vec = self.add(format!("VECTOR('',#{dd},{:?})", b[k] - a[k]));
                let line = self.add(format!("LINE('',#{p},#{vec})"));
                let e = self.add(format!("EDGE_CURVE('',#{},#{},#{line},.T.)", v[i], v[j]));
                edges.insert((i, j), e);
            }
        }
        let mut faces = Vec::new();
        for k in 0..3 {
            for side in 0..2 {
                let (a, b) = ((k + 1) % 3, (k + 2) % 3);
                // counter-clockwise seen from outside: e_a × e_b = e_k
                let mut cyc: Vec<usize> = [(0, 0), (1, 0), (1, 1), (0, 1)]
                    .iter()
                    .map(|&(x, y)| side << k | x << a | y << b)
                    .collect();
                if side == 0 {
                    cyc.reverse();
                }
                let mut oes = Vec::new();
                if degenerate && faces.is_empty() {
                    let c = corner(cyc[0]);
                    let p = self.point(c);
                    let dd = self.dir([0.0, 0.0, 1.0]);
                    let vec = self.add(format!("VECTOR('',#{dd},1.0)"));
                    let line = self.add(format!("LINE('',#{p},#{vec})"));
                    let v0 = v[cyc[0]];
                    let e = self.add(format!("EDGE_CURVE('',#{v0},#{v0},#{line},.T.)"));
                    oes.push(self.add(format!("ORIENTED_EDGE('',*,*,#{e},.T.)")));
                }
                for m in 0..4 {
                    let (p, q) = (cyc[m], cyc[(m + 1) % 4]);
                    let (e, fwd) = match edges.get(&(p, q)) {
                        Some(&e) => (e, true),
                        None => (edges[&(q, p)], false),
                    };
                    let o = if fwd { ".T." } else { ".F." };
                    oes.push(self.add(format!("ORIENTED_EDGE('',*,*,#{e},{o})")));
                }
                let list: Vec<String> = oes.iter().map(|x| format!("#{x}")).collect();
                let lp = self.add(format!("EDGE_LOOP('',({}))", list.join(",")));
                let fb = self.add(format!("FACE_OUTER_BOUND('',#{lp},.T.)"));
                let mut n = [0.0; 3];
                n[k] = if side == 1 { 1.0 } else { -1.0 };
                let mut o = [0.0; 3];
                o[k] = side as f64 * s[k];
                let mut r = [0.0; 3];
                r[a] = 1.0;
                let pl = self.axis(o, n, r);
                let plane = self.add(format!("PLANE('',#{pl})"));
                faces.push(self.add(format!("ADVANCED_FACE('',(#{fb}),#{plane},.T.)")));
            }
        }
        let list: Vec<String> = faces.iter().map(|x| format!("#{x}")).collect();
        let shell = self.add(format!("CLOSED_SHELL('',({}))", list.join(",")));
        self.add(format!("MANIFOLD_SOLID_BREP('',#{shell})"))
    }
    /// A product with its definition: returns the PRODUCT_DEFINITION.
    fn product(&mut self, name: &str, app: usize) -> usize {
        let pc = self.add(format!("PRODUCT_CONTEXT('',#{app},'mechanical')"));
        let p = self.add(format!("PRODUCT('{name}','{name}','',(#{pc}))"));
        let f = self.add(format!("PRODUCT_DEFINITION_FORMATION('','',#{p})"));
        let c = self.add(format!(
            "PRODUCT_DEFINITION_CONTEXT('part definition',#{app},'design')"
        ));
        self.add(format!("PRODUCT_DEFINITION('design','',#{f},#{c})"))
    }
    /// Gives product definition `pd` the shape representation `rep`.
    fn shape(&mut self, pd: usize, rep: usize) {
        let pds = self.add(format!("PRODUCT_DEFINITION_SHAPE('','',#{pd})"));
        self.add(format!("SHAPE_DEFINITION_REPRESENTATION(#{pds},#{rep})"));
    }
    /// Places `child` (shape `child_rep`, frame `from` in it) in `parent`
    /// (shape `parent_rep`) at frame `to`, as occurrence `name`.
    #[allow(clippy::too_many_arguments)]
    fn occurrence(
        &mut self,
        name: &str,
        parent: usize,
        parent_rep: usize,
        child: usize,
        child_rep: usize,
        from: usize,
        to: usize,
    ) {
        let n = self.add(format!(
            "NEXT_ASSEMBLY_USAGE_OCCURRENCE('{name}','{name}','',#{parent},#{child},$)"
        ));
        let pds = self.add(format!("PRODUCT_DEFINITION_SHAPE('','',#{n})"));
        let idt = self.add(format!("ITEM_DEFINED_TRANSFORMATION('','',#{from},#{to})"));
        let rr = self.add(format!(
            "( REPRESENTATION_RELATIONSHIP('','',#{child_rep},#{parent_rep}) \
             REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION(#{idt}) \
             SHAPE_REPRESENTATION_RELATIONSHIP() )"
        ));
        self.add(format!(
            "CONTEXT_DEPENDENT_SHAPE_REPRESENTATION(#{rr},#{pds})"
        ));
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

/// The representation context with a length unit and, when given, the
/// file's distance uncertainty.
fn context(w: &mut Writer, uncertainty: Option<f64>) -> usize {
    let lu = w.add("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )");
    let unc = match uncertainty {
        Some(u) => {
            let m = w.add(format!(
                "UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE({u:?}),#{lu},'distance_accuracy_value','')"
            ));
            format!(" GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#{m}))")
        }
        None => String::new(),
    };
    w.add(format!(
        "( GEOMETRIC_REPRESENTATION_CONTEXT(3){unc} GLOBAL_UNIT_ASSIGNED_CONTEXT((#{lu})) \
         REPRESENTATION_CONTEXT('','') )"
    ))
}

/// A top assembly holding a sub-assembly `pair` twice (at z = 100 and,
/// turned a quarter about x, at y = 50); `pair` holds the box part twice
/// (at x = 10, and turned a quarter about z at y = 10). The box part's
/// shape is a SHAPE_REPRESENTATION linked to its
/// ADVANCED_BREP_SHAPE_REPRESENTATION, as OpenCascade writes it.
fn nested_assembly() -> String {
    let mut w = Writer::new();
    let app = w.add("APPLICATION_CONTEXT('')");
    let ctx = context(&mut w, None);
    let origin = w.axis([0.0; 3], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    // the part
    let solid = w.box_solid([1.0, 2.0, 3.0], 0.0, false);
    let box_pd = w.product("box", app);
    let box_sr = w.add(format!("SHAPE_REPRESENTATION('',(#{origin}),#{ctx})"));
    let brep = w.add(format!(
        "ADVANCED_BREP_SHAPE_REPRESENTATION('',(#{solid},#{origin}),#{ctx})"
    ));
    w.add(format!(
        "SHAPE_REPRESENTATION_RELATIONSHIP('','',#{box_sr},#{brep})"
    ));
    w.shape(box_pd, box_sr);
    // the sub-assembly
    let pair_pd = w.product("pair", app);
    let a1 = w.axis([10.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let a2 = w.axis([0.0, 10.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]);
    let pair_sr = w.add(format!(
        "SHAPE_REPRESENTATION('',(#{origin},#{a1},#{a2}),#{ctx})"
    ));
    w.shape(pair_pd, pair_sr);
    w.occurrence("box_a", pair_pd, pair_sr, box_pd, box_sr, origin, a1);
    w.occurrence("box_b", pair_pd, pair_sr, box_pd, box_sr, origin, a2);
    // the top
    let top_pd = w.product("top", app);
    let t1 = w.axis([0.0, 0.0, 100.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let t2 = w.axis([0.0, 50.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]);
    let top_sr = w.add(format!(
        "SHAPE_REPRESENTATION('',(#{origin},#{t1},#{t2}),#{ctx})"
    ));
    w.shape(top_pd, top_sr);
    w.occurrence("pair_1", top_pd, top_sr, pair_pd, pair_sr, origin, t1);
    w.occurrence("pair_2", top_pd, top_sr, pair_pd, pair_sr, origin, t2);
    w.text()
}

fn assert_box(lo: P3, hi: P3, want: [f64; 6], what: &str) {
    let got = [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z];
    for k in 0..6 {
        assert!(
            (got[k] - want[k]).abs() < 1e-9,
            "{what}: bounding box {got:?}, expected {want:?}"
        );
    }
}

/// Nested instances are placed by the composition of their placements; a
/// part used four times is four volumes with their own vertices, named
/// after the part and the instance path.
#[test]
fn nested_assembly_instances_are_placed_and_named() {
    let s = parse_step(&nested_assembly(), "nested").unwrap_or_else(|e| panic!("{e}"));
    let m = &s.model;
    assert_eq!(m.volumes.len(), 4);
    assert_eq!(m.vertices.len(), 32, "each instance has its own vertices");
    assert_eq!(m.faces.len(), 24);
    // box [0,1]×[0,2]×[0,3]; box_a moved by x + 10; box_b turned x → y
    // about z and moved by y + 10: (x, y, z) ↦ (−y, x + 10, z)
    // pair_1: moved by z + 100; pair_2: axis −y, reference x, so y' = z' ×
    // x' = +z: (x, y, z) ↦ (x, 50 − z, y)
    let want = [
        ("box (pair_1/box_a)", [10.0, 0.0, 100.0, 11.0, 2.0, 103.0]),
        ("box (pair_1/box_b)", [-2.0, 10.0, 100.0, 0.0, 11.0, 103.0]),
        ("box (pair_2/box_a)", [10.0, 47.0, 0.0, 11.0, 50.0, 2.0]),
        ("box (pair_2/box_b)", [-2.0, 47.0, 10.0, 0.0, 50.0, 11.0]),
    ];
    for (name, b) in want {
        let v = m
            .volumes
            .iter()
            .position(|v| v.name.as_deref() == Some(name))
            .unwrap_or_else(|| {
                let names: Vec<_> = m.volumes.iter().map(|v| v.name.clone()).collect();
                panic!("no volume {name:?} in {names:?}")
            });
        let (lo, hi) = volume_bbox(m, v).unwrap();
        assert_box(lo, hi, b, name);
    }
}

/// A single part with a product keeps its geometry where the file draws
/// it, its volume named after the product.
#[test]
fn single_part_volume_is_named_after_its_product() {
    let mut w = Writer::new();
    let app = w.add("APPLICATION_CONTEXT('')");
    let ctx = context(&mut w, None);
    let origin = w.axis([0.0; 3], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let solid = w.box_solid([1.0, 2.0, 3.0], 0.0, false);
    let pd = w.product("lonely box", app);
    let rep = w.add(format!(
        "ADVANCED_BREP_SHAPE_REPRESENTATION('',(#{solid},#{origin}),#{ctx})"
    ));
    w.shape(pd, rep);
    let s = parse_step(&w.text(), "single").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.model.volumes.len(), 1);
    assert_eq!(s.model.volumes[0].name.as_deref(), Some("lonely box"));
    let (lo, hi) = volume_bbox(&s.model, 0).unwrap();
    assert_box(lo, hi, [0.0, 0.0, 0.0, 1.0, 2.0, 3.0], "lonely box");
}

/// The 18 solids of OpenCascade's as1 assembly (pythonocc-demos'
/// as1-oc-214.stp, in ../shared/realstep beside the repository or $BUBBLEMESH_REALSTEP; the
/// test is skipped without it) are where Gmsh puts them. Expected boxes:
/// Gmsh 4.15.2, `gmsh.option.setNumber("Geometry.OCCBoundsUseStl", 1)`,
/// `gmsh.model.occ.importShapes(file)`, then `gmsh.model.getBoundingBox(3,
/// tag)` for each volume (the tessellation's bounds: OpenCascade's default
/// boxes of B-spline faces enclose their control points), in Gmsh's order,
/// which is the file's.
#[test]
fn as1_assembly_parts_are_where_gmsh_puts_them() {
    let dir = realstep_dir();
    let path = std::path::Path::new(&dir).join("pyocc_as1-oc-214.stp");
    if !path.exists() {
        eprintln!("skipped: {} not found", path.display());
        return;
    }
    #[rustfmt::skip]
    let gmsh: [[f64; 6]; 18] = [
        [175.000, 67.500, 50.000, 178.000, 82.500, 70.000],
        [2.000, 67.500, 50.000, 5.000, 82.500, 70.000],
        [-10.000, 70.001, 55.000, 190.000, 79.999, 65.000],
        [17.500, 67.500, -4.000, 32.500, 82.500, 33.000],
        [15.000, 67.500, -3.000, 35.000, 82.500, 0.000],
        [40.000, 54.510, -4.000, 55.000, 69.510, 33.000],
        [37.500, 54.510, -3.000, 57.500, 69.510, 0.000],
        [40.000, 80.490, -4.000, 55.000, 95.490, 33.000],
        [37.500, 80.490, -3.000, 57.500, 95.490, 0.000],
        [5.000, 25.000, 20.000, 55.000, 125.000, 80.000],
        [0.000, 0.000, 0.000, 180.000, 150.000, 20.000],
        [147.500, 67.500, -4.000, 162.500, 82.500, 33.000],
        [145.000, 67.500, -3.000, 165.000, 82.500, 0.000],
        [125.000, 80.490, -4.000, 140.000, 95.490, 33.000],
        [122.500, 80.490, -3.000, 142.500, 95.490, 0.000],
        [125.000, 54.510, -4.000, 140.000, 69.510, 33.000],
        [122.500, 54.510, -3.000, 142.500, 69.510, 0.000],
        [125.000, 25.000, 20.000, 175.000, 125.000, 80.000],
    ];
    let s = read_step(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = &s.model;
    assert_eq!(m.volumes.len(), 18);
    for (v, want) in gmsh.iter().enumerate() {
        let (lo, hi) = volume_bbox(m, v).unwrap();
        let got = [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z];
        for k in 0..6 {
            assert!(
                (got[k] - want[k]).abs() < 0.01,
                "volume {v} {:?}: {got:?}, Gmsh {want:?}",
                m.volumes[v].name
            );
        }
    }
    let (lo, hi) = m.bbox().unwrap();
    assert!((lo.z + 4.0).abs() < 1e-6 && (hi.z - 80.0).abs() < 1e-6);
    let names: Vec<&str> = m.volumes.iter().filter_map(|v| v.name.as_deref()).collect();
    assert!(names.contains(&"nut (rod-assembly_1/nut_1)"), "{names:?}");
    assert!(names.contains(&"l-bracket (l-bracket-assembly_2/l-bracket_1)"));
}

/// A closed edge on a LINE (zero length, as some systems write at poles and
/// collapsed boundaries) is read as its vertex, not refused.
#[test]
fn closed_edge_on_a_line_reads_as_its_vertex() {
    let mut w = Writer::new();
    let _ = w.add("APPLICATION_CONTEXT('')");
    w.box_solid([1.0, 2.0, 3.0], 0.0, true);
    let s = parse_step(&w.text(), "degenerate").unwrap_or_else(|e| panic!("{e}"));
    let m = &s.model;
    assert_eq!(s.info.degenerate_edges.len(), 1);
    assert_eq!((m.vertices.len(), m.edges.len(), m.faces.len()), (8, 12, 6));
    assert_eq!(m.volumes.len(), 1);
    assert!(m
        .faces
        .iter()
        .all(|f| f.loops.len() == 1 && f.loops[0].edges.len() == 4));
}

/// A face whose boundary lies 1e-2 off its surface (a box of size 3.7 whose
/// vertices are pushed off its planes) is read, its boundary projected
/// onto the surface, and the gap recorded per face.
#[test]
fn boundary_off_its_surface_by_1e_2_reads_with_its_gap_recorded() {
    let mut w = Writer::new();
    let _ = w.add("APPLICATION_CONTEXT('')");
    w.box_solid([1.0, 2.0, 3.0], 1e-2, false);
    let s = parse_step(&w.text(), "off").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.model.faces.len(), 6);
    assert_eq!(s.info.face_gap.len(), 6);
    for g in &s.info.face_gap {
        assert!((g - 1e-2).abs() < 1e-6, "gap {g}, expected 1e-2");
    }
}

/// The file's UNCERTAINTY_MEASURE_WITH_UNIT widens the accepted gap: a
/// boundary 0.1 off its surface (beyond the default 1e-2 of the part's
/// size) reads with an uncertainty of 0.05 and is refused without one.
#[test]
fn file_uncertainty_widens_the_accepted_gap() {
    for unc in [Some(0.05), None] {
        let mut w = Writer::new();
        let _ = w.add("APPLICATION_CONTEXT('')");
        let _ = context(&mut w, unc);
        w.box_solid([1.0, 2.0, 3.0], 0.1, false);
        let r = parse_step(&w.text(), "off");
        match unc {
            Some(_) => {
                let s = r.unwrap_or_else(|e| panic!("{e}"));
                let g = s.info.face_gap.iter().cloned().fold(0.0, f64::max);
                assert!((g - 0.1).abs() < 1e-6, "gap {g}");
            }
            None => {
                let e = r.expect_err("0.1 off without an uncertainty is refused");
                assert!(e.to_string().contains("off its surface"), "{e}");
            }
        }
    }
}

/// Files of other CAD systems that were refused while reading (in
/// ../shared/realstep or $BUBBLEMESH_REALSTEP; skipped without them):
/// a degenerate LINE edge (NX's MVE, an OpenCascade repatch), a boundary
/// point Newton's inversion could not map onto its B-spline surface
/// (pythonocc's 11752).
#[test]
fn realstep_files_once_refused_read() {
    let dir = realstep_dir();
    for f in [
        "as_0082_MVE_100-3_AP203.stp",
        "as_repatch-hpdc.stp",
        "pyocc_11752.stp",
    ] {
        let path = std::path::Path::new(&dir).join(f);
        if !path.exists() {
            eprintln!("skipped: {} not found", path.display());
            continue;
        }
        let s = read_step(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.model.volumes.len(), 1, "{f}");
    }
}

/// A shape that places a part's representation twice through MAPPED_ITEMs
/// (target ∘ origin⁻¹ each), the part being the assembly's child by an
/// occurrence without a placement of its own: two volumes, placed, named
/// after the part.
#[test]
fn mapped_items_place_a_representation_twice() {
    let mut w = Writer::new();
    let app = w.add("APPLICATION_CONTEXT('')");
    let ctx = context(&mut w, None);
    let origin = w.axis([0.0; 3], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let solid = w.box_solid([1.0, 2.0, 3.0], 0.0, false);
    let box_pd = w.product("box", app);
    let brep = w.add(format!(
        "ADVANCED_BREP_SHAPE_REPRESENTATION('',(#{solid},#{origin}),#{ctx})"
    ));
    w.shape(box_pd, brep);
    let map = w.add(format!("REPRESENTATION_MAP(#{origin},#{brep})"));
    let t1 = w.axis([20.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let t2 = w.axis([40.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
    let m1 = w.add(format!("MAPPED_ITEM('',#{map},#{t1})"));
    let m2 = w.add(format!("MAPPED_ITEM('',#{map},#{t2})"));
    let pallet_pd = w.product("pallet", app);
    let sr = w.add(format!(
        "SHAPE_REPRESENTATION('',(#{origin},#{m1},#{m2}),#{ctx})"
    ));
    w.shape(pallet_pd, sr);
    w.add(format!(
        "NEXT_ASSEMBLY_USAGE_OCCURRENCE('1','box_1','',#{pallet_pd},#{box_pd},$)"
    ));
    let s = parse_step(&w.text(), "mapped").unwrap_or_else(|e| panic!("{e}"));
    let m = &s.model;
    let names: Vec<_> = m.volumes.iter().map(|v| v.name.clone()).collect();
    assert_eq!(m.volumes.len(), 2, "{names:?}");
    // x + 20; and z' = x, x' = y, y' = z: (x, y, z) ↦ (40 + z, x, y)
    for (v, name, b) in [
        (0, "box [1]", [20.0, 0.0, 0.0, 21.0, 2.0, 3.0]),
        (1, "box [2]", [40.0, 0.0, 0.0, 43.0, 1.0, 2.0]),
    ] {
        assert_eq!(m.volumes[v].name.as_deref(), Some(name));
        let (lo, hi) = volume_bbox(m, v).unwrap();
        assert_box(lo, hi, b, name);
    }
}

/// Checks each volume's bounding box of realstep file `f` against Gmsh's
/// (`gmsh`, the file's volumes in order, in Gmsh's millimetres: `scale`
/// converts them to the file's unit), to 0.01 of the file's unit.
fn assert_gmsh_boxes(f: &str, gmsh: &[[f64; 6]], scale: f64) {
    let dir = realstep_dir();
    let path = std::path::Path::new(&dir).join(f);
    if !path.exists() {
        eprintln!("skipped: {} not found", path.display());
        return;
    }
    let s = read_step(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = &s.model;
    assert_eq!(m.volumes.len(), gmsh.len(), "{f}");
    for (v, want) in gmsh.iter().enumerate() {
        let (lo, hi) = volume_bbox(m, v).unwrap();
        let got = [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z];
        for k in 0..6 {
            assert!(
                (got[k] - want[k] * scale).abs() < 0.01,
                "{f}: volume {v} {:?}: {got:?}, Gmsh {want:?} × {scale}",
                m.volumes[v].name
            );
        }
    }
}

/// Three more assemblies (a validation test model with mapped items in its
/// drawing, two Pro/ENGINEER exports) place their parts where Gmsh does; boxes obtained as for as1-oc-214
/// above. pyocc_as1_pe_203 is in inches, which Gmsh reports in millimetres.
#[test]
fn other_assemblies_are_placed_where_gmsh_puts_them() {
    #[rustfmt::skip]
    let trj3 = [
            [125.000, 25.000, 20.000, 175.000, 125.000, 80.000],
            [122.500, 54.510, -3.000, 142.500, 69.510, 0.000],
            [125.000, 54.510, -4.000, 140.000, 69.510, 33.000],
            [122.500, 80.490, -3.000, 142.500, 95.490, 0.000],
            [125.000, 80.490, -4.000, 140.000, 95.490, 33.000],
            [145.000, 67.500, -3.000, 165.000, 82.500, 0.000],
            [147.500, 67.500, -4.000, 162.500, 82.500, 33.000],
            [0.000, 0.000, 0.000, 180.000, 150.000, 20.000],
            [5.000, 25.000, 20.000, 55.000, 125.000, 80.000],
            [37.500, 80.490, -3.000, 57.500, 95.490, 0.000],
            [40.000, 80.490, -4.000, 55.000, 95.490, 33.000],
            [37.500, 54.510, -3.000, 57.500, 69.510, 0.000],
            [40.000, 54.510, -4.000, 55.000, 69.510, 33.000],
            [15.000, 67.500, -3.000, 35.000, 82.500, 0.000],
            [17.500, 67.500, -4.000, 32.500, 82.500, 33.000],
            [-10.000, 70.001, 55.000, 190.000, 79.999, 65.000],
            [2.000, 67.500, 50.000, 5.000, 82.500, 70.000],
            [175.000, 67.500, 50.000, 178.000, 82.500, 70.000],
    ];
    assert_gmsh_boxes("as_trj3_as1-tc-214.stp", &trj3, 1.0);
    #[rustfmt::skip]
    let mechanism = [
            [-70.000, -30.000, -25.000, 80.000, 0.000, 25.000],
            [-70.000, -8.000, -25.000, 0.000, 100.000, 25.000],
            [-85.000, 15.000, -15.000, 80.000, 45.000, 15.000],
    ];
    assert_gmsh_boxes("as_Mechanism_Example.stp", &mechanism, 1.0);
    #[rustfmt::skip]
    let pe203 = [
            [-3556.000, -508.000, -1905.000, 1016.000, 0.000, 1905.000],
            [-381.000, 0.000, -1270.000, 889.000, 1524.000, 1270.000],
            [190.500, -685.800, -190.500, 571.500, 330.200, 190.500],
            [190.500, -584.200, -254.000, 571.500, -508.000, 254.000],
            [-381.000, -685.800, 139.456, 0.000, 330.200, 520.456],
            [-381.000, -584.200, 75.956, 0.000, -508.000, 583.956],
            [-381.000, -685.800, -520.456, 0.000, 330.200, -139.456],
            [-381.000, -584.200, -583.956, 0.000, -508.000, -75.956],
            [-3429.000, 0.000, -1270.000, -2159.000, 1524.000, 1270.000],
            [-3111.500, -685.800, -190.500, -2730.500, 330.200, 190.500],
            [-3111.500, -584.200, -254.000, -2730.500, -508.000, 254.000],
            [-2540.000, -685.800, -520.456, -2159.000, 330.200, -139.456],
            [-2540.000, -584.200, -583.956, -2159.000, -508.000, -75.956],
            [-2540.000, -685.800, 139.456, -2159.000, 330.200, 520.456],
            [-2540.000, -584.200, 75.956, -2159.000, -508.000, 583.956],
            [-3810.000, 889.000, -127.000, 1270.000, 1143.000, 127.000],
            [-3505.200, 825.500, -254.000, -3429.000, 1206.500, 254.000],
            [889.000, 825.500, -254.000, 965.200, 1206.500, 254.000],
    ];
    assert_gmsh_boxes("pyocc_as1_pe_203.stp", &pe203, 1.0 / 25.4);
}

/// `../shared/realstep` beside the repository (as the developers and CI have
/// it), or `$BUBBLEMESH_REALSTEP`. Under CI the files must be there.
fn realstep_dir() -> String {
    let dir = std::env::var("BUBBLEMESH_REALSTEP").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/realstep").to_string()
    });
    if std::env::var_os("CI").is_some() && !std::path::Path::new(&dir).is_dir() {
        panic!("CI is set but the realstep files are not at {dir}");
    }
    dir
}

/// The length unit the contexts assign is read: inch files (Pro/E's
/// as1_pe_203, the joystick) are in inches, the others in millimetres or
/// metres, and every file of ../shared/realstep names one.
#[test]
fn length_units_of_realstep_files_are_read() {
    let dir = realstep_dir();
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!("skipped: {dir} not found");
        return;
    };
    let mut seen = Vec::new();
    for e in entries.flatten() {
        let path = e.path();
        let ext = path.extension().and_then(|x| x.to_str()).unwrap_or("");
        if !matches!(ext.to_ascii_lowercase().as_str(), "stp" | "step") {
            continue;
        }
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let m = match bubblemesh_truck::read_step(&path) {
            Ok(m) => m,
            Err(err) => panic!("{name}: {err}"),
        };
        let u = m
            .info
            .length_unit
            .unwrap_or_else(|| panic!("{name}: no length unit read"));
        seen.push(format!("{name}: {} {}", u.name, u.metres));
        if name == "pyocc_as1_pe_203.stp" {
            assert_eq!(u.name, "inch");
            assert!((u.metres - 0.0254).abs() < 1e-12);
        }
        if name == "pyocc_as1-oc-214.stp" {
            assert_eq!(u.name, "millimetre");
            assert!((u.metres - 1e-3).abs() < 1e-15);
        }
    }
    eprintln!("{}", seen.join("\n"));
    assert!(seen.len() >= 40, "{} files", seen.len());
}
