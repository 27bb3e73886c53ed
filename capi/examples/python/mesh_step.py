#!/usr/bin/env python3
"""Mesh a part CadQuery exported to STEP through bubblemesh's C ABI (ctypes).

The default part is fixtures/step/block_holes.step, written by CadQuery 2.8
(a 40 x 30 x 12 block with filleted and chamfered edges, four through holes
and a counterbored one; fixtures/manifest.json has its CAD volume and
area). The whole file goes to `bm_mesh_step_file`, which reads it with the
library's STEP reader and meshes the solid's boundary; the arrays are read
back and checked:

- every triangle lies on one of the file's faces;
- the surface is closed and consistently oriented: every edge is shared by
  exactly two triangles, once in each direction;
- the volume it encloses (divergence theorem) is the manifest's CAD volume
  within 1 % (the triangles are chords of the curved faces, so a coarse
  spacing loses a little), and its area likewise.

With --cadquery the part is instead generated here by CadQuery (when it is
importable, e.g. from /work/venvs/cq), exported to a temporary STEP file,
and checked against CadQuery's own volume and area.

Usage:
    python3 mesh_step.py [--lib PATH] [--step FILE] [--size D] [-o OUT.msh]
    python3 mesh_step.py --cadquery [--lib PATH] [--size D]

--lib defaults to $BUBBLEMESH_LIB, else target/{release,debug} of this
repository (build with `cargo build --release -p bubblemesh-capi`). Exits
non-zero when meshing fails or a check does not pass. Needs only the
standard library (CadQuery for --cadquery).
"""

import argparse
import ctypes as C
import json
import math
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
FIXTURES = os.path.join(ROOT, "fixtures")

BM_OK = 0


class Entity(C.Structure):
    _fields_ = [("dim", C.c_int32), ("id", C.c_uint32)]


class BubbleMeshError(RuntimeError):
    def __init__(self, code, name, message):
        super().__init__(f"{name}: {message}")
        self.code = code


def load(path):
    lib = C.CDLL(path)
    P = C.c_void_p
    sig = {
        "bm_version": ([], C.c_char_p),
        "bm_result_name": ([C.c_int], C.c_char_p),
        "bm_last_error_message": ([], C.c_char_p),
        "bm_spacing_from_expr": ([C.c_char_p, C.POINTER(P)], C.c_int),
        "bm_spacing_free": ([P], None),
        "bm_mesh_step_file": ([C.c_char_p, P, C.c_int, C.c_int, C.POINTER(P)], C.c_int),
        "bm_mesh_free": ([P], None),
        "bm_mesh_node_count": ([P, C.POINTER(C.c_size_t)], C.c_int),
        "bm_mesh_triangle_count": ([P, C.POINTER(C.c_size_t)], C.c_int),
        "bm_mesh_nodes": ([P, C.POINTER(C.c_double), C.c_size_t], C.c_int),
        "bm_mesh_triangles": ([P, C.POINTER(C.c_uint32), C.c_size_t], C.c_int),
        "bm_mesh_triangle_entities": ([P, C.POINTER(Entity), C.c_size_t], C.c_int),
        "bm_mesh_write": ([P, C.c_char_p], C.c_int),
    }
    for name, (args, res) in sig.items():
        f = getattr(lib, name)
        f.argtypes, f.restype = args, res
    return lib


def check(lib, rc):
    """Raises with the library's message when a call did not return BM_OK."""
    if rc != BM_OK:
        raise BubbleMeshError(rc, lib.bm_result_name(rc).decode(), lib.bm_last_error_message().decode())


def find_lib(arg):
    if arg:
        return arg
    if os.environ.get("BUBBLEMESH_LIB"):
        return os.environ["BUBBLEMESH_LIB"]
    for profile in ("release", "debug"):
        p = os.path.join(ROOT, "target", profile, "libbubblemesh_capi.so")
        if os.path.exists(p):
            return p
    sys.exit("libbubblemesh_capi.so not found: build it (cargo build -p bubblemesh-capi) or pass --lib")


def manifest_entry(step_path):
    """The manifest's record of a fixture (by file name), or None."""
    with open(os.path.join(FIXTURES, "manifest.json")) as f:
        parts = json.load(f)["parts"]
    name = os.path.basename(step_path)
    for p in parts:
        if os.path.basename(p["file"]) == name:
            return p
    return None


def cadquery_part(directory):
    """Builds the block with holes in CadQuery and exports it; returns the
    STEP path, its CAD volume and area (None when CadQuery is missing)."""
    try:
        import cadquery as cq
    except ImportError:
        return None
    part = (
        cq.Workplane("XY").box(40, 30, 12)
        .edges("|Z").fillet(4)
        .faces(">Z").workplane().rect(28, 18, forConstruction=True).vertices().hole(6)
        .faces(">Z").workplane().cboreHole(8, 14, 3)
    )
    path = os.path.join(directory, "cq_block.step")
    cq.exporters.export(part, path)
    solid = part.val()
    return path, solid.Volume(), solid.Area()


def mesh_arrays(lib, path, spacing):
    """Meshes the STEP file's faces (dim -1: a solid's boundary); returns
    node coordinates, triangles and the face of each triangle."""
    mesh = C.c_void_p()
    check(lib, lib.bm_mesh_step_file(path.encode(), spacing, -1, 0, C.byref(mesh)))
    try:
        nn, nt = C.c_size_t(), C.c_size_t()
        check(lib, lib.bm_mesh_node_count(mesh, C.byref(nn)))
        check(lib, lib.bm_mesh_triangle_count(mesh, C.byref(nt)))
        xyz = (C.c_double * (3 * nn.value))()
        tri = (C.c_uint32 * (3 * nt.value))()
        ent = (Entity * nt.value)()
        check(lib, lib.bm_mesh_nodes(mesh, xyz, len(xyz)))
        check(lib, lib.bm_mesh_triangles(mesh, tri, len(tri)))
        check(lib, lib.bm_mesh_triangle_entities(mesh, ent, len(ent)))
        return mesh, list(xyz), list(tri), [(e.dim, e.id) for e in ent]
    except Exception:
        lib.bm_mesh_free(mesh)
        raise


def surface_checks(xyz, tri):
    """(edges not shared by exactly two triangles once in each direction,
    enclosed volume, area)."""
    directed = {}
    nt = len(tri) // 3
    for t in range(nt):
        for k in range(3):
            e = (tri[3 * t + k], tri[3 * t + (k + 1) % 3])
            directed[e] = directed.get(e, 0) + 1
    bad = sum(1 for (a, b), n in directed.items() if n != 1 or directed.get((b, a)) != 1)
    # about the centroid of the nodes, so round-off does not grow with the
    # part's distance from the origin
    n = len(xyz) // 3
    c = [sum(xyz[3 * i + k] for i in range(n)) / n for k in range(3)]
    vol6, area2 = 0.0, 0.0
    for t in range(nt):
        a, b, d = ([xyz[3 * tri[3 * t + j] + k] - c[k] for k in range(3)] for j in range(3))
        cx = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        vol6 += cx[0] * d[0] + cx[1] * d[1] + cx[2] * d[2]
        u = [b[k] - a[k] for k in range(3)]
        w = [d[k] - a[k] for k in range(3)]
        area2 += math.sqrt(
            (u[1] * w[2] - u[2] * w[1]) ** 2 + (u[2] * w[0] - u[0] * w[2]) ** 2 + (u[0] * w[1] - u[1] * w[0]) ** 2
        )
    return bad, vol6 / 6.0, area2 / 2.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lib")
    ap.add_argument("--step", default=os.path.join(FIXTURES, "step", "block_holes.step"))
    ap.add_argument("--size", type=float, default=1.2, help="node spacing (model units, mm)")
    ap.add_argument("--cadquery", action="store_true",
                    help="generate the part with CadQuery instead of reading --step")
    ap.add_argument("-o", "--output", help="write the mesh (.msh, .vtu, .stl, .obj, .mesh)")
    ap.add_argument("--tolerance", type=float, default=0.01, help="relative volume and area tolerance")
    args = ap.parse_args()

    lib = load(find_lib(args.lib))
    print("bubblemesh", lib.bm_version().decode())

    tmp = tempfile.TemporaryDirectory()
    if args.cadquery:
        made = cadquery_part(tmp.name)
        if made is None:
            sys.exit("--cadquery: cadquery is not importable (try /work/venvs/cq/bin/python)")
        path, cad_volume, cad_area = made
        source = "CadQuery (generated here)"
    else:
        path = args.step
        entry = manifest_entry(path)
        if entry is None or entry.get("volume") is None:
            sys.exit(f"{path}: no CAD volume in fixtures/manifest.json for this file")
        cad_volume, cad_area = entry["volume"], entry["area"]
        source = f"fixtures/manifest.json ({entry['generator']})"

    spacing = C.c_void_p()
    check(lib, lib.bm_spacing_from_expr(str(args.size).encode(), C.byref(spacing)))
    try:
        mesh, xyz, tri, ent = mesh_arrays(lib, path, spacing)
    finally:
        lib.bm_spacing_free(spacing)
    try:
        nt = len(tri) // 3
        faces = {i for d, i in ent if d == 2}
        off = sum(1 for d, _ in ent if d != 2)
        bad, volume, area = surface_checks(xyz, tri)
        dv = (volume - cad_volume) / cad_volume
        da = (area - cad_area) / cad_area
        print(f"{os.path.basename(path)}: {len(xyz) // 3} nodes, {nt} triangles on {len(faces)} faces")
        print(f"edges not shared by two triangles (once each way): {bad}")
        print(f"enclosed volume {volume:.3f}, CAD {cad_volume:.3f} ({source}): {100 * dv:+.3f} %")
        print(f"area {area:.3f}, CAD {cad_area:.3f}: {100 * da:+.3f} %")
        if args.output:
            check(lib, lib.bm_mesh_write(mesh, args.output.encode()))
            print("wrote", args.output)
        failed = []
        if nt == 0 or off:
            failed.append(f"{nt} triangles, {off} not on a face")
        if bad:
            failed.append(f"{bad} edges open, non-manifold or misoriented")
        if not abs(dv) <= args.tolerance:
            failed.append(f"volume off by {100 * dv:+.3f} %")
        if not abs(da) <= args.tolerance:
            failed.append(f"area off by {100 * da:+.3f} %")
        if failed:
            sys.exit("checks failed: " + "; ".join(failed))
        print("checks passed")
    finally:
        lib.bm_mesh_free(mesh)
        tmp.cleanup()


if __name__ == "__main__":
    main()
