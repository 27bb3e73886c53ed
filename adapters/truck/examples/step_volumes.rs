//! Prints each volume a STEP file becomes, its name and bounding box, and
//! the largest gap between a face's boundary and its surface:
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
            let worst = s
                .info
                .face_gap
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1));
            if let Some((f, g)) = worst {
                println!(
                    "largest boundary gap {g:.3e} (face {f}, #{}); {} degenerate edges",
                    s.info.face_ids[f],
                    s.info.degenerate_edges.len()
                );
            }
            if let Some((lo, hi)) = m.bbox() {
                println!("all {lo:?} {hi:?}");
            }
        }
    }
}
