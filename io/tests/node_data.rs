//! Per-node fields ($NodeData in MSH 2.2 and 4.1, PointData in VTU) read by
//! `read_with_node_data`, in the order of the mesh's nodes.

use bubblemesh_io::read_with_node_data;

const MSH41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$Nodes\n1 3 1 3\n2 1 0 3\n3\n1\n2\n1 0 0\n0 0 0\n0 1 0\n$EndNodes\n\
$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n$EndElements\n\
$NodeData\n1\n\"size\"\n1\n0.0\n3\n0\n1\n3\n3 0.3\n1 0.1\n2 0.2\n$EndNodeData\n";

#[test]
fn msh41_node_data_follows_node_tags() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.msh");
    std::fs::write(&p, MSH41).unwrap();
    let (mesh, fields) = read_with_node_data(&p).unwrap();
    assert_eq!(fields.len(), 1);
    assert_eq!(fields[0].name, "size");
    // nodes are ordered by tag: tag 1 at (0,0,0), tag 2 (0,1,0), tag 3 (1,0,0)
    for (n, v) in mesh.nodes.iter().zip(&fields[0].values) {
        let want = if n.pos.x == 1.0 {
            0.3
        } else if n.pos.y == 1.0 {
            0.2
        } else {
            0.1
        };
        assert_eq!(*v, want, "{:?}", n.pos);
    }
    // the plain reader ignores the section
    assert_eq!(bubblemesh_io::read(&p).unwrap().nodes.len(), 3);
}

#[test]
fn msh22_and_vtu_node_data_and_bad_counts() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("b.msh");
    std::fs::write(
        &p,
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n\
         $Elements\n1\n1 2 2 0 1 1 2 3\n$EndElements\n\
         $NodeData\n1\n\"err\"\n0\n3\n0\n1\n2\n1 5\n3 7\n$EndNodeData\n",
    )
    .unwrap();
    let (_, f) = read_with_node_data(&p).unwrap();
    assert_eq!(f[0].values[0], 5.0);
    assert!(f[0].values[1].is_nan());
    assert_eq!(f[0].values[2], 7.0);

    let v = dir.path().join("c.vtu");
    std::fs::write(
        &v,
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0">
<UnstructuredGrid><Piece NumberOfPoints="3" NumberOfCells="1">
<PointData><DataArray type="Float64" Name="size" format="ascii">0.1 0.2 0.3</DataArray></PointData>
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0</DataArray></Points>
<Cells><DataArray type="Int64" Name="connectivity" format="ascii">0 1 2</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">3</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">5</DataArray></Cells>
</Piece></UnstructuredGrid></VTKFile>
"#,
    )
    .unwrap();
    let (m, f) = read_with_node_data(&v).unwrap();
    assert_eq!(m.triangles.len(), 1);
    assert_eq!(f[0].name, "size");
    assert_eq!(f[0].values, vec![0.1, 0.2, 0.3]);
    let bad = std::fs::read_to_string(&v)
        .unwrap()
        .replace("0.1 0.2 0.3", "0.1 0.2");
    std::fs::write(&v, bad).unwrap();
    let e = read_with_node_data(&v).unwrap_err().to_string();
    assert!(e.contains("c.vtu") && e.contains("'size'"), "{e}");
}
