//! Our output read by independent readers: meshio (and Gmsh itself when its
//! Python module is installed). Skipped, with a message, when python3 or the
//! module is missing; a failure to read is a test failure.

mod common;

use std::path::Path;
use std::process::Command;

use bubblemesh_io::write;
use common::{python_has, sample_mesh, tet_only};

fn run_python(script: &str, args: &[&Path]) -> String {
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .expect("python3 runs");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "python failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The lines of our output (marked with `@`; meshio may print its own).
fn counts(stdout: &str) -> String {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix('@'))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// Prints `@type count` per cell block, summed over blocks.
const MESHIO: &str = r#"
import sys, logging, collections
logging.disable(logging.WARNING)
import meshio
m = meshio.read(sys.argv[1])
c = collections.Counter()
for b in m.cells:
    c[b.type] += len(b.data)
print("@points", len(m.points))
for k in sorted(c):
    print("@" + k, c[k])
"#;

#[test]
fn meshio_reads_our_files() {
    if !python_has("meshio") {
        eprintln!("skipped: python3 with meshio is not available");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let m = sample_mesh();
    for (name, want) in [
        ("a.msh", "points 8\nline 4\ntetra 6\ntriangle 2\nvertex 4\n"),
        ("a.vtu", "points 8\nline 4\ntetra 6\ntriangle 2\n"),
        ("a.mesh", "points 8\nline 4\ntetra 6\ntriangle 2\n"),
        ("a.stl", "points 4\ntriangle 2\n"),
        ("a.obj", "points 4\ntriangle 2\n"),
    ] {
        let p = dir.path().join(name);
        write(&m, &p).unwrap();
        let got = counts(&run_python(MESHIO, &[&p]));
        assert_eq!(got, want, "{name}");
    }
    // Surface of a tet-only mesh.
    let p = dir.path().join("t.stl");
    write(&tet_only(), &p).unwrap();
    assert_eq!(
        counts(&run_python(MESHIO, &[&p])),
        "points 8\ntriangle 12\n"
    );
}

/// Opens the file in Gmsh and prints node count, element counts per
/// dimension, and entity counts per dimension.
const GMSH: &str = r#"
import sys, gmsh
gmsh.initialize(["-v", "0"])
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(sys.argv[1])
tags, _, _ = gmsh.model.mesh.getNodes()
print("nodes", len(tags))
for d in range(4):
    types, elems, _ = gmsh.model.mesh.getElements(d)
    print("dim", d, [int(t) for t in types], [len(e) for e in elems],
          "entities", len(gmsh.model.getEntities(d)))
print("boundary of surface 1", gmsh.model.getBoundary([(2, 1)], oriented=True))
gmsh.finalize()
"#;

#[test]
fn gmsh_opens_our_msh() {
    if !python_has("gmsh") {
        eprintln!("skipped: python3 with gmsh is not available");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.msh");
    write(&sample_mesh(), &p).unwrap();
    let got = run_python(GMSH, &[&p]);
    assert_eq!(
        got,
        "nodes 8\n\
         dim 0 [15] [4] entities 4\n\
         dim 1 [1] [4] entities 4\n\
         dim 2 [2] [2] entities 1\n\
         dim 3 [4] [6] entities 1\n\
         boundary of surface 1 [(1, 1), (1, 2), (1, 3), (1, 4)]\n"
    );
}
