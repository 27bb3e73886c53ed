//! Prints each volume a STEP file becomes, its name and bounding box:
//! `cargo run --example step_volumes FILE`.
use bubblemesh_truck::{read_step, step::volume_bbox};

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: step_volumes FILE.step");
    match read_step(std::path::Path::new(&path)) {
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
        Ok(s) => {
            let m = &s.model;
            println!("{} volumes", m.volumes.len());
            for (i, v) in m.volumes.iter().enumerate() {
                let b = volume_bbox(m, i);
                let b = b.map(|(lo, hi)| {
                    format!(
                        "({:.3}, {:.3}, {:.3}, {:.3}, {:.3}, {:.3})",
                        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
                    )
                });
                println!("  {i} {:?} {}", v.name, b.unwrap_or_default());
            }
            if let Some((lo, hi)) = m.bbox() {
                println!("all {lo:?} {hi:?}");
            }
        }
    }
}
