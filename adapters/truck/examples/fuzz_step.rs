//! A mutation fuzzer for the STEP reader on the stable toolchain (no
//! cargo-fuzz, which needs nightly): seed files are mutated with a fixed
//! seed (byte flips, STEP tokens inserted, ranges deleted or duplicated,
//! splices of two seeds, truncation, numbers made extreme, references
//! redirected) and each mutant goes through
//! [`parse_step`] (parser, entity table, conversion).
//!
//! ```sh
//! cargo run --release -p bubblemesh-truck --example fuzz_step -- \
//!     --seconds 60 --seed 1 --out fuzz-finds fixtures/step/*.step
//! ```
//!
//! A *find* is a mutant that makes the reader panic (caught by
//! `parse_step`, which then says "internal error"), or that takes longer
//! than `--slow` seconds (default 10). Finds are written to `--out` as
//! `panic-N.step` / `slow-N.step`. The mutant under test is also written to
//! `OUT/current.step` before each run, so that an abort or a hang the
//! wrapper's `timeout` kills (scripts/fuzz_step.sh) leaves it on disk.
//! Exit status: 0 if nothing was found, 1 otherwise.
use std::path::PathBuf;
use std::time::{Duration, Instant};

use bubblemesh_truck::parse_step;

/// xorshift64*: deterministic for a given seed, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// Tokens that steer mutants into the parser's and the conversion's corners.
const TOKENS: &[&str] = &[
    "(",
    ")",
    ",",
    "'",
    "''",
    "/*",
    "*/",
    "$",
    "*",
    ";",
    "=",
    "#",
    "#1",
    "#0",
    "#99999999",
    "#18446744073709551616",
    ".T.",
    ".F.",
    ".",
    "\"0F\"",
    "1.E308",
    "-1.E308",
    "1.E400",
    "0.",
    "-0.",
    "1E-320",
    "9223372036854775808",
    "()",
    "((((((((",
    "))))))))",
    "ENDSEC;",
    "DATA;",
    "END-ISO-10303-21;",
    "\\X2\\",
    "\\X0\\",
    "\u{feff}",
    "\n",
    "CARTESIAN_POINT",
    "LINE",
    "CIRCLE",
    "B_SPLINE_CURVE_WITH_KNOTS",
    "EDGE_CURVE",
    "ADVANCED_FACE",
    "VERTEX_LOOP",
    "99",
    "-1",
    "1000000000",
];

fn mutate(rng: &mut Rng, seeds: &[Vec<u8>], base: &[u8]) -> Vec<u8> {
    let mut v = base.to_vec();
    for _ in 0..1 + rng.below(4) {
        let n = v.len();
        match rng.below(9) {
            0 if n > 0 => {
                let i = rng.below(n);
                v[i] = b" ()',;#$*.=0123456789E-+/\"\\"[rng.below(27)];
            }
            1 => {
                let i = rng.below(n + 1);
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
                v.splice(i..i, t.iter().copied());
            }
            2 if n > 0 => {
                let i = rng.below(n);
                let len = 1 + rng.below(64.min(n - i));
                v.drain(i..i + len);
            }
            3 if n > 0 => {
                let i = rng.below(n);
                let len = 1 + rng.below(256.min(n - i));
                let piece = v[i..i + len].to_vec();
                let j = rng.below(n + 1);
                v.splice(j..j, piece);
            }
            4 if !seeds.is_empty() => {
                let other = &seeds[rng.below(seeds.len())];
                if !other.is_empty() && n > 0 {
                    let i = rng.below(n);
                    let j = rng.below(other.len());
                    let len = rng.below(512.min(other.len() - j) + 1);
                    v.splice(i..i, other[j..j + len].iter().copied());
                }
            }
            5 if n > 0 => v.truncate(rng.below(n)),
            6 | 7 if n > 0 => {
                // a reference #N redirected to another entity (type
                // confusion and cycles in the conversion, valid syntax)
                let i = rng.below(n);
                if let Some(k) = v[i..].iter().position(|&c| c == b'#') {
                    let s = i + k + 1;
                    let mut e = s;
                    while e < v.len() && v[e].is_ascii_digit() {
                        e += 1;
                    }
                    if e > s {
                        let to = (1 + rng.below(400)).to_string();
                        v.splice(s..e, to.bytes());
                    }
                }
            }
            _ if n > 0 => {
                // a number of the file replaced by an extreme one
                let i = rng.below(n);
                if let Some(k) = v[i..].iter().position(|c| c.is_ascii_digit()) {
                    let s = i + k;
                    let mut e = s;
                    while e < v.len() && (v[e].is_ascii_digit() || v[e] == b'.') {
                        e += 1;
                    }
                    let t = ["0.", "1.E308", "1.E-308", "-1.", "3", "0", "1.E20"][rng.below(7)];
                    v.splice(s..e, t.bytes());
                }
            }
            _ => {}
        }
    }
    v
}

fn main() {
    let mut seconds = 60.0f64;
    let mut seed = 1u64;
    let mut slow = 10.0f64;
    let mut out = PathBuf::from("fuzz-finds");
    let mut files = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = |name: &str| {
            args.next()
                .unwrap_or_else(|| panic!("{name} needs a value"))
        };
        match a.as_str() {
            "--seconds" => seconds = val("--seconds").parse().expect("--seconds N"),
            "--seed" => seed = val("--seed").parse().expect("--seed N"),
            "--slow" => slow = val("--slow").parse().expect("--slow N"),
            "--out" => out = PathBuf::from(val("--out")),
            _ => files.push(PathBuf::from(a)),
        }
    }
    let seeds: Vec<Vec<u8>> = files.iter().filter_map(|f| std::fs::read(f).ok()).collect();
    if seeds.is_empty() {
        eprintln!("fuzz_step: no seed files");
        std::process::exit(64);
    }
    std::fs::create_dir_all(&out).expect("create the output directory");
    // panics are expected to be caught by parse_step; keep the output short
    std::panic::set_hook(Box::new(|info| {
        eprintln!("panic: {info}");
    }));
    let mut rng = Rng(seed.max(1));
    let start = Instant::now();
    let budget = Duration::from_secs_f64(seconds);
    let (mut runs, mut finds, mut ok) = (0u64, 0u64, 0u64);
    while start.elapsed() < budget {
        let base = &seeds[rng.below(seeds.len())];
        let m = mutate(&mut rng, &seeds, base);
        let _ = std::fs::write(out.join("current.step"), &m);
        let text = String::from_utf8_lossy(&m);
        let t = Instant::now();
        let r = std::panic::catch_unwind(|| parse_step(&text, "fuzz.step"));
        let dt = t.elapsed().as_secs_f64();
        runs += 1;
        let kind = match &r {
            Err(_) => Some("panic"),
            Ok(Err(e)) if e.reason.contains("panic was caught") => Some("panic"),
            _ if dt > slow => Some("slow"),
            Ok(Ok(_)) => {
                ok += 1;
                None
            }
            Ok(Err(_)) => None,
        };
        if let Some(kind) = kind {
            finds += 1;
            let path = out.join(format!("{kind}-{finds}.step"));
            let _ = std::fs::write(&path, &m);
            eprintln!("find: {kind} ({dt:.1} s) -> {}", path.display());
        }
    }
    let _ = std::fs::remove_file(out.join("current.step"));
    println!(
        "fuzz_step: {runs} inputs in {:.0} s (seed {seed}), {ok} read without error, {finds} finds",
        start.elapsed().as_secs_f64()
    );
    std::process::exit(if finds > 0 { 1 } else { 0 });
}
