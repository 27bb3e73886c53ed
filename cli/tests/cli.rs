//! The command line as a user drives it: real domain files in, real mesh
//! files out, read back and checked.

use std::collections::HashMap;

mod support;
use support::*;

#[test]
fn meshes_a_domain_into_every_format_and_reads_it_back() {
    let dir = tempfile::tempdir().unwrap();
    let input = example("plate_two_holes.toml");
    for ext in ["msh", "vtu", "stl", "obj", "mesh"] {
        let out = dir.path().join(format!("plate.{ext}"));
        let o = run(&[
            "mesh",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--size",
            "0.05",
            "--dim",
            "2",
        ]);
        assert!(o.status.success(), "{ext}: {}", stderr(&o));
        let mesh = bubblemesh_io::read(&out).unwrap();
        assert!(
            mesh.triangles.len() > 500,
            "{ext}: {} triangles",
            mesh.triangles.len()
        );
        // area of the plate minus the holes, to the chord error of the holes
        let area: f64 = mesh
            .triangles
            .iter()
            .map(|t| {
                let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
                0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm()
            })
            .sum();
        let exact = 2.0 - 2.0 * std::f64::consts::PI * 0.04;
        assert!((area - exact).abs() < 0.01, "{ext}: area {area}");
    }
}

#[test]
fn report_holds_timings_energy_and_quality() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sq.msh");
    let rep = dir.path().join("rep.json");
    let o = run(&[
        "mesh",
        example("square.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        "0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)",
        "--report",
        rep.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rep).unwrap()).unwrap();
    let face = &v["engine"]["faces"][0];
    let energy = face["relax"]["energy"].as_array().unwrap();
    assert!(energy.len() > 10);
    let first = energy[0]["total"].as_f64().unwrap();
    let last = energy.last().unwrap()["total"].as_f64().unwrap();
    assert!(last < first, "energy must fall: {first} -> {last}");
    assert!(v["engine"]["timings"]["total_s"].as_f64().unwrap() > 0.0);
    let q = v["quality"]["triangles"]["q_mean"].as_f64().unwrap();
    assert!(q > 0.97, "q_mean {q}");
    let band = v["quality"]["spacing"]["frac_within_sqrt2"]
        .as_f64()
        .unwrap();
    assert!(band > 0.995, "band {band}");
}

/// Thesis Fig. 1.14: internal constraint curves and points are in the mesh.
#[test]
fn constraint_edges_and_points_are_in_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.msh");
    let input = example("constrained.toml");
    let o = run(&[
        "mesh",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        "0.05",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let model = bubblemesh_analytic::read_domain(&input).unwrap();
    let mesh = bubblemesh_io::read(&out).unwrap();
    let mut tri_edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t.nodes[k], t.nodes[(k + 1) % 3]);
            *tri_edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let face = &model.faces[0];
    assert!(!face.embedded_edges.is_empty() && !face.embedded_vertices.is_empty());
    let embedded: Vec<u32> = face.embedded_edges.clone();
    let mut checked = 0;
    for l in &mesh.lines {
        if embedded.contains(&l.entity.id) && l.entity.dim == 1 {
            let key = (l.nodes[0].min(l.nodes[1]), l.nodes[0].max(l.nodes[1]));
            // an embedded edge is inside the face: two triangles on it
            assert_eq!(
                tri_edges.get(&key),
                Some(&2),
                "constraint segment {key:?} missing"
            );
            checked += 1;
        }
    }
    assert!(checked > 5);
    for &v in &face.embedded_vertices {
        let p = model.vertices[v as usize].point;
        let found = mesh.nodes.iter().any(|n| (n.pos - p).norm() < 1e-12);
        assert!(found, "constraint point {p:?} is not a node");
    }
}

#[test]
fn quality_command_reads_any_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("h.vtu");
    let o = run(&[
        "mesh",
        example("hexagon.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        "0.1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json = dir.path().join("q.json");
    let o = run(&[
        "quality",
        out.to_str().unwrap(),
        "--size",
        "0.1",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["triangles"]["count"].as_u64(), Some(600));
    assert!(v["triangles"]["q_min"].as_f64().unwrap() > 0.9995);
}

#[test]
fn default_size_is_printed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.msh");
    let o = run(&[
        "mesh",
        example("square.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("no --size given"), "{}", stderr(&o));
}

/// Every failure exits 1 with a message naming the problem and leaves no
/// output file behind.
#[test]
fn bad_input_gives_a_clear_error_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.msh");
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "format = \"bubblemesh-domain 1\"\n[[face]]\nouter = { polygon = [[0,0],[1,0]] }\n",
    )
    .unwrap();
    let garbage = dir.path().join("garbage.toml");
    std::fs::write(&garbage, "\u{0}\u{1}not toml at all [[[").unwrap();
    let sq = example("square.toml");
    let sq = sq.to_str().unwrap();
    let xyz = dir.path().join("x.xyz");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "mesh",
                "/nonexistent/part.toml",
                "-o",
                out.to_str().unwrap(),
            ],
            "part.toml",
        ),
        (
            vec!["mesh", bad.to_str().unwrap(), "-o", out.to_str().unwrap()],
            "bad.toml",
        ),
        (
            vec![
                "mesh",
                garbage.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
            "garbage.toml",
        ),
        (
            vec!["mesh", sq, "-o", out.to_str().unwrap(), "--size", "-0.1"],
            "spacing",
        ),
        (
            vec![
                "mesh",
                sq,
                "-o",
                out.to_str().unwrap(),
                "--size",
                "0.1 + (x",
            ],
            "0.1 + (x",
        ),
        (
            vec!["mesh", sq, "-o", out.to_str().unwrap(), "--size", "0.1 + w"],
            "'w'",
        ),
        (
            vec!["mesh", sq, "-o", out.to_str().unwrap(), "--size", "x - 0.5"],
            "spacing",
        ),
        (
            vec!["mesh", sq, "-o", out.to_str().unwrap(), "--dim", "3"],
            "highest dimension",
        ),
        (
            vec!["mesh", sq, "-o", out.to_str().unwrap(), "--size", "1e-9"],
            "bubbles",
        ),
        (
            vec!["mesh", sq, "-o", xyz.to_str().unwrap(), "--size", "0.1"],
            "xyz",
        ),
        (
            vec!["mesh", "part.step", "-o", out.to_str().unwrap()],
            "STEP",
        ),
    ];
    for (args, needle) in cases {
        let o = run(&args);
        assert_eq!(
            o.status.code(),
            Some(1),
            "{args:?} should fail: {}",
            stderr(&o)
        );
        let e = stderr(&o);
        assert!(
            e.contains(needle),
            "{args:?}: message {e:?} should name {needle:?}"
        );
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        assert!(!out.exists(), "{args:?} left an output file");
    }
}

/// `--threads 0`, and `--circle-points` negative or above 1000 (a cap
/// finer than any spacing meant, minutes of work), are usage errors naming
/// the option (clap's exit status 2), not a silent single thread or a run.
#[test]
fn zero_threads_and_bad_circle_points_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.msh");
    let sq = example("square.toml");
    for (option, value) in [
        ("--threads", "0"),
        ("--circle-points", "1001"),
        ("--circle-points", "-3"),
    ] {
        let o = run(&[
            "mesh",
            sq.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            option,
            value,
        ]);
        assert_eq!(o.status.code(), Some(2), "{option} {value}: {}", stderr(&o));
        // clap names the option, or the stray value it did not take
        assert!(
            stderr(&o).contains(option) || stderr(&o).contains(value),
            "{}",
            stderr(&o)
        );
        assert!(!out.exists());
    }
}

/// Curvature- and view-based spacing from the command line, combined with
/// an expression by minimum and bounded by --d-max.
#[test]
fn curvature_and_view_spacing_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let coarse = dir.path().join("c.msh");
    let fine = dir.path().join("f.msh");
    let patch = example("nurbs_patch.toml");
    for (out, eps) in [(&coarse, "0.004"), (&fine, "0.001")] {
        let o = run(&[
            "mesh",
            patch.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--curvature",
            eps,
            "--d-max",
            "0.2",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let (c, f) = (
        bubblemesh_io::read(&coarse).unwrap(),
        bubblemesh_io::read(&fine).unwrap(),
    );
    // a quarter of the tolerance: about twice the triangles per unit length
    assert!(
        f.triangles.len() > 2 * c.triangles.len(),
        "{} vs {}",
        f.triangles.len(),
        c.triangles.len()
    );
    // view spacing: smaller elements near the viewpoint at a corner
    let v = dir.path().join("v.msh");
    let o = run(&[
        "mesh",
        example("square.toml").to_str().unwrap(),
        "-o",
        v.to_str().unwrap(),
        "--view-spacing",
        "0,0,0.2,0.1",
        "--size",
        "0.08",
        "--combine",
        "min",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = bubblemesh_io::read(&v).unwrap();
    let near = m
        .nodes
        .iter()
        .filter(|n| n.pos.x < 0.25 && n.pos.y < 0.25)
        .count();
    let far = m
        .nodes
        .iter()
        .filter(|n| n.pos.x > 0.75 && n.pos.y > 0.75)
        .count();
    assert!(near > 3 * far, "near {near} far {far}");
}

/// `--fcc` selects the thesis's FCC start and stage 2 for a uniform
/// spacing; without it the cube starts from the BCC lattice. The report
/// says which, and both meshes are of the quality issue 5 asks.
#[test]
fn fcc_flag_chooses_the_volume_lattice() {
    let mut means = HashMap::new();
    for (flag, lattice) in [(None, "bcc"), (Some("--fcc"), "fcc")] {
        let mut extra = vec!["--dim", "3"];
        extra.extend(flag);
        let v = mesh_report(&example("cube.toml"), "0.05", &extra);
        assert_eq!(v["engine"]["volumes"][0]["lattice"], lattice);
        let t = &v["quality"]["tets"];
        assert!(t["q_min"].as_f64().unwrap() > 0.45);
        means.insert(lattice, t["q_mean"].as_f64().unwrap());
    }
    assert!(means["fcc"] > 0.90, "{means:?}");
    assert!(means["bcc"] > means["fcc"], "{means:?}");
}

/// Where a uniform spacing's BCC start is given up, a bulky volume relaxes
/// only the lattice's layer next to the boundary (`bcc_layer`) and must
/// come out at least as good as the thesis's FCC path over the whole
/// volume (`--fcc`), within the volume quality bounds; a volume that is
/// mostly layer takes the FCC path. fixtures/step/cylinder.step (r 10,
/// h 20): at 1.5 a third of its lattice is layer, at 2 half; BCC is given
/// up at both.
#[test]
fn a_bulky_volume_relaxes_only_its_boundary_layer() {
    let mesh = |size: &str, flag: Option<&str>| {
        let mut extra = vec!["--dim", "3"];
        extra.extend(flag);
        let v = mesh_report(&fixture("cylinder.step"), size, &extra);
        let vol = &v["engine"]["volumes"][0];
        let t = &v["quality"]["tets"];
        let (mean, min, dihedral) = (
            t["q_mean"].as_f64().unwrap(),
            t["q_min"].as_f64().unwrap(),
            t["dihedral_min"].as_f64().unwrap(),
        );
        assert!(min >= 0.5 && dihedral >= 25.0, "{size} {flag:?}: {t}");
        (
            vol["lattice"].clone(),
            vol["bcc_rejected"].is_number(),
            mean,
        )
    };
    let (lattice, rejected, layered) = mesh("1.5", None);
    assert_eq!(lattice, "bcc_layer");
    assert!(rejected, "the BCC start is given up first");
    let (lattice, _, fcc) = mesh("1.5", Some("--fcc"));
    assert_eq!(lattice, "fcc");
    assert!(layered >= fcc, "bcc_layer {layered}, fcc {fcc}");
    let (lattice, rejected, _) = mesh("2", None);
    assert_eq!(lattice, "fcc");
    assert!(rejected);
}

/// `--unit` converts a STEP file's coordinates (the fixtures are in
/// millimetres): the same mesh comes out scaled, with `--size` read in the
/// new unit, and the summary and report say which unit the numbers are in.
#[test]
fn unit_converts_step_coordinates_and_size() {
    let dir = tempfile::tempdir().unwrap();
    let step =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/step/block_holes.step");
    let mm = dir.path().join("mm.msh");
    let cm = dir.path().join("cm.msh");
    let report = dir.path().join("cm.json");
    let a = run(&[
        "mesh",
        step.to_str().unwrap(),
        "-o",
        mm.to_str().unwrap(),
        "--size",
        "3",
        "--threads",
        "1",
    ]);
    assert!(a.status.success(), "{}", stderr(&a));
    let b = run(&[
        "mesh",
        step.to_str().unwrap(),
        "-o",
        cm.to_str().unwrap(),
        "--size",
        "0.3",
        "--unit",
        "cm",
        "--threads",
        "1",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(b.status.success(), "{}", stderr(&b));
    assert!(
        stderr(&b).contains("converted from the file's millimetre"),
        "{}",
        stderr(&b)
    );
    let (m1, m2) = (
        bubblemesh_io::read(&mm).unwrap(),
        bubblemesh_io::read(&cm).unwrap(),
    );
    let bbox = |m: &bubblemesh_core::Mesh| {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for n in &m.nodes {
            for k in 0..3 {
                lo[k] = lo[k].min(n.pos[k]);
                hi[k] = hi[k].max(n.pos[k]);
            }
        }
        (lo, hi)
    };
    let ((lo1, hi1), (lo2, hi2)) = (bbox(&m1), bbox(&m2));
    for k in 0..3 {
        let extent = hi1[k] - lo1[k];
        assert!(extent > 1.0, "axis {k}: extent {extent} mm");
        assert!(
            (lo2[k] * 10.0 - lo1[k]).abs() < 1e-9 * extent,
            "axis {k}: {} cm vs {} mm",
            lo2[k],
            lo1[k]
        );
        assert!(
            (hi2[k] * 10.0 - hi1[k]).abs() < 1e-9 * extent,
            "axis {k}: {} cm vs {} mm",
            hi2[k],
            hi1[k]
        );
    }
    // the spacing scaled with the coordinates: about as many nodes (not
    // the same: stage 1 of a graded curved face depends on the unit — the
    // through holes' walls, capped to seven nodes per turn inside, start
    // from 21 bubbles in mm and 27 in cm, 646 and 666 nodes in all, see
    // docs/decisions.md, session 22; a --size left unconverted would give
    // 100 times as many)
    let (n1, n2) = (m1.nodes.len() as f64, m2.nodes.len() as f64);
    assert!((n1 - n2).abs() < 0.04 * n1, "{n1} nodes in mm, {n2} in cm");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(
        r["step"]["length_unit"]["name"], "centimetre",
        "{}",
        r["step"]
    );
    assert_eq!(
        r["step"]["file_length_unit"]["name"], "millimetre",
        "{}",
        r["step"]
    );
}

/// `--unit` is refused, with nothing written, for an unknown unit and for a
/// domain file (which has no unit).
#[test]
fn unit_is_refused_where_it_cannot_apply() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.msh");
    let step = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/step/cube.step");
    let o = run(&[
        "mesh",
        step.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--unit",
        "furlong",
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("unknown length unit 'furlong'; expected mm, cm, m, in or ft"),
        "{}",
        stderr(&o)
    );
    let toml = example("square.toml");
    let o = run(&[
        "mesh",
        toml.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--unit",
        "mm",
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("--unit applies to STEP files"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "a refused run wrote {}", out.display());
}

/// Two boxes that share the face x = 1 but are separate solids: each is
/// meshed on its own and is valid, and the run says, on stderr and in the
/// report, that the parts touch without being joined (meshcheck counts the
/// pairs as duplicate nodes); one box alone says nothing.
#[test]
fn touching_solids_are_reported_not_silently_written() {
    let dir = tempfile::tempdir().unwrap();
    let two = dir.path().join("two.toml");
    std::fs::write(
        &two,
        "format = \"bubblemesh-domain 1\"\n\n[[solid]]\nname = \"a\"\nbox = { min = [0, 0, 0], max = [1, 1, 1] }\n\n\
         [[solid]]\nname = \"b\"\nbox = { min = [1, 0, 0], max = [2, 1, 1] }\n",
    )
    .unwrap();
    let out = dir.path().join("two.msh");
    let rep = dir.path().join("two.json");
    let o = run(&[
        "mesh",
        two.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        "0.25",
        "--dim",
        "3",
        "-q",
        "--report",
        rep.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("separate parts of the mesh touch at 16 pair(s) of coinciding nodes"),
        "{}",
        stderr(&o)
    );
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&rep).unwrap()).unwrap();
    assert_eq!(j["engine"]["touching"]["node_pairs"], 16);
    assert_eq!(j["engine"]["touching"]["at"][0], 1.0);
    // one box: nothing touches
    let one = dir.path().join("one.toml");
    std::fs::write(
        &one,
        "format = \"bubblemesh-domain 1\"\n\n[[solid]]\nname = \"a\"\nbox = { min = [0, 0, 0], max = [1, 1, 1] }\n",
    )
    .unwrap();
    let o = run(&[
        "mesh",
        one.to_str().unwrap(),
        "-o",
        dir.path().join("one.msh").to_str().unwrap(),
        "--size",
        "0.25",
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("touch"), "{}", stderr(&o));
}

/// A square hole of side 0.3·d in a plate: the run says that short edges
/// grade the spacing (one note, naming the shortest), the report lists
/// them under `engine.circle_points.short_edges`, and `--circle-points 0`
/// turns the grading off (no note, no list).
#[test]
fn short_edges_are_reported_and_can_be_turned_off() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.toml");
    std::fs::write(
        &input,
        "format = \"bubblemesh-domain 1\"\n[[face]]\n\
         outer = { polygon = [[0, 0], [1, 0], [1, 1], [0, 1]] }\n\
         holes = [ { polygon = [[0.47, 0.47], [0.47, 0.53], [0.53, 0.53], [0.53, 0.47]] } ]\n",
    )
    .unwrap();
    let out = dir.path().join("plate.msh");
    let rep = dir.path().join("rep.json");
    for (cp, graded) in [("7", true), ("0", false)] {
        let o = run(&[
            "mesh",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--size",
            "0.2",
            "--circle-points",
            cp,
            "--report",
            rep.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let note = stderr(&o).contains("shorter than 0.6 times the size");
        assert_eq!(note, graded, "--circle-points {cp}: {}", stderr(&o));
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&rep).unwrap()).unwrap();
        let short = r["engine"]["circle_points"]["short_edges"]
            .as_array()
            .map_or(0, |a| a.len());
        assert_eq!(
            short,
            if graded { 4 } else { 0 },
            "{}",
            r["engine"]["circle_points"]
        );
    }
}

/// Faces are meshed side by side on several threads (and stage 2 steps
/// split across them), yet the file is the one-thread file byte for byte:
/// each face reads only its edges' mesh and is appended in face order.
/// Checked on a part with 33 faces, as surfaces and into tetrahedra, on
/// four threads whatever the machine has.
#[test]
fn every_thread_count_writes_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let step =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/step/block_holes.step");
    for dim in ["2", "3"] {
        let mut files = Vec::new();
        for threads in ["1", "4"] {
            let out = dir.path().join(format!("t{threads}_{dim}.msh"));
            let o = run(&[
                "mesh",
                step.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--size",
                "3",
                "--dim",
                dim,
                "--threads",
                threads,
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
            files.push(std::fs::read(&out).unwrap());
        }
        let m = bubblemesh_io::read(&dir.path().join(format!("t1_{dim}.msh"))).unwrap();
        assert!(m.triangles.len() > 100, "{}", m.triangles.len());
        assert!(
            files[0] == files[1],
            "--dim {dim}: four threads wrote another mesh than one"
        );
    }
}
