//! Hostile input (issue 23): each test guards one find — the exit status,
//! the message, the input's bytes, and that a failed run leaves no file or
//! directory behind.

use std::path::{Path, PathBuf};
use std::process::Output;

mod support;
use support::*;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A copy of the unit-square example in a fresh directory.
fn square_in(dir: &Path) -> PathBuf {
    let p = dir.join("in.toml");
    std::fs::copy(example("square.toml"), &p).unwrap();
    p
}

fn write_toml(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn assert_failed_cleanly(o: &Output, code: i32) {
    assert_eq!(o.status.code(), Some(code), "{}", stderr(o));
    assert!(!stderr(o).contains("panicked"), "{}", stderr(o));
}

// --- 1: --threads ---------------------------------------------------------

#[test]
fn threads_beyond_the_bound_are_a_usage_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    for n in [
        "3000",
        "100000",
        "18446744073709551615",
        "18446744073709551616",
    ] {
        let o = run(&[
            "mesh",
            s(&input),
            "-o",
            s(&out),
            "--size",
            "0.2",
            "--threads",
            n,
        ]);
        assert_failed_cleanly(&o, 2);
        assert!(stderr(&o).contains("--threads"), "{n}: {}", stderr(&o));
        assert!(!out.exists(), "{n}");
    }
    // the bound itself is accepted
    let o = run(&[
        "mesh",
        s(&input),
        "-o",
        s(&out),
        "--size",
        "0.2",
        "--threads",
        "64",
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

// --- 2, 4, 5: outputs against inputs and each other ---------------------------

#[test]
fn report_naming_the_input_is_refused_and_the_input_bytes_stay() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let before = std::fs::read(&input).unwrap();
    let out = dir.path().join("a.msh");
    // also through another spelling of the same path
    let dotted = dir.path().join(".").join("in.toml");
    for report in [&input, &dotted] {
        let o = run(&[
            "mesh",
            s(&input),
            "-o",
            s(&out),
            "--size",
            "0.2",
            "--report",
            s(report),
        ]);
        assert_failed_cleanly(&o, 1);
        assert!(stderr(&o).contains("input"), "{}", stderr(&o));
        assert_eq!(std::fs::read(&input).unwrap(), before);
        assert_eq!(names(dir.path()), ["in.toml"]);
    }
}

#[test]
fn every_output_naming_an_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let mesh = dir.path().join("m.msh");
    let o = run(&["mesh", s(&input), "-o", s(&mesh), "--size", "0.2", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(&mesh).unwrap();
    let o = run(&["quality", s(&mesh), "--json", s(&mesh)]);
    assert_failed_cleanly(&o, 1);
    assert!(stderr(&o).contains("--json"), "{}", stderr(&o));
    // draw's -o must be a picture, and its --plots directory not the mesh
    let o = run(&[
        "draw",
        s(&mesh),
        "-o",
        s(&dir.path().join("p.svg")),
        "--plots",
        s(&mesh),
    ]);
    assert_failed_cleanly(&o, 1);
    assert_eq!(std::fs::read(&mesh).unwrap(), before);
    assert_eq!(names(dir.path()), ["in.toml", "m.msh"]);
}

#[test]
fn report_and_output_naming_the_same_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    let o = run(&[
        "mesh",
        s(&input),
        "-o",
        s(&out),
        "--size",
        "0.2",
        "--report",
        s(&out),
    ]);
    assert_failed_cleanly(&o, 1);
    assert!(
        stderr(&o).contains("-o and --report name the same file"),
        "{}",
        stderr(&o)
    );
    assert_eq!(names(dir.path()), ["in.toml"]);
    // --animate and -o
    let page = dir.path().join("a.html");
    let o = run(&[
        "mesh",
        s(&input),
        "-o",
        s(&page),
        "--size",
        "0.2",
        "--animate",
        s(&page),
    ]);
    assert_failed_cleanly(&o, 1);
    assert_eq!(names(dir.path()), ["in.toml"]);
}

#[test]
fn report_in_a_missing_directory_or_on_a_directory_leaves_no_mesh_behind() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    for (report, says) in [
        (dir.path().join("nonexist/r.json"), "does not exist"),
        (sub.clone(), "is a directory"),
    ] {
        let o = run(&[
            "mesh",
            s(&input),
            "-o",
            s(&out),
            "--size",
            "0.2",
            "--report",
            s(&report),
        ]);
        assert_failed_cleanly(&o, 1);
        assert!(stderr(&o).contains(says), "{}", stderr(&o));
        assert!(!out.exists(), "{report:?}: the mesh stayed behind");
        assert_eq!(names(dir.path()), ["in.toml", "sub"]);
        assert!(names(&sub).is_empty());
    }
}

// --- 3: special files ----------------------------------------------------

#[cfg(unix)]
#[test]
fn report_to_a_device_is_written_in_place_never_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    let null = Path::new("/dev/null");
    if null.exists() {
        let o = run(&[
            "mesh",
            s(&input),
            "-o",
            s(&out),
            "--size",
            "0.2",
            "--report",
            "/dev/null",
            "-q",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(std::fs::metadata(null)
            .unwrap()
            .file_type()
            .is_char_device());
        assert!(out.exists());
        std::fs::remove_file(&out).unwrap();
    }
    let full = Path::new("/dev/full");
    if full.exists() {
        let o = run(&[
            "mesh",
            s(&input),
            "-o",
            s(&out),
            "--size",
            "0.2",
            "--report",
            "/dev/full",
        ]);
        assert_failed_cleanly(&o, 1);
        assert!(
            stderr(&o).contains("/dev/full") && stderr(&o).contains("No space left"),
            "{}",
            stderr(&o)
        );
        assert!(std::fs::metadata(full)
            .unwrap()
            .file_type()
            .is_char_device());
        assert!(
            !out.exists(),
            "the mesh stayed behind after the failed report"
        );
    }
    assert_eq!(names(dir.path()), ["in.toml"]);
}

// --- 15: directories a failed run made -----------------------------------

#[test]
fn a_failed_run_removes_the_directories_it_created() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    let plots = dir.path().join("plots");
    let frames = dir.path().join("frames");
    // fails after the directories are made: the spacing is negative
    let o = run(&[
        "mesh",
        s(&input),
        "-o",
        s(&out),
        "--size",
        "x - 2",
        "--plots",
        s(&plots),
        "--frames",
        s(&frames),
    ]);
    assert_failed_cleanly(&o, 1);
    assert_eq!(names(dir.path()), ["in.toml"]);
    // fails at the last output: the plots staged before it go too
    let o = run(&[
        "mesh",
        s(&input),
        "-o",
        s(&out),
        "--size",
        "0.2",
        "--plots",
        s(&plots),
        "--report",
        "/dev/full",
    ]);
    if Path::new("/dev/full").exists() {
        assert_failed_cleanly(&o, 1);
        assert_eq!(names(dir.path()), ["in.toml"]);
    }
}

// --- 6: element types the reader does not take -------------------------------

const TWO_TRIANGLES_41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$Nodes\n1 4 1 4\n2 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n$EndNodes\n\
$Elements\n1 2 1 2\n2 1 TYPE 2\n1 1 2 3\n2 1 3 4\n$EndElements\n";

#[test]
fn quality_refuses_an_unknown_element_type() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("m.msh");
    std::fs::write(&m, TWO_TRIANGLES_41.replace("TYPE", "999")).unwrap();
    let o = run(&["quality", s(&m)]);
    assert_failed_cleanly(&o, 1);
    assert!(
        stderr(&o).contains("unknown element type 999"),
        "{}",
        stderr(&o)
    );
    // the same with the type the reader takes: two triangles
    std::fs::write(&m, TWO_TRIANGLES_41.replace("TYPE", "2")).unwrap();
    let o = run(&["quality", s(&m)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("2 triangles"), "{}", stdout(&o));
}

#[test]
fn quality_warns_naming_the_elements_it_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("q.msh");
    let quads = TWO_TRIANGLES_41.replace("2 1 TYPE 2\n1 1 2 3\n2 1 3 4\n", "2 1 3 1\n1 1 2 3 4\n");
    std::fs::write(&m, quads).unwrap();
    let o = run(&["quality", s(&m)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("warning") && e.contains("skipped 1") && e.contains("quadrangle"),
        "{e}"
    );
    // Medit quadrilaterals likewise
    let m = dir.path().join("q.mesh");
    std::fs::write(
        &m,
        "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 1\n1 0 0 1\n1 1 0 1\n\
         0 1 0 1\nQuadrilaterals\n1\n1 2 3 4 1\nEnd\n",
    )
    .unwrap();
    let o = run(&["quality", s(&m)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("warning") && e.contains("skipped 1") && e.contains("Quadrilaterals"),
        "{e}"
    );
}

// --- 7: formats that cannot hold the mesh --------------------------------

#[test]
fn a_curve_only_model_to_stl_or_obj_is_an_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_toml(
        dir.path(),
        "curve.toml",
        "format = \"bubblemesh-domain 1\"\n[[curve]]\nline = [[0, 0, 0], [1, 1, 1]]\n",
    );
    for ext in ["stl", "obj"] {
        let out = dir.path().join(format!("c.{ext}"));
        let o = run(&["mesh", s(&input), "-o", s(&out), "--size", "0.1"]);
        assert_failed_cleanly(&o, 1);
        assert!(stderr(&o).contains("no triangles"), "{}", stderr(&o));
        assert_eq!(names(dir.path()), ["curve.toml"]);
    }
    // .msh holds edges
    let out = dir.path().join("c.msh");
    let o = run(&["mesh", s(&input), "-o", s(&out), "--size", "0.1", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

// --- 8, 10: the --size expression ----------------------------------------

#[test]
fn an_overlong_size_expression_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    let expr = format!("0.05{}", "+0*x".repeat(29_000));
    let t = std::time::Instant::now();
    let o = run(&["mesh", s(&input), "-o", s(&out), "--size", &expr]);
    assert!(t.elapsed().as_secs_f64() < 10.0, "{:?}", t.elapsed());
    assert_failed_cleanly(&o, 1);
    assert!(stderr(&o).contains("at most 10000"), "{}", stderr(&o));
    assert!(stderr(&o).len() < 1000, "the message quotes it all");
    assert!(!out.exists());
}

#[test]
fn size_errors_name_the_mistake_not_parser_internals() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    for (expr, says) in [
        ("foo(x)", "unknown function 'foo'"),
        ("0x10", "invalid number '0x10'"),
        ("0.1 +", "not a well-formed expression"),
        ("0.1 + w", "unknown variable 'w'"),
    ] {
        let o = run(&["mesh", s(&input), "-o", s(&out), "--size", expr]);
        assert_failed_cleanly(&o, 1);
        let e = stderr(&o);
        assert!(e.contains(says), "{expr}: {e}");
        assert!(!e.contains("wlog") && !e.contains(" ops "), "{expr}: {e}");
    }
    assert_eq!(names(dir.path()), ["in.toml"]);
}

// --- 9: far from the origin ----------------------------------------------

#[test]
fn a_unit_square_far_from_the_origin_is_not_refused_as_arealess() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_toml(
        dir.path(),
        "far.toml",
        "format = \"bubblemesh-domain 1\"\n[[face]]\nname = \"far\"\nouter = { polygon = \
         [[1e8, 1e8], [100000001, 1e8], [100000001, 100000001], [1e8, 100000001]] }\n",
    );
    let out = dir.path().join("far.msh");
    let o = run(&["mesh", s(&input), "-o", s(&out), "--size", "0.1", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("encloses no area"), "{}", stderr(&o));
    // the same mesh as at the origin: area 1, well-shaped triangles
    let m = bubblemesh_io::read(&out).unwrap();
    assert!(m.triangles.len() > 150, "{} triangles", m.triangles.len());
    let area: f64 = m
        .triangles
        .iter()
        .map(|t| {
            let p = t.nodes.map(|i| m.nodes[i as usize].pos);
            let (u, v) = (p[1] - p[0], p[2] - p[0]);
            0.5 * (u.x * v.y - u.y * v.x)
        })
        .sum();
    assert!((area - 1.0).abs() < 1e-6, "area {area}");
}

// --- 11: plugins ---------------------------------------------------------

#[test]
fn a_plugin_that_is_a_directory_is_named_so() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let lib = dir.path().join("some_dir.so");
    std::fs::create_dir(&lib).unwrap();
    let out = dir.path().join("a.msh");
    let o = run(&["mesh", s(&input), "-o", s(&out), "--plugin", s(&lib)]);
    assert_failed_cleanly(&o, 1);
    assert!(
        stderr(&o).contains("is a directory, not a shared library"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

// --- 12: holes in (u,v) --------------------------------------------------

#[test]
fn a_hole_outside_the_parameter_range_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(example("cylinder.toml"))
        .unwrap()
        .replace(
            "holes_uv = [[[-0.4, 0.4], [0.4, 0.4], [0.4, 0.6], [-0.4, 0.6]]]",
            "holes_uv = [[[-0.4, 5.4], [0.4, 5.4], [0.4, 5.6], [-0.4, 5.6]]]",
        );
    assert!(text.contains("5.4"));
    let input = write_toml(dir.path(), "cyl.toml", &text);
    let out = dir.path().join("c.msh");
    let o = run(&["mesh", s(&input), "-o", s(&out)]);
    assert_failed_cleanly(&o, 1);
    let e = stderr(&o);
    assert!(
        e.contains("hole 1 lies outside the surface's parameter range"),
        "{e}"
    );
    assert!(!e.contains("smaller size"), "{e}");
    assert!(!out.exists());
}

// --- 13: degenerate numbers in messages -----------------------------------

#[test]
fn quality_of_coincident_nodes_reports_no_negative_angle() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("m.msh");
    let text = TWO_TRIANGLES_41.replace("TYPE", "2").replace(
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n",
        "0 0 0\n0 0 0\n0 0 0\n1 1 0\n",
    );
    std::fs::write(&m, text).unwrap();
    let o = run(&["quality", s(&m)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(!out.contains("-180"), "{out}");
    assert!(out.contains("2 degenerate"), "{out}");
}

#[test]
fn the_default_size_of_a_tiny_model_is_printed_with_significant_digits() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_toml(
        dir.path(),
        "tiny.toml",
        "format = \"bubblemesh-domain 1\"\n[[face]]\nouter = { polygon = \
         [[0, 0], [1e-6, 0], [1e-6, 1e-6], [0, 1e-6]] }\n",
    );
    let out = dir.path().join("t.msh");
    let o = run(&["mesh", s(&input), "-o", s(&out), "--fast"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    let d: f64 = e
        .split("using d = ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("{e}"));
    let want = 2f64.sqrt() * 1e-6 / 40.0;
    assert!((d - want).abs() < 1e-5 * want, "{d} vs {want}: {e}");
}

// --- 14: elements too thin to be useful ----------------------------------

#[test]
fn a_strip_thinner_than_the_spacing_warns_naming_the_face() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_toml(
        dir.path(),
        "strip.toml",
        "format = \"bubblemesh-domain 1\"\n[[face]]\nname = \"strip\"\nouter = { polygon = \
         [[0, 0], [1, 0], [1, 1e-7], [0, 1e-7]] }\n",
    );
    let out = dir.path().join("s.msh");
    let report = dir.path().join("s.json");
    let o = run(&[
        "mesh",
        s(&input),
        "-o",
        s(&out),
        "--size",
        "0.1",
        "-q",
        "--report",
        s(&report),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("warning") && e.contains("face 0 'strip'") && e.contains("radius ratio below"),
        "{e}"
    );
    // the report names the face, where its worst element is and how thin
    // the strip is there
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let p = &r["poor_elements"][0];
    assert_eq!(
        (p["dim"].as_u64(), p["id"].as_u64(), p["name"].as_str()),
        (Some(2), Some(0), Some("strip")),
        "{p}"
    );
    let thick = p["thickness"].as_f64().unwrap();
    assert!(thick > 0.0 && thick <= 1.0001e-7, "thickness {thick}");
    let y = p["at"][1].as_f64().unwrap();
    assert!((0.0..=1e-7).contains(&y), "at {}", p["at"]);
    // a good mesh gives no such warning
    let sq = square_in(dir.path());
    let o = run(&["mesh", s(&sq), "-o", s(&out), "--size", "0.1", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
}

// --- 16: help ------------------------------------------------------------

#[test]
fn mesh_help_names_step_and_toml_inputs() {
    let o = run(&["mesh", "--help"]);
    assert!(o.status.success());
    let h = stdout(&o);
    assert!(
        h.contains(".step") && h.contains(".stp") && h.contains(".toml"),
        "{h}"
    );
    let o = run(&["--help"]);
    assert!(stdout(&o).contains("STEP"), "{}", stdout(&o));
}

/// A spacing so small that an edge's bubble count overflows usize
/// (1e-300 on a unit square): the count wrapped to 0 and the edge
/// placement looped forever. It must be the too-many-bubbles error, at
/// once, with nothing written.
#[test]
fn tiny_size_overflowing_the_bubble_count_is_an_error_not_a_hang() {
    let dir = tempfile::tempdir().unwrap();
    let input = square_in(dir.path());
    let out = dir.path().join("a.msh");
    let t = std::time::Instant::now();
    let o = run(&["mesh", s(&input), "-o", s(&out), "--size", "1e-300"]);
    assert_failed_cleanly(&o, 1);
    assert!(stderr(&o).contains("bubbles"), "{}", stderr(&o));
    assert!(!out.exists());
    assert!(t.elapsed().as_secs() < 60, "took {:?}", t.elapsed());
}
