//! Headless Chromium for the browser tests (Debian's `chromium` package;
//! `.ci/run` installs it). Without a browser these tests skip with a printed
//! reason, except under CI (the environment variable `CI` set), where a
//! missing browser fails them: CI must run them. `BUBBLEMESH_SKIP_BROWSER=1`
//! skips them anywhere.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub struct Chromium {
    exe: PathBuf,
    profile: tempfile::TempDir,
}

/// The browser, or `None` when the tests skip it (asked to, or no browser
/// outside CI).
pub fn chromium() -> Option<Chromium> {
    if std::env::var("BUBBLEMESH_SKIP_BROWSER").is_ok_and(|v| v == "1") {
        eprintln!("BUBBLEMESH_SKIP_BROWSER=1: skipping the headless-browser check");
        return None;
    }
    let names = ["chromium", "chromium-browser", "google-chrome"];
    let path = std::env::var_os("PATH").unwrap_or_default();
    let exe = names
        .iter()
        .flat_map(|n| std::env::split_paths(&path).map(move |d| d.join(n)))
        .find(|p| p.is_file());
    let Some(exe) = exe else {
        if std::env::var_os("CI").is_some() {
            panic!(
                "no headless browser found (looked for {names:?} in PATH), and CI is set: \
                 install Debian's chromium (apt-get install chromium) or set \
                 BUBBLEMESH_SKIP_BROWSER=1"
            );
        }
        eprintln!(
            "SKIP: no headless browser found (looked for {names:?} in PATH; install Debian's \
             chromium to run this test; under CI it is required)"
        );
        return None;
    };
    Some(Chromium {
        exe,
        profile: tempfile::tempdir().unwrap(),
    })
}

impl Chromium {
    fn command(&self) -> Command {
        let mut c = Command::new(&self.exe);
        c.args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-extensions",
            "--no-first-run",
            "--hide-scrollbars",
            "--virtual-time-budget=5000",
        ]);
        c.arg(format!("--user-data-dir={}", self.profile.path().display()));
        c
    }

    /// Runs the browser with a time limit; returns stdout.
    fn run(&self, mut c: Command) -> String {
        let out = tempfile::NamedTempFile::new().unwrap();
        let mut child = c
            .stdin(Stdio::null())
            .stdout(out.reopen().unwrap())
            .stderr(Stdio::null())
            .spawn()
            .expect("start chromium");
        let t0 = Instant::now();
        loop {
            if let Some(status) = child.try_wait().unwrap() {
                assert!(status.success(), "chromium failed: {status}");
                break;
            }
            if t0.elapsed() > Duration::from_secs(120) {
                let _ = child.kill();
                let _ = child.wait();
                panic!("chromium did not finish in 120 s");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        std::fs::read_to_string(out.path()).unwrap()
    }

    /// A screenshot of `url` at `w`×`h` CSS pixels into `png`.
    pub fn screenshot(&self, url: &str, png: &Path, w: u32, h: u32) {
        let mut c = self.command();
        c.arg(format!("--screenshot={}", png.display()))
            .arg(format!("--window-size={w},{h}"))
            .arg(url);
        self.run(c);
        assert!(png.is_file(), "chromium wrote no screenshot");
    }

    /// The DOM of `url` after its scripts ran.
    pub fn dump_dom(&self, url: &str) -> String {
        let mut c = self.command();
        c.arg("--window-size=800,600").arg("--dump-dom").arg(url);
        self.run(c)
    }
}

/// `file://` address of a path, with an optional fragment.
pub fn file_url(path: &Path, fragment: &str) -> String {
    let abs = std::fs::canonicalize(path).unwrap();
    let mut u = format!("file://{}", abs.display());
    if !fragment.is_empty() {
        u.push('#');
        u.push_str(fragment);
    }
    u
}

/// The text content of the element with `id` in a dumped DOM.
pub fn element_text(dom: &str, id: &str) -> Option<String> {
    let at = dom.find(&format!("id=\"{id}\""))?;
    let rest = &dom[at..];
    let start = rest.find('>')? + 1;
    let end = rest[start..].find('<')? + start;
    Some(rest[start..end].trim().to_string())
}

/// Decoded RGBA pixels of a PNG file: (width, height, rgba).
pub fn decode_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let mut dec = png::Decoder::new(std::fs::File::open(path).unwrap());
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    let rgba: Vec<u8> = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf
            .chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        other => panic!("unexpected PNG colour type {other:?}"),
    };
    (info.width, info.height, rgba)
}

/// Within the rectangle [x0, x1) × [y0, y1): the fraction of pixels that
/// are not white, and the number of distinct colours.
pub fn ink(img: &(u32, u32, Vec<u8>), x0: u32, x1: u32, y0: u32, y1: u32) -> (f64, usize) {
    let (w, h, px) = img;
    let mut colours = std::collections::HashSet::new();
    let (mut inked, mut total) = (0usize, 0usize);
    for y in y0..y1.min(*h) {
        for x in x0..x1.min(*w) {
            let k = 4 * (y * w + x) as usize;
            let c = [px[k], px[k + 1], px[k + 2]];
            total += 1;
            if c.iter().any(|&v| v < 245) {
                inked += 1;
            }
            colours.insert(c);
        }
    }
    (inked as f64 / total.max(1) as f64, colours.len())
}
