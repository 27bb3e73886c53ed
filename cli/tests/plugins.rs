//! `bubblemesh mesh --plugin LIB --plugin-arg KEY=VALUE` and
//! `--plugin-config FILE`: the curvature plugin gives the same mesh as the
//! built-in `--curvature`; bad plugins fail the run with a message naming
//! the library, never a crash.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_bubblemesh")
}

/// A plugin's shared library built for this test run (the plugins are
/// dev-dependencies, so cargo builds their cdylibs next to this test).
fn lib(crate_name: &str) -> PathBuf {
    let file = format!(
        "{}{crate_name}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap().to_path_buf();
    [deps.clone(), deps.parent().unwrap().to_path_buf()]
        .into_iter()
        .map(|d| d.join(&file))
        .find(|p| p.exists())
        .unwrap_or_else(|| panic!("{file} not found next to {}", exe.display()))
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples")
}

fn run(args: &[&str]) -> Output {
    Command::new(bin()).args(args).output().unwrap()
}

fn nodes(report: &Path) -> u64 {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    v["engine"]["nodes"].as_u64().unwrap()
}

#[test]
fn curvature_plugin_gives_the_builtin_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let input = examples().join("nurbs_patch.toml");
    let (r1, r2) = (dir.path().join("a.json"), dir.path().join("b.json"));
    let (o1, o2) = (dir.path().join("a.msh"), dir.path().join("b.msh"));
    let builtin = run(&[
        "mesh",
        input.to_str().unwrap(),
        "-o",
        o1.to_str().unwrap(),
        "-q",
        "--curvature",
        "0.002",
        "--report",
        r1.to_str().unwrap(),
    ]);
    assert!(builtin.status.success(), "{builtin:?}");
    let plug = lib("bubblemesh_plugin_curvature");
    let plugin = run(&[
        "mesh",
        input.to_str().unwrap(),
        "-o",
        o2.to_str().unwrap(),
        "-q",
        "--plugin",
        plug.to_str().unwrap(),
        "--plugin-arg",
        "eps=0.002",
        "--report",
        r2.to_str().unwrap(),
    ]);
    assert!(plugin.status.success(), "{plugin:?}");
    assert_eq!(nodes(&r1), nodes(&r2), "same spacing, same mesh");
    assert_eq!(std::fs::read(&o1).unwrap(), std::fs::read(&o2).unwrap());

    // the same through a configuration file, combined with --size by min
    let cfg = dir.path().join("plugins.toml");
    std::fs::write(
        &cfg,
        format!(
            "[[plugin]]\npath = {:?}\nargs = {{ eps = 0.002 }}\n",
            plug.to_str().unwrap()
        ),
    )
    .unwrap();
    let r3 = dir.path().join("c.json");
    let o3 = dir.path().join("c.msh");
    let both = run(&[
        "mesh",
        input.to_str().unwrap(),
        "-o",
        o3.to_str().unwrap(),
        "-q",
        "--plugin-config",
        cfg.to_str().unwrap(),
        "--size",
        "0.03",
        "--report",
        r3.to_str().unwrap(),
    ]);
    assert!(both.status.success(), "{both:?}");
    assert!(
        nodes(&r3) > nodes(&r2),
        "min with a finer --size adds nodes"
    );
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn bad_plugins_fail_the_run_with_the_library_named() {
    let dir = tempfile::tempdir().unwrap();
    let input = examples().join("square.toml");
    let out = dir.path().join("x.msh");
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    let bad = lib("bubblemesh_plugin_testbad");
    let bad = bad.to_str().unwrap();
    for mode in ["nan", "negative", "panic"] {
        let r = run(&[
            "mesh",
            i,
            "-o",
            o,
            "-q",
            "--size",
            "0.1",
            "--plugin",
            bad,
            "--plugin-arg",
            &format!("mode={mode}"),
            "--plugin-arg",
            "after=10",
        ]);
        assert_eq!(r.status.code(), Some(1), "{mode}: {r:?}");
        let e = stderr(&r);
        assert!(
            e.contains("libbubblemesh_plugin_testbad") && e.contains("square.toml"),
            "{mode}: {e}"
        );
        assert!(!out.exists(), "{mode}: no output on failure");
        eprintln!("{mode}: {e}");
    }
    let r = run(&["mesh", i, "-o", o, "--plugin", "/no/such/lib.so"]);
    assert_eq!(r.status.code(), Some(1));
    assert!(
        stderr(&r).contains("/no/such/lib.so: no such file"),
        "{}",
        stderr(&r)
    );
    let r = run(&["mesh", i, "-o", o, "--plugin-arg", "eps=1", "--plugin", bad]);
    assert_eq!(r.status.code(), Some(1));
    assert!(stderr(&r).contains("before any --plugin"), "{}", stderr(&r));
    let r = run(&[
        "mesh",
        i,
        "-o",
        o,
        "--plugin",
        bad,
        "--plugin-arg",
        "mode=bogus",
    ]);
    assert_eq!(r.status.code(), Some(1));
    assert!(
        stderr(&r).contains("unknown mode 'bogus'"),
        "{}",
        stderr(&r)
    );
}
