//! What the shipped plugins compute: the curvature plugin equals the
//! built-in curvature spacing and holds the chord error (≤ 1.1 ε, measured);
//! the view plugin evens out the projected size of triangles; the size-field
//! plugin interpolates a previous mesh's node values.

mod common;

use std::sync::Arc;

use bubblemesh_analytic::parse_domain;
use bubblemesh_core::curvature::Curvature;
use bubblemesh_core::spacing::{Constant, Spacing, SpacingQuery};
use bubblemesh_core::{mesh_model, EntityRef, Mesh, Model, Options, Surface, P3};
use bubblemesh_plugin_host::{Plugin, PluginSpacing};
use common::*;

fn curvature_plugin(model: &Arc<Model>, a: &[(&str, &str)]) -> PluginSpacing {
    let p = Plugin::load(&plugin_lib("bubblemesh_plugin_curvature")).unwrap();
    PluginSpacing::new(p, &args(a), model.clone()).unwrap()
}

/// Queries on every vertex, along every edge and over every face.
fn samples(model: &Model) -> Vec<SpacingQuery> {
    let mut qs = Vec::new();
    for (i, v) in model.vertices.iter().enumerate() {
        qs.push(SpacingQuery {
            point: v.point,
            entity: EntityRef::new(0, i as u32),
            params: [0.0; 2],
        });
    }
    for (i, e) in model.edges.iter().enumerate() {
        for k in 0..=20 {
            let t = e.t0 + (e.t1 - e.t0) * k as f64 / 20.0;
            qs.push(SpacingQuery {
                point: e.curve.point(t),
                entity: EntityRef::new(1, i as u32),
                params: [t, 0.0],
            });
        }
    }
    for (i, f) in model.faces.iter().enumerate() {
        let (u, v) = f.surface.domain();
        for a in 0..=20 {
            for b in 0..=20 {
                let uv = [
                    u[0] + (u[1] - u[0]) * a as f64 / 20.0,
                    v[0] + (v[1] - v[0]) * b as f64 / 20.0,
                ];
                qs.push(SpacingQuery {
                    point: f.surface.point(uv[0], uv[1]),
                    entity: EntityRef::new(2, i as u32),
                    params: uv,
                });
            }
        }
    }
    qs
}

#[test]
fn curvature_plugin_equals_the_builtin_everywhere() {
    let torus = "format = \"bubblemesh-domain 1\"\n[[surface]]\nname = \"t\"\n\
                 torus = { center = [0, 0, 0], axis = [0, 0, 1], major = 1, minor = 0.3 }\n";
    let cyl = std::fs::read_to_string(plugins_dir().join("../examples/cylinder.toml")).unwrap();
    for (text, name) in [(torus, "torus"), (BUMP, "bump"), (cyl.as_str(), "cylinder")] {
        let model = Arc::new(parse_domain(text, name).unwrap());
        let builtin = Curvature::new(model.clone(), 0.001, 0.002, 0.2);
        let plugin = curvature_plugin(
            &model,
            &[("eps", "0.001"), ("d_min", "0.002"), ("d_max", "0.2")],
        );
        let qs = samples(&model);
        let mut out = vec![0.0; qs.len()];
        plugin.spacing_batch(&qs, &mut out);
        let mut varied = (f64::INFINITY, 0.0f64);
        for (q, d) in qs.iter().zip(&out) {
            let b = builtin.spacing(q);
            assert!(
                (d - b).abs() <= 1e-12 * b,
                "{name} {:?}: plugin {d} vs built-in {b}",
                q.entity
            );
            varied = (varied.0.min(b), varied.1.max(b));
        }
        // (constant on the torus and the cylinder: |k1| = 1/minor radius)
        if name == "bump" {
            assert!(
                varied.1 > 1.5 * varied.0,
                "{name}: the field should vary: {varied:?}"
            );
        }
    }
}

/// Largest distance from sample points of every triangle to the surface.
fn max_deviation(mesh: &Mesh, s: &dyn Surface) -> f64 {
    let mut worst: f64 = 0.0;
    for t in &mesh.triangles {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos.coords);
        let hint = mesh.nodes[t.nodes[0] as usize].params;
        for (a, b) in [
            (1.0 / 3.0, 1.0 / 3.0),
            (0.5, 0.5),
            (0.5, 0.0),
            (0.0, 0.5),
            (0.25, 0.5),
            (0.5, 0.25),
            (0.25, 0.25),
        ] {
            let q = P3::from(p[0] * (1.0 - a - b) + p[1] * a + p[2] * b);
            let uv = s.inverse(&q, Some(hint)).expect("closest point");
            worst = worst.max((s.point(uv[0], uv[1]) - q).norm());
        }
    }
    worst
}

#[test]
fn curvature_plugin_holds_the_chord_error() {
    let model = Arc::new(parse_domain(BUMP, "bump.toml").unwrap());
    let eps = 0.001;
    let s = curvature_plugin(
        &model,
        &[("eps", "0.001"), ("d_min", "0.002"), ("d_max", "0.2")],
    );
    let (mesh, _) = mesh_model(&model, &s, &Options::default()).unwrap();
    assert!(s.failure().is_none());
    let dev = max_deviation(&mesh, model.faces[0].surface.as_ref());
    eprintln!(
        "curvature plugin, eps {eps}: {} triangles, max distance to the surface {dev:.3e} = {:.3} eps",
        mesh.triangles.len(),
        dev / eps
    );
    assert!(dev <= 1.1 * eps, "deviation {dev} > 1.1 eps");
}

/// Per triangle: its angular size seen from `v` (√area / distance of the
/// centroid, what eq. 4.6.2 equalises) and its solid angle's square root
/// (which also counts foreshortening).
fn projected_sizes(mesh: &Mesh, v: P3) -> (Vec<f64>, Vec<f64>) {
    let mut ang = Vec::new();
    let mut solid = Vec::new();
    for t in &mesh.triangles {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
        let area = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
        let c = P3::from((p[0].coords + p[1].coords + p[2].coords) / 3.0);
        ang.push(area.sqrt() / (c - v).norm());
        let d = p.map(|q| (q - v).normalize());
        let sa = 0.5 * (d[1] - d[0]).cross(&(d[2] - d[0])).norm();
        solid.push(sa.sqrt());
    }
    (ang, solid)
}

/// p95 / p5.
fn spread(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    let at = |f: f64| x[((x.len() - 1) as f64 * f).round() as usize];
    at(0.95) / at(0.05)
}

#[test]
fn view_plugin_evens_the_projected_size() {
    let strip = "format = \"bubblemesh-domain 1\"\n[[face]]\nname = \"strip\"\n\
                 outer = { polygon = [[0, 0], [4, 0], [4, 1], [0, 1]] }\n";
    let model = Arc::new(parse_domain(strip, "strip.toml").unwrap());
    let v = P3::new(-0.5, 0.5, 0.5);
    let p = Plugin::load(&plugin_lib("bubblemesh_plugin_view")).unwrap();
    let s = PluginSpacing::new(
        p,
        &args(&[("viewpoint", "-0.5,0.5,0.5"), ("factor", "0.06")]),
        model.clone(),
    )
    .unwrap();
    let (mesh, _) = mesh_model(&model, &s, &Options::default()).unwrap();
    let (ang, solid) = projected_sizes(&mesh, v);
    let (sv, ss) = (spread(ang), spread(solid));
    // a uniform mesh with the same number of nodes
    let area = 4.0;
    let d = (area / (mesh.nodes.len() as f64 * 0.866)).sqrt();
    let (uni, _) = mesh_model(&model, &Constant(d), &Options::default()).unwrap();
    let (ua, us) = projected_sizes(&uni, v);
    let (su, sus) = (spread(ua), spread(us));
    eprintln!(
        "view plugin: {} nodes, spread (p95/p5) of angular size {sv:.2}, of sqrt(solid angle) {ss:.2}; \
         uniform d = {d:.4} ({} nodes): {su:.2}, {sus:.2}",
        mesh.nodes.len(),
        uni.nodes.len()
    );
    assert!(sv < 1.6, "view spacing: angular sizes spread {sv}");
    assert!(su > 2.0 * sv, "uniform spread {su} vs view {sv}");
}

#[test]
fn sizefield_plugin_interpolates_node_values() {
    let square = "format = \"bubblemesh-domain 1\"\n[[face]]\nname = \"sq\"\n\
                  outer = { polygon = [[0, 0], [1, 0], [1, 1], [0, 1]] }\n";
    let model = Arc::new(parse_domain(square, "sq.toml").unwrap());
    let (bg, _) = mesh_model(&model, &Constant(0.1), &Options::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let f = |p: &P3| 0.02 + 0.05 * p.x + 0.03 * p.y;
    for ext in ["msh", "vtu"] {
        let path = dir.path().join(format!("bg.{ext}"));
        bubblemesh_io::write(&bg, &path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let text = if ext == "msh" {
            let mut s = format!(
                "$NodeData\n1\n\"size\"\n1\n0.0\n3\n0\n1\n{}\n",
                bg.nodes.len()
            );
            for (i, n) in bg.nodes.iter().enumerate() {
                s.push_str(&format!("{} {:.17e}\n", i + 1, f(&n.pos)));
            }
            s.push_str("$EndNodeData\n");
            text + &s
        } else {
            let vals: Vec<String> = bg
                .nodes
                .iter()
                .map(|n| format!("{:.17e}", f(&n.pos)))
                .collect();
            text.replacen(
                "<PointData>",
                &format!(
                    "<PointData>\n<DataArray type=\"Float64\" Name=\"size\" format=\"ascii\">{}</DataArray>",
                    vals.join(" ")
                ),
                1,
            )
        };
        std::fs::write(&path, text).unwrap();
        let p = Plugin::load(&plugin_lib("bubblemesh_plugin_sizefield")).unwrap();
        let s = PluginSpacing::new(
            p.clone(),
            &args(&[("mesh", path.to_str().unwrap())]),
            model.clone(),
        )
        .unwrap();
        for k in 0..200 {
            let (x, y) = ((k % 17) as f64 / 16.0, (k / 17) as f64 / 11.8);
            let q = SpacingQuery {
                point: P3::new(x, y.min(1.0), 0.0),
                entity: EntityRef::new(2, 0),
                params: [x, y],
            };
            let (d, want) = (s.spacing(&q), f(&q.point));
            assert!((d - want).abs() < 1e-9, "{ext}: {d} vs {want} at {x}, {y}");
        }
        // errors name the file and what is missing
        let e = PluginSpacing::new(
            p.clone(),
            &args(&[("mesh", path.to_str().unwrap()), ("field", "nope")]),
            model.clone(),
        )
        .err()
        .unwrap()
        .to_string();
        assert!(
            e.contains("no node field 'nope'") && e.contains("size"),
            "{e}"
        );
    }
}
