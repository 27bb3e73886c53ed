//! `-o mesh.html` in headless Chromium on a real mesh: the page renders
//! (the screenshot is not blank) and reports the mesh's element count.
//! `.ci/run` installs Chromium; without it the test skips (fails under CI);
//! set BUBBLEMESH_SKIP_BROWSER=1 to skip.

#[path = "../../viz/tests/common/chromium.rs"]
mod chromium;

use std::path::Path;
use std::process::Command;

use chromium::{chromium, decode_png, element_text, file_url, ink};

#[test]
fn the_viewer_page_renders_a_real_mesh_in_chromium() {
    let Some(browser) = chromium() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/plate_two_holes.toml");
    let page = dir.path().join("plate.html");
    let report = dir.path().join("report.json");
    let o = Command::new(env!("CARGO_BIN_EXE_bubblemesh"))
        .args(["mesh", input.to_str().unwrap(), "-o"])
        .arg(&page)
        .args(["--size", "0.04", "--dim", "2", "--report"])
        .arg(&report)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let counts = &v["quality"]["counts"];
    let elements = counts["triangles"].as_u64().unwrap() + counts["tetrahedra"].as_u64().unwrap();
    assert!(elements > 1000, "{elements}");

    let dom = browser.dump_dom(&file_url(&page, ""));
    assert_eq!(
        element_text(&dom, "element-count"),
        Some(elements.to_string()),
        "the page reports the mesh's element count"
    );
    assert_eq!(
        element_text(&dom, "drawn-count"),
        Some(elements.to_string())
    );
    // the quality table is in the page
    assert!(dom.contains("q_min"));

    let shot = dir.path().join("plate.png");
    browser.screenshot(&file_url(&page, ""), &shot, 800, 600);
    let img = decode_png(&shot);
    // the canvas is the left part of the page
    let canvas_w = img.0.saturating_sub(340);
    let (frac, colours) = ink(&img, 0, canvas_w, 0, img.1);
    assert!(frac > 0.2, "the canvas is blank: ink {frac}");
    assert!(colours > 30, "{colours} colours");
    // greenish pixels: near-equilateral triangles in the quality colours
    let (w, px) = (img.0, &img.2);
    let green = (0..img.1)
        .flat_map(|y| (0..canvas_w).map(move |x| 4 * (y * w + x) as usize))
        .filter(|&k| {
            px[k + 1] as i32 > px[k] as i32 + 20 && px[k + 1] as i32 > px[k + 2] as i32 + 20
        })
        .count();
    assert!(green > 10_000, "{green} green pixels");

    // the page refers to nothing outside itself
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(!html.contains("<link") && !html.contains(" src=") && !html.contains("https:"));
}
