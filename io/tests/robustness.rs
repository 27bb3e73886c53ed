//! Atomic writes, and readers on bad input: errors naming the file, never
//! a panic.

mod common;

use std::fs;
use std::path::Path;

use bubblemesh_core::mesh::{Element, Mesh};
use bubblemesh_core::model::EntityRef;
use bubblemesh_io::{read, write, IoError};
use common::sample_mesh;

const EXTS: [&str; 5] = ["msh", "vtu", "stl", "obj", "mesh"];

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

#[test]
fn writing_into_a_missing_directory_fails_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("missing").join("out.msh");
    let err = write(&sample_mesh(), &target).unwrap_err();
    assert!(matches!(err, IoError::Io { .. }), "{err}");
    assert!(err.to_string().contains("out.msh"), "{err}");
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn a_failed_write_leaves_the_existing_target_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("out.vtu");
    fs::write(&target, "previous content").unwrap();
    // An element referring to a missing node: rejected before writing.
    let mut bad = sample_mesh();
    bad.triangles.push(Element {
        nodes: [0, 1, 99],
        entity: EntityRef::new(2, 0),
    });
    let err = write(&bad, &target).unwrap_err();
    assert!(matches!(err, IoError::InvalidMesh { .. }), "{err}");
    assert!(
        err.to_string().contains("out.vtu") && err.to_string().contains("99"),
        "{err}"
    );
    assert_eq!(fs::read_to_string(&target).unwrap(), "previous content");
    assert_eq!(files_in(dir.path()), ["out.vtu"]);

    // A failure at the final rename (the target is a non-empty directory):
    // the temporary file is removed.
    let target = dir.path().join("busy.msh");
    fs::create_dir(&target).unwrap();
    fs::write(target.join("keep"), "x").unwrap();
    let err = write(&sample_mesh(), &target).unwrap_err();
    assert!(err.to_string().contains("busy.msh"), "{err}");
    assert_eq!(files_in(dir.path()), ["busy.msh", "out.vtu"]);
    assert_eq!(files_in(&target), ["keep"]);
}

#[test]
fn a_successful_write_replaces_the_target_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    for ext in EXTS {
        let target = dir.path().join(format!("out.{ext}"));
        fs::write(&target, "old").unwrap();
        write(&sample_mesh(), &target).unwrap();
        assert_ne!(fs::read(&target).unwrap(), b"old");
    }
    assert_eq!(files_in(dir.path()).len(), EXTS.len());
}

#[test]
fn non_finite_coordinates_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = sample_mesh();
    m.nodes[3].pos.y = f64::NAN;
    let err = write(&m, &dir.path().join("x.obj")).unwrap_err();
    assert!(err.to_string().contains("node 3"), "{err}");
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn unknown_extension_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let err = write(&sample_mesh(), &dir.path().join("out.ply")).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("out.ply") && msg.contains("'.ply'") && msg.contains(".vtu"),
        "{msg}"
    );
    let err = read(&dir.path().join("in.ply")).unwrap_err();
    assert!(err.to_string().contains("in.ply"));
}

fn expect_error(path: &Path, what: &str) -> String {
    match read(path) {
        Ok(m) => panic!(
            "{what}: {} read without error ({} nodes)",
            path.display(),
            m.nodes.len()
        ),
        Err(e) => {
            let msg = e.to_string();
            let name = path.file_name().unwrap().to_string_lossy();
            assert!(
                msg.contains(&*name),
                "{what}: '{msg}' does not name the file"
            );
            msg
        }
    }
}

#[test]
fn missing_empty_and_garbage_files_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for ext in EXTS {
        let p = dir.path().join(format!("absent.{ext}"));
        expect_error(&p, "missing");

        let p = dir.path().join(format!("empty.{ext}"));
        fs::write(&p, "").unwrap();
        let msg = expect_error(&p, "empty");
        assert!(msg.contains("empty"), "{msg}");

        let p = dir.path().join(format!("blank.{ext}"));
        fs::write(&p, "\n  \n").unwrap();
        expect_error(&p, "blank");

        let p = dir.path().join(format!("text.{ext}"));
        fs::write(&p, "hello world\nthis is not a mesh\n").unwrap();
        expect_error(&p, "text");

        let p = dir.path().join(format!("binary.{ext}"));
        let bytes: Vec<u8> = (0..1000u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        fs::write(&p, bytes).unwrap();
        expect_error(&p, "binary garbage");
    }
}

#[test]
fn truncated_files_are_errors_with_a_line_number() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["msh", "vtu", "mesh", "stl"] {
        let full = dir.path().join(format!("full.{ext}"));
        write(&sample_mesh(), &full).unwrap();
        let data = fs::read(&full).unwrap();
        let p = dir.path().join(format!("cut.{ext}"));
        fs::write(&p, &data[..data.len() / 2]).unwrap();
        let msg = expect_error(&p, "truncated");
        if ext != "stl" {
            assert!(
                msg.contains("cut.") && msg.contains(&format!("cut.{ext}:")),
                "{msg}"
            );
        }
    }
}

#[test]
fn specific_errors_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str, &str)] = &[
        (
            "a.msh",
            "$MeshFormat\n4.1 1 8\n$EndMeshFormat\n",
            "binary MSH",
        ),
        ("b.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", "version 3.0"),
        (
            "c.msh",
            "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 0 0\n$EndNodes\n$Elements\n1\n1 1 2 0 1 1 3\n$EndElements\n",
            "node tag 3",
        ),
        (
            "d.msh",
            "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 x 0\n$EndNodes\n",
            "d.msh:7: expected a coordinate",
        ),
        ("e.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n", "out of range"),
        ("f.obj", "v 0 0 0\nfoo 1 2\n", "unknown OBJ statement 'foo'"),
        (
            "g.mesh",
            "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 1\nTriangles\n1\n1 2 3 1\nEnd\n",
            "vertex index 2",
        ),
        ("h.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", "truncated"),
        (
            "i.vtu",
            "<?xml version=\"1.0\"?><VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"1\" NumberOfCells=\"0\"><Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"binary\">AAAA</DataArray></Points></Piece></UnstructuredGrid></VTKFile>",
            "only ASCII",
        ),
    ];
    for (name, content, want) in cases {
        let p = dir.path().join(name);
        fs::write(&p, content).unwrap();
        let msg = expect_error(&p, name);
        assert!(msg.contains(want), "{name}: '{msg}' lacks '{want}'");
    }
}

/// A small deterministic generator (no extra dependency).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
}

#[test]
fn readers_never_panic_on_cut_or_corrupted_files() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Lcg(7);
    let mut mesh = sample_mesh();
    mesh.nodes.truncate(8);
    for ext in EXTS {
        let full = dir.path().join(format!("full.{ext}"));
        write(&mesh, &full).unwrap();
        let data = fs::read(&full).unwrap();
        let p = dir.path().join(format!("x.{ext}"));
        // Every prefix.
        for cut in 0..data.len() {
            fs::write(&p, &data[..cut]).unwrap();
            let _ = read(&p);
        }
        // Random byte changes, insertions and deletions.
        for _ in 0..400 {
            let mut d = data.clone();
            for _ in 0..1 + rng.next() % 4 {
                let at = (rng.next() as usize) % d.len();
                match rng.next() % 3 {
                    0 => d[at] = b" 0123456789-.e$<>/\n\"x"[(rng.next() % 21) as usize],
                    1 => d.insert(at, (rng.next() % 256) as u8),
                    _ => {
                        d.remove(at);
                    }
                }
            }
            fs::write(&p, &d).unwrap();
            if let Ok(m) = read(&p) {
                // Whatever was read is a consistent mesh.
                let n = m.nodes.len() as u32;
                assert!(m.triangles.iter().all(|t| t.nodes.iter().all(|&v| v < n)));
                assert!(m.tetrahedra.iter().all(|t| t.nodes.iter().all(|&v| v < n)));
                assert!(m.lines.iter().all(|t| t.nodes.iter().all(|&v| v < n)));
            }
        }
    }
}

#[test]
fn huge_counts_do_not_exhaust_memory() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("a.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n999999999999\n1 0 0 0\n"),
        ("b.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 99999999999 1 99999999999\n0 1 0 99999999999\n1\n"),
        ("c.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n99999999999999\n0 0 0 1\n"),
        ("e.vtu", "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"18446744073709551615\" NumberOfCells=\"0\"><Points><DataArray NumberOfComponents=\"3\" format=\"ascii\">0 0 0</DataArray></Points></Piece></UnstructuredGrid></VTKFile>"),
        ("d.vtu", "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"99999999999\" NumberOfCells=\"0\"></Piece></UnstructuredGrid></VTKFile>"),
    ];
    for (name, content) in cases {
        let p = dir.path().join(name);
        fs::write(&p, content).unwrap();
        expect_error(&p, name);
    }
}

#[test]
fn an_stl_with_several_solids_gives_several_faces() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("two.stl");
    let facet = |z: f64| {
        format!(
            "facet normal 0 0 1\n outer loop\n  vertex 0 0 {z}\n  vertex 1 0 {z}\n  vertex 0 1 {z}\n endloop\nendfacet\n"
        )
    };
    fs::write(
        &p,
        format!(
            "solid a\n{}{}endsolid a\nsolid b\n{}endsolid b\n",
            facet(0.0),
            facet(1.0),
            facet(0.0)
        ),
    )
    .unwrap();
    let m: Mesh = read(&p).unwrap();
    assert_eq!(m.triangles.len(), 3);
    assert_eq!(m.nodes.len(), 6);
    let faces: Vec<u32> = m.triangles.iter().map(|t| t.entity.id).collect();
    assert_eq!(faces, [0, 0, 1]);
    assert_eq!(m.entities.len(), 2);
}

#[test]
fn obj_reads_polygons_slashes_and_negative_indices() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("q.obj");
    fs::write(
        &p,
        "# quad\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\nvt 0 0\nvn 0 0 1\ng grp\ns off\nf 1/1/1 2/1/1 3//1 4\nf -4 -3 -1\nl 1 2 3\n",
    )
    .unwrap();
    let m = read(&p).unwrap();
    assert_eq!(m.nodes.len(), 4);
    let t: Vec<[u32; 3]> = m.triangles.iter().map(|t| t.nodes).collect();
    assert_eq!(t, [[0, 1, 2], [0, 2, 3], [0, 1, 3]]);
    assert_eq!(m.lines.len(), 2);
    // Nodes on a line are on the edge (lowest dimension wins).
    assert_eq!(m.nodes[0].entity, EntityRef::new(1, 0));
    assert_eq!(m.nodes[3].entity, EntityRef::new(2, 0));
}

#[test]
fn medit_reads_2d_files_and_skips_other_sections() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("q.mesh");
    fs::write(
        &p,
        "MeshVersionFormatted 1\n# comment\nDimension\n2\nVertices\n4\n0 0 1\n1 0 1\n1 1 1\n0 1 2\n\
         Quadrilaterals\n1\n1 2 3 4 1\nRequiredVertices 1 1\nTriangles\n2\n1 2 3 5\n1 3 4 5\nCorners\n1\n4\nEnd\n",
    )
    .unwrap();
    let m = read(&p).unwrap();
    assert_eq!(m.nodes.len(), 4);
    assert_eq!(m.nodes[2].pos.z, 0.0);
    assert_eq!(m.triangles.len(), 2);
    assert_eq!(m.triangles[0].entity, EntityRef::new(2, 4));
    // Corner 4 has vertex ref 2 → vertex 1.
    assert_eq!(m.nodes[3].entity, EntityRef::new(0, 1));
    assert_eq!(m.nodes[0].entity, EntityRef::new(2, 4));
}

#[test]
fn vtu_written_by_meshio_style_is_read() {
    // As meshio writes ASCII VTU (no entity data; a comment; arrays on lines).
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.vtu");
    fs::write(
        &p,
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<!--This file was created by meshio v5.3.5-->
<UnstructuredGrid>
<Piece NumberOfPoints="4" NumberOfCells="3">
<Points>
<DataArray type="Float64" Name="Points" NumberOfComponents="3" format="ascii">
0.00000000000e+00 0.00000000000e+00 0.00000000000e+00
1.00000000000e+00 0.00000000000e+00 0.00000000000e+00
0.00000000000e+00 1.00000000000e+00 0.00000000000e+00
0.00000000000e+00 0.00000000000e+00 1.00000000000e+00
</DataArray>
</Points>
<Cells>
<DataArray type="Int64" Name="connectivity" format="ascii">
0 1 2 0 1 2 3 0
</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">
3 7 8
</DataArray>
<DataArray type="Int64" Name="types" format="ascii">
5 10 1
</DataArray>
</Cells>
<CellData>
<DataArray type="Int64" Name="c" format="ascii">
1 2 3
</DataArray>
</CellData>
</Piece>
</UnstructuredGrid>
</VTKFile>
"#,
    )
    .unwrap();
    let m = read(&p).unwrap();
    assert_eq!(
        (m.nodes.len(), m.triangles.len(), m.tetrahedra.len()),
        (4, 1, 1)
    );
    assert_eq!(m.nodes[3].entity, EntityRef::new(3, 0));
    assert_eq!(m.nodes[0].entity, EntityRef::new(2, 0));
}
