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

#[test]
fn torus_and_plate_through_callbacks() {
    if !have("cc", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("torus_plate", dir.path(), false);
    let msh = dir.path().join("torus_plate.msh");
    let stdout = run(Command::new(&exe).arg(&msh), "torus_plate");
    assert!(stdout.contains("all checks passed"), "{stdout}");
    // the file it wrote reads back with the same entities
    let mesh = bubblemesh_io::read(&msh).unwrap();
    let faces: std::collections::BTreeSet<u32> =
        mesh.triangles.iter().map(|t| t.entity.id).collect();
    assert_eq!(faces.into_iter().collect::<Vec<_>>(), vec![0, 1]);
}

#[test]
fn torus_and_plate_under_valgrind() {
    if !have("cc", "--version") || !have("valgrind", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("torus_plate", dir.path(), false);
    // a coarser spacing keeps valgrind's run short; the checks are the same
    let stdout = run(valgrind(&exe).args(["-d", "0.15"]), "valgrind torus_plate");
    assert!(stdout.contains("all checks passed"), "{stdout}");
}

#[test]
fn torus_and_plate_linked_statically() {
    if !have("cc", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("torus_plate", dir.path(), true);
    let stdout = run(
        Command::new(&exe).args(["-d", "0.15"]),
        "torus_plate (static)",
    );
    assert!(stdout.contains("all checks passed"), "{stdout}");
}

#[test]
fn failing_callbacks_and_bad_arguments_give_codes_and_messages() {
    if !have("cc", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("callback_errors", dir.path(), false);
    let stdout = run(&mut Command::new(&exe), "callback_errors");
    assert!(stdout.contains("all cases behaved"), "{stdout}");
}

#[test]
fn failing_callbacks_under_valgrind() {
    if !have("cc", "--version") || !have("valgrind", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("callback_errors", dir.path(), false);
    let stdout = run(&mut valgrind(&exe), "valgrind callback_errors");
    assert!(stdout.contains("all cases behaved"), "{stdout}");
}

#[test]
fn python_ctypes_example() {
    if !have("python3", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plate.vtu");
    let script = manifest_dir().join("examples/python/mesh_plate.py");
    let stdout = run(
        Command::new("python3")
            .arg(&script)
            .arg("--lib")
            .arg(lib_dir().join(so_name()))
            .arg("-o")
            .arg(&out),
        "mesh_plate.py",
    );
    assert!(stdout.contains("checks passed"), "{stdout}");
    let mesh = bubblemesh_io::read(&out).unwrap();
    assert!(mesh.triangles.len() > 50);
}

/// The STEP shortcut: cube.step meshed into a closed surface and into
/// tetrahedra; missing, garbage, truncated and unsupported files refused.
fn step_file(under_valgrind: bool) {
    if !have("cc", "--version") || (under_valgrind && !have("valgrind", "--version")) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("step_file", dir.path(), false);
    let mut cmd = if under_valgrind {
        valgrind(&exe)
    } else {
        Command::new(&exe)
    };
    let stdout = run(cmd.arg(fixtures()).arg(dir.path()), "step_file");
    assert!(stdout.contains("all checks passed"), "{stdout}");
}

#[test]
fn step_file_meshes_a_fixture_and_refuses_bad_files() {
    step_file(false);
}

#[test]
fn step_file_under_valgrind() {
    step_file(true);
}

/// dim 3 on a box (planar faces) and a ball (a callback sphere with a
/// contains callback).
#[test]
fn volumes_through_callbacks() {
    if !have("cc", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("volume", dir.path(), false);
    let stdout = run(&mut Command::new(&exe), "volume");
    assert!(stdout.contains("all checks passed"), "{stdout}");
}

#[test]
fn volumes_under_valgrind() {
    if !have("cc", "--version") || !have("valgrind", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("volume", dir.path(), false);
    // d = 0.2 is already the coarsest the unit sphere allows (about a fifth
    // of the radius), so valgrind runs the native case
    let stdout = run(&mut valgrind(&exe), "valgrind volume");
    assert!(stdout.contains("all checks passed"), "{stdout}");
}

/// Spacing plugins: the curvature plugin on a callback torus, and plugins
/// that cannot be used.
fn plugin_spacing(under_valgrind: bool) {
    if !have("cc", "--version") || (under_valgrind && !have("valgrind", "--version")) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = compile("plugin_spacing", dir.path(), false);
    let mut cmd = if under_valgrind {
        valgrind(&exe)
    } else {
        Command::new(&exe)
    };
    cmd.arg(plugin_lib("bubblemesh_plugin_curvature"))
        .arg(plugin_lib("bubblemesh_plugin_testbad"))
        .arg(dir.path());
    if under_valgrind {
        // coarser under valgrind (same checks)
        cmd.arg("0.04");
    }
    let stdout = run(&mut cmd, "plugin_spacing");
    assert!(stdout.contains("all checks passed"), "{stdout}");
}

#[test]
fn plugin_spacing_loads_the_curvature_plugin_and_refuses_bad_ones() {
    plugin_spacing(false);
}

#[test]
fn plugin_spacing_under_valgrind() {
    plugin_spacing(true);
}

/// The Python example meshing a CadQuery-exported part through
/// bm_mesh_step_file: a closed surface enclosing the manifest's CAD volume
/// within 1 %.
#[test]
fn python_step_example() {
    if !have("python3", "--version") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("part.msh");
    let script = manifest_dir().join("examples/python/mesh_step.py");
    let stdout = run(
        Command::new("python3")
            .arg(&script)
            .arg("--lib")
            .arg(lib_dir().join(so_name()))
            .arg("-o")
            .arg(&out),
        "mesh_step.py",
    );
    assert!(stdout.contains("checks passed"), "{stdout}");
    let mesh = bubblemesh_io::read(&out).unwrap();
    assert!(mesh.triangles.len() > 500);
}
