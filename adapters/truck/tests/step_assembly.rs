//! A CadQuery assembly (fixtures/step/assembly_nested.step, written by
//! cq.Assembly's own STEP export from fixtures/cadquery_parts.py): every
//! instance is placed where OpenCascade puts it, nested placements composed,
//! and each volume is named after its product and instance.
//!
//! The expected boxes are in the manifest's `instances`: OpenCascade's XCAF
//! reader (STEPCAFControl_Reader) walked from the top assembly, each leaf's
//! shape moved by its composed location, tight box (BRepBndLib::AddOptimal).

use std::path::PathBuf;

use bubblemesh_truck::{read_step, step::volume_bbox};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn manifest_part(name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(root().join("fixtures/manifest.json")).unwrap();
    let m: serde_json::Value = serde_json::from_str(&text).unwrap();
    m["parts"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap_or_else(|| panic!("{name} not in fixtures/manifest.json"))
        .clone()
}

fn bbox6(b: &serde_json::Value) -> [f64; 6] {
    let c = |k: &str, i: usize| b[k][i].as_f64().unwrap();
    [
        c("min", 0),
        c("min", 1),
        c("min", 2),
        c("max", 0),
        c("max", 1),
        c("max", 2),
    ]
}

/// Every instance of the manifest is one volume of the model with
/// OpenCascade's bounding box (within 0.01 mm: the model's box samples each
/// edge at 33 points, exact here since every circle is placed with an axis
/// of its frame along a sampled direction) and a name carrying its product's
/// and instance's names. The volumes are matched to the instances by box,
/// one to one, so the test does not depend on the reading order.
#[test]
fn cadquery_assembly_instances_are_placed_and_named() {
    let p = manifest_part("assembly_nested");
    let inst = p["instances"].as_array().unwrap();
    assert!(
        inst.len() >= 3,
        "the fixture should have at least three instances"
    );
    let file = root().join("fixtures").join(p["file"].as_str().unwrap());
    let s = read_step(&file).unwrap_or_else(|e| panic!("{e}"));
    let m = &s.model;
    assert_eq!(m.volumes.len(), inst.len(), "one volume per instance");
    let boxes: Vec<[f64; 6]> = (0..m.volumes.len())
        .map(|v| {
            let (lo, hi) = volume_bbox(m, v).unwrap();
            [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]
        })
        .collect();
    let names: Vec<String> = m
        .volumes
        .iter()
        .map(|v| v.name.clone().unwrap_or_default())
        .collect();
    let tol = 0.01;
    let mut used = vec![false; m.volumes.len()];
    for i in inst {
        let want = bbox6(&i["bbox"]);
        let product = i["product"].as_str().unwrap();
        let instance = i["instance"].as_str().unwrap();
        let hits: Vec<usize> = (0..boxes.len())
            .filter(|&v| (0..6).all(|k| (boxes[v][k] - want[k]).abs() < tol))
            .collect();
        assert_eq!(
            hits.len(),
            1,
            "instance {instance} of {product}: OpenCascade box {want:?}, \
             volumes' boxes {boxes:?} (names {names:?})"
        );
        let v = hits[0];
        assert!(!used[v], "volume {v} matches two instances");
        used[v] = true;
        assert!(
            names[v].contains(product),
            "volume {v} ({:?}) is instance {instance} of product {product}",
            names[v]
        );
        assert!(
            names[v].contains(instance),
            "volume {v} ({:?}) is instance {instance} of product {product}",
            names[v]
        );
        // the instance's own faces, no more
        assert_eq!(
            m.volumes[v].faces.len() as u64,
            i["faces"].as_u64().unwrap(),
            "faces of {instance}"
        );
    }
    // the whole model spans the kernel's box of the compound
    let (lo, hi) = m.bbox().unwrap();
    let want = bbox6(&p["bbox"]);
    let got = [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z];
    for k in 0..6 {
        assert!(
            (got[k] - want[k]).abs() < tol,
            "model box {got:?}, OpenCascade {want:?}"
        );
    }
}

/// The nested placement is composed, not just the innermost one: the
/// sub-assembly's instances are turned 45 degrees about z, so their boxes
/// are not those of the parts at their own origins, nor of the parts placed
/// by their own (inner) locations only.
#[test]
fn nested_placement_is_composed() {
    let p = manifest_part("assembly_nested");
    let inst = p["instances"].as_array().unwrap();
    let nested: Vec<_> = inst
        .iter()
        .filter(|i| i["path"].as_str().unwrap().contains('/'))
        .collect();
    assert!(
        nested.len() >= 2,
        "the fixture should place a sub-assembly with two instances"
    );
    // the arm plate, turned 90° about x then 45° about z: its box is
    // 30 cos45 + 4 sin45 wide in x and y (both 24.04), 20 high
    let arm_plate = nested
        .iter()
        .find(|i| i["instance"] == "arm_plate")
        .unwrap();
    let b = bbox6(&arm_plate["bbox"]);
    let w = (30.0 + 4.0) * std::f64::consts::FRAC_1_SQRT_2;
    assert!((b[3] - b[0] - w).abs() < 1e-6 && (b[4] - b[1] - w).abs() < 1e-6);
    assert!((b[5] - b[2] - 20.0).abs() < 1e-6);
    // ... and the reader agrees (matched by its name)
    let file = root().join("fixtures").join(p["file"].as_str().unwrap());
    let s = read_step(&file).unwrap_or_else(|e| panic!("{e}"));
    let v = s
        .model
        .volumes
        .iter()
        .position(|v| v.name.as_deref().is_some_and(|n| n.contains("arm_plate")))
        .expect("a volume named after the instance arm_plate");
    let (lo, hi) = volume_bbox(&s.model, v).unwrap();
    let got = [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z];
    for k in 0..6 {
        assert!(
            (got[k] - b[k]).abs() < 0.01,
            "arm_plate: {got:?}, OpenCascade {b:?}"
        );
    }
}
