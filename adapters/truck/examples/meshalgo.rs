//! truck's own STEP conversion and tessellation, for comparison only
//! (bench/run_step.py's truck-meshalgo column):
//!
//! ```sh
//! cargo run --release -p bubblemesh-truck --example meshalgo -- PART.step OUT.obj TOL
//! ```
//!
//! Every shell of the file is converted by truck-stepio 0.3
//! (`Table::to_compressed_shell`) and tessellated by truck-meshalgo 0.4's
//! `robust_triangulation(TOL)` (TOL: the largest distance, in file units,
//! between a triangle and its surface that truck aims at; it has no edge
//! length target). Vertices within 1e-6 × the mesh's size are merged, the
//! mesh written as OBJ. Faces truck cannot tessellate are dropped by truck
//! itself; this program counts them and says so on stderr, and exits 2 if
//! any face was dropped (the OBJ is still written).
//!
//! This is *not* how bubblemesh reads STEP (see src/step/mod.rs for why): it
//! can take a lot of memory on OpenCascade-written files (unclamped periodic
//! B-splines); run it under a memory limit (`prlimit --as=...`).
use std::path::Path;

use truck_meshalgo::prelude::*;
use truck_stepio::r#in::{ruststep, Table};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: meshalgo PART.step OUT.obj TOL");
        std::process::exit(64);
    }
    let tol: f64 = match args[3].parse() {
        Ok(t) if t > 0.0 => t,
        _ => {
            eprintln!("meshalgo: TOL must be a positive number, got {:?}", args[3]);
            std::process::exit(64);
        }
    };
    let text = match std::fs::read_to_string(&args[1]) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("meshalgo: {}: {e}", args[1]);
            std::process::exit(1);
        }
    };
    let exchange = match ruststep::parser::parse(&text) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("meshalgo: {}: STEP syntax error: {e}", args[1]);
            std::process::exit(1);
        }
    };
    let mut mesh = PolygonMesh::default();
    let (mut faces, mut dropped, mut shells) = (0usize, 0usize, 0usize);
    for section in &exchange.data {
        let table = Table::from_data_section(section);
        let mut ids: Vec<&u64> = table.shell.keys().collect();
        ids.sort();
        for id in ids {
            let shell = match table.to_compressed_shell(&table.shell[id]) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("meshalgo: shell #{id}: truck-stepio cannot convert it: {e:?}");
                    std::process::exit(1);
                }
            };
            shells += 1;
            faces += shell.faces.len();
            let meshed = shell.robust_triangulation(tol);
            dropped += meshed.faces.iter().filter(|f| f.surface.is_none()).count();
            mesh.merge(meshed.to_polygon());
        }
    }
    let size = mesh.bounding_box().diameter();
    mesh.put_together_same_attrs(1e-6 * size.max(1e-300))
        .remove_degenerate_faces()
        .remove_unused_attrs();
    let path: &Path = args[2].as_ref();
    let file = match std::fs::File::create(path) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("meshalgo: {}: {e}", path.display());
            std::process::exit(1);
        }
    };
    if let Err(e) = obj::write(&mesh, file) {
        eprintln!("meshalgo: {}: {e}", path.display());
        std::process::exit(1);
    }
    eprintln!(
        "meshalgo: {shells} shells, {faces} faces, {dropped} dropped by truck, {} triangles, shell condition {:?}",
        mesh.faces().len(),
        mesh.shell_condition()
    );
    if dropped > 0 {
        std::process::exit(2);
    }
}
