//! Volume meshing (thesis §4.1.3, §4.3.3, §5.1.4) end to end on the domain
//! format's solids: every mesh must be valid (no inverted or flat
//! tetrahedron, the tetrahedra's boundary exactly the faces' triangles,
//! the tetrahedra's volume equal to the boundary's enclosed volume) and of
//! the quality and spacing the method exists for.

use std::collections::HashMap;

use bubblemesh_analytic::parse_domain;
use bubblemesh_core::engine::VolumeLattice;
use bubblemesh_core::measure::tet_radius_ratio as radius_ratio;
use bubblemesh_core::quality::analyse;
use bubblemesh_core::spacing::{Constant, Expr};
use bubblemesh_core::{mesh_model, Mesh, Options, Spacing};

const CUBE: &str = r#"
format = "bubblemesh-domain 1"
[[solid]]
name = "cube"
box = { min = [0, 0, 0], max = [1, 1, 1] }
"#;

const BALL: &str = r#"
format = "bubblemesh-domain 1"
[[solid]]
ball = { center = [0, 0, 0], radius = 1 }
"#;

fn mesh3(text: &str, spacing: &dyn Spacing) -> Mesh {
    mesh3_with(text, spacing, VolumeLattice::Auto)
}

fn mesh3_with(text: &str, spacing: &dyn Spacing, lattice: VolumeLattice) -> Mesh {
    let model = parse_domain(text, "test.toml").expect("domain");
    let opts = Options {
        dim: Some(3),
        volume_lattice: lattice,
        ..Default::default()
    };
    mesh_model(&model, spacing, &opts).expect("volume mesh").0
}

fn signed_volume6(m: &Mesh, t: &[u32; 4]) -> f64 {
    let [a, b, c, d] = t.map(|k| m.nodes[k as usize].pos);
    (b - a).dot(&(c - a).cross(&(d - a)))
}

/// Validity: positive tets, conformity with the boundary triangles, equal
/// volumes. Returns the tets' volume.
fn check_valid(m: &Mesh) -> f64 {
    assert!(!m.tetrahedra.is_empty());
    // faces of tets: interior ones twice (opposite orientation), boundary
    // ones once, and those are exactly the triangles, with the same
    // orientation (outward)
    let mut faces: HashMap<[u32; 3], Vec<[u32; 3]>> = HashMap::new();
    let mut vol = 0.0;
    for t in &m.tetrahedra {
        let v6 = signed_volume6(m, &t.nodes);
        assert!(v6 > 0.0, "inverted or flat tetrahedron {:?}", t.nodes);
        vol += v6 / 6.0;
        let n = t.nodes;
        for f in [
            [n[1], n[2], n[3]],
            [n[0], n[3], n[2]],
            [n[0], n[1], n[3]],
            [n[0], n[2], n[1]],
        ] {
            let mut k = f;
            k.sort_unstable();
            faces.entry(k).or_default().push(f);
        }
    }
    let mut boundary: HashMap<[u32; 3], [u32; 3]> = HashMap::new();
    let mut enclosed = 0.0;
    for t in &m.triangles {
        let mut k = t.nodes;
        k.sort_unstable();
        boundary.insert(k, t.nodes);
        let [a, b, c] = t.nodes.map(|i| m.nodes[i as usize].pos.coords);
        enclosed += a.dot(&b.cross(&c)) / 6.0;
    }
    for (k, fs) in &faces {
        match fs.len() {
            1 => {
                let tri = boundary.get(k).unwrap_or_else(|| {
                    panic!("tet face {k:?} on the hull is not a boundary triangle")
                });
                // same cyclic order: the tet's outward face = the triangle
                let f = fs[0];
                let rot =
                    |x: [u32; 3]| [[x[0], x[1], x[2]], [x[1], x[2], x[0]], [x[2], x[0], x[1]]];
                assert!(
                    rot(f).contains(tri),
                    "boundary triangle {tri:?} is not outward"
                );
            }
            2 => assert!(
                !boundary.contains_key(k),
                "boundary triangle {k:?} inside the volume"
            ),
            n => panic!("face {k:?} shared by {n} tetrahedra"),
        }
    }
    for k in boundary.keys() {
        assert!(
            faces.contains_key(k),
            "boundary triangle {k:?} is not a tet face"
        );
    }
    assert!(
        ((vol - enclosed) / enclosed).abs() < 1e-9,
        "tets {vol} vs enclosed {enclosed}"
    );
    // every tet node is referenced and interior nodes are tagged with the volume
    for t in &m.tetrahedra {
        assert_eq!(t.entity.dim, 3);
    }
    vol
}

#[test]
fn cube_uniform_is_valid_sliver_free_and_follows_the_spacing() {
    let s = Constant(0.1);
    let m = mesh3(CUBE, &s);
    let vol = check_valid(&m);
    assert!((vol - 1.0).abs() < 1e-9, "a box is meshed exactly: {vol}");
    let r = analyse(&m, Some(&s));
    let t = r.tets.expect("tets");
    assert_eq!(t.inverted, 0);
    // 0.551 / 0.910 measured (at d = 0.1 the BCC start is given up for
    // FCC: 4.9 % of its tetrahedra are poor; the volume-quality bounds are
    // ≥ 0.90 / 0.45, [25°, 140°])
    assert!(t.q_min > 0.5, "min radius ratio {}", t.q_min);
    assert!(t.q_mean > 0.90, "mean radius ratio {}", t.q_mean);
    assert!(t.dihedral_min > 25.0, "min dihedral {}", t.dihedral_min);
    assert!(t.dihedral_max < 140.0, "max dihedral {}", t.dihedral_max);
    let sp = r.spacing.expect("spacing");
    assert!(
        sp.frac_within_sqrt2 > 0.95,
        "L/d band {}",
        sp.frac_within_sqrt2
    );
    assert!(
        (sp.ratio_mean - 1.0).abs() < 0.08,
        "mean L/d {}",
        sp.ratio_mean
    );
}

#[test]
fn ball_volume_matches_its_boundary_and_the_true_volume_to_chord_error() {
    let s = Constant(0.2);
    let m = mesh3(BALL, &s);
    let vol = check_valid(&m);
    let exact = 4.0 / 3.0 * std::f64::consts::PI;
    // an inscribed polyhedron with edges ~0.2 on r = 1 loses about
    // 3·(chord sagitta ≈ d²/(8·3^0.5·r)...) of the volume: a few percent
    assert!(vol < exact && vol > 0.95 * exact, "{vol} vs {exact}");
    let t = analyse(&m, Some(&s)).tets.expect("tets");
    // 0.550 / 0.909 measured
    assert!(t.q_min > 0.5, "min radius ratio {}", t.q_min);
    assert!(t.q_mean > 0.895, "mean radius ratio {}", t.q_mean);
}

#[test]
fn graded_cube_follows_the_spacing() {
    let s = Expr::parse("0.06 + 0.12*x").expect("expr");
    let m = mesh3(CUBE, &s);
    check_valid(&m);
    let r = analyse(&m, Some(&s));
    let sp = r.spacing.expect("spacing");
    assert!(
        sp.frac_within_sqrt2 > 0.93,
        "L/d band {}",
        sp.frac_within_sqrt2
    );
    assert!(
        (sp.ratio_mean - 1.0).abs() < 0.1,
        "mean L/d {}",
        sp.ratio_mean
    );
    // graded: many more nodes near x = 0 than near x = 1
    let left = m.nodes.iter().filter(|n| n.pos.x < 0.25).count();
    let right = m.nodes.iter().filter(|n| n.pos.x > 0.75).count();
    assert!(left > 3 * right, "left {left} right {right}");
    // 0.550 / 0.894 measured
    let t = r.tets.expect("tets");
    assert!(t.q_min > 0.5, "min radius ratio {}", t.q_min);
    assert!(t.q_mean > 0.885, "mean radius ratio {}", t.q_mean);
}

/// Radius ratio of every tetrahedron (the engine's own measure).
fn radius_ratios(m: &Mesh) -> Vec<f64> {
    m.tetrahedra
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.nodes.map(|k| m.nodes[k as usize].pos);
            radius_ratio(&a, &b, &c, &d)
        })
        .collect()
}

/// A uniform spacing starts volumes from a body-centred cubic lattice
/// (engine::volume): away from the boundary every tetrahedron is the BCC
/// one (radius ratio 3/√10 = 0.9487), and the mean beats the thesis's FCC
/// path on the same cube, which stays available and valid (at d = 0.05:
/// 0.925 against 0.913; at d = 0.07 and coarser, 2 % or more of BCC's
/// tetrahedra next to the boundary are poor and the engine falls back to
/// FCC, see volume::BCC_MAX_BAD).
#[test]
fn uniform_cube_is_bcc_inside_and_beats_the_fcc_path() {
    let s = Constant(0.05);
    let bcc = mesh3(CUBE, &s);
    check_valid(&bcc);
    let qb = radius_ratios(&bcc);
    let regular = qb
        .iter()
        .filter(|&&q| (q - 3.0 / 10f64.sqrt()).abs() < 1e-3)
        .count();
    let inside: usize = bcc
        .tetrahedra
        .iter()
        .filter(|t| {
            t.nodes.iter().all(|&k| {
                let p = bcc.nodes[k as usize].pos;
                (0..3).all(|i| p[i] > 0.25 && p[i] < 0.75)
            })
        })
        .count();
    assert!(
        regular as f64 > 0.9 * inside as f64,
        "{regular} BCC tetrahedra, {inside} in the middle of the cube"
    );
    let fcc = mesh3_with(CUBE, &s, VolumeLattice::Fcc);
    check_valid(&fcc);
    let qf = radius_ratios(&fcc);
    let mean = |q: &[f64]| q.iter().sum::<f64>() / q.len() as f64;
    let min = |q: &[f64]| q.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(
        mean(&qb) > mean(&qf) + 0.008,
        "BCC {} FCC {}",
        mean(&qb),
        mean(&qf)
    );
    assert!(
        min(&qb) > 0.5 && min(&qf) > 0.5,
        "{} {}",
        min(&qb),
        min(&qf)
    );
}
