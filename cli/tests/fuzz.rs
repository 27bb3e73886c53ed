//! Fuzzing on the stable toolchain: the TOML domain reader, the mesh readers
//! (.msh .vtu .stl .obj .mesh) and the --size expression parser get mutated
//! copies of a seed corpus (examples/, io/tests/data/, meshes written by
//! bubblemesh itself, a list of expressions). A case passes when the reader
//! returns (a result or an error) without panicking, within a time limit.
//!
//! - `fuzz_for_a_time_budget` (ignored by default; `scripts/fuzz.sh` runs
//!   it): `BUBBLEMESH_FUZZ_SECS` seconds (default 60) from the seed
//!   `BUBBLEMESH_FUZZ_SEED` (default fixed). A panic or a case slower than
//!   `BUBBLEMESH_FUZZ_HANG_SECS` (default 10) is saved under
//!   `target/fuzz-finds/` and fails the run; a find worth keeping goes into
//!   `cli/tests/fuzz_finds/<target>/` (the target is the directory name).
//! - `fuzz_finds_stay_fixed` replays every kept find (CI runs it).
//! - `fuzz_smoke` runs a short fixed-seed burst on every test run.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bubblemesh_core::spacing::Expr;
use bubblemesh_core::P3;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The readers under test, by name.
const TARGETS: [&str; 7] = ["toml", "msh", "vtu", "stl", "obj", "mesh", "expr"];

/// Runs one input through a target's reader; Err on a panic.
fn exercise(target: &str, data: &[u8]) -> Result<(), String> {
    let r = catch_unwind(AssertUnwindSafe(|| match target {
        "toml" => {
            let text = String::from_utf8_lossy(data);
            let _ = bubblemesh_analytic::parse_domain(&text, "fuzz.toml");
        }
        "msh" => {
            let _ = bubblemesh_io::msh::parse(data);
            let _ = bubblemesh_io::msh::parse_with_node_data(data);
            let _ = bubblemesh_io::msh::parse_with_notes(data);
        }
        "vtu" => {
            let _ = bubblemesh_io::vtu::parse(data);
            let _ = bubblemesh_io::vtu::parse_with_node_data(data);
            let _ = bubblemesh_io::vtu::parse_with_notes(data);
        }
        "stl" => {
            let _ = bubblemesh_io::stl::parse(data);
        }
        "obj" => {
            let _ = bubblemesh_io::obj::parse(data);
        }
        "mesh" => {
            let _ = bubblemesh_io::medit::parse(data);
        }
        "expr" => {
            let text = String::from_utf8_lossy(data);
            if let Ok(e) = Expr::parse(&text) {
                for p in [
                    P3::new(0.0, 0.0, 0.0),
                    P3::new(0.5, -1.0, 2.0),
                    P3::new(1e300, -1e-300, f64::NAN),
                ] {
                    let _ = e.eval(&p);
                }
                let _ = e.check_positive(&[P3::new(0.25, 0.5, 0.75)]);
            }
        }
        other => panic!("unknown fuzz target {other}"),
    }));
    r.map_err(|e| {
        e.downcast_ref::<String>()
            .cloned()
            .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "a panic".into())
    })
}

/// xorshift64*: small, deterministic, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// The seed corpus of each target.
fn seeds() -> Vec<(&'static str, Vec<u8>)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(root().join("examples")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            out.push(("toml", std::fs::read(&p).unwrap()));
        }
    }
    let data = root().join("io/tests/data");
    let mut meshes = Vec::new();
    for f in ["gmsh_cube_v41.msh", "gmsh_cube_v22.msh"] {
        let bytes = std::fs::read(data.join(f)).unwrap();
        meshes.push(bubblemesh_io::msh::parse(&bytes).unwrap());
        out.push(("msh", bytes));
    }
    // each format as bubblemesh writes it, from a tetrahedral and a
    // triangle mesh
    let mut tri = meshes[0].clone();
    tri.tetrahedra.clear();
    meshes.push(tri);
    for m in &meshes {
        let mut w = |target: &'static str, f: &dyn Fn(&mut Vec<u8>) -> std::io::Result<()>| {
            let mut buf = Vec::new();
            f(&mut buf).unwrap();
            out.push((target, buf));
        };
        w("msh", &|b| bubblemesh_io::msh::write_to(m, b));
        w("vtu", &|b| bubblemesh_io::vtu::write_to(m, b));
        w("stl", &|b| bubblemesh_io::stl::write_to(m, b));
        w("obj", &|b| bubblemesh_io::obj::write_to(m, b));
        w("mesh", &|b| bubblemesh_io::medit::write_to(m, b));
    }
    out.push((
        "stl",
        b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n\
          endloop\nendfacet\nendsolid t\n"
            .to_vec(),
    ));
    for e in [
        "0.05",
        "1e-3",
        "0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)",
        "0.02 + 0.1*max(min(sqrt((x-0.5)^2+(y-0.5)^2), sqrt((x-1.5)^2+(y-0.5)^2)) - 0.2, 0)",
        "0.1*(1 + sin(PI*x)**2) + abs(z)",
        "exp(-x) + ln(2 + y) + log(3) + cos(z) + tan(0.1)",
        "atan2(y, x) + 4",
    ] {
        out.push(("expr", e.as_bytes().to_vec()));
    }
    out
}

const INTERESTING: &[&str] = &[
    "0",
    "-0",
    "1e308",
    "-1e308",
    "1e-320",
    "nan",
    "inf",
    "-1",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "99999999999",
    "0.0000001",
    "",
    "\"\"",
    "[]",
    "{}",
];

const BYTES: &[u8] = b"0123456789.-+eE[](){},=\"'\n\t $#/*^<>&;:xyzab";

/// One mutation of `data` in place.
fn mutate(rng: &mut Rng, data: &mut Vec<u8>, corpus: &[Vec<u8>]) {
    let n = data.len();
    match rng.below(8) {
        0 if n > 0 => {
            let i = rng.below(n);
            data[i] ^= 1 << rng.below(8);
        }
        1 if n > 0 => {
            let i = rng.below(n);
            data[i] = BYTES[rng.below(BYTES.len())];
        }
        2 if n > 0 => {
            let i = rng.below(n);
            let len = 1 + rng.below((n - i).min(64));
            data.drain(i..i + len);
        }
        3 if n > 0 => {
            let i = rng.below(n);
            let len = 1 + rng.below((n - i).min(256));
            let chunk: Vec<u8> = data[i..i + len].to_vec();
            let at = rng.below(n + 1);
            for _ in 0..1 + rng.below(3) {
                data.splice(at..at, chunk.iter().copied());
            }
        }
        4 => {
            // a number (a run of digits, signs, dots, exponents) replaced
            let digits: Vec<usize> = (0..n).filter(|&i| data[i].is_ascii_digit()).collect();
            if !digits.is_empty() {
                let mut i = digits[rng.below(digits.len())];
                let is_num = |c: u8| c.is_ascii_digit() || b".-+eE".contains(&c);
                while i > 0 && is_num(data[i - 1]) {
                    i -= 1;
                }
                let mut j = i;
                while j < n && is_num(data[j]) {
                    j += 1;
                }
                let with = INTERESTING[rng.below(INTERESTING.len())].as_bytes();
                data.splice(i..j, with.iter().copied());
            }
        }
        5 if n > 0 => data.truncate(rng.below(n)),
        6 if !corpus.is_empty() => {
            // splice in a piece of another seed of the same target
            let other = &corpus[rng.below(corpus.len())];
            if !other.is_empty() {
                let i = rng.below(other.len());
                let len = 1 + rng.below((other.len() - i).min(512));
                let at = rng.below(n + 1);
                data.splice(at..at, other[i..i + len].iter().copied());
            }
        }
        _ => {
            let at = rng.below(n + 1);
            let with = INTERESTING[rng.below(INTERESTING.len())].as_bytes();
            data.splice(at..at, with.iter().copied());
        }
    }
    data.truncate(1 << 20);
}

/// What a run found.
#[derive(Default)]
struct Finds {
    panics: Vec<(String, PathBuf, String)>,
    cases: usize,
}

/// Fuzzes for `budget` from `seed`; a case slower than `hang` is saved and
/// ends the process (a watchdog cannot stop a thread).
fn fuzz(seed: u64, budget: Duration, max_cases: usize, hang: Duration) -> Finds {
    let corpus = seeds();
    let out_dir = root().join("target/fuzz-finds");
    let current: Arc<Mutex<(String, Vec<u8>)>> = Arc::default();
    let started = Arc::new(AtomicU64::new(u64::MAX));
    let done = Arc::new(AtomicBool::new(false));
    let t0 = Instant::now();
    let watchdog = {
        let (current, started, done, out_dir) = (
            current.clone(),
            started.clone(),
            done.clone(),
            out_dir.clone(),
        );
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(100));
                let s = started.load(Ordering::Relaxed);
                if s != u64::MAX && t0.elapsed().as_millis() as u64 > s + hang.as_millis() as u64 {
                    let (target, data) = current.lock().unwrap().clone();
                    let p = save(&out_dir, "hang", &target, &data);
                    eprintln!(
                        "fuzz: {target} took over {hang:?} on the input saved as {}",
                        p.display()
                    );
                    std::process::exit(3);
                }
            }
        })
    };
    // panics are expected and caught: keep their messages off the terminal
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Rng(seed | 1);
    let mut finds = Finds::default();
    while t0.elapsed() < budget && finds.cases < max_cases {
        let (target, base) = &corpus[rng.below(corpus.len())];
        let same: Vec<Vec<u8>> = corpus
            .iter()
            .filter(|(t, _)| t == target)
            .map(|(_, d)| d.clone())
            .collect();
        let mut data = base.clone();
        for _ in 0..1 + rng.below(4) {
            mutate(&mut rng, &mut data, &same);
        }
        *current.lock().unwrap() = (target.to_string(), data.clone());
        started.store(t0.elapsed().as_millis() as u64, Ordering::Relaxed);
        let r = exercise(target, &data);
        started.store(u64::MAX, Ordering::Relaxed);
        finds.cases += 1;
        if let Err(msg) = r {
            let p = save(&out_dir, "panic", target, &data);
            finds.panics.push((target.to_string(), p, msg));
        }
    }
    std::panic::set_hook(hook);
    done.store(true, Ordering::Relaxed);
    watchdog.join().unwrap();
    finds
}

/// Saves a find as `dir/<kind>-<target>-<hash>.<target>`.
fn save(dir: &Path, kind: &str, target: &str, data: &[u8]) -> PathBuf {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in data {
        h = (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
    }
    let _ = std::fs::create_dir_all(dir);
    let p = dir.join(format!("{kind}-{target}-{h:016x}.{target}"));
    let _ = std::fs::write(&p, data);
    p
}

fn report(f: &Finds) {
    eprintln!("fuzz: {} cases, {} panics", f.cases, f.panics.len());
    for (target, p, msg) in &f.panics {
        eprintln!("  {target}: {msg} (input saved as {})", p.display());
    }
    assert!(f.panics.is_empty(), "{} panics", f.panics.len());
}

fn env_num(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
#[ignore = "a long run: scripts/fuzz.sh"]
fn fuzz_for_a_time_budget() {
    let secs = env_num("BUBBLEMESH_FUZZ_SECS", 60);
    let seed = env_num("BUBBLEMESH_FUZZ_SEED", 0x5eed_b0bb_1e5e_ed01);
    let hang = env_num("BUBBLEMESH_FUZZ_HANG_SECS", 10);
    eprintln!("fuzz: seed {seed}, {secs} s");
    let f = fuzz(
        seed,
        Duration::from_secs(secs),
        usize::MAX,
        Duration::from_secs(hang),
    );
    report(&f);
}

/// A short fixed-seed burst, so that the harness itself stays working.
#[test]
fn fuzz_smoke() {
    let f = fuzz(
        0x5eed_b0bb_1e5e_ed01,
        Duration::from_secs(20),
        300,
        Duration::from_secs(60),
    );
    report(&f);
}

/// Every kept find (cli/tests/fuzz_finds/<target>/*) still returns without
/// a panic.
#[test]
fn fuzz_finds_stay_fixed() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_finds");
    let mut n = 0;
    for target in TARGETS {
        let Ok(entries) = std::fs::read_dir(dir.join(target)) else {
            continue;
        };
        for e in entries {
            let p = e.unwrap().path();
            let data = std::fs::read(&p).unwrap();
            let t = Instant::now();
            exercise(target, &data).unwrap_or_else(|m| panic!("{}: {m}", p.display()));
            assert!(
                t.elapsed() < Duration::from_secs(10),
                "{}: {:?}",
                p.display(),
                t.elapsed()
            );
            n += 1;
        }
    }
    eprintln!("replayed {n} fuzz finds");
}
