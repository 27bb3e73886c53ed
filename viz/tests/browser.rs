//! The viewer page in headless Chromium: it renders (the screenshot is not
//! blank), reports the mesh's element count, and its clipping plane cuts
//! through tetrahedra. Set BUBBLEMESH_SKIP_BROWSER=1 to skip.

mod common;

use bubblemesh_core::quality;
use bubblemesh_viz::geometry::boundary_faces;
use bubblemesh_viz::ViewerOptions;
use common::chromium::{chromium, decode_png, element_text, file_url, ink};
use common::meshes::{cube_tets, icosphere};

#[test]
fn viewer_renders_tetrahedra_and_clips_through_them() {
    let Some(browser) = chromium() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let m = cube_tets(4);
    let q = quality::analyse(&m, None);
    let page = bubblemesh_viz::viewer(
        &m,
        &ViewerOptions {
            title: "cube".into(),
            quality: Some(&q),
            ..Default::default()
        },
    )
    .unwrap();
    let path = dir.path().join("cube.html");
    std::fs::write(&path, page).unwrap();

    // unclipped: the cube's boundary
    let dom = browser.dump_dom(&file_url(&path, ""));
    assert_eq!(
        element_text(&dom, "element-count").as_deref(),
        Some(m.tetrahedra.len().to_string().as_str()),
        "element count"
    );
    assert_eq!(element_text(&dom, "drawn-count").unwrap(), "192");

    // clipped at x = 0.5: the boundary of the tetrahedra whose centroid has
    // x <= 0.5, which includes faces inside the cube
    let kept = m.tetrahedra.iter().enumerate().filter(|(_, t)| {
        t.nodes
            .iter()
            .map(|&v| m.nodes[v as usize].pos.x)
            .sum::<f64>()
            / 4.0
            <= 0.5
    });
    let expect = boundary_faces(kept.map(|(i, t)| (i, t.nodes))).len();
    let dom = browser.dump_dom(&file_url(&path, "clip=x:0.5"));
    assert_eq!(
        element_text(&dom, "drawn-count").unwrap(),
        expect.to_string()
    );
    assert!(expect != 192 && expect > 0);

    let shot = dir.path().join("cube.png");
    browser.screenshot(&file_url(&path, "clip=x:0.5"), &shot, 800, 600);
    let img = decode_png(&shot);
    let (frac, colours) = ink(&img, 0, 440, 0, img.1);
    assert!(frac > 0.05, "the canvas is blank: ink {frac}");
    assert!(colours > 20, "the canvas has {colours} colours");
}

#[test]
fn viewer_renders_a_surface() {
    let Some(browser) = chromium() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let m = icosphere(3);
    let page = bubblemesh_viz::viewer(&m, &ViewerOptions::default()).unwrap();
    let path = dir.path().join("sphere.html");
    std::fs::write(&path, page).unwrap();
    let dom = browser.dump_dom(&file_url(&path, "color=entity"));
    assert_eq!(
        element_text(&dom, "element-count").unwrap(),
        m.triangles.len().to_string()
    );
    assert_eq!(
        element_text(&dom, "drawn-count").unwrap(),
        m.triangles.len().to_string()
    );
}
