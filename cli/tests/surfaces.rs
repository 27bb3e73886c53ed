//! Curved faces end to end: sphere (poles), torus (two seams), cylinder
//! (a hole across its seam), cone (apex), trimmed NURBS patch with a hole.
//! Each mesh is read back and checked for what a user relies on: a valid,
//! consistently oriented surface with the right boundary, nodes on the
//! surface, the right area, and the requested spacing.

use std::collections::HashMap;

use bubblemesh_core::{Mesh, P3};

mod support;

const TAU: f64 = std::f64::consts::TAU;

fn mesh_example(name: &str, size: &str) -> Mesh {
    mesh_example_with(name, size, &[])
}

fn mesh_example_with(name: &str, size: &str, extra: &[&str]) -> Mesh {
    let dir = tempfile::tempdir().unwrap();
    let o = support::mesh_in(dir.path(), &support::example(name), size, extra);
    assert!(o.status.success(), "{name}: {}", support::stderr(&o));
    bubblemesh_io::read(&dir.path().join("m.msh")).unwrap()
}

struct Checked {
    boundary_loops: usize,
    area: f64,
    band: f64,
}

/// Validity checks common to every surface mesh; returns the numbers the
/// callers compare with the exact geometry.
fn check(mesh: &Mesh, d: f64) -> Checked {
    assert!(!mesh.triangles.is_empty());
    // directed edge uses: an interior edge is used once in each direction
    let mut uses: HashMap<(u32, u32), i32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t.nodes[k], t.nodes[(k + 1) % 3]);
            assert_ne!(a, b, "degenerate triangle");
            *uses.entry((a, b)).or_default() += 1;
        }
    }
    let mut boundary: Vec<(u32, u32)> = Vec::new();
    for (&(a, b), &c) in &uses {
        assert_eq!(
            c, 1,
            "edge ({a},{b}) used twice in one direction: inconsistent orientation or a fold"
        );
        if !uses.contains_key(&(b, a)) {
            boundary.push((a, b));
        }
    }
    // boundary loops (each boundary vertex starts exactly one boundary edge)
    let next: HashMap<u32, u32> = boundary.iter().cloned().collect();
    assert_eq!(next.len(), boundary.len(), "a boundary vertex is pinched");
    let mut seen = std::collections::HashSet::new();
    let mut loops = 0;
    for &(a, _) in &boundary {
        if seen.contains(&a) {
            continue;
        }
        loops += 1;
        let mut v = a;
        while seen.insert(v) {
            v = next[&v];
        }
    }
    // every node used, none duplicated
    let mut used = vec![false; mesh.nodes.len()];
    for t in &mesh.triangles {
        for &v in &t.nodes {
            used[v as usize] = true;
        }
    }
    assert!(used.iter().all(|&u| u), "unreferenced node");
    let mut pts: Vec<P3> = mesh.nodes.iter().map(|n| n.pos).collect();
    pts.sort_by(|a, b| a.x.total_cmp(&b.x));
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            if pts[j].x - pts[i].x > 0.2 * d {
                break;
            }
            assert!(
                (pts[j] - pts[i]).norm() > 0.2 * d,
                "nodes closer than 0.2 d at {:?}",
                pts[i]
            );
        }
    }
    let area = mesh
        .triangles
        .iter()
        .map(|t| {
            let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
            0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm()
        })
        .sum();
    let mut edges: Vec<(u32, u32)> = uses.keys().map(|&(a, b)| (a.min(b), a.max(b))).collect();
    edges.sort_unstable();
    edges.dedup();
    let inside = edges
        .iter()
        .filter(|(a, b)| {
            let r = (mesh.nodes[*a as usize].pos - mesh.nodes[*b as usize].pos).norm() / d;
            (std::f64::consts::FRAC_1_SQRT_2..=std::f64::consts::SQRT_2).contains(&r)
        })
        .count();
    Checked {
        boundary_loops: loops,
        area,
        band: inside as f64 / edges.len() as f64,
    }
}

fn radius_ratios(mesh: &Mesh) -> Vec<f64> {
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
            let (a, b, c) = (
                (p[1] - p[2]).norm(),
                (p[0] - p[2]).norm(),
                (p[0] - p[1]).norm(),
            );
            (b + c - a) * (c + a - b) * (a + b - c) / (a * b * c)
        })
        .collect()
}

fn radius_ratio_mean(mesh: &Mesh) -> f64 {
    let q = radius_ratios(mesh);
    q.iter().sum::<f64>() / q.len() as f64
}

/// The sphere is closed through its poles, its nodes are on it, and it is
/// not slivered along the seam (checked by the mean quality).
#[test]
fn sphere_is_closed_through_its_poles() {
    let d = 0.1;
    let m = mesh_example("sphere.toml", "0.1");
    let c = check(&m, d);
    assert_eq!(c.boundary_loops, 0);
    for n in &m.nodes {
        assert!((n.pos.coords.norm() - 1.0).abs() < 1e-9);
    }
    // both poles are covered: nodes within a spacing of each
    for z in [1.0, -1.0] {
        assert!(m
            .nodes
            .iter()
            .any(|n| (n.pos - P3::new(0.0, 0.0, z)).norm() < d));
    }
    let exact = 2.0 * TAU;
    assert!((c.area - exact).abs() / exact < 0.01, "area {}", c.area);
    assert!(c.band > 0.99, "band {}", c.band);
    assert!(radius_ratio_mean(&m) > 0.95);
}

/// Case F of meshkit (sphere r = 1, d = 0.05) reaches issue 3's quality:
/// mean radius ratio ≥ 0.99, minimum ≥ 0.85, edges in the spacing band.
/// Regression for stage 1 on curved faces: from the (u,v) quadtree the
/// packing froze into small crystals (494 five- and 476 seven-valent nodes)
/// and gave 0.982 / 0.849; the grown lattice (`engine::growth`) gives about
/// 0.992 / 0.90.
/// Issue 3's surface quality target: mean radius ratio ≥ 0.99, minimum
/// ≥ 0.85.
fn assert_issue_3_quality(m: &Mesh) {
    let q = radius_ratios(m);
    let mean = q.iter().sum::<f64>() / q.len() as f64;
    let min = q.iter().cloned().fold(1.0, f64::min);
    assert!(
        mean >= 0.99 && min >= 0.85,
        "q mean {mean:.4}, min {min:.4}"
    );
}

#[test]
fn sphere_at_case_f_spacing_reaches_the_quality_target() {
    let d = 0.05;
    let m = mesh_example("sphere.toml", "0.05");
    let c = check(&m, d);
    assert_eq!(c.boundary_loops, 0);
    assert!(c.band >= 0.995, "band {}", c.band);
    assert_issue_3_quality(&m);
}

/// A uniformly spaced face of a surface mesh relaxes with steps twice as
/// long (`RelaxSettings::long_steps`) and half as many of them, and still
/// reaches case F's quality: the sphere ran all 600 steps with the short
/// step (0.9933 / 0.900 in 1.17 s), and reaches 0.9934 / 0.900 in 300 of
/// the long ones (0.69 s). The graded square (case B) keeps the short step.
#[test]
fn a_uniform_surface_settles_in_half_the_steps_each_twice_as_long() {
    let dir = tempfile::tempdir().unwrap();
    let rep = dir.path().join("r.json");
    let run = |input: &str, size: &str| {
        let o = support::mesh_in(
            dir.path(),
            &support::example(input),
            size,
            &["--report", rep.to_str().unwrap()],
        );
        assert!(o.status.success(), "{}", support::stderr(&o));
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&rep).unwrap()).unwrap();
        let relax = r["engine"]["faces"][0]["relax"].clone();
        (
            bubblemesh_io::read(&dir.path().join("m.msh")).unwrap(),
            relax,
        )
    };
    let (m, long) = run("sphere.toml", "0.05");
    assert!(
        long["steps"].as_u64().unwrap() <= 300,
        "{} steps",
        long["steps"]
    );
    check(&m, 0.05);
    assert_issue_3_quality(&m);
    let (_, short) = run("square.toml", "0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)");
    let (h_long, h_short) = (
        long["time_step"].as_f64().unwrap(),
        short["time_step"].as_f64().unwrap(),
    );
    // the sphere's bubbles are surface bubbles like the square's: the same
    // equivalent stiffness (eq. 4.3.4), so the same short step
    assert!(
        (h_long / h_short - 2.0).abs() < 1e-12,
        "time steps {h_long} and {h_short}"
    );
}

#[test]
fn torus_is_closed_across_both_seams() {
    let d = 0.06;
    let m = mesh_example("torus.toml", "0.06");
    let c = check(&m, d);
    assert_eq!(c.boundary_loops, 0);
    let exact = TAU * TAU * 0.3;
    assert!((c.area - exact).abs() / exact < 0.01, "area {}", c.area);
    assert!(c.band > 0.99, "band {}", c.band);
    assert!(radius_ratio_mean(&m) > 0.95);
}

/// Stage 1 alone (`--fast`) on the sphere (periodic in u, two poles):
/// closed, valid meshes. Regression: the oblique quadtree's root starts
/// left of the parameter box, so seeds came one period off (u < 0) and the
/// seam's copies in the connection overlapped: "constraint segments cross"
/// at every size. (Still failing: `--fast` on the torus at some sizes,
/// where quadtree leaves of two levels meet at the v seam and leave gaps
/// of two spacings that only stage 2 fills.)
#[test]
fn fast_mode_meshes_the_sphere() {
    for (name, d, exact) in [
        ("sphere.toml", 0.1, 2.0 * TAU),
        ("sphere.toml", 0.05, 2.0 * TAU),
    ] {
        let m = mesh_example_with(name, &d.to_string(), &["--fast"]);
        let c = check(&m, d);
        assert_eq!(c.boundary_loops, 0, "{name} at {d}");
        // stage 1 alone is coarser in quality, not in coverage: the chord
        // error of size d on radius 1 (sphere) or 0.3 (torus) stays small
        assert!(
            (c.area - exact).abs() / exact < 0.05,
            "{name} at {d}: area {}",
            c.area
        );
    }
}

/// The hole straddles the cylinder's seam: three boundary loops, and no
/// seam line (no node row at u = 0 needed, checked through quality).
#[test]
fn cylinder_with_a_hole_across_its_seam() {
    let d = 0.05;
    let m = mesh_example("cylinder.toml", "0.05");
    let c = check(&m, d);
    assert_eq!(c.boundary_loops, 3);
    for n in &m.nodes {
        assert!((n.pos.x.hypot(n.pos.y) - 0.5).abs() < 1e-9);
    }
    let exact = TAU * 0.5 - 0.8 * 0.5 * 0.2;
    assert!((c.area - exact).abs() / exact < 0.01, "area {}", c.area);
    assert!(c.band > 0.99, "band {}", c.band);
    assert!(radius_ratio_mean(&m) > 0.97);
}

/// The cone's apex neither traps nor repels bubbles: the tip is meshed.
#[test]
fn cone_is_meshed_through_its_apex() {
    let d = 0.05;
    let m = mesh_example("cone.toml", "0.05");
    let c = check(&m, d);
    assert_eq!(c.boundary_loops, 1);
    let apex = P3::new(0.0, 0.0, 1.0);
    assert!(
        m.nodes.iter().any(|n| (n.pos - apex).norm() < 1e-9),
        "no node at the apex"
    );
    // lateral area π r s with s = 1.2, r = s sin 30°
    let exact = std::f64::consts::PI * 0.6 * 1.2;
    assert!((c.area - exact).abs() / exact < 0.01, "area {}", c.area);
    assert!(c.band > 0.98, "band {}", c.band);
}

#[test]
fn trimmed_nurbs_patch_with_a_hole() {
    let d = 0.05;
    let m = mesh_example("nurbs_patch.toml", "0.05");
    let c = check(&m, d);
    assert_eq!(c.boundary_loops, 2);
    assert!(c.band > 0.99, "band {}", c.band);
    assert!(radius_ratio_mean(&m) > 0.97);
}

/// Meshes a one-surface domain file with `--size 1` and returns the mesh
/// and the run's report.
fn mesh_domain_with_report(surface: &str) -> (Mesh, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("domain.toml");
    std::fs::write(
        &input,
        format!("format = \"bubblemesh-domain 1\"\n[[surface]]\n{surface}\n"),
    )
    .unwrap();
    let report = dir.path().join("r.json");
    let o = support::mesh_in(
        dir.path(),
        &input,
        "1",
        &["--report", report.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", support::stderr(&o));
    let r = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    (bubblemesh_io::read(&dir.path().join("m.msh")).unwrap(), r)
}

/// A tube eight times longer than its diameter, meshed at twice its
/// radius: the circles at its ends take seven nodes per turn
/// (`--circle-points`), and so must its middle, four spacings from them,
/// where the spacing graded from the circles is back to the size asked
/// (three nodes per turn: a triangular prism for a tube). The face is
/// named in the report as meshed finer than asked.
#[test]
fn the_middle_of_a_long_tube_keeps_seven_nodes_per_turn() {
    let (m, r) = mesh_domain_with_report(
        "name = \"tube\"\ncylinder = { origin = [0, 0, 0], axis = [0, 0, 1], radius = 0.5, height = 8 }",
    );
    check(&m, 1.0);
    // every edge in the middle spans at most a sixth of a turn
    let angle = |p: &P3| p.y.atan2(p.x);
    let mut middle = 0;
    for t in &m.triangles {
        let q = t.nodes.map(|i| m.nodes[i as usize].pos);
        if q.iter().all(|p| (3.0..5.0).contains(&p.z)) {
            middle += 1;
            for k in 0..3 {
                let mut a = (angle(&q[k]) - angle(&q[(k + 1) % 3])).abs();
                a = a.min(TAU - a);
                assert!(
                    a < TAU / 6.0,
                    "an edge spans {:.0}° of the tube's turn",
                    a.to_degrees()
                );
            }
        }
    }
    assert!(middle > 20, "{middle} triangles in the middle");
    let capped = &r["engine"]["circle_points"]["capped_faces"];
    assert_eq!(capped.as_array().map(Vec::len), Some(1), "report: {capped}");
}

/// The same tube as a wire, its radius a tenth of the spacing (2πρ/7 below
/// d/6): seven nodes per turn along its whole length would be some 600
/// bubbles for a feature the spacing does not resolve, so only its end
/// circles are capped (`FACE_CAP_FLOOR`); and a tube one spacing long
/// (shorter than `FACE_CAP_MIN_LENGTH`) is graded by its circles alone.
#[test]
fn wires_and_short_tubes_are_capped_by_their_circles_only() {
    // a tube of the given radius and height at size 1: its mesh and the
    // report's circle-point section, asserting that no face was capped
    let uncapped = |radius: f64, height: f64| {
        let (m, r) = mesh_domain_with_report(&format!(
            "name = \"tube\"\ncylinder = {{ origin = [0, 0, 0], axis = [0, 0, 1], \
             radius = {radius}, height = {height} }}"
        ));
        let cp = r["engine"]["circle_points"].clone();
        assert!(
            cp["capped_faces"].is_null(),
            "r = {radius}, h = {height}: {cp}"
        );
        (m, cp)
    };
    let (wire, cp) = uncapped(0.1, 8.0);
    assert_eq!(cp["edges"].as_array().map(Vec::len), Some(2), "{cp}");
    assert!(
        wire.nodes.len() < 450,
        "{} nodes on the wire",
        wire.nodes.len()
    );
    let (ring, _) = uncapped(0.5, 1.0);
    check(&ring, 1.0);
}
