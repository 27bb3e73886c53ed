//! Loading plugins: the shipped ones load; each kind of bad library or
//! misbehaving plugin gives a clear error naming the file, and never a
//! crash; batches are one call; calls from several threads agree.

mod common;

use std::sync::Arc;

use bubblemesh_analytic::parse_domain;
use bubblemesh_core::spacing::{Constant, MinOf, Spacing, SpacingQuery};
use bubblemesh_core::{mesh_model, EntityRef, Options, P3};
use bubblemesh_plugin_host::{Plugin, PluginError, PluginSpacing};
use common::*;

const SQUARE: &str = r#"
format = "bubblemesh-domain 1"
[[face]]
name = "square"
outer = { polygon = [[0, 0], [1, 0], [1, 1], [0, 1]] }
"#;

fn square() -> Arc<bubblemesh_core::Model> {
    Arc::new(parse_domain(SQUARE, "square.toml").unwrap())
}

fn q(x: f64, y: f64) -> SpacingQuery {
    SpacingQuery {
        point: P3::new(x, y, 0.0),
        entity: EntityRef::new(2, 0),
        params: [x, y],
    }
}

#[test]
fn shipped_plugins_load_with_name_and_description() {
    for (lib, name) in [
        ("bubblemesh_plugin_curvature", "curvature"),
        ("bubblemesh_plugin_view", "view"),
        ("bubblemesh_plugin_sizefield", "sizefield"),
        ("bubblemesh_plugin_template", "template-radial"),
    ] {
        let p = Plugin::load(&plugin_lib(lib)).unwrap();
        assert_eq!(p.name(), name);
        assert!(p.thread_safe(), "{name}: Rust plugins are thread-safe");
        assert!(p.description().contains("args"), "{}", p.description());
    }
}

#[test]
fn template_plugin_computes_its_formula() {
    let p = Plugin::load(&plugin_lib("bubblemesh_plugin_template")).unwrap();
    let s = PluginSpacing::new(
        p,
        &args(&[("center", "0,0,0"), ("d0", "0.01"), ("growth", "0.5")]),
        square(),
    )
    .unwrap();
    assert!((s.spacing(&q(0.3, 0.4)) - (0.01 + 0.5 * 0.5)).abs() < 1e-12);
}

#[test]
fn missing_file_and_non_library_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.so");
    let e = Plugin::load(&missing).unwrap_err();
    assert!(matches!(e, PluginError::Missing { .. }));
    assert!(e.to_string().contains("nope.so") && e.to_string().contains("no such file"));

    // a directory named like a library: said so, not "no such file"
    let d = dir.path().join("some_dir.so");
    std::fs::create_dir(&d).unwrap();
    let e = Plugin::load(&d).unwrap_err();
    assert!(matches!(e, PluginError::IsDirectory { .. }), "{e}");
    assert!(
        e.to_string().contains("some_dir.so")
            && e.to_string()
                .contains("is a directory, not a shared library"),
        "{e}"
    );

    let text = dir.path().join("text.so");
    std::fs::write(&text, "this is not a shared library\n").unwrap();
    let e = Plugin::load(&text).unwrap_err();
    assert!(matches!(e, PluginError::NotLoadable { .. }), "{e}");
    assert!(e.to_string().contains("text.so"), "{e}");
}

#[test]
fn c_libraries_that_are_not_plugins_are_refused() {
    if !have_cc() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let src = |f: &str| plugins_dir().join("host/tests/c").join(f);
    let lib = dir.path().join("libnot.so");
    cc(&[src("not_a_plugin.c")], &lib, true, &[]);
    let e = Plugin::load(&lib).unwrap_err();
    assert!(matches!(e, PluginError::NotAPlugin { .. }), "{e}");
    assert!(e.to_string().contains("bubblemesh_plugin_entry"), "{e}");

    let cases: [(&str, &str); 5] = [
        ("BAD=1", "ABI version 99"),
        (
            "BAD=2",
            "sizeof(BmQuery) is 168 bytes in the plugin, 176 here",
        ),
        ("BAD=3", "not the magic"),
        ("BAD=4", "returned NULL"),
        ("BAD=5", "NULL init, spacing or destroy"),
    ];
    for (def, want) in cases {
        let lib = dir.path().join(format!("lib{}.so", def.replace('=', "")));
        cc(&[src("bad_table.c")], &lib, true, &[def]);
        let e = Plugin::load(&lib).unwrap_err().to_string();
        assert!(
            e.contains(want) && e.contains(lib.to_str().unwrap()),
            "{def}: {e}"
        );
        eprintln!("{def}: {e}");
    }
    // the good table of the same file loads
    let lib = dir.path().join("libgood.so");
    cc(&[src("bad_table.c")], &lib, true, &["BAD=0"]);
    Plugin::load(&lib).unwrap();
}

fn testbad(mode: &str) -> Result<PluginSpacing, PluginError> {
    let p = Plugin::load(&plugin_lib("bubblemesh_plugin_testbad")).unwrap();
    PluginSpacing::new(p, &args(&[("mode", mode)]), square())
}

#[test]
fn bad_arguments_and_a_panic_in_init_are_errors() {
    let e = match testbad("panic_init") {
        Err(e) => e.to_string(),
        Ok(_) => panic!("init panicked but was accepted"),
    };
    assert!(
        e.contains("panicked in init") && e.contains("testbad"),
        "{e}"
    );
    let p = Plugin::load(&plugin_lib("bubblemesh_plugin_curvature")).unwrap();
    let e = PluginSpacing::new(p.clone(), &args(&[("eps", "-1")]), square())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("eps=-1") && e.contains("libbubblemesh_plugin_curvature"),
        "{e}"
    );
    let e = PluginSpacing::new(p.clone(), &args(&[("epsilon", "0.1")]), square())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("unknown argument 'epsilon'") && e.contains("known: eps"),
        "{e}"
    );
    let e = PluginSpacing::new(p, &[], square())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("eps is required"), "{e}");
}

#[test]
fn panics_nan_zero_negative_and_failures_are_caught() {
    for (mode, want) in [
        ("panic", "panicked: testbad: deliberate panic in spacing"),
        ("nan", "returned the spacing NaN"),
        ("zero", "returned the spacing 0"),
        ("negative", "returned the spacing -0.1"),
        ("inf", "returned the spacing inf"),
        ("fail", "testbad: deliberate failure"),
    ] {
        let s = testbad(mode).unwrap();
        let d = s.spacing(&q(0.25, 0.5));
        assert!(d.is_nan(), "{mode}: {d}");
        let f = s.failure().expect("failure kept").to_string();
        assert!(f.contains(want), "{mode}: {f}");
        assert!(
            f.contains("(0.25, 0.5, 0)") && f.contains("face"),
            "{mode}: {f}"
        );
        // later calls answer NaN without calling the plugin again
        assert!(s.spacing(&q(0.5, 0.5)).is_nan());
        assert_eq!(s.failure().unwrap(), f);
    }
}

#[test]
fn meshing_stops_on_a_bad_value_even_behind_a_minimum() {
    let model = square();
    let p = Plugin::load(&plugin_lib("bubblemesh_plugin_testbad")).unwrap();
    // fine for the first 20 points, then NaN
    let s = PluginSpacing::new(
        p.clone(),
        &args(&[("mode", "nan"), ("after", "20"), ("d", "0.1")]),
        model.clone(),
    )
    .unwrap();
    let r = mesh_model(&model, &s, &Options::default());
    assert!(r.is_err(), "meshing went on with NaN spacing");
    assert!(s.failure().unwrap().contains("NaN"));
    // min(NaN, c) = c hides the NaN from the engine: failure() still tells
    let s = PluginSpacing::new(
        p,
        &args(&[("mode", "negative"), ("after", "20")]),
        model.clone(),
    )
    .unwrap();
    let both = MinOf(vec![Box::new(s.clone()), Box::new(Constant(0.1))]);
    let _ = mesh_model(&model, &both, &Options::default());
    assert!(s.failure().unwrap().contains("-0.1"));
}

#[test]
fn a_batch_is_one_call() {
    let s = testbad("fail").unwrap();
    let qs: Vec<SpacingQuery> = (0..1000).map(|i| q(i as f64 / 1000.0, 0.5)).collect();
    let mut out = vec![0.0; qs.len()];
    s.spacing_batch(&qs, &mut out);
    assert!(out.iter().all(|d| d.is_nan()));
    let f = s.failure().unwrap();
    assert!(f.contains("batch of 1000 points"), "{f}");
}

#[test]
fn several_threads_get_the_serial_answers() {
    let model = square();
    let p = Plugin::load(&plugin_lib("bubblemesh_plugin_template")).unwrap();
    let s = PluginSpacing::new(
        p,
        &args(&[("center", "0.5,0.5,0"), ("d0", "0.01"), ("growth", "0.3")]),
        model,
    )
    .unwrap();
    let qs: Vec<SpacingQuery> = (0..4000)
        .map(|i| q((i % 63) as f64 / 63.0, (i / 63) as f64 / 64.0))
        .collect();
    let mut serial = vec![0.0; qs.len()];
    s.spacing_batch(&qs, &mut serial);
    std::thread::scope(|sc| {
        for t in 0..4 {
            let (s, qs, serial) = (&s, &qs, &serial);
            sc.spawn(move || {
                for (k, chunk) in qs.chunks(37).enumerate() {
                    let mut out = vec![0.0; chunk.len()];
                    if (k + t) % 2 == 0 {
                        s.spacing_batch(chunk, &mut out);
                    } else {
                        for (o, q) in out.iter_mut().zip(chunk) {
                            *o = s.spacing(q);
                        }
                    }
                    assert_eq!(&out[..], &serial[k * 37..k * 37 + chunk.len()]);
                }
            });
        }
    });
    assert!(s.failure().is_none());
}
