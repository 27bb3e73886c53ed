//! Pictures, pages and plots of hand-built meshes: SVG parses as XML with
//! one polygon per element, PNG decodes and is not blank, surfaces are
//! painted far to near, pages need no network.

mod common;

use bubblemesh_core::engine::EnergySample;
use bubblemesh_core::mesh::{Element, Mesh, Node};
use bubblemesh_core::model::EntityRef;
use bubblemesh_core::quality;
use bubblemesh_core::{P3, V3};
use bubblemesh_viz::geometry::{boundary_faces, Measures};
use bubblemesh_viz::{anim, plots, ColorBy, PictureOptions, ViewerOptions, VizError};
use common::chromium::{decode_png, ink};
use common::meshes::{cube_tets, grid, icosphere};

fn svg_doc(svg: &str) -> roxmltree::Document<'_> {
    roxmltree::Document::parse(svg).expect("the SVG parses as XML")
}

fn count(doc: &roxmltree::Document, tag: &str) -> usize {
    doc.descendants().filter(|n| n.has_tag_name(tag)).count()
}

fn png_image(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let f = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(f.path(), bytes).unwrap();
    decode_png(f.path())
}

#[test]
fn svg_holds_one_polygon_per_triangle_in_both_colourings() {
    let m = grid(12);
    for color in [ColorBy::Quality, ColorBy::Entity] {
        let svg = bubblemesh_viz::svg(
            &m,
            &PictureOptions {
                color,
                ..Default::default()
            },
        )
        .unwrap();
        let doc = svg_doc(&svg);
        assert_eq!(count(&doc, "polygon"), m.triangles.len());
        assert_eq!(count(&doc, "line"), m.lines.len());
        let fills: std::collections::HashSet<&str> = doc
            .descendants()
            .filter(|n| n.has_tag_name("polygon"))
            .map(|n| n.attribute("fill").unwrap())
            .collect();
        match color {
            // right isosceles triangles: one quality, one colour
            ColorBy::Quality => assert_eq!(fills.len(), 1, "{fills:?}"),
            // two faces, two colours
            ColorBy::Entity => assert_eq!(fills.len(), 2, "{fills:?}"),
        }
        let q: f64 = doc
            .descendants()
            .find(|n| n.has_tag_name("polygon"))
            .unwrap()
            .attribute("data-q")
            .unwrap()
            .parse()
            .unwrap();
        assert!((q - 0.828).abs() < 1e-3, "{q}");
    }
}

#[test]
fn quality_colours_separate_good_and_bad_triangles() {
    let mut m = grid(4);
    // squash one node: its triangles get worse
    m.nodes[6].pos = P3::new(0.45, 0.27, 0.0);
    let svg = bubblemesh_viz::svg(&m, &PictureOptions::default()).unwrap();
    let doc = svg_doc(&svg);
    let fills: std::collections::HashSet<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("polygon"))
        .map(|n| n.attribute("fill").unwrap())
        .collect();
    assert!(fills.len() >= 3, "{fills:?}");
}

#[test]
fn tetrahedral_meshes_draw_their_boundary_faces() {
    let n = 3;
    let m = cube_tets(n);
    assert_eq!(
        boundary_faces(m.tetrahedra.iter().map(|t| t.nodes).enumerate()).len(),
        12 * n * n
    );
    let svg = bubblemesh_viz::svg(&m, &PictureOptions::default()).unwrap();
    let doc = svg_doc(&svg);
    assert_eq!(count(&doc, "polygon"), 12 * n * n);
    let png = bubblemesh_viz::png(&m, &PictureOptions::default()).unwrap();
    let img = png_image(&png);
    let (frac, colours) = ink(&img, 0, img.0, 0, img.1);
    assert!(frac > 0.3 && colours > 5, "{frac} {colours}");
}

#[test]
fn png_decodes_at_the_asked_width_and_is_not_blank() {
    for (m, view) in [
        (grid(10), None),
        (icosphere(2), Some(V3::new(0.3, -1.0, 0.5))),
    ] {
        let png = bubblemesh_viz::png(
            &m,
            &PictureOptions {
                width: 400,
                view,
                ..Default::default()
            },
        )
        .unwrap();
        let img = png_image(&png);
        assert_eq!(img.0, 400);
        let (frac, colours) = ink(&img, 0, img.0, 0, img.1);
        assert!(frac > 0.5, "ink {frac}");
        assert!(colours > 10, "{colours} colours");
    }
}

#[test]
fn surfaces_are_painted_far_to_near() {
    // a big poor triangle at z = 0 and a small equilateral one at z = 1,
    // listed near-first; the small one shows only when seen from +z
    let e = EntityRef::new(2, 0);
    let n = |x: f64, y: f64, z: f64| Node {
        pos: P3::new(x, y, z),
        entity: e,
        params: [0.0; 2],
    };
    let h = 3f64.sqrt() / 2.0 * 0.4;
    let m = Mesh {
        nodes: vec![
            n(0.3, 0.3, 1.0),
            n(0.7, 0.3, 1.0),
            n(0.5, 0.3 + h, 1.0),
            n(-1.0, -1.0, 0.0),
            n(3.0, -1.0, 0.0),
            n(-1.0, 1.5, 0.0),
        ],
        triangles: vec![
            Element {
                nodes: [0, 1, 2],
                entity: e,
            },
            Element {
                nodes: [3, 4, 5],
                entity: e,
            },
        ],
        ..Default::default()
    };
    let q = |i: usize| {
        let [a, b, c] = m.triangles[i].nodes.map(|v| m.nodes[v as usize].pos);
        bubblemesh_viz::geometry::triangle_q(&a, &b, &c)
    };
    let front = bubblemesh_viz::color::quality(q(0));
    let back = bubblemesh_viz::color::quality(q(1));
    assert_ne!(front, back);
    for (dir, expect) in [(1.0, front), (-1.0, back)] {
        let o = PictureOptions {
            view: Some(V3::new(0.0, 0.0, dir)),
            width: 400,
            edges: Some(false),
            legend: false,
            ..Default::default()
        };
        let img = png_image(&bubblemesh_viz::png(&m, &o).unwrap());
        // the small triangle's centroid, in pixels: locate it through the SVG
        let svg = bubblemesh_viz::svg(&m, &o).unwrap();
        let doc = svg_doc(&svg);
        let small = doc
            .descendants()
            .filter(|x| x.has_tag_name("polygon"))
            .find(|x| x.attribute("data-q").unwrap().starts_with("1.0"))
            .unwrap();
        let pts: Vec<f64> = small
            .attribute("points")
            .unwrap()
            .split([' ', ','])
            .map(|v| v.parse().unwrap())
            .collect();
        let cx = ((pts[0] + pts[2] + pts[4]) / 3.0) as u32;
        let cy = ((pts[1] + pts[3] + pts[5]) / 3.0) as u32;
        let k = 4 * (cy * img.0 + cx) as usize;
        let got = (img.2[k], img.2[k + 1], img.2[k + 2]);
        // surfaces are shaded by the angle to the view, so the pixel is the
        // element's colour scaled by a factor in (0, 1]: check it is the
        // nearer triangle's colour so scaled, and not the farther one's
        let shade_of = |c: (u8, u8, u8)| -> Option<f64> {
            let s = got.1 as f64 / c.1 as f64;
            let close = |a: u8, b: u8| (a as f64 - s * b as f64).abs() <= 3.0;
            (s > 0.3 && s <= 1.01 && close(got.0, c.0) && close(got.2, c.2)).then_some(s)
        };
        let other = if dir > 0.0 { back } else { front };
        assert!(
            shade_of((expect.0, expect.1, expect.2)).is_some(),
            "view {dir}: pixel {got:?} at the small triangle is not a shade of {expect:?}"
        );
        assert!(
            shade_of((other.0, other.1, other.2)).is_none() || other == expect,
            "view {dir}: pixel {got:?} could be the hidden triangle's {other:?}"
        );
    }
}

#[test]
fn bubbles_are_one_circle_per_node() {
    let m = grid(6);
    let d = vec![1.0 / 6.0; m.nodes.len()];
    let svg = bubblemesh_viz::svg(
        &m,
        &PictureOptions {
            bubbles: Some(d),
            ..Default::default()
        },
    )
    .unwrap();
    let doc = svg_doc(&svg);
    assert_eq!(count(&doc, "circle"), m.nodes.len());
    assert_eq!(count(&doc, "polygon"), m.triangles.len());
    // on a surface seen obliquely the bubbles are tangent discs: ellipses,
    // circles where the surface faces the viewer
    let sphere = icosphere(2);
    let svg = bubblemesh_viz::svg(
        &sphere,
        &PictureOptions {
            bubbles: Some(vec![0.2; sphere.nodes.len()]),
            ..Default::default()
        },
    )
    .unwrap();
    let doc = svg_doc(&svg);
    let (c, e) = (count(&doc, "circle"), count(&doc, "ellipse"));
    assert_eq!(c + e, sphere.nodes.len());
    assert!(e > sphere.nodes.len() / 2, "{c} circles, {e} ellipses");
    let png = bubblemesh_viz::png(
        &sphere,
        &PictureOptions {
            bubbles: Some(vec![0.2; sphere.nodes.len()]),
            width: 300,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(ink(&png_image(&png), 0, 300, 0, 300).0 > 0.5);
    // wrong length: an error, not a panic
    let e = bubblemesh_viz::svg(
        &m,
        &PictureOptions {
            bubbles: Some(vec![1.0]),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("bubble"), "{e}");
}

#[test]
fn broken_meshes_give_errors() {
    let mut m = grid(2);
    m.triangles[0].nodes[1] = 99;
    assert!(matches!(
        bubblemesh_viz::svg(&m, &PictureOptions::default()),
        Err(VizError::InvalidMesh(_))
    ));
    assert!(bubblemesh_viz::viewer(&m, &ViewerOptions::default()).is_err());
    assert!(matches!(
        bubblemesh_viz::png(&Mesh::default(), &PictureOptions::default()),
        Err(VizError::Empty)
    ));
}

#[test]
fn the_viewer_page_is_self_contained_and_carries_the_mesh() {
    let m = icosphere(2);
    let q = quality::analyse(&m, None);
    let page = bubblemesh_viz::viewer(
        &m,
        &ViewerOptions {
            title: "sphere <&>".into(),
            quality: Some(&q),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(page.starts_with("<!DOCTYPE html>"));
    assert!(page.contains("id=\"element-count\""));
    assert!(page.contains("sphere &lt;&amp;&gt;"));
    for banned in ["<link", " src=", "https:", "import(", "fetch("] {
        assert!(!page.contains(banned), "the page refers outside: {banned}");
    }
    // the only http: is the SVG namespace
    assert!(page.matches("http:").all(|_| true));
    assert!(
        !page.contains("http://")
            || page.matches("http://").count()
                == page.matches("http://www.w3.org/2000/svg").count()
    );
    let start = page.find("id=\"mesh-data\">").unwrap() + "id=\"mesh-data\">".len();
    let end = start + page[start..].find("</script>").unwrap();
    let data: serde_json::Value = serde_json::from_str(&page[start..end]).unwrap();
    assert_eq!(
        data["tris"].as_array().unwrap().len(),
        3 * m.triangles.len()
    );
    assert_eq!(data["nodes"].as_array().unwrap().len(), 3 * m.nodes.len());
    assert_eq!(data["triQ"].as_array().unwrap().len(), m.triangles.len());
    // the quality report is a table
    assert!(page.contains("<table id=\"quality\">"));
    assert!(page.contains("q_min"));
}

#[test]
fn plots_parse_and_count_what_they_show() {
    let samples: Vec<EnergySample> = (1..=50)
        .map(|s| {
            let k = (-(s as f64) / 10.0).exp();
            EnergySample {
                step: s,
                kinetic: k,
                potential: 2.0 * k + 0.1,
                total: 3.0 * k + 0.1,
                bubbles: 100,
            }
        })
        .collect();
    let svg = plots::energy(&[
        plots::FaceEnergy {
            name: "plate".into(),
            samples: &samples,
        },
        plots::FaceEnergy {
            name: "fast".into(),
            samples: &[],
        },
    ]);
    let doc = svg_doc(&svg);
    let series: Vec<&str> = doc
        .descendants()
        .filter_map(|n| n.attribute("data-series"))
        .collect();
    assert_eq!(series, ["kinetic", "total", "potential", "bubbles"]);
    let empty = plots::energy(&[]);
    assert!(svg_doc(&empty).root().text().is_none() || empty.contains("no stage-2"));

    let m = grid(8);
    let spacing = bubblemesh_core::spacing::Constant(1.0 / 8.0);
    let measures = Measures::of(&m, Some(&spacing));
    assert_eq!(measures.q.len(), m.triangles.len());
    assert_eq!(measures.angles.len(), 3 * m.triangles.len());
    // 8×8 grid: 2·8·9 axis edges and 64 diagonals
    assert_eq!(measures.length_ratio.len(), 2 * 8 * 9 + 64);
    let hists = plots::quality_histograms(&measures);
    let stems: Vec<&str> = hists.iter().map(|h| h.0).collect();
    assert_eq!(stems, ["radius_ratio", "angles", "length_ratio"]);
    for (stem, svg) in &hists {
        let doc = svg_doc(svg);
        let total: usize = doc
            .descendants()
            .filter_map(|n| n.attribute("data-count"))
            .map(|c| c.parse::<usize>().unwrap())
            .sum();
        let expect = match *stem {
            "radius_ratio" => measures.q.len(),
            "angles" => measures.angles.len(),
            _ => measures.length_ratio.len(),
        };
        assert_eq!(total, expect, "{stem}");
    }
}

#[test]
fn the_animation_page_holds_every_frame() {
    let m = grid(4);
    let frames: Vec<anim::Frame> = (0..3)
        .map(|k| anim::Frame {
            label: format!("frame {k}"),
            svg: bubblemesh_viz::svg(&m, &PictureOptions::default()).unwrap(),
        })
        .collect();
    let page = anim::page("t", &[], &frames);
    assert_eq!(page.matches("<figure class=\"frame\"").count(), 3);
    assert!(!page.contains("<?xml"));
    assert!(page.contains("id=\"frame-count\">3<"));
}
