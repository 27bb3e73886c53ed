//! The C plugin of plugins/c-example, compiled with the system C compiler
//! against the generated header, loads and gives the Rust view plugin's
//! values; the C compiler lays the ABI structs out as Rust does.

mod common;

use std::process::Command;
use std::sync::Arc;

use bubblemesh_analytic::parse_domain;
use bubblemesh_core::spacing::{Spacing, SpacingQuery};
use bubblemesh_core::{EntityRef, P3};
use bubblemesh_plugin_api::{BmArg, BmInitInfo, BmPlugin, BmQuery};
use bubblemesh_plugin_host::{Plugin, PluginSpacing};
use common::*;
use std::mem::{offset_of, size_of};

#[test]
fn c_compiler_sees_the_rust_layout() {
    if !have_cc() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = dir.path().join("layout");
    cc(
        &[plugins_dir().join("host/tests/c/layout.c")],
        &exe,
        false,
        &[],
    );
    let out = Command::new(&exe).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let want: Vec<(&str, usize)> = vec![
        ("sizeof(BmQuery)", size_of::<BmQuery>()),
        ("offsetof(BmQuery, point)", offset_of!(BmQuery, point)),
        ("offsetof(BmQuery, params)", offset_of!(BmQuery, params)),
        ("offsetof(BmQuery, dim)", offset_of!(BmQuery, dim)),
        ("offsetof(BmQuery, id)", offset_of!(BmQuery, id)),
        ("offsetof(BmQuery, geom)", offset_of!(BmQuery, geom)),
        ("offsetof(BmQuery, reserved)", offset_of!(BmQuery, reserved)),
        ("offsetof(BmQuery, tangent)", offset_of!(BmQuery, tangent)),
        (
            "offsetof(BmQuery, curve_curvature)",
            offset_of!(BmQuery, curve_curvature),
        ),
        ("offsetof(BmQuery, normal)", offset_of!(BmQuery, normal)),
        ("offsetof(BmQuery, k1)", offset_of!(BmQuery, k1)),
        ("offsetof(BmQuery, k2)", offset_of!(BmQuery, k2)),
        ("offsetof(BmQuery, dir1)", offset_of!(BmQuery, dir1)),
        ("offsetof(BmQuery, dir2)", offset_of!(BmQuery, dir2)),
        ("sizeof(BmPlugin)", size_of::<BmPlugin>()),
        ("offsetof(BmPlugin, flags)", offset_of!(BmPlugin, flags)),
        (
            "offsetof(BmPlugin, init_info_size)",
            offset_of!(BmPlugin, init_info_size),
        ),
        ("offsetof(BmPlugin, name)", offset_of!(BmPlugin, name)),
        (
            "offsetof(BmPlugin, description)",
            offset_of!(BmPlugin, description),
        ),
        ("offsetof(BmPlugin, init)", offset_of!(BmPlugin, init)),
        ("offsetof(BmPlugin, spacing)", offset_of!(BmPlugin, spacing)),
        ("offsetof(BmPlugin, destroy)", offset_of!(BmPlugin, destroy)),
        ("sizeof(BmInitInfo)", size_of::<BmInitInfo>()),
        (
            "offsetof(BmInitInfo, bbox_min)",
            offset_of!(BmInitInfo, bbox_min),
        ),
        (
            "offsetof(BmInitInfo, bbox_max)",
            offset_of!(BmInitInfo, bbox_max),
        ),
        (
            "offsetof(BmInitInfo, model_size)",
            offset_of!(BmInitInfo, model_size),
        ),
        ("sizeof(BmArg)", size_of::<BmArg>()),
        ("offsetof(BmArg, value)", offset_of!(BmArg, value)),
    ];
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), want.len(), "{text}");
    for (line, (name, v)) in lines.iter().zip(&want) {
        assert_eq!(*line, format!("{name} {v}"), "C and Rust disagree");
    }
}

#[test]
fn c_plugin_loads_and_matches_the_rust_view_plugin() {
    if !have_cc() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let so = dir.path().join("libview_c.so");
    cc(
        &[plugins_dir().join("c-example/view_plugin.c")],
        &so,
        true,
        &[],
    );
    let c = Plugin::load(&so).unwrap();
    assert_eq!(c.name(), "view-c");
    assert!(
        !c.thread_safe(),
        "the C example declares itself not thread-safe"
    );
    let model = Arc::new(parse_domain(BUMP, "bump.toml").unwrap());
    let a = args(&[
        ("viewpoint", "0.2,-1,2"),
        ("factor", "0.05"),
        ("d_min", "0.01"),
    ]);
    let cs = PluginSpacing::new(c.clone(), &a, model.clone()).unwrap();
    let rust = Plugin::load(&plugin_lib("bubblemesh_plugin_view")).unwrap();
    let rs = PluginSpacing::new(rust, &a, model.clone()).unwrap();
    let qs: Vec<SpacingQuery> = (0..500)
        .map(|i| {
            let (u, v) = ((i % 25) as f64 / 24.0, (i / 25) as f64 / 19.0);
            SpacingQuery {
                point: model.faces[0].surface.point(u, v),
                entity: EntityRef::new(2, 0),
                params: [u, v],
            }
        })
        .collect();
    let (mut x, mut y) = (vec![0.0; qs.len()], vec![0.0; qs.len()]);
    cs.spacing_batch(&qs, &mut x);
    rs.spacing_batch(&qs, &mut y);
    for (a, b) in x.iter().zip(&y) {
        assert!((a - b).abs() <= 1e-14 * b, "C {a} vs Rust {b}");
    }
    // not thread-safe: the host serialises; the answers stay right
    std::thread::scope(|s| {
        for _ in 0..4 {
            let (cs, qs, y) = (&cs, &qs, &y);
            s.spawn(move || {
                for (q, want) in qs.iter().zip(y) {
                    assert!((cs.spacing(q) - want).abs() <= 1e-14 * want);
                }
            });
        }
    });
    assert!(cs.failure().is_none());
    // its own argument checking reaches the user with the path
    let e = PluginSpacing::new(c, &args(&[("viewpoint", "1,2")]), model)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("libview_c.so") && e.contains("viewpoint=1,2"),
        "{e}"
    );
    let _ = P3::origin();
}
