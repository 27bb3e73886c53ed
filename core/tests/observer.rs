//! The observer in `Options`: a run tells it each stage of each entity, in
//! order, with snapshots that agree with the mesh; observing does not
//! change the mesh.

mod common;

use std::sync::{Arc, Mutex};

use bubblemesh_core::spacing::Constant;
use bubblemesh_core::{mesh_model, EntityRef, Event, Mesh, Options};

/// What the test observer keeps of an event.
#[derive(Clone, Debug, PartialEq)]
enum Seen {
    Stage1(EntityRef, usize),
    Step(EntityRef, usize),
    Done(EntityRef, usize),
}

fn same_mesh(a: &Mesh, b: &Mesh) -> bool {
    a.nodes.len() == b.nodes.len()
        && a.nodes.iter().zip(&b.nodes).all(|(p, q)| p.pos == q.pos)
        && a.lines
            .iter()
            .map(|l| l.nodes)
            .eq(b.lines.iter().map(|l| l.nodes))
        && a.triangles
            .iter()
            .map(|t| t.nodes)
            .eq(b.triangles.iter().map(|t| t.nodes))
}

#[test]
fn a_run_tells_its_observer_each_stage_in_order_and_meshes_the_same() {
    let model = common::square();
    let spacing = Constant(0.1);
    let (plain, _) = mesh_model(&model, &spacing, &Options::default()).unwrap();

    let seen = Arc::new(Mutex::new(Vec::new()));
    let s = seen.clone();
    let opts = Options {
        observer: Some(Arc::new(move |e: &Event<'_>| {
            let x = match *e {
                Event::Stage1 {
                    entity,
                    fixed,
                    positions,
                    diameters,
                } => {
                    assert_eq!(positions.len(), diameters.len());
                    assert!(fixed < positions.len());
                    Seen::Stage1(entity, positions.len())
                }
                Event::Step {
                    entity,
                    step,
                    max_steps,
                    positions,
                    diameters,
                    ..
                } => {
                    assert_eq!(positions.len(), diameters.len());
                    assert!((1..=max_steps).contains(&step));
                    Seen::Step(entity, step)
                }
                Event::Done { entity, mesh } => Seen::Done(entity, mesh.nodes.len()),
                Event::Pass { .. } => return,
            };
            s.lock().unwrap().push(x);
        })),
        ..Default::default()
    };
    let (mesh, report) = mesh_model(&model, &spacing, &opts).unwrap();
    assert!(same_mesh(&mesh, &plain), "observing changed the mesh");

    let seen = seen.lock().unwrap();
    let face = EntityRef::new(2, 0);
    // every edge, then the face, is done once, in that order
    let done: Vec<EntityRef> = seen
        .iter()
        .filter_map(|x| match x {
            Seen::Done(e, _) => Some(*e),
            _ => None,
        })
        .collect();
    let mut want: Vec<EntityRef> = (0..model.edges.len() as u32)
        .map(|i| EntityRef::new(1, i))
        .collect();
    want.push(face);
    assert_eq!(done, want);
    // the last one sees the whole mesh
    assert_eq!(seen.last(), Some(&Seen::Done(face, mesh.nodes.len())));
    // stage 1 of the face, then each of its stage-2 steps from 1 on
    let stage1 = seen
        .iter()
        .position(|x| matches!(x, Seen::Stage1(e, _) if *e == face))
        .expect("stage 1 of the face");
    let steps: Vec<usize> = seen[stage1..]
        .iter()
        .filter_map(|x| match x {
            Seen::Step(e, k) if *e == face => Some(*k),
            _ => None,
        })
        .collect();
    let relaxed = report.faces[0].relax.as_ref().unwrap().steps;
    assert_eq!(steps, (1..=relaxed).collect::<Vec<_>>());
}
