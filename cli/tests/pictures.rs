//! Pictures from the command line: `-o` .svg/.png/.html, --color, --view,
//! --bubbles, --plots, --frames, --animate and `bubblemesh draw`.

#[path = "../../viz/tests/common/chromium.rs"]
mod chromium;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use chromium::{decode_png, ink};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bubblemesh"))
        .args(args)
        .output()
        .expect("run bubblemesh")
}

fn ok(args: &[&str]) -> String {
    let o = run(args);
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {e}");
    e
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Triangles in the report of a run.
fn report_triangles(report: &Path) -> usize {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    v["quality"]["counts"]["triangles"].as_u64().unwrap() as usize
}

fn polygons(svg: &Path) -> (usize, usize, std::collections::HashSet<String>) {
    let text = std::fs::read_to_string(svg).unwrap();
    let doc = roxmltree::Document::parse(&text).expect("SVG parses as XML");
    let polys: Vec<_> = doc
        .descendants()
        .filter(|n| n.has_tag_name("polygon"))
        .collect();
    let circles = doc
        .descendants()
        .filter(|n| n.has_tag_name("circle"))
        .count();
    let fills = polys
        .iter()
        .map(|n| n.attribute("fill").unwrap().to_string())
        .collect();
    (polys.len(), circles, fills)
}

#[test]
fn svg_and_png_of_a_real_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let plate = example("plate_two_holes.toml");
    let svg = dir.path().join("plate.svg");
    let rep = dir.path().join("rep.json");
    ok(&[
        "mesh",
        s(&plate),
        "-o",
        s(&svg),
        "--size",
        "0.05",
        "--dim",
        "2",
        "--report",
        s(&rep),
    ]);
    let n = report_triangles(&rep);
    assert!(n > 500, "{n} triangles");
    let (polys, circles, fills) = polygons(&svg);
    assert_eq!(polys, n, "one polygon per triangle");
    assert_eq!(circles, 0);
    assert!(fills.len() > 3, "quality colours: {fills:?}");

    let png = dir.path().join("plate.png");
    ok(&[
        "mesh",
        s(&plate),
        "-o",
        s(&png),
        "--size",
        "0.05",
        "--width",
        "600",
        "--quiet",
    ]);
    let img = decode_png(&png);
    assert_eq!(img.0, 600);
    let (frac, colours) = ink(&img, 0, img.0, 0, img.1);
    assert!(frac > 0.6 && colours > 20, "ink {frac}, {colours} colours");
}

#[test]
fn entity_colours_bubbles_and_views() {
    let dir = tempfile::tempdir().unwrap();
    let two = example("two_faces.toml");
    let svg = dir.path().join("two.svg");
    let msh = dir.path().join("two.msh");
    ok(&["mesh", s(&two), "-o", s(&msh), "--size", "0.1", "--quiet"]);
    let mesh = bubblemesh_io::read(&msh).unwrap();
    ok(&[
        "mesh",
        s(&two),
        "-o",
        s(&svg),
        "--size",
        "0.1",
        "--color",
        "entity",
        "--bubbles",
        "--quiet",
    ]);
    let (polys, circles, fills) = polygons(&svg);
    assert_eq!(polys, mesh.triangles.len());
    assert_eq!(fills.len(), 2, "two faces, two colours: {fills:?}");
    assert_eq!(circles, mesh.nodes.len(), "one bubble per node");
    // an oblique view of the flat mesh still draws every triangle
    ok(&[
        "mesh",
        s(&two),
        "-o",
        s(&svg),
        "--size",
        "0.1",
        "--view",
        "-1,-2,1",
        "--quiet",
    ]);
    assert_eq!(polygons(&svg).0, mesh.triangles.len());
    // a bad view is a usage error
    let o = run(&[
        "mesh",
        s(&two),
        "-o",
        s(&svg),
        "--size",
        "0.1",
        "--view",
        "0,0,0",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn draw_renders_a_mesh_file() {
    let dir = tempfile::tempdir().unwrap();
    let msh = dir.path().join("sq.msh");
    ok(&[
        "mesh",
        s(&example("square.toml")),
        "-o",
        s(&msh),
        "--size",
        "0.1",
        "--quiet",
    ]);
    let mesh = bubblemesh_io::read(&msh).unwrap();
    let svg = dir.path().join("sq.svg");
    ok(&["draw", s(&msh), "-o", s(&svg), "--bubbles"]);
    let (polys, circles, _) = polygons(&svg);
    assert_eq!((polys, circles), (mesh.triangles.len(), mesh.nodes.len()));
    let html = dir.path().join("sq.html");
    let plots = dir.path().join("plots");
    ok(&[
        "draw",
        s(&msh),
        "-o",
        s(&html),
        "--size",
        "0.1",
        "--plots",
        s(&plots),
    ]);
    assert!(std::fs::read_to_string(&html)
        .unwrap()
        .contains("id=\"element-count\""));
    for f in [
        "radius_ratio.svg",
        "angles.svg",
        "length_ratio.svg",
        "index.html",
    ] {
        assert!(plots.join(f).is_file(), "{f}");
    }
    assert!(!plots.join("energy.svg").exists());
    // draw only writes pictures
    let o = run(&["draw", s(&msh), "-o", s(&dir.path().join("x.msh"))]);
    assert_eq!(o.status.code(), Some(1));
}

#[test]
fn plots_hold_the_energy_history_and_the_histograms() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sq.msh");
    let plots = dir.path().join("plots");
    ok(&[
        "mesh",
        s(&example("square.toml")),
        "-o",
        s(&out),
        "--size",
        "0.02 + 0.1*x",
        "--plots",
        s(&plots),
        "--quiet",
    ]);
    for f in ["energy", "radius_ratio", "angles", "length_ratio"] {
        let text = std::fs::read_to_string(plots.join(format!("{f}.svg"))).unwrap();
        let doc = roxmltree::Document::parse(&text).expect(f);
        if f == "energy" {
            let series: Vec<&str> = doc
                .descendants()
                .filter_map(|n| n.attribute("data-series"))
                .collect();
            assert_eq!(series, ["kinetic", "total", "potential", "bubbles"]);
        } else {
            assert!(
                doc.descendants()
                    .any(|n| n.attribute("class") == Some("bar")),
                "{f} has bars"
            );
        }
    }
    let index = std::fs::read_to_string(plots.join("index.html")).unwrap();
    assert!(index.contains("energy.svg") && index.contains("q_min"));
}

#[test]
fn frames_and_animation_of_the_bubbles_settling() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sq.msh");
    let frames = dir.path().join("frames");
    let page = dir.path().join("settle.html");
    ok(&[
        "mesh",
        s(&example("square.toml")),
        "-o",
        s(&out),
        "--size",
        "0.03 + 0.1*x",
        "--frames",
        s(&frames),
        "--animate",
        s(&page),
        "--quiet",
    ]);
    let mut svgs: Vec<PathBuf> = std::fs::read_dir(&frames)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
        .collect();
    svgs.sort();
    assert!(svgs.len() >= 3, "{} frames", svgs.len());
    let mesh = bubblemesh_io::read(&out).unwrap();
    // the last frame is the mesh written, with its bubbles
    let (polys, circles, _) = polygons(svgs.last().unwrap());
    assert_eq!((polys, circles), (mesh.triangles.len(), mesh.nodes.len()));
    for p in &svgs {
        let img = decode_png(&p.with_extension("png"));
        assert!(ink(&img, 0, img.0, 0, img.1).0 > 0.5, "{}", p.display());
    }
    let html = std::fs::read_to_string(&page).unwrap();
    assert_eq!(html.matches("<figure class=\"frame\"").count(), svgs.len());
    assert!(html.contains("stage 1"));
    // --animate wants a page
    let o = run(&[
        "mesh",
        s(&example("square.toml")),
        "-o",
        s(&out),
        "--animate",
        s(&dir.path().join("a.svg")),
    ]);
    assert_eq!(o.status.code(), Some(1));
}

#[test]
fn unknown_extensions_fail_before_meshing_and_name_the_picture_formats() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.jpg");
    let o = run(&[
        "mesh",
        s(&example("square.toml")),
        "-o",
        s(&out),
        "--size",
        "0.1",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("x.jpg") && e.contains(".svg, .png, .html"),
        "{e}"
    );
    assert!(e.contains(".msh"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
