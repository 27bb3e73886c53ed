//! Times the STEP reader on files: ruststep's nom parser (what the reader
//! used before), our Part 21 parser, and the whole read (parse, entity
//! table, conversion to the model). Best of `REPEAT` runs each, in ms.
//!
//! ```sh
//! cargo run --release -p bubblemesh-truck --example step_parse_time -- [--compare] FILE...
//! ```
//!
//! `--compare`: also check that both parsers give the same instances (they
//! may differ only in strings, which ruststep does not decode).
use std::time::Instant;

use bubblemesh_truck::step::part21;
use truck_stepio::r#in::ruststep;

const REPEAT: usize = 3;

fn best<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut t = f64::INFINITY;
    let mut out = None;
    for _ in 0..REPEAT {
        let s = Instant::now();
        let r = f();
        t = t.min(s.elapsed().as_secs_f64() * 1e3);
        out = Some(r);
    }
    (t, out.expect("REPEAT > 0"))
}

fn main() {
    println!(
        "{:>9} {:>9} {:>10} {:>10} {:>9}  file",
        "KiB", "entities", "ruststep", "part21", "read_step"
    );
    let compare = std::env::args().any(|a| a == "--compare");
    for path in std::env::args().skip(1).filter(|a| a != "--compare") {
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{path}: {e}");
                continue;
            }
        };
        let text = String::from_utf8_lossy(&bytes);
        let (t_old, old) = best(|| ruststep::parser::parse(&text).is_ok());
        let (t_new, new) = best(|| part21::parse(&text).map(|e| e.instances.len()));
        if compare {
            compare_asts(&text, &path);
        }
        let (t_all, all) = best(|| bubblemesh_truck::parse_step(&text, &path).is_ok());
        println!(
            "{:>9.0} {:>9} {:>9.1}{} {:>9.1}{} {:>8.1}{}  {}",
            bytes.len() as f64 / 1024.0,
            new.as_ref().map_or(0, |n| *n),
            t_old,
            if old { " " } else { "!" },
            t_new,
            if new.is_ok() { " " } else { "!" },
            t_all,
            if all { " " } else { "!" },
            path.rsplit('/').next().unwrap_or(&path)
        );
    }
    println!("(ms, best of {REPEAT}; '!' marks a failure)");
}

/// Reports the instances where the two parsers disagree (strings aside).
fn compare_asts(text: &str, path: &str) {
    use ruststep::ast::{EntityInstance, Parameter};
    fn strip(p: &mut Parameter) {
        match p {
            Parameter::String(s) => s.clear(),
            Parameter::List(v) => v.iter_mut().for_each(strip),
            Parameter::Typed { parameter, .. } => strip(parameter),
            _ => {}
        }
    }
    fn norm(i: &EntityInstance) -> EntityInstance {
        let mut i = i.clone();
        match &mut i {
            EntityInstance::Simple { record, .. } => strip(&mut record.parameter),
            EntityInstance::Complex { subsuper, .. } => {
                subsuper.0.iter_mut().for_each(|r| strip(&mut r.parameter))
            }
        }
        i
    }
    let (Ok(old), Ok(new)) = (ruststep::parser::parse(text), part21::parse(text)) else {
        println!("compare {path}: a parser failed");
        return;
    };
    let old: Vec<_> = old.data.iter().flat_map(|d| d.entities.iter()).collect();
    if old.len() != new.instances.len() {
        println!(
            "compare {path}: {} vs {} instances",
            old.len(),
            new.instances.len()
        );
    }
    let mut diff = 0;
    for (a, b) in old.iter().zip(&new.instances) {
        if norm(a) != norm(b) {
            if diff == 0 {
                println!("compare {path}: first difference:\n  {a:?}\n  {b:?}");
            }
            diff += 1;
        }
    }
    let strings = old
        .iter()
        .zip(&new.instances)
        .filter(|(a, b)| **a != *b)
        .count();
    println!("compare {path}: {diff} instances differ, {strings} counting strings");
}
