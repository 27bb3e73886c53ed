//! Engine tests on planar domains: each asserts the property the feature
//! exists for, so it fails when the feature breaks.

mod common;

use std::collections::{HashMap, HashSet};

use bubblemesh_core::bubbles::constraint::{Carrier, OnFace};
use bubblemesh_core::bubbles::population;
use bubblemesh_core::bubbles::system::{RelaxSettings, System};
use bubblemesh_core::engine::Options;
use bubblemesh_core::face::region::Region;
use bubblemesh_core::geom::{Plane, P3, V3};
use bubblemesh_core::spacing::{Constant, Expr};
use bubblemesh_core::{mesh_model, EntityRef, Mesh};

fn interior_valences(mesh: &Mesh) -> Vec<usize> {
    let mut edge_count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t.nodes[k], t.nodes[(k + 1) % 3]);
            *edge_count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut boundary = HashSet::new();
    let mut val = vec![0usize; mesh.nodes.len()];
    for (&(a, b), &c) in &edge_count {
        val[a as usize] += 1;
        val[b as usize] += 1;
        if c == 1 {
            boundary.insert(a);
            boundary.insert(b);
        }
    }
    (0..mesh.nodes.len() as u32)
        .filter(|i| !boundary.contains(i))
        .map(|i| val[i as usize])
        .collect()
}

/// Thesis Fig. 5.2: the regular hexagon of side 1 with d = 0.1 is the
/// perfect equilateral lattice.
#[test]
fn hexagon_is_the_perfect_lattice() {
    let (mesh, _) = mesh_model(&common::hexagon(), &Constant(0.1), &Options::default()).unwrap();
    assert_eq!(mesh.nodes.len(), 331);
    assert_eq!(mesh.triangles.len(), 600);
    let q = common::radius_ratios(&mesh);
    assert!(
        q.iter().all(|&q| q > 0.9995),
        "min q {}",
        q.iter().cloned().fold(1.0, f64::min)
    );
    let v = interior_valences(&mesh);
    assert_eq!(v.len(), 331 - 60);
    assert!(v.iter().all(|&v| v == 6));
}

/// The 2D benchmark cases A–C keep their quality and spacing (measured
/// values are in bench/; these bounds are a margin below them).
#[test]
fn benchmark_cases_keep_quality_and_spacing() {
    let cases = [
        (common::square(), "0.02", 0.99, 0.70),
        // the graded cases B and C at issue 2's targets (mean 0.99, min 0.80):
        // packed bubbles alone gave 0.9852 / 0.900 and 0.9823 / 0.818, the
        // conformal-lattice start (engine::conformal) 0.9930 / 0.887 and
        // 0.9928 / 0.894
        (
            common::square(),
            "0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)",
            0.99,
            0.80,
        ),
        (
            common::plate_two_holes(),
            "0.02 + 0.1*max(min(sqrt((x-0.5)^2+(y-0.5)^2), sqrt((x-1.5)^2+(y-0.5)^2)) - 0.2, 0)",
            0.99,
            0.80,
        ),
    ];
    for (model, expr, q_mean_min, q_min_min) in cases {
        let s = Expr::parse(expr).unwrap();
        let (mesh, _) = mesh_model(&model, &s, &Options::default()).unwrap();
        let q = common::radius_ratios(&mesh);
        let q_mean = q.iter().sum::<f64>() / q.len() as f64;
        let q_min = q.iter().cloned().fold(1.0, f64::min);
        let (band, mean) = common::spacing_conformance(&mesh, |p| s.eval(p));
        assert!(q_mean >= q_mean_min, "{expr}: mean q {q_mean}");
        assert!(q_min >= q_min_min, "{expr}: min q {q_min}");
        assert!(
            band >= 0.995,
            "{expr}: only {band} of edges within [1/√2, √2]"
        );
        assert!((mean - 1.0).abs() < 0.05, "{expr}: mean L/d {mean}");
    }
}

/// Case C's holes have a spacing proportional to the distance from their
/// centre (a flat metric in log-polar coordinates): the conformal lattice
/// puts rings of as many nodes as each hole has around it. Before its
/// columns followed the hole's nodes (`conformal::align_to_hole`) and the
/// flattening was exact (`conformal::newton`), a ring lost a node where the
/// layout closed: a hole node in only two triangles beside a seven-valent
/// node, and q 0.75 there.
#[test]
fn hole_rings_close_without_a_seam() {
    let model = common::plate_two_holes();
    let s = Expr::parse(
        "0.02 + 0.1*max(min(sqrt((x-0.5)^2+(y-0.5)^2), sqrt((x-1.5)^2+(y-0.5)^2)) - 0.2, 0)",
    )
    .unwrap();
    let (mesh, report) = mesh_model(&model, &s, &Options::default()).unwrap();
    let cones = report.faces[0]
        .lattice_cones
        .expect("the face is meshed from the lattice");
    assert!(cones.0 + cones.1 <= 10, "cones {cones:?}");
    let mut tris_at = vec![0usize; mesh.nodes.len()];
    for t in &mesh.triangles {
        for &v in &t.nodes {
            tris_at[v as usize] += 1;
        }
    }
    let mut on_holes = 0;
    for (i, n) in mesh.nodes.iter().enumerate() {
        let r = ((n.pos.x - 0.5).hypot(n.pos.y - 0.5)).min((n.pos.x - 1.5).hypot(n.pos.y - 0.5));
        if (r - 0.2).abs() < 1e-9 {
            on_holes += 1;
            assert!(
                tris_at[i] >= 3,
                "hole node at ({}, {}) is in {} triangles",
                n.pos.x,
                n.pos.y,
                tris_at[i]
            );
        }
    }
    assert!(on_holes > 100, "{on_holes} nodes on the holes");
}

/// Stage 2 improves on stage 1 (thesis Fig. 5.3).
#[test]
fn stage_two_improves_stage_one() {
    let s = Expr::parse("0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)").unwrap();
    let fast = Options {
        fast: true,
        ..Default::default()
    };
    let (m1, _) = mesh_model(&common::square(), &s, &fast).unwrap();
    let (m2, _) = mesh_model(&common::square(), &s, &Options::default()).unwrap();
    let mean = |m: &Mesh| {
        let q = common::radius_ratios(m);
        q.iter().sum::<f64>() / q.len() as f64
    };
    let minq = |m: &Mesh| common::radius_ratios(m).into_iter().fold(1.0, f64::min);
    assert!(
        mean(&m2) > mean(&m1) + 0.01,
        "{} vs {}",
        mean(&m2),
        mean(&m1)
    );
    assert!(
        minq(&m2) > minq(&m1) + 0.2,
        "{} vs {}",
        minq(&m2),
        minq(&m1)
    );
}

/// Stage 2 on several threads gives the single-threaded mesh bit for bit:
/// every force is taken at the start of a step (eq. 4.4.6) and each move
/// depends on its own bubble alone, so the order of work cannot matter.
#[test]
fn parallel_stage_two_equals_serial() {
    let s = Expr::parse("0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)").unwrap();
    let mut par = Options::default();
    par.relax.parallel = true;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    let (serial, _) = mesh_model(&common::square(), &s, &Options::default()).unwrap();
    let (parallel, _) = pool
        .install(|| mesh_model(&common::square(), &s, &par))
        .unwrap();
    assert_eq!(serial.nodes.len(), parallel.nodes.len());
    for (a, b) in serial.nodes.iter().zip(&parallel.nodes) {
        assert_eq!(a.pos, b.pos);
    }
    let tris = |m: &Mesh| m.triangles.iter().map(|t| t.nodes).collect::<Vec<_>>();
    assert_eq!(tris(&serial), tris(&parallel));
}

/// Edge bubbles stay on their curve (eq. 4.5.1): every node of the holes'
/// circles is on the circle to rounding.
#[test]
fn edge_bubbles_stay_on_their_curve() {
    let s = Expr::parse("0.02 + 0.05*x").unwrap();
    let (mesh, _) = mesh_model(&common::plate_two_holes(), &s, &Options::default()).unwrap();
    let mut on_circles = 0;
    for n in &mesh.nodes {
        if n.entity.dim == 1 && (n.entity.id == 4 || n.entity.id == 5) {
            let c = if n.entity.id == 4 {
                (0.5, 0.5)
            } else {
                (1.5, 0.5)
            };
            let r = ((n.pos.x - c.0).powi(2) + (n.pos.y - c.1).powi(2)).sqrt();
            assert!((r - 0.2).abs() < 1e-12, "node at radius {r}");
            on_circles += 1;
        }
    }
    assert!(on_circles > 30, "{on_circles} nodes on the circles");
}

/// Every node and element records the entity it came from, and the
/// boundary of each face is made of its edges' lines.
#[test]
fn nodes_and_elements_record_their_entities() {
    let (mesh, _) = mesh_model(
        &common::plate_two_holes(),
        &Constant(0.05),
        &Options::default(),
    )
    .unwrap();
    assert!(mesh
        .triangles
        .iter()
        .all(|t| t.entity == EntityRef::new(2, 0)));
    let mut edge_count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t.nodes[k], t.nodes[(k + 1) % 3]);
            *edge_count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let lines: HashSet<(u32, u32)> = mesh
        .lines
        .iter()
        .map(|l| (l.nodes[0].min(l.nodes[1]), l.nodes[0].max(l.nodes[1])))
        .collect();
    let boundary: HashSet<(u32, u32)> = edge_count
        .iter()
        .filter(|(_, &c)| c == 1)
        .map(|(e, _)| *e)
        .collect();
    assert_eq!(
        boundary, lines,
        "the triangles' boundary must be exactly the edge mesh"
    );
    // the mesh covers the plate minus the holes
    let area: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
            0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).z
        })
        .sum();
    let exact = 2.0 - 2.0 * std::f64::consts::PI * 0.04;
    assert!((area - exact).abs() < 0.01, "area {area} vs {exact}");
    assert!(mesh.triangles.iter().all(|t| {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
        (p[1] - p[0]).cross(&(p[2] - p[0])).z > 0.0
    }));
}

fn square_system<'a>(spacing: &'a Constant) -> System<'a, OnFace<'static>> {
    // boundary of the unit square at spacing d, as fixed bubbles
    let d = spacing.0;
    let n = (1.0 / d).round() as usize;
    let mut boundary = Vec::new();
    for k in 0..n {
        boundary.push([k as f64 / n as f64, 0.0]);
    }
    for k in 0..n {
        boundary.push([1.0, k as f64 / n as f64]);
    }
    for k in 0..n {
        boundary.push([1.0 - k as f64 / n as f64, 1.0]);
    }
    for k in 0..n {
        boundary.push([0.0, 1.0 - k as f64 / n as f64]);
    }
    let plane: &'static Plane = Box::leak(Box::new(Plane::xy()));
    let carrier = OnFace::new(
        plane,
        Region::new(&[boundary.clone()]),
        EntityRef::new(2, 0),
    );
    let nf = boundary.len();
    System {
        carrier,
        spacing,
        dim: 2,
        n_fixed: nf,
        pos: boundary.iter().map(|p| P3::new(p[0], p[1], 0.0)).collect(),
        params: boundary,
        vel: vec![V3::zeros(); nf],
        d: vec![d; nf],
        fixed_ids: (0..nf as u32).collect(),
        pressure: 1.0,
    }
}

fn hex_fill(sys: &mut System<'_, OnFace<'static>>, d: f64, skip: impl Fn(f64, f64) -> bool) {
    let h = d * 3f64.sqrt() / 2.0;
    let mut j = 1;
    while j as f64 * h < 1.0 - 0.5 * d {
        let y = j as f64 * h;
        let off = if j % 2 == 1 { 0.5 * d } else { 0.0 };
        let mut i = 1;
        while off + i as f64 * d < 1.0 - 0.5 * d {
            let x = off + i as f64 * d;
            if !skip(x, y) {
                sys.push_free(P3::new(x, y, 0.0), [x, y], d);
            }
            i += 1;
        }
        j += 1;
    }
}

/// Population control (§4.7) fills a hole: a lattice with a missing patch
/// gets bubbles back where the patch was.
#[test]
fn population_control_fills_a_gap() {
    let s = Constant(0.05);
    let mut sys = square_system(&s);
    let hole = |x: f64, y: f64| (x - 0.5).powi(2) + (y - 0.5).powi(2) < 0.12f64.powi(2);
    hex_fill(&mut sys, 0.05, hole);
    let count_in_hole = |sys: &System<'_, OnFace<'static>>| {
        (sys.n_fixed..sys.n())
            .filter(|&i| hole(sys.pos[i].x, sys.pos[i].y))
            .count()
    };
    assert_eq!(count_in_hole(&sys), 0);
    let stats = sys.relax(&RelaxSettings::default(), |_, _, _| {}).unwrap();
    assert!(stats.added >= 10, "added {}", stats.added);
    // the hole's area holds about 0.12²π / (√3/2 · 0.05²) ≈ 21 bubbles
    let back = count_in_hole(&sys);
    assert!(back >= 15, "only {back} bubbles back in the hole");
}

/// Population control deletes an overlapping bubble: a duplicate placed
/// at 0.1 d from a lattice bubble is removed.
#[test]
fn population_control_removes_an_overlap() {
    let s = Constant(0.05);
    let mut sys = square_system(&s);
    hex_fill(&mut sys, 0.05, |_, _| false);
    let before = sys.n();
    let p = sys.pos[sys.n() / 2];
    sys.push_free(p + V3::new(0.005, 0.0, 0.0), [p.x + 0.005, p.y], 0.05);
    let grid = sys.grid();
    let mut pairs = Vec::new();
    sys.pairs(&grid, &mut pairs, None);
    let (deleted, added) = population::control(&mut sys, &pairs, &grid, None).unwrap();
    assert_eq!((deleted, added), (1, 0));
    assert_eq!(sys.n(), before);
}

/// A spacing that is zero, negative or NaN somewhere is reported with the
/// place, not meshed.
#[test]
fn bad_spacing_is_reported() {
    for expr in ["x - 0.5", "0*x", "sqrt(x - 2)"] {
        let s = Expr::parse(expr).unwrap();
        let err = mesh_model(&common::square(), &s, &Options::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("spacing"), "{expr}: {err}");
    }
}

/// Bubbles moved by the first fundamental form stay on the face and inside
/// its region.
#[test]
fn face_bubbles_stay_inside_the_region() {
    let s = Constant(0.05);
    let mut sys = square_system(&s);
    hex_fill(&mut sys, 0.05, |_, _| false);
    // kick every bubble toward the outside
    for i in sys.n_fixed..sys.n() {
        sys.vel[i] = V3::new(sys.pos[i].x - 0.5, sys.pos[i].y - 0.5, 0.0) * 2.0;
    }
    sys.relax(&RelaxSettings::default(), |_, _, _| {}).unwrap();
    for i in sys.n_fixed..sys.n() {
        assert!(sys.carrier.contains(sys.params[i]));
        assert_eq!(sys.pos[i].z, 0.0);
    }
}

/// Lattice growth on a plane with a uniform spacing lays one perfect
/// hexagonal crystal: every grown bubble's nearest neighbour is at exactly
/// d, every bubble a spacing inside the square has six neighbours at d, and
/// no point of the square (a spacing inside) is farther than d/√3 (the
/// hexagonal lattice's covering radius) from a bubble — so stage 2 starts
/// without holes and without defects.
#[test]
fn growth_on_a_plane_is_one_hexagonal_crystal() {
    use bubblemesh_core::face::growth;
    use bubblemesh_core::face::placement::Seed;
    let d = 0.05;
    let plane = Plane::xy();
    let square = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let carrier = OnFace::new(&plane, Region::new(&[square]), EntityRef::new(2, 0));
    let start = Seed {
        pos: P3::new(0.5, 0.5, 0.0),
        params: [0.5, 0.5],
        d,
    };
    let mut d_at = |_: &P3, _: [f64; 2]| Ok(d);
    let grown = growth::grow(&carrier, &start, &[], &mut d_at).unwrap();
    // the hexagonal lattice's density: 2/(√3 d²) per unit area
    let expect = 2.0 / (3f64.sqrt() * d * d);
    assert!(
        (grown.len() as f64 - expect).abs() < 0.1 * expect,
        "{} bubbles, {expect:.0} expected",
        grown.len()
    );
    let inner = |p: &P3| (d..=1.0 - d).contains(&p.x) && (d..=1.0 - d).contains(&p.y);
    for (i, s) in grown.iter().enumerate() {
        let mut nearest = f64::INFINITY;
        let mut at_d = 0;
        for (j, t) in grown.iter().enumerate() {
            if i != j {
                let r = (s.pos - t.pos).norm();
                nearest = nearest.min(r);
                if (r - d).abs() < 1e-9 {
                    at_d += 1;
                }
            }
        }
        assert!((nearest - d).abs() < 1e-9, "bubble {i}: nearest {nearest}");
        if inner(&s.pos) {
            assert_eq!(at_d, 6, "bubble {i} at {:?}", s.pos);
        }
    }
    for k in 0..=40 {
        for l in 0..=40 {
            let p = P3::new(k as f64 / 40.0, l as f64 / 40.0, 0.0);
            if inner(&p) {
                let gap = grown
                    .iter()
                    .map(|s| (s.pos - p).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(gap <= d / 3f64.sqrt() + 1e-9, "gap {gap} at {p:?}");
            }
        }
    }
}
