//! write → read round trips for every format.

mod common;

use std::path::{Path, PathBuf};

use bubblemesh_core::mesh::{Element, Mesh};
use bubblemesh_core::model::EntityRef;
use bubblemesh_io::{read, write};
use common::{enclosed_volume, sample_mesh, tet_only};

fn roundtrip(m: &Mesh, name: &str) -> (tempfile::TempDir, PathBuf, Mesh) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    write(m, &path).unwrap();
    let back = read(&path).unwrap_or_else(|e| panic!("{e}"));
    (dir, path, back)
}

fn nodes_of<const N: usize>(e: &[Element<N>]) -> Vec<[u32; N]> {
    e.iter().map(|e| e.nodes).collect()
}

fn entities_of<const N: usize>(e: &[Element<N>]) -> Vec<EntityRef> {
    e.iter().map(|e| e.entity).collect()
}

/// Same nodes (exact coordinates and entities) and the same elements.
fn assert_same(a: &Mesh, b: &Mesh) {
    assert_eq!(a.nodes.len(), b.nodes.len());
    for (i, (x, y)) in a.nodes.iter().zip(&b.nodes).enumerate() {
        assert_eq!(x.pos, y.pos, "node {i}");
        assert_eq!(x.entity, y.entity, "node {i}");
    }
    assert_eq!(nodes_of(&a.lines), nodes_of(&b.lines));
    assert_eq!(nodes_of(&a.triangles), nodes_of(&b.triangles));
    assert_eq!(nodes_of(&a.tetrahedra), nodes_of(&b.tetrahedra));
    assert_eq!(entities_of(&a.lines), entities_of(&b.lines));
    assert_eq!(entities_of(&a.triangles), entities_of(&b.triangles));
    assert_eq!(entities_of(&a.tetrahedra), entities_of(&b.tetrahedra));
}

#[test]
fn msh_keeps_everything() {
    let m = sample_mesh();
    let (_d, _p, back) = roundtrip(&m, "a.msh");
    assert_same(&m, &back);
    // Entities with their boundaries.
    assert_eq!(back.entities.len(), m.entities.len());
    for (x, y) in m.entities.iter().zip(&back.entities) {
        assert_eq!(x.entity, y.entity);
        assert_eq!(x.boundary, y.boundary, "{:?}", x.entity);
        assert_eq!(x.name, y.name, "{:?}", x.entity);
    }
}

#[test]
fn msh_layout() {
    let (_d, p, _) = roundtrip(&sample_mesh(), "a.msh");
    let text = std::fs::read_to_string(p).unwrap();
    assert!(text.starts_with("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"));
    // 4 points, 4 curves, 1 surface, 1 volume.
    assert!(text.contains("$Entities\n4 4 1 1\n"), "{text}");
    // Blocks: 4 vertices + volume for nodes; 4 points + 4 lines + 1 + 1 (4 + 4 + 2 + 6 elements).
    assert!(text.contains("$Nodes\n5 8 1 8\n"), "{text}");
    assert!(text.contains("$Elements\n10 16 1 16\n"), "{text}");
    // Edge 1 (tag 1), in physical group 1, is bounded by points 1 and -2.
    assert!(
        text.contains("\n1 0.3333333333333333 -2.5 0.1 1.0333333333333332 -2.5 0.1 1 1 2 1 -2\n"),
        "{text}"
    );
}

#[test]
fn msh_without_entities_synthesises_them() {
    let mut m = sample_mesh();
    m.entities.clear();
    let (_d, _p, back) = roundtrip(&m, "a.msh");
    assert_same(&m, &back);
    assert_eq!(back.entities.len(), 10);
    assert!(back.entities.iter().all(|e| e.boundary.is_empty()));
}

#[test]
fn vtu_keeps_nodes_elements_and_entities() {
    let m = sample_mesh();
    let (_d, _p, back) = roundtrip(&m, "a.vtu");
    assert_same(&m, &back);
}

#[test]
fn medit_keeps_nodes_elements_and_entities() {
    let m = sample_mesh();
    let (_d, p, back) = roundtrip(&m, "a.mesh");
    // Node entities: vertices through Corners, the others inferred (the
    // top corners are only in tetrahedra, so in volume 0 as written).
    assert_same(&m, &back);
    let text = std::fs::read_to_string(p).unwrap();
    assert!(text.starts_with("MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n8\n"));
    assert!(text.contains("\nTetrahedra\n6\n"));
    assert!(text.trim_end().ends_with("End"));
}

#[test]
fn obj_keeps_the_triangles() {
    let m = sample_mesh();
    let (_d, _p, back) = roundtrip(&m, "a.obj");
    // Only the nodes of the triangles (0, 1, 2, 3) are written, in order.
    assert_eq!(back.nodes.len(), 4);
    for i in 0..4 {
        assert_eq!(back.nodes[i].pos, m.nodes[i].pos);
    }
    assert_eq!(nodes_of(&back.triangles), nodes_of(&m.triangles));
    assert!(back.lines.is_empty() && back.tetrahedra.is_empty());
    assert_eq!(back.triangles[0].entity, EntityRef::new(2, 0));
    assert_eq!(back.nodes[0].entity, EntityRef::new(2, 0));
}

#[test]
fn stl_keeps_the_triangles_in_single_precision() {
    let m = sample_mesh();
    let (_d, _p, back) = roundtrip(&m, "a.stl");
    assert_eq!(back.triangles.len(), 2);
    assert_eq!(back.nodes.len(), 4, "shared vertices are merged");
    for t in 0..2 {
        for k in 0..3 {
            let a = m.nodes[m.triangles[t].nodes[k] as usize].pos;
            let b = back.nodes[back.triangles[t].nodes[k] as usize].pos;
            assert!((a - b).norm() < 1e-6, "{a} {b}");
        }
    }
}

#[test]
fn surface_formats_write_the_outward_boundary_of_tet_meshes() {
    let m = tet_only();
    for name in ["a.stl", "a.obj"] {
        let (_d, _p, back) = roundtrip(&m, name);
        assert_eq!(back.triangles.len(), 12, "{name}");
        assert_eq!(back.nodes.len(), 8, "{name}");
        let v = enclosed_volume(&back);
        assert!((v - 0.343).abs() < 1e-5, "{name}: {v}");
    }
    // Negatively oriented tetrahedra give the same outward surface.
    let mut neg = tet_only();
    for t in &mut neg.tetrahedra {
        t.nodes.swap(0, 1);
    }
    let (_d, _p, back) = roundtrip(&neg, "n.obj");
    assert!((enclosed_volume(&back) - 0.343).abs() < 1e-9);
}

#[test]
fn empty_mesh_round_trips_where_the_format_allows() {
    let m = Mesh::default();
    for name in ["e.msh", "e.vtu", "e.mesh", "e.stl"] {
        let (_d, _p, back) = roundtrip(&m, name);
        assert!(back.nodes.is_empty() && back.triangles.is_empty(), "{name}");
    }
}

#[test]
fn reads_gmsh_files() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    for f in ["gmsh_cube_v41.msh", "gmsh_cube_v22.msh"] {
        let m = read(&data.join(f)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.nodes.len(), 45, "{f}");
        assert_eq!(m.lines.len(), 24, "{f}");
        assert_eq!(m.triangles.len(), 84, "{f}");
        assert_eq!(m.tetrahedra.len(), 100, "{f}");
        // The 8 cube corners are on the 8 vertices; 12 curves, 6 surfaces.
        let on_vertices = m.nodes.iter().filter(|n| n.entity.dim == 0).count();
        assert_eq!(on_vertices, 8, "{f}");
        let faces: std::collections::BTreeSet<u32> =
            m.triangles.iter().map(|t| t.entity.id).collect();
        assert_eq!(faces.len(), 6, "{f}");
        let vol: f64 = m
            .tetrahedra
            .iter()
            .map(|t| common::signed_volume(&m.nodes, t.nodes).abs())
            .sum();
        assert!((vol - 1.0).abs() < 1e-12, "{f}: {vol}");
        if f.contains("v41") {
            // Boundaries from $Entities: volume 1 is bounded by 6 surfaces.
            let v = m
                .entities
                .iter()
                .find(|e| e.entity == EntityRef::new(3, 0))
                .unwrap();
            assert_eq!(v.boundary.len(), 6);
            // Interior nodes are in the volume.
            assert!(m.nodes.iter().any(|n| n.entity.dim == 3));
        }
    }
}

#[test]
fn msh_output_reads_back_after_gmsh_round_trip_in_our_reader() {
    // Write what we read from Gmsh, read it again: identical.
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let m = read(&data.join("gmsh_cube_v41.msh")).unwrap();
    let (_d, _p, back) = roundtrip(&m, "g.msh");
    assert_same(&m, &back);
}
