//! Helpers the command-line test files share: the built binary, the
//! repository's example inputs and fixtures, a run's output as text, a
//! mesh run into a folder and a mesh run's report.
#![allow(dead_code)] // each test file uses a part

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `bubblemesh` binary built for these tests.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_bubblemesh"))
}

/// A file of the repository's `examples/`.
pub fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
}

/// A STEP fixture of the repository's `fixtures/step/`.
pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/step")
        .join(name)
}

/// `bubblemesh mesh input -o <dir>/m.msh --size size extra…` to the end
/// (the mesh, if written, is `dir.join("m.msh")`).
pub fn mesh_in(dir: &Path, input: &Path, size: &str, extra: &[&str]) -> Output {
    let out = dir.join("m.msh");
    let mut args = vec![
        "mesh",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        size,
    ];
    args.extend_from_slice(extra);
    run(&args)
}

/// `bubblemesh mesh input -o <tmp>.msh --size size --report <tmp>.json
/// extra…`, which must succeed; its report.
pub fn mesh_report(input: &Path, size: &str, extra: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let rep = dir.path().join("r.json");
    let mut args = vec!["--report", rep.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = mesh_in(dir.path(), input, size, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_str(&std::fs::read_to_string(&rep).unwrap()).unwrap()
}

/// Runs `bubblemesh args…` to the end.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("run bubblemesh")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The smallest angle of the mesh's triangles, in degrees.
pub fn smallest_angle(m: &bubblemesh_core::Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.nodes.map(|k| m.nodes[k as usize].pos);
            bubblemesh_core::measure::triangle_min_angle(&a, &b, &c).to_degrees()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The smallest dihedral angle of the mesh's tetrahedra, in degrees.
pub fn smallest_dihedral(m: &bubblemesh_core::Mesh) -> f64 {
    m.tetrahedra
        .iter()
        .map(|t| {
            let [a, b, c, e] = t.nodes.map(|n| m.nodes[n as usize].pos);
            bubblemesh_core::measure::dihedral_extremes(&a, &b, &c, &e).0
        })
        .fold(f64::INFINITY, f64::min)
}
