//! Prints what a STEP file becomes: `cargo run --example step_info FILE`.
use bubblemesh_truck::read_step;

fn main() {
    let path = std::env::args().nth(1).expect("usage: step_info FILE.step");
    match read_step(std::path::Path::new(&path)) {
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
        Ok(s) => {
            let m = &s.model;
            println!(
                "{} vertices, {} edges, {} faces, {} volumes; seams {:?}",
                m.vertices.len(),
                m.edges.len(),
                m.faces.len(),
                m.volumes.len(),
                s.info.seams
            );
            for (i, e) in m.edges.iter().enumerate() {
                println!(
                    "edge {i} {:?}: t [{:.4}, {:.4}] {} -> {}",
                    e.name, e.t0, e.t1, e.start, e.end
                );
            }
            for (i, f) in m.faces.iter().enumerate() {
                let loops: Vec<Vec<(u32, bool)>> = f
                    .loops
                    .iter()
                    .map(|l| l.edges.iter().map(|u| (u.edge, u.forward)).collect())
                    .collect();
                println!(
                    "face {i} {:?}: domain {:?} periods {:?} loops {:?} embedded {:?} same_sense {}",
                    f.name,
                    f.surface.domain(),
                    f.surface.periods(),
                    loops,
                    f.embedded_vertices,
                    s.info.face_same_sense[i]
                );
            }
            for sh in &s.info.shells {
                println!("{sh:?}");
            }
        }
    }
}
