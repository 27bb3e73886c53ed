#!/usr/bin/env python3
"""Mesh a planar part through bubblemesh's C ABI with ctypes.

The part is what this CadQuery script exports to STEP:

    import cadquery as cq
    part = cq.Workplane("XY").rect(2.0, 2.0).extrude(0.1).faces(">Z").workplane().hole(1.0)
    cq.exporters.export(part, "plate.step")

that is, a 2 x 2 plate with a hole of diameter 1 through its centre. Its top
face is meshed here the way a CAD program hands its model to the library:
the host describes the face itself, answering the library's queries — its
vertices, its edges as curve callbacks (four lines and the hole's circle),
and the plane face bounded by the outer loop and the hole. (A host that has
the STEP file can pass it whole instead: see mesh_step.py, which uses
`bm_mesh_step_file`.)

Usage:
    python3 mesh_plate.py [--lib PATH] [--size D] [-o OUT.vtu]

--lib defaults to $BUBBLEMESH_LIB, else target/{release,debug} of this
repository (build with `cargo build --release -p bubblemesh-capi`).
Exits non-zero when meshing fails or a check does not pass.
"""

import argparse
import ctypes as C
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", ".."))

BM_OK = 0

# --- the C declarations we use (see capi/include/bubblemesh.h) -------------

CURVE_EVAL = C.CFUNCTYPE(C.c_int, C.c_void_p, C.c_double, C.c_int, C.POINTER(C.c_double))
SPACING_FN = C.CFUNCTYPE(
    C.c_int, C.c_void_p, C.c_double, C.c_double, C.c_double, C.c_int, C.c_uint32,
    C.c_double, C.c_double, C.POINTER(C.c_double),
)


class CurveCallbacks(C.Structure):
    _fields_ = [("eval", CURVE_EVAL)]


class EdgeUse(C.Structure):
    _fields_ = [("edge", C.c_uint32), ("forward", C.c_int)]


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
        "bm_model_new": ([C.POINTER(P)], C.c_int),
        "bm_model_free": ([P], None),
        "bm_model_add_vertex": ([P, C.c_double, C.c_double, C.c_double, C.POINTER(C.c_uint32)], C.c_int),
        "bm_model_add_curve": ([P, C.POINTER(CurveCallbacks), P, C.c_double, C.c_double,
                                C.c_uint32, C.c_uint32, C.POINTER(C.c_uint32)], C.c_int),
        "bm_model_add_plane_face": ([P, C.POINTER(C.c_double), C.POINTER(C.c_double), C.POINTER(EdgeUse),
                                     C.POINTER(C.c_size_t), C.c_size_t, C.POINTER(C.c_uint32)], C.c_int),
        "bm_model_set_name": ([P, C.c_int, C.c_uint32, C.c_char_p], C.c_int),
        "bm_spacing_from_expr": ([C.c_char_p, C.POINTER(P)], C.c_int),
        "bm_spacing_from_callback": ([SPACING_FN, P, C.POINTER(P)], C.c_int),
        "bm_spacing_free": ([P], None),
        "bm_mesh_generate": ([P, P, C.c_int, C.c_int, C.POINTER(P)], C.c_int),
        "bm_mesh_free": ([P], None),
        "bm_mesh_node_count": ([P, C.POINTER(C.c_size_t)], C.c_int),
        "bm_mesh_triangle_count": ([P, C.POINTER(C.c_size_t)], C.c_int),
        "bm_mesh_line_count": ([P, C.POINTER(C.c_size_t)], C.c_int),
        "bm_mesh_nodes": ([P, C.POINTER(C.c_double), C.c_size_t], C.c_int),
        "bm_mesh_triangles": ([P, C.POINTER(C.c_uint32), C.c_size_t], C.c_int),
        "bm_mesh_lines": ([P, C.POINTER(C.c_uint32), C.c_size_t], C.c_int),
        "bm_mesh_line_entities": ([P, C.POINTER(Entity), C.c_size_t], C.c_int),
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


# --- the part ---------------------------------------------------------------

HALF, HOLE_R, Z = 1.0, 0.5, 0.1  # the plate's top face: z = 0.1


def line(a, b):
    def ev(_user, t, order, out):
        for k in range(3):
            d = b[k] - a[k]
            out[k] = a[k] + t * d if order == 0 else (d if order == 1 else 0.0)
        return 0
    return CURVE_EVAL(ev)


def circle(c, r):
    def ev(_user, t, order, out):
        ct, st = math.cos(t), math.sin(t)
        x, y = [(ct, st), (-st, ct), (-ct, -st)][order]
        out[0], out[1], out[2] = c[0] * (order == 0) + r * x, c[1] * (order == 0) + r * y, c[2] * (order == 0)
        return 0
    return CURVE_EVAL(ev)


def describe_plate(lib, model, keep):
    """Adds the top face of the plate; `keep` holds the ctypes callbacks alive."""
    corners = [(-HALF, -HALF, Z), (HALF, -HALF, Z), (HALF, HALF, Z), (-HALF, HALF, Z)]
    vid = []
    for p in corners:
        v = C.c_uint32()
        check(lib, lib.bm_model_add_vertex(model, *p, C.byref(v)))
        vid.append(v.value)
    uses = []
    for k in range(4):
        cb = CurveCallbacks(line(corners[k], corners[(k + 1) % 4]))
        keep.append(cb)
        e = C.c_uint32()
        check(lib, lib.bm_model_add_curve(model, C.byref(cb), None, 0.0, 1.0,
                                          vid[k], vid[(k + 1) % 4], C.byref(e)))
        uses.append(EdgeUse(e.value, 1))
    hv, he = C.c_uint32(), C.c_uint32()
    check(lib, lib.bm_model_add_vertex(model, HOLE_R, 0.0, Z, C.byref(hv)))
    cb = CurveCallbacks(circle((0.0, 0.0, Z), HOLE_R))
    keep.append(cb)
    check(lib, lib.bm_model_add_curve(model, C.byref(cb), None, 0.0, 2 * math.pi,
                                      hv.value, hv.value, C.byref(he)))
    uses.append(EdgeUse(he.value, 0))  # the hole runs clockwise
    arr = (EdgeUse * len(uses))(*uses)
    lengths = (C.c_size_t * 2)(4, 1)
    origin, normal = (C.c_double * 3)(0, 0, Z), (C.c_double * 3)(0, 0, 1)
    face = C.c_uint32()
    check(lib, lib.bm_model_add_plane_face(model, origin, normal, arr, lengths, 2, C.byref(face)))
    check(lib, lib.bm_model_set_name(model, 2, face.value, b"top"))
    return he.value


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lib")
    ap.add_argument("--size", type=float, default=0.1, help="node spacing far from the hole")
    ap.add_argument("-o", "--output", help="write the mesh (.msh, .vtu, .stl, .obj, .mesh)")
    args = ap.parse_args()

    lib = load(find_lib(args.lib))
    print("bubblemesh", lib.bm_version().decode())

    # spacing from a Python callback: finer near the hole
    def d(_user, x, y, z, dim, ent, u, v, out):
        r = math.hypot(x, y)
        out[0] = args.size * min(1.0, 0.5 + 0.5 * max(r - HOLE_R, 0.0) / 0.5)
        return 0
    spacing_cb = SPACING_FN(d)
    spacing = C.c_void_p()
    check(lib, lib.bm_spacing_from_callback(spacing_cb, None, C.byref(spacing)))

    mesh = C.c_void_p()
    keep = []
    model = C.c_void_p()
    check(lib, lib.bm_model_new(C.byref(model)))
    try:
        hole_edge = describe_plate(lib, model, keep)
        check(lib, lib.bm_mesh_generate(model, spacing, 2, 0, C.byref(mesh)))
        nn, nt, nl = C.c_size_t(), C.c_size_t(), C.c_size_t()
        check(lib, lib.bm_mesh_node_count(mesh, C.byref(nn)))
        check(lib, lib.bm_mesh_triangle_count(mesh, C.byref(nt)))
        check(lib, lib.bm_mesh_line_count(mesh, C.byref(nl)))
        xyz = (C.c_double * (3 * nn.value))()
        tri = (C.c_uint32 * (3 * nt.value))()
        lin = (C.c_uint32 * (2 * nl.value))()
        ent = (Entity * nl.value)()
        check(lib, lib.bm_mesh_nodes(mesh, xyz, len(xyz)))
        check(lib, lib.bm_mesh_triangles(mesh, tri, len(tri)))
        check(lib, lib.bm_mesh_lines(mesh, lin, len(lin)))
        check(lib, lib.bm_mesh_line_entities(mesh, ent, len(ent)))
        print(f"{nn.value} nodes, {nt.value} triangles, {nl.value} boundary segments")

        # area: exact area plus the circular segments cut off by the hole's chords
        def p(i):
            return xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]
        area, worst_z, down = 0.0, 0.0, 0
        for t in range(nt.value):
            a, b, c = p(tri[3 * t]), p(tri[3 * t + 1]), p(tri[3 * t + 2])
            cz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            area += 0.5 * abs(cz)
            down += cz <= 0
            worst_z = max(worst_z, *(abs(q[2] - Z) for q in (a, b, c)))
        caps = 0.0
        for k in range(nl.value):
            if ent[k].id == hole_edge:
                a, b = p(lin[2 * k]), p(lin[2 * k + 1])
                th = 2 * math.asin(math.dist(a, b) / (2 * HOLE_R))
                caps += HOLE_R ** 2 / 2 * (th - math.sin(th))
        exact = (2 * HALF) ** 2 - math.pi * HOLE_R ** 2
        print(f"area {area:.6f}, exact {exact:.6f}, chord bound {caps:.3e}")
        ok = exact - 1e-12 <= area <= exact + caps * (1 + 1e-9) + 1e-12 and down == 0 and worst_z < 1e-12
        if args.output:
            check(lib, lib.bm_mesh_write(mesh, args.output.encode()))
            print("wrote", args.output)
        if not ok:
            sys.exit(f"checks failed: area {area}, {down} triangles facing down, z off by {worst_z}")
        print("checks passed")
    finally:
        lib.bm_mesh_free(mesh)
        lib.bm_model_free(model)
        lib.bm_spacing_free(spacing)


if __name__ == "__main__":
    main()
