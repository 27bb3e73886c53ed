#!/usr/bin/env python3
"""Mesh every STEP fixture (fixtures/manifest.json) with bubblemesh, Gmsh
(OpenCascade STEP reader, default 2D algorithm) and truck-meshalgo (for
comparison only); check every mesh with the independent meshcheck.py; print
one table and write bench/out/step/results.json and
bench/out/step/RESULTS_step.md.

    python3 bench/run_step.py [--parts a,b] [--skip gmsh,truck-meshalgo] [--timeout 600]
                              [--truck-mem-mb 3000] [--divisor 25]

Sizes: each part's default `mesh_size` from the manifest (uniform spacing d),
or with `--divisor N` the diagonal of its manifest bounding box over N (the
sizes engineers ask for: N = 25 for surfaces, issue 22), with results in
bench/out/step_divN/.

Volume: enclosed volume of the triangle mesh (divergence theorem), computed
here after orienting each closed component consistently (outer components
positive, components inside another negative), compared to the CAD volume.
Next to it, the *expected* chord error: a mesh of edge length h loses
(h²/8) ∫ H dA of volume under the curved faces (H: mean curvature; see
fixtures/chord_deficit.py, which stores c = ∫ H dA / (8 V) per part), so the
expected relative error is −c · d² · E[(L/d)²], with E[(L/d)²] = mean² + std²
of the mesh's own edge-length ratios (meshcheck). Status `ok` means |vol err| ≤
0.5 % and the mesh closed; `explained` means |measured − expected| ≤ 0.1 % +
25 % of |expected| (the estimate assumes h small against the radii).

truck-meshalgo: `examples/meshalgo.rs` of adapters/truck (truck-stepio's own
STEP conversion + `robust_triangulation(TOL)`), built with
`cargo build --release -p bubblemesh-truck --example meshalgo`; TOL (its
chord tolerance: it has no edge-length target) = d²/(8 · 4d) = d/32, the
sagitta of a chord d on a radius of 4d (the manifest's sizes are about a
quarter of the parts' smaller radii). It runs under `prlimit --as`
(--truck-mem-mb) and the timeout; out of memory, a crash, a timeout or faces
truck drops are reported as failures.
"""
import argparse, json, os, subprocess, sys, time
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "bench", "out", "step")
MESHCHECK = "/work/shared/meshkit/meshcheck.py"
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
# BUBBLEMESH_BIN: another build to measure (a copy, so that cargo may go on)
BM = os.environ.get("BUBBLEMESH_BIN", os.path.join(TARGET, "release", "bubblemesh"))
TRUCK = os.path.join(TARGET, "release", "examples", "meshalgo")
TRUCK_MEM_MB = 3000


def enclosed_volume(path):
    import meshio
    m = meshio.read(path)
    tris = np.concatenate([c.data for c in m.cells if c.type == "triangle"]) if any(
        c.type == "triangle" for c in m.cells) else np.zeros((0, 3), int)
    pts = m.points[:, :3] if m.points.shape[1] >= 3 else np.c_[m.points, np.zeros(len(m.points))]
    if len(tris) == 0:
        return None, 0
    # merge coincident nodes (a writer may duplicate them)
    key = np.round(pts / (1e-9 * (np.ptp(pts, axis=0).max() + 1e-300)))
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    tris = inv[tris]
    up = np.zeros((inv.max() + 1, 3))
    up[inv] = pts
    pts = up
    # edge -> triangles
    edges = {}
    for t, (a, b, c) in enumerate(tris):
        for u, v in ((a, b), (b, c), (c, a)):
            edges.setdefault((min(u, v), max(u, v)), []).append((t, u, v))
    n = len(tris)
    flip = np.zeros(n, bool)
    comp = -np.ones(n, int)
    nc = 0
    for s in range(n):
        if comp[s] >= 0:
            continue
        comp[s] = nc
        stack = [s]
        while stack:
            t = stack.pop()
            a, b, c = tris[t]
            for u, v in ((a, b), (b, c), (c, a)):
                # direction of (u,v) in t as oriented
                du, dv = (v, u) if flip[t] else (u, v)
                for (o, x, y) in edges[(min(u, v), max(u, v))]:
                    if o == t or comp[o] >= 0:
                        continue
                    comp[o] = nc
                    # o must traverse the shared edge opposite to t
                    same = (x == du and y == dv)
                    flip[o] = same  # x,y as stored; flip if same direction
                    stack.append(o)
        nc += 1
    T = tris.copy()
    T[flip] = T[flip][:, ::-1]
    p0, p1, p2 = pts[T[:, 0]], pts[T[:, 1]], pts[T[:, 2]]
    v6 = np.einsum("ij,ij->i", p0, np.cross(p1, p2))
    vols = np.array([v6[comp == k].sum() / 6 for k in range(nc)])
    absv = np.abs(vols)
    # a component inside another's bbox (and smaller) is a void
    boxes = []
    for k in range(nc):
        q = pts[np.unique(T[comp == k])]
        boxes.append((q.min(0), q.max(0)))
    total = 0.0
    for k in range(nc):
        inside = any(j != k and absv[j] > absv[k] and np.all(boxes[j][0] <= boxes[k][0] + 1e-9)
                     and np.all(boxes[k][1] <= boxes[j][1] + 1e-9) for j in range(nc))
        total += -absv[k] if inside else absv[k]
    return total, nc


def check(path, size, part):
    cmd = [sys.executable, MESHCHECK, path, "--spacing", str(size), "--dim", "2"]
    if part.get("area"):
        cmd += ["--ref-area", str(part["area"])]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        return {"error": r.stderr[-400:]}
    return json.loads(r.stdout)


def run_bubblemesh(step, out, size, timeout):
    t = time.perf_counter()
    r = subprocess.run([BM, "mesh", step, "-o", out, "--size", str(size), "--dim", "2", "--quiet", "--threads", "1"],
                       capture_output=True, text=True, timeout=timeout)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        return dt, (r.stderr.strip().splitlines() or ["failed"])[-1]
    return dt, None


def run_gmsh(step, out, size, timeout):
    code = f"""
import gmsh, time, sys
gmsh.initialize(); gmsh.option.setNumber('General.Terminal', 0)
gmsh.model.occ.importShapes({step!r}); gmsh.model.occ.synchronize()
gmsh.option.setNumber('Mesh.MeshSizeMin', {size}); gmsh.option.setNumber('Mesh.MeshSizeMax', {size})
gmsh.option.setNumber('Mesh.MeshSizeFromPoints', 0); gmsh.option.setNumber('Mesh.MeshSizeFromCurvature', 0)
gmsh.option.setNumber('Mesh.MeshSizeExtendFromBoundary', 0)
t = time.perf_counter(); gmsh.model.mesh.generate(2); dt = time.perf_counter() - t
gmsh.option.setNumber('Mesh.Binary', 1); gmsh.write({out!r}); print(dt)
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout)
    if r.returncode != 0:
        return None, (r.stderr.strip().splitlines() or ["failed"])[-1]
    return float(r.stdout.strip().splitlines()[-1]), None


def read_obj(path):
    """Vertices and triangles of an OBJ file (v / f lines; 'a/b/c' indices,
    polygons fanned). meshio refuses truck's files, whose vt and v counts
    differ."""
    pts, tris = [], []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                pts.append([float(x) for x in w[1:4]])
            elif w[0] == "f":
                idx = [int(x.split("/")[0]) for x in w[1:]]
                idx = [i - 1 if i > 0 else len(pts) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    tris.append([idx[0], idx[k], idx[k + 1]])
    return np.array(pts, float).reshape(-1, 3), np.array(tris, int).reshape(-1, 3)


def run_truck(step, out, size, timeout):
    obj = out[:-4] + ".obj"
    cmd = ["prlimit", f"--as={TRUCK_MEM_MB << 20}", "--", TRUCK, step, obj, str(size / 32)]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    dt = time.perf_counter() - t
    lines = r.stderr.strip().splitlines() or [""]
    msg = lines[-1]
    for k, l in enumerate(lines):
        if "memory allocation" in l:
            msg = l
            break
        if "panicked at" in l:
            msg = "panicked: " + (lines[k + 1] if k + 1 < len(lines) else l)
            break
    msg = msg[:200]
    if r.returncode == 2 and os.path.exists(obj):
        return dt, "faces dropped: " + msg
    if r.returncode != 0:
        why = {-6: "abort (out of memory?)", -9: "killed", -11: "segfault",
               101: "panic"}.get(r.returncode, f"exit {r.returncode}")
        return dt, f"{why} (limit {TRUCK_MEM_MB} MB): {msg}"
    # meshcheck and the volume read .msh: convert the OBJ
    import meshio
    pts, tris = read_obj(obj)
    meshio.write(out, meshio.Mesh(pts, [("triangle", tris)]), file_format="gmsh22", binary=True)
    return dt, None


def main():
    global TRUCK_MEM_MB
    ap = argparse.ArgumentParser()
    ap.add_argument("--parts", default="")
    ap.add_argument("--skip", default="")
    ap.add_argument("--timeout", type=float, default=600)
    ap.add_argument("--truck-mem-mb", type=int, default=TRUCK_MEM_MB)
    ap.add_argument("--divisor", type=float, default=0.0,
                    help="size = bounding-box diagonal / N instead of the manifest's mesh_size")
    a = ap.parse_args()
    TRUCK_MEM_MB = a.truck_mem_mb
    global OUT
    if a.divisor > 0:
        OUT = os.path.join(ROOT, "bench", "out", f"step_div{a.divisor:g}")
    man = json.load(open(os.path.join(ROOT, "fixtures", "manifest.json")))
    os.makedirs(OUT, exist_ok=True)
    res_path = os.path.join(OUT, "results.json")
    results = json.load(open(res_path)) if os.path.exists(res_path) else {}
    want = set(a.parts.split(",")) if a.parts else None
    skip = set(a.skip.split(",")) if a.skip else set()
    mesher = {"bubblemesh": run_bubblemesh, "gmsh": run_gmsh}
    if os.path.exists(TRUCK):
        mesher["truck-meshalgo"] = run_truck
    elif "truck-meshalgo" not in skip:
        print(f"note: {TRUCK} not built, no truck-meshalgo column "
              "(cargo build --release -p bubblemesh-truck --example meshalgo)")
    for part in man["parts"]:
        if want and part["name"] not in want:
            continue
        step = os.path.join(ROOT, "fixtures", part["file"])
        size = diagonal_size(part, a.divisor) if a.divisor > 0 else part["mesh_size"]
        for name, fn in mesher.items():
            if name in skip:
                continue
            out = os.path.join(OUT, f"{part['name']}__{name}.msh")
            if os.path.exists(out):
                os.remove(out)
            try:
                dt, err = fn(step, out, size, a.timeout)
            except subprocess.TimeoutExpired:
                dt, err = a.timeout, "timeout"
            row = {"time": dt, "error": err, "size": size}
            if err is None and os.path.exists(out):
                rep = check(out, size, part)
                row["check"] = rep
                try:
                    vol, ncomp = enclosed_volume(out)
                except Exception as e:  # noqa
                    vol, ncomp = None, 0
                row["volume"] = vol
                row["components"] = ncomp
                if part.get("volume") and vol is not None:
                    row["volume_rel_error"] = vol / part["volume"] - 1
                    c = part.get("chord_deficit_coeff")
                    sp = rep.get("spacing", {})
                    if c is not None and "ratio_mean" in sp:
                        l2 = sp["ratio_mean"] ** 2 + sp.get("ratio_std", 0) ** 2
                        row["volume_expected_rel_error"] = -c * size ** 2 * l2
            results[f"{part['name']}__{name}"] = row
            print(part["name"], name, fmt_row(row), flush=True)
            json.dump(results, open(res_path, "w"), indent=1)
    write_md(man, results)


def diagonal_size(part, divisor):
    """The manifest bounding box's diagonal over `divisor`, to six digits."""
    lo, hi = part["bbox"]["min"], part["bbox"]["max"]
    diag = sum((h - l) ** 2 for l, h in zip(lo, hi)) ** 0.5
    return float(f"{diag / divisor:.6g}")


def fmt_row(r):
    if r.get("error"):
        return f"ERROR {r['error']}"
    c = r.get("check", {})
    t = c.get("triangles", {})
    v = c.get("validity", {})
    s = c.get("spacing", {})
    ve = r.get("volume_rel_error")
    return (f"tris {t.get('count')} qmin {t.get('q_min', 0):.3f} qmean {t.get('q_mean', 0):.3f} "
            f"minang {t.get('min_angle_min', 0):.1f} valid {v.get('valid')} closed {v.get('boundary_closed')} "
            f"L/d {s.get('ratio_mean', 0):.3f} vol {'' if ve is None else f'{100*ve:+.3f}%'} "
            f"expected {pct(r.get('volume_expected_rel_error'))} {status(r)} t {r['time']:.2f}s")


def pct(x):
    return "" if x is None else f"{100 * x:+.3f}%"


def status(r):
    """ok / FAIL (|vol err| > 0.5 % or open), and whether the chord error explains it."""
    ve, ex = r.get("volume_rel_error"), r.get("volume_expected_rel_error")
    if ve is None:
        return ""
    closed = r.get("check", {}).get("validity", {}).get("closed_surface")
    ok = abs(ve) <= 0.005 and closed
    s = "ok" if ok else "FAIL"
    if ex is not None:
        s += ", explained" if abs(ve - ex) <= 0.001 + 0.25 * abs(ex) else ", NOT explained"
    return s


def write_md(man, results):
    lines = ["# STEP fixtures: bubblemesh vs Gmsh vs truck-meshalgo", "",
             "Generated by `python3 bench/run_step.py` (uniform size = each part's manifest `mesh_size`,"
             " or with `--divisor N` its bounding-box diagonal / N; surface meshes).",
             "q = radius ratio 2r_in/r_circ; L/d = edge length over target spacing (mean, fraction in [1/√2, √2]);"
             " vol err = enclosed volume vs CAD; chord = expected vol err from the chord error,"
             " −c·d²·E[(L/d)²] (fixtures/chord_deficit.py); status: ok = closed and |vol err| ≤ 0.5 %,"
             " explained = |vol err − chord| ≤ 0.1 % + 25 % |chord|. truck-meshalgo: chord tolerance d/32,"
             " under a memory limit; for comparison only.", "",
             "| part | d | mesher | triangles | q min | q mean | min angle | max angle | L/d mean | L/d in √2 | valid | closed | boundary loops | area err | vol err | chord | status | time s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for part in man["parts"]:
        for name in ("bubblemesh", "gmsh", "truck-meshalgo"):
            r = results.get(f"{part['name']}__{name}")
            if r is None:
                continue
            if r.get("error"):
                lines.append(f"| {part['name']} | {r.get('size', part['mesh_size'])} | {name} | error: {str(r['error'])[:150].replace('|', '/')} |||||||||||||| {r['time'] or 0:.2f} |")
                continue
            c = r.get("check", {})
            t = c.get("triangles", {})
            v = c.get("validity", {})
            s = c.get("spacing", {})
            ae = c.get("area_rel_error")
            ve = r.get("volume_rel_error")
            lines.append(
                f"| {part['name']} | {r.get('size', part['mesh_size'])} | {name} | {t.get('count')} | {t.get('q_min', 0):.3f} | {t.get('q_mean', 0):.3f} | "
                f"{t.get('min_angle_min', 0):.1f} | {t.get('max_angle_max', 0):.1f} | {s.get('ratio_mean', 0):.3f} | "
                f"{s.get('frac_within_sqrt2', 0):.3f} | {v.get('valid')} | {v.get('closed_surface')} | {v.get('boundary_components')} | "
                f"{pct(ae)} | {pct(ve)} | {pct(r.get('volume_expected_rel_error'))} | {status(r)} | {r['time']:.2f} |")
    open(os.path.join(OUT, "RESULTS_step.md"), "w").write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
