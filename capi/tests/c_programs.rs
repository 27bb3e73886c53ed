//! The C programs in tests/c/, compiled with the system C compiler against
//! the libraries cargo just built, run natively and under valgrind; and the
//! Python ctypes examples.
//!
//! The shared library is the one cargo built for this test run: it sits
//! next to this test's executable (target/<profile>/deps). A missing tool
//! (cc, valgrind, python3) skips its test with a message, except under CI
//! (CI set), where it fails: CI must run them.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The directory holding libbubblemesh_capi.{so,a} built for this run.
fn lib_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap().to_path_buf();
    for d in [deps.clone(), deps.parent().unwrap().to_path_buf()] {
        if d.join(so_name()).exists() {
            return d;
        }
    }
    panic!(
        "{} not found next to {} (is crate-type cdylib still set?)",
        so_name(),
        exe.display()
    );
}

/// The shared library of the workspace plugin crate `crate_name` (e.g.
/// "bubblemesh_plugin_curvature"): the plugins are dev-dependencies of this
/// crate, so cargo builds their cdylibs next to the test executables.
fn plugin_lib(crate_name: &str) -> PathBuf {
    let file = format!(
        "{}{crate_name}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap().to_path_buf();
    for d in [deps.clone(), deps.parent().unwrap().to_path_buf()] {
        if d.join(&file).exists() {
            return d.join(&file);
        }
    }
    panic!("{file} not found next to {}", exe.display());
}

fn fixtures() -> PathBuf {
    manifest_dir().join("../fixtures/step")
}

fn so_name() -> &'static str {
    if cfg!(target_os = "macos") {
        "libbubblemesh_capi.dylib"
    } else {
        "libbubblemesh_capi.so"
    }
}

/// Whether `tool` runs; when it does not, panics under CI and returns
/// false (skip) elsewhere.
fn have(tool: &str, arg: &str) -> bool {
    let ok = Command::new(tool)
        .arg(arg)
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ok {
        if std::env::var_os("CI").is_some() {
            panic!("{tool} is required under CI but does not run");
        }
        eprintln!("SKIP: {tool} not available");
    }
    ok
}

fn show(what: &str, out: &Output) -> String {
    format!(
        "{what}: {}\n--- stdout ---\n{}\n--- stderr ---\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Compiles tests/c/<name>.c into `dir`, linked against the shared library
/// (`static_link` false) or the static one.
fn compile(name: &str, dir: &Path, static_link: bool) -> PathBuf {
    let src = manifest_dir().join("tests/c").join(format!("{name}.c"));
    let exe = dir.join(name);
    let lib = lib_dir();
    let mut cmd = Command::new("cc");
    cmd.args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-O1", "-g"])
        .arg("-I")
        .arg(manifest_dir().join("include"))
        .arg(&src)
        .arg("-o")
        .arg(&exe);
    if static_link {
        cmd.arg(lib.join("libbubblemesh_capi.a"))
            .args(["-lpthread", "-ldl", "-lm"]);
    } else {
        cmd.arg("-L")
            .arg(&lib)
            .arg("-lbubblemesh_capi")
            .arg("-lm")
            .arg(format!("-Wl,-rpath,{}", lib.display()));
    }
    let out = cmd.output().expect("cannot run cc");
    assert!(out.status.success(), "{}", show("cc", &out));
    exe
}

fn run(cmd: &mut Command, what: &str) -> String {
    let out = cmd
        .env("LD_LIBRARY_PATH", lib_dir())
        .output()
        .unwrap_or_else(|e| panic!("cannot run {what}: {e}"));
    let text = show(what, &out);
    assert!(out.status.success(), "{text}");
    eprintln!("{text}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn valgrind(exe: &Path) -> Command {
    let mut c = Command::new("valgrind");
    c.args([
        "--error-exitcode=1",
        "--leak-check=full",
        "--errors-for-leak-kinds=definite",
        "--quiet",
    ])
    .arg(exe);
    c
}

/// How a C program runs: linked against the shared library, linked
/// statically, or under valgrind (shared).
#[derive(Clone, Copy, Debug, PartialEq)]
enum How {
    Native,
    Static,
    Valgrind,
}

/// The success line every C program prints last.
const PASSED: &str = "all checks passed";

/// Compiles tests/c/<name>.c into a temporary directory, runs it `how`
/// with the arguments `args` makes from that directory, and asserts that
/// it printed `passed`. Returns the directory (with what the program
/// wrote), or None when the machine lacks `cc` (or valgrind).
fn run_c(
    name: &str,
    how: How,
    args: impl FnOnce(&Path) -> Vec<std::ffi::OsString>,
    passed: &str,
) -> Option<tempfile::TempDir> {
    if !have("cc", "--version") || (how == How::Valgrind && !have("valgrind", "--version")) {
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile(name, dir.path(), how == How::Static);
    let mut cmd = if how == How::Valgrind {
        valgrind(&exe)
    } else {
        Command::new(&exe)
    };
    cmd.args(args(dir.path()));
    let stdout = run(&mut cmd, &format!("{name} ({how:?})"));
    assert!(stdout.contains(passed), "{stdout}");
    Some(dir)
}

fn os(args: &[&str]) -> Vec<std::ffi::OsString> {
    args.iter().map(|a| a.into()).collect()
}

#[test]
fn torus_and_plate_through_callbacks() {
    let Some(dir) = run_c(
        "torus_plate",
        How::Native,
        |d| vec![d.join("torus_plate.msh").into()],
        PASSED,
    ) else {
        return;
    };
    // the file it wrote reads back with the same entities
    let mesh = bubblemesh_io::read(&dir.path().join("torus_plate.msh")).unwrap();
    let faces: std::collections::BTreeSet<u32> =
        mesh.triangles.iter().map(|t| t.entity.id).collect();
    assert_eq!(faces.into_iter().collect::<Vec<_>>(), vec![0, 1]);
}

/// A coarser spacing keeps valgrind's run short; the checks are the same.
#[test]
fn torus_and_plate_under_valgrind() {
    run_c(
        "torus_plate",
        How::Valgrind,
        |_| os(&["-d", "0.15"]),
        PASSED,
    );
}

#[test]
fn torus_and_plate_linked_statically() {
    run_c("torus_plate", How::Static, |_| os(&["-d", "0.15"]), PASSED);
}

#[test]
fn failing_callbacks_and_bad_arguments_give_codes_and_messages() {
    run_c(
        "callback_errors",
        How::Native,
        |_| vec![],
        "all cases behaved",
    );
}

#[test]
fn failing_callbacks_under_valgrind() {
    run_c(
        "callback_errors",
        How::Valgrind,
        |_| vec![],
        "all cases behaved",
    );
}

/// The STEP shortcut: cube.step meshed into a closed surface and into
/// tetrahedra; missing, garbage, truncated and unsupported files refused.
fn step_file(how: How) {
    run_c(
        "step_file",
        how,
        |d| vec![fixtures().into(), d.into()],
        PASSED,
    );
}

#[test]
fn step_file_meshes_a_fixture_and_refuses_bad_files() {
    step_file(How::Native);
}

#[test]
fn step_file_under_valgrind() {
    step_file(How::Valgrind);
}

/// dim 3 on a box (planar faces) and a ball (a callback sphere with a
/// contains callback). d = 0.2 is already the coarsest the unit sphere
/// allows (about a fifth of the radius), so valgrind runs the native case.
#[test]
fn volumes_through_callbacks() {
    run_c("volume", How::Native, |_| vec![], PASSED);
}

#[test]
fn volumes_under_valgrind() {
    run_c("volume", How::Valgrind, |_| vec![], PASSED);
}

/// Spacing plugins: the curvature plugin on a callback torus, and plugins
/// that cannot be used; coarser under valgrind (same checks).
fn plugin_spacing(how: How) {
    run_c(
        "plugin_spacing",
        how,
        |d| {
            let mut a = vec![
                plugin_lib("bubblemesh_plugin_curvature").into(),
                plugin_lib("bubblemesh_plugin_testbad").into(),
                d.into(),
            ];
            if how == How::Valgrind {
                a.push("0.04".into());
            }
            a
        },
        PASSED,
    );
}

#[test]
fn plugin_spacing_loads_the_curvature_plugin_and_refuses_bad_ones() {
    plugin_spacing(How::Native);
}

#[test]
fn plugin_spacing_under_valgrind() {
    plugin_spacing(How::Valgrind);
}

/// Re-meshing: the plate's state saved, loaded and re-meshed after its
/// hole moved (locally in a sphere, and continuously), cube.step re-meshed
/// in a corner box; far nodes kept bit for bit, the report's remesh
/// section; bad state files, a state of another model and bad regions
/// refused. Coarser under valgrind (same checks).
fn remesh(how: How) -> Option<tempfile::TempDir> {
    run_c(
        "remesh",
        how,
        |d| {
            let mut a: Vec<std::ffi::OsString> = vec![fixtures().into(), d.into()];
            if how == How::Valgrind {
                a.extend(os(&["0.08", "0.15"]));
            }
            a
        },
        PASSED,
    )
}

#[test]
fn remesh_from_a_saved_state_keeps_far_nodes_and_refuses_bad_states() {
    let Some(dir) = remesh(How::Native) else {
        return;
    };
    // the state file the C program saved is the command line's format:
    // the core reads it, and it holds the plate's 5 edges and its face
    let bytes = std::fs::read(dir.path().join("old.state")).unwrap();
    let state = bubblemesh_core::remesh::State::from_bytes(&bytes).unwrap();
    assert_eq!(state.entities.len(), 6);
    assert_eq!(state.spacing, "0.04");
    assert_eq!(state.source, "bm_model");
    assert!(state.entities.iter().all(|e| !e.bubbles.is_empty()));
}

#[test]
fn remesh_under_valgrind() {
    remesh(How::Valgrind);
}

/// Runs a Python ctypes example against the library; it must print
/// "checks passed" and write `out_name`, which is read back.
fn python_example(script: &str, out_name: &str) -> Option<bubblemesh_core::Mesh> {
    if !have("python3", "--version") {
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join(out_name);
    let stdout = run(
        Command::new("python3")
            .arg(manifest_dir().join("examples/python").join(script))
            .arg("--lib")
            .arg(lib_dir().join(so_name()))
            .arg("-o")
            .arg(&out),
        script,
    );
    assert!(stdout.contains("checks passed"), "{stdout}");
    Some(bubblemesh_io::read(&out).unwrap())
}

#[test]
fn python_ctypes_example() {
    if let Some(mesh) = python_example("mesh_plate.py", "plate.vtu") {
        assert!(mesh.triangles.len() > 50);
    }
}

/// The Python example meshing a CadQuery-exported part through
/// bm_mesh_step_file: a closed surface enclosing the manifest's CAD volume
/// within 1 %.
#[test]
fn python_step_example() {
    if let Some(mesh) = python_example("mesh_step.py", "part.msh") {
        assert!(mesh.triangles.len() > 500);
    }
}
