//! Throughput benchmark (not run in CI):
//!
//! ```text
//! cargo run --release -p bubblemesh-delaunay --example throughput -- 1000000
//! cargo run --release -p bubblemesh-delaunay --example throughput -- 100000 --write /tmp/pts
//! ```
//!
//! Prints, for N uniform random points in the unit cube and for an FCC
//! lattice of about N points: points, tets, wall and CPU seconds of the
//! `tetrahedralize` call (one thread), tets/second for both.
//! `--only uniform|fcc` runs one input. `--write DIR` also stores both point sets as raw little-endian f64 triples
//! (`DIR/uniform.f64`, `DIR/fcc.f64`) for `bench/compare_scipy.py`.
use bubblemesh_delaunay::tetrahedralize;
use std::time::Instant;

fn uniform(n: usize) -> Vec<[f64; 3]> {
    // SplitMix64, fixed seed: the same points on every run.
    let mut s = 0x1234_5678u64;
    let mut next = || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

/// Integer points of [0, m]^3 with even coordinate sum, m chosen so that
/// there are about `n` of them.
fn fcc(n: usize) -> Vec<[f64; 3]> {
    let m = ((2.0 * n as f64).cbrt().round() as usize).max(2);
    let mut pts = Vec::with_capacity(n + n / 8);
    for i in 0..=m {
        for j in 0..=m {
            for k in 0..=m {
                if (i + j + k) % 2 == 0 {
                    pts.push([i as f64, j as f64, k as f64]);
                }
            }
        }
    }
    pts
}

/// CPU time of this thread in seconds (Linux `/proc/thread-self/schedstat`,
/// nanoseconds on CPU), so that other processes on a shared machine do not
/// inflate the number; `None` elsewhere.
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(s.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
}

fn write(path: &std::path::Path, pts: &[[f64; 3]]) {
    let bytes: Vec<u8> = pts.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args
        .first()
        .map(|a| a.parse().expect("usage: throughput N [--write DIR]"))
        .unwrap_or(100_000);
    let dir = args
        .iter()
        .position(|a| a == "--write")
        .map(|i| std::path::PathBuf::from(&args[i + 1]));
    println!(
        "{:<8} {:>10} {:>10} {:>8} {:>8} {:>11} {:>11}",
        "input", "points", "tets", "wall_s", "cpu_s", "tets/s_wall", "tets/s_cpu"
    );
    let only = args
        .iter()
        .position(|a| a == "--only")
        .map(|i| args[i + 1].clone());
    for (name, make) in [
        ("uniform", uniform as fn(usize) -> Vec<[f64; 3]>),
        ("fcc", fcc),
    ] {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let pts = make(n);
        if let Some(d) = &dir {
            std::fs::create_dir_all(d).unwrap();
            write(&d.join(format!("{name}.f64")), &pts);
        }
        let c0 = cpu_seconds();
        let t0 = Instant::now();
        let t = tetrahedralize(&pts).expect("tetrahedralize");
        let s = t0.elapsed().as_secs_f64();
        let c = cpu_seconds().zip(c0).map_or(f64::NAN, |(b, a)| b - a);
        let m = t.tets.len() as f64;
        println!(
            "{:<8} {:>10} {:>10} {:>8.3} {:>8.3} {:>11.0} {:>11.0}",
            name,
            pts.len(),
            t.tets.len(),
            s,
            c,
            m / s,
            m / c
        );
    }
}
