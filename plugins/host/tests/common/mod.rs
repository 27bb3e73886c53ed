//! Shared by the plugin tests: where cargo put the plugins' shared
//! libraries, and compiling C plugins with the system compiler.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The shared library of the workspace plugin crate `crate_name` (e.g.
/// "bubblemesh_plugin_curvature") that cargo built for this test run: the
/// plugins are dev-dependencies of this crate, so their cdylibs sit next to
/// the test executable (target/<profile>/deps).
pub fn plugin_lib(crate_name: &str) -> PathBuf {
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
    panic!(
        "{file} not found next to {} (is crate-type cdylib set?)",
        exe.display()
    );
}

/// Whether the C compiler runs; panics under CI (it must), else skips.
pub fn have_cc() -> bool {
    let ok = Command::new("cc")
        .arg("--version")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ok {
        if std::env::var_os("CI").is_some() {
            panic!("cc is required under CI but does not run");
        }
        eprintln!("SKIP: cc not available");
    }
    ok
}

pub fn plugins_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Compiles C sources into `out` (a shared library when `shared`, else an
/// executable) against plugins/c-example/bubblemesh_plugin.h.
pub fn cc(sources: &[PathBuf], out: &Path, shared: bool, defines: &[&str]) {
    let mut c = Command::new("cc");
    c.args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-O2"])
        .arg("-I")
        .arg(plugins_dir().join("c-example"));
    if shared {
        c.args(["-shared", "-fPIC"]);
    }
    for d in defines {
        c.arg(format!("-D{d}"));
    }
    c.args(sources).arg("-o").arg(out).arg("-lm");
    let o = c.output().expect("cannot run cc");
    assert!(
        o.status.success(),
        "cc failed: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

pub const BUMP: &str = r#"
format = "bubblemesh-domain 1"
[[surface]]
name = "bump"
nurbs = { degree = [3, 3], points = [
  [[0, 0, 0], [0, 0.33, 0], [0, 0.67, 0], [0, 1, 0]],
  [[0.33, 0, 0], [0.33, 0.33, 0.6], [0.33, 0.67, 0.1], [0.33, 1, 0]],
  [[0.67, 0, 0], [0.67, 0.33, 0.1], [0.67, 0.67, 0.0], [0.67, 1, 0]],
  [[1, 0, 0], [1, 0.33, 0], [1, 0.67, 0], [1, 1, 0]] ] }
"#;

pub fn args(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}
