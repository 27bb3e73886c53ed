//! Quick engine probe on the benchmark domains (development aid):
//! `cargo run --release -p bubblemesh-core --example probe -- A`
#[path = "../tests/common/mod.rs"]
mod common;
use bubblemesh_core::spacing::Expr;
use bubblemesh_core::*;

fn main() {
    let case = std::env::args().nth(1).unwrap_or("A".into());
    let fast = std::env::args().any(|a| a == "--fast");
    let (model, expr) = match case.as_str() {
        "A" => (common::square(), "0.02"),
        "B" => (common::square(), "0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)"),
        "C" => (
            common::plate_two_holes(),
            "0.02 + 0.1*max(min(sqrt((x-0.5)^2+(y-0.5)^2), sqrt((x-1.5)^2+(y-0.5)^2)) - 0.2, 0)",
        ),
        "D" => (common::hexagon(), "0.1"),
        "E" => (common::square(), "0.002"),
        "F" => (
            common::closed_surface(std::sync::Arc::new(common::Sphere(1.0))),
            "0.05",
        ),
        "G" => (
            common::closed_surface(std::sync::Arc::new(common::Torus(1.0, 0.3))),
            "0.03",
        ),
        _ => panic!("case"),
    };
    let s = Expr::parse(expr).unwrap();
    let mut opts = Options {
        fast,
        ..Default::default()
    };
    if let Ok(v) = std::env::var("STEPS") {
        opts.relax.max_steps = v.parse().unwrap();
    }
    if std::env::var("RK4").is_ok() {
        opts.relax.integrator = bubblemesh_core::engine::Integrator::Rk4;
    }
    if let Ok(v) = std::env::var("POPUNTIL") {
        opts.relax.population_until = v.parse().unwrap();
    }
    let (mesh, rep) = mesh_model(&model, &s, &opts).unwrap();
    if let Ok(path) = std::env::var("OUT") {
        write_obj(&mesh, &path);
    }
    let q = common::radius_ratios(&mesh);
    let qmin = q.iter().cloned().fold(1.0, f64::min);
    let qmean = q.iter().sum::<f64>() / q.len() as f64;
    let (frac, lmean) = common::spacing_conformance(&mesh, |p| s.eval(p));
    println!("case {case}: nodes {} tris {} qmin {qmin:.3} qmean {qmean:.4} L/d in band {:.4} mean {lmean:.3}", mesh.nodes.len(), mesh.triangles.len(), frac);
    for f in &rep.faces {
        if let Some(r) = &f.relax {
            println!(
                "  face {}: stage1 {} final {} steps {} conv {} del {} add {} move {:.2e}",
                f.face,
                f.stage1_bubbles,
                f.bubbles,
                r.steps,
                r.converged,
                r.deleted,
                r.added,
                r.final_max_move
            );
        } else {
            println!("  face {}: stage1 {}", f.face, f.stage1_bubbles);
        }
    }
    println!("  timings {:?}", rep.timings);
    if let Some(r) = &rep.faces[0].relax {
        let e = &r.energy;
        for k in [
            0usize,
            e.len() / 4,
            e.len() / 2,
            3 * e.len() / 4,
            e.len() - 1,
        ] {
            println!(
                "   E[{}] kin {:.3e} pot {:.3e} n {}",
                e[k].step, e[k].kinetic, e[k].potential, e[k].bubbles
            );
        }
    }
    worst(&mesh, &q);
}

#[allow(dead_code)]
pub fn worst(mesh: &bubblemesh_core::Mesh, q: &[f64]) {
    let mut idx: Vec<usize> = (0..q.len()).collect();
    idx.sort_by(|&a, &b| q[a].total_cmp(&q[b]));
    for &i in idx.iter().take(8) {
        let t = &mesh.triangles[i];
        let c = t
            .nodes
            .map(|n| mesh.nodes[n as usize].pos)
            .iter()
            .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
            / 3.0;
        let dims: Vec<u8> = t
            .nodes
            .iter()
            .map(|&n| mesh.nodes[n as usize].entity.dim)
            .collect();
        println!(
            "   q {:.3} at ({:.3},{:.3}) node dims {:?}",
            q[i], c.x, c.y, dims
        );
    }
    let mut band = [(0.0, 0usize); 8];
    for (i, t) in mesh.triangles.iter().enumerate() {
        let c = t
            .nodes
            .map(|n| mesh.nodes[n as usize].pos)
            .iter()
            .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
            / 3.0;
        let r = ((c.x - 0.5).powi(2) + (c.y - 0.5).powi(2)).sqrt();
        let k = ((r / 0.1) as usize).min(7);
        band[k].0 += 1.0 - q[i];
        band[k].1 += 1;
    }
    println!(
        "   deficit by radius band 0.1: {:?}",
        band.iter()
            .map(|(s, n)| format!("{:.1}/{} ", s, n))
            .collect::<String>()
    );
    let bins = [0.6, 0.7, 0.8, 0.9, 0.95, 0.98, 0.99, 1.01];
    let mut h = vec![0; bins.len()];
    for &x in q {
        let k = bins.iter().position(|&b| x < b).unwrap();
        h[k] += 1;
    }
    println!(
        "   hist (<0.6,<0.7,<0.8,<0.9,<0.95,<0.98,<0.99,≤1): {:?}",
        h
    );
}

fn write_obj(mesh: &bubblemesh_core::Mesh, path: &str) {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    for n in &mesh.nodes {
        writeln!(f, "v {} {} {}", n.pos.x, n.pos.y, n.pos.z).unwrap();
    }
    for t in &mesh.triangles {
        writeln!(
            f,
            "f {} {} {}",
            t.nodes[0] + 1,
            t.nodes[1] + 1,
            t.nodes[2] + 1
        )
        .unwrap();
    }
}
