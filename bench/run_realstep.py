#!/usr/bin/env python3
"""Mesh every STEP file of ../shared/realstep (parts and assemblies written by
other CAD systems) with bubblemesh and with Gmsh in the same run, check every
mesh with the independent ../shared/meshkit/meshcheck.py, print one table and
write bench/out/realstep/results.json and bench/out/realstep/RESULTS.md.

    python3 bench/run_realstep.py [--modes surf,tet] [--files a,b] [--timeout 300]
                                  [--mem-mb 8000] [--threads 1]
                                  [--divisor-surf 25] [--divisor-tet 20]
                                  [--dir DIR]

Sizes (shared/realstep/SOURCES.md): surfaces (`--dim 2`) at d = diag/25,
tetrahedra (`--dim 3`) at d = diag/20, diag being the diagonal of the part's
bounding box as Gmsh's OpenCascade import reports it (`Geometry.OCCBoundsUseStl`,
so the box is tight), the same d for both meshers. Other divisors (a sweep
over sizes) write to bench/out/realstep_s<surf>_t<tet>/. OpenCascade converts every
file to millimetres, so bubblemesh runs with `--unit mm` (files in metres,
centimetres or inches would otherwise be meshed at 1000, 10 or 25.4 times d).

`--dir DIR` runs the same comparison on every STEP file of another folder
(e.g. the seeded random parts of bench/random_parts.py), writing to
bench/out/<DIR's name>_meshed/.

Gmsh: OpenCascade STEP import, Frontal-Delaunay (algorithm 6) for surfaces,
HXT (algorithm 10) for tetrahedra, uniform size d (no size from points or
curvature), one thread. Its times are import, mesh and write, measured inside
its process. bubblemesh: the whole process (`bubblemesh mesh FILE -o OUT
--size d --dim N --unit mm --threads 1 --quiet`), wall time.

Both run under the same address-space limit (`prlimit --as`) and timeout. A
run is `valid` when it exits 0 and meshcheck says valid; a run that exits 0
with an invalid mesh is counted separately as `WRONG` (the one outcome a
mesher must never have). The summary per mode also counts, over the files
both mesh validly, issue 22's comparisons (mean radius ratio and smallest
angle or dihedral angle at least Gmsh's, naming the files below) and the
median of bubblemesh's time over Gmsh's.
"""
import argparse, json, os, statistics, subprocess, sys, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")
REALSTEP = os.path.join(SHARED, "realstep")
MESHCHECK = os.path.join(SHARED, "meshkit", "meshcheck.py")
OUT = os.path.join(os.environ.get("BUBBLEMESH_BENCH_OUT", os.path.join(ROOT, "bench", "out")), "realstep")
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
# BUBBLEMESH_BIN: another build to measure (a copy, so that cargo may go on)
BM = os.environ.get("BUBBLEMESH_BIN", os.path.join(TARGET, "release", "bubblemesh"))
DIVISOR = {"surf": 25.0, "tet": 20.0}
DIM = {"surf": 2, "tet": 3}

GMSH_CODE = r"""
import gmsh, json, math, sys, time
step, out, div, dim = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
gmsh.initialize(); gmsh.option.setNumber('General.Terminal', 0)
gmsh.option.setNumber('General.NumThreads', 1)
gmsh.option.setNumber('Geometry.OCCBoundsUseStl', 1)
t = time.perf_counter()
gmsh.model.occ.importShapes(step); gmsh.model.occ.synchronize()
t_import = time.perf_counter() - t
x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(-1, -1)
diag = math.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2 + (z1 - z0) ** 2)
d = diag / div
res = {"diag": diag, "d": d, "import_s": t_import,
       "n_volumes": len(gmsh.model.getEntities(3)), "n_faces": len(gmsh.model.getEntities(2)),
       "volume_boxes": [list(gmsh.model.getBoundingBox(3, tag)) for _, tag in gmsh.model.getEntities(3)]}
print(json.dumps(res), flush=True)
for k, v in (('Mesh.MeshSizeMin', d), ('Mesh.MeshSizeMax', d), ('Mesh.MeshSizeFromPoints', 0),
             ('Mesh.MeshSizeFromCurvature', 0), ('Mesh.MeshSizeExtendFromBoundary', 0),
             ('Mesh.Algorithm', 6), ('Mesh.Algorithm3D', 10)):
    gmsh.option.setNumber(k, v)
t = time.perf_counter()
gmsh.model.mesh.generate(dim)
res["mesh_s"] = time.perf_counter() - t
t = time.perf_counter()
gmsh.option.setNumber('Mesh.Binary', 1); gmsh.write(out)
res["write_s"] = time.perf_counter() - t
print(json.dumps(res), flush=True)
"""


def limited(cmd, mem_mb):
    return ["prlimit", f"--as={mem_mb << 20}", "--"] + cmd


def last_line(text):
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return lines[-1][:300] if lines else ""


def run_gmsh(step, out, mode, timeout, mem_mb):
    """Gmsh's numbers: the first JSON line (import) is kept even when meshing fails."""
    cmd = limited([sys.executable, "-c", GMSH_CODE, step, out, str(DIVISOR[mode]), str(DIM[mode])], mem_mb)
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as e:
        info = {}
        for l in (e.stdout or b"").decode(errors="replace").splitlines():
            if l.startswith("{"):
                info = json.loads(l)
        info["error"] = f"timeout {timeout:.0f} s"
        return info
    info = {}
    for l in r.stdout.splitlines():
        if l.startswith("{"):
            info = json.loads(l)
    if r.returncode != 0 or "mesh_s" not in info:
        info["error"] = last_line(r.stderr) or f"exit {r.returncode}"
    return info


def run_bubblemesh(step, out, d, mode, timeout, mem_mb, threads):
    cmd = limited([BM, "mesh", step, "-o", out, "--size", repr(d), "--dim", str(DIM[mode]),
                   "--unit", "mm", "--quiet", "--threads", str(threads)], mem_mb)
    t = time.perf_counter()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"time_s": timeout, "error": f"timeout {timeout:.0f} s"}
    info = {"time_s": time.perf_counter() - t, "exit": r.returncode}
    if r.returncode != 0:
        info["error"] = last_line(r.stderr) or f"exit {r.returncode}"
    warnings = [l for l in r.stderr.splitlines() if "warning" in l.lower()]
    if warnings:
        info["warnings"] = warnings[:5]
    return info


def meshcheck(path, mode, timeout):
    cmd = [sys.executable, MESHCHECK, path, "--dim", str(DIM[mode])]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": "meshcheck timeout"}
    if r.returncode != 0:
        return {"error": last_line(r.stderr)}
    rep = json.loads(r.stdout)
    v = rep.get("validity", {})
    out = {"valid": v.get("valid", False)}
    if mode == "tet":
        t = rep.get("tets", {})
        out.update(n=t.get("count"), q_mean=t.get("q_mean"), q_min=t.get("q_min"),
                   worst=t.get("dihedral_min"), euler=v.get("boundary_euler_char"),
                   comps=v.get("boundary_components"))
    else:
        t = rep.get("triangles", {})
        # Euler characteristic V - E + F of the triangulated surface (meshcheck
        # gives the counts, not the sum).
        euler = None
        if None not in (rep.get("n_nodes"), v.get("n_edges"), t.get("count")):
            euler = rep["n_nodes"] - rep.get("unreferenced_nodes", 0) - v["n_edges"] + t["count"]
        out.update(n=t.get("count"), q_mean=t.get("q_mean"), q_min=t.get("q_min"),
                   worst=t.get("min_angle_min"), comps=v.get("boundary_components"),
                   closed=v.get("closed_surface"), euler=euler)
    bad = {k: v[k] for k in ("edges_shared_by_gt2", "n_inconsistent_orientation_edges", "n_zero_area",
                             "n_inverted", "unreferenced_nodes", "duplicate_node_pairs",
                             "boundary_vertices_not_deg2") if v.get(k)}
    if bad:
        out["defects"] = bad
    return out


# Two meshes tie on a measure within this relative tolerance: where both
# keep the same triangle of CAD vertices (a face of three vertices), its
# smallest angle differs in the 13th digit between the two STEP readers
# (29.309107185142036 against 29.30910718514275 on a random part).
TIE = 1e-9


def at_least(bm, gmsh):
    """bubblemesh's measure at least Gmsh's, ties within TIE counted."""
    return bm >= gmsh - TIE * max(abs(gmsh), 1.0)


def fmt(x, f="{:.3f}"):
    return "–" if x is None else f.format(x)


def outcome(run, chk):
    if run.get("error"):
        return "fail"
    if not chk or chk.get("error"):
        return "unchecked"
    return "valid" if chk.get("valid") else "WRONG"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--modes", default="surf,tet")
    ap.add_argument("--files", default="", help="comma-separated substrings of file names")
    ap.add_argument("--timeout", type=float, default=300)
    ap.add_argument("--mem-mb", type=int, default=8000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--dir", default="", help="the STEP files of this folder instead of ../shared/realstep")
    ap.add_argument("--skip-gmsh", action="store_true", help="reuse Gmsh's results from the last run")
    ap.add_argument("--divisor-surf", type=float, default=DIVISOR["surf"],
                    help="surfaces at d = diag / this (default 25, the benchmark's)")
    ap.add_argument("--divisor-tet", type=float, default=DIVISOR["tet"],
                    help="tetrahedra at d = diag / this (default 20, the benchmark's)")
    a = ap.parse_args()
    global OUT, REALSTEP
    if a.dir:
        REALSTEP = os.path.abspath(a.dir)
        OUT = os.path.join(os.path.dirname(OUT), os.path.basename(REALSTEP.rstrip("/")) + "_meshed")
    if (a.divisor_surf, a.divisor_tet) != (DIVISOR["surf"], DIVISOR["tet"]):
        # other sizes (a robustness sweep) keep their own results
        OUT = f"{OUT}_s{a.divisor_surf:g}_t{a.divisor_tet:g}"
        DIVISOR.update(surf=a.divisor_surf, tet=a.divisor_tet)
    if not os.path.exists(BM):
        sys.exit(f"{BM} not found: cargo build --release -p bubblemesh-cli")
    os.makedirs(OUT, exist_ok=True)
    files = sorted(f for f in os.listdir(REALSTEP) if f.lower().endswith((".stp", ".step")))
    if a.files:
        keys = a.files.split(",")
        files = [f for f in files if any(k in f for k in keys)]
    res_path = os.path.join(OUT, "results.json")
    old = json.load(open(res_path)) if os.path.exists(res_path) else {}
    results = dict(old)
    for mode in a.modes.split(","):
        for f in files:
            key = f"{mode}:{f}"
            step = os.path.join(REALSTEP, f)
            stem = os.path.splitext(f)[0]
            g_out = os.path.join(OUT, f"{stem}.{mode}.gmsh.msh")
            b_out = os.path.join(OUT, f"{stem}.{mode}.bm.msh")
            if a.skip_gmsh and key in old:
                g, gc = old[key]["gmsh"], old[key]["gmsh_check"]
                if gc and os.path.exists(g_out):
                    gc = meshcheck(g_out, mode, a.timeout)
            else:
                g = run_gmsh(step, g_out, mode, a.timeout, a.mem_mb)
                gc = meshcheck(g_out, mode, a.timeout) if not g.get("error") else None
            d = g.get("d")
            if d is None:
                print(f"{mode:4} {f}: Gmsh could not import it ({g.get('error')}); skipped", flush=True)
                results[key] = {"gmsh": g, "gmsh_check": None, "bm": None, "bm_check": None}
                continue
            if os.path.exists(b_out):
                os.remove(b_out)
            b = run_bubblemesh(step, b_out, d, mode, a.timeout, a.mem_mb, a.threads)
            bc = meshcheck(b_out, mode, a.timeout) if not b.get("error") else None
            results[key] = {"gmsh": g, "gmsh_check": gc, "bm": b, "bm_check": bc}
            go, bo = outcome(g, gc), outcome(b, bc)
            g_t = sum(g.get(k, 0) for k in ("import_s", "mesh_s", "write_s"))
            print(f"{mode:4} {f[:44]:44} d={d:.4g}  gmsh {go:5} {g_t:6.2f}s q {fmt((gc or {}).get('q_mean'))}"
                  f"  | bm {bo:5} {b['time_s']:6.2f}s q {fmt((bc or {}).get('q_mean'))}"
                  + (f"  [{b['error'][:110]}]" if b.get("error") else "")
                  + (f"  defects {bc['defects']}" if bc and bc.get("defects") else ""), flush=True)
            json.dump(results, open(res_path, "w"), indent=1)
    write_table(results)


def write_table(results):
    lines = ["| mode | file | d | Gmsh | Gmsh s | Gmsh q mean / min | bm | bm s | bm q mean / min | worst angle (bm / Gmsh) "
             "| topology χ, boundary loops (bm / Gmsh) | bm message |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    summary = {}
    for key in sorted(results):
        mode, f = key.split(":", 1)
        r = results[key]
        g, gc, b, bc = r["gmsh"], r["gmsh_check"], r["bm"], r["bm_check"]
        if b is None:
            continue
        go, bo = outcome(g, gc), outcome(b, bc)
        s = summary.setdefault(mode, {"n": 0, "gmsh_valid": 0, "bm_valid": 0, "bm_wrong": 0,
                                      "bm_valid_where_gmsh_valid": 0, "bm_only": 0,
                                      "same_topology": 0, "other_topology": [],
                                      "mean_at_least": 0, "worst_at_least": 0, "below": [],
                                      "ratios": []})
        s["n"] += 1
        s["gmsh_valid"] += go == "valid"
        s["bm_valid"] += bo == "valid"
        s["bm_wrong"] += bo == "WRONG"
        s["bm_valid_where_gmsh_valid"] += go == "valid" and bo == "valid"
        s["bm_only"] += go != "valid" and bo == "valid"
        topo = lambda c: None if not c or c.get("euler") is None else (c["euler"], c.get("comps"))
        bt, gt = topo(bc), topo(gc)
        if go == "valid" and bo == "valid" and bt is not None and gt is not None:
            if bt == gt:
                s["same_topology"] += 1
            else:
                s["other_topology"].append(f)
        tp = f"{'–' if bt is None else '%d, %d' % bt} / {'–' if gt is None else '%d, %d' % gt}"
        g_t = sum(g.get(k, 0) for k in ("import_s", "mesh_s", "write_s"))
        if go == "valid" and bo == "valid":
            # issue 22: mean quality and worst angle at least Gmsh's
            mean_ok = at_least(bc["q_mean"], gc["q_mean"])
            worst_ok = at_least(bc["worst"], gc["worst"])
            s["mean_at_least"] += mean_ok
            s["worst_at_least"] += worst_ok
            if not (mean_ok and worst_ok):
                s["below"].append(f"{f} ({'mean' if not mean_ok else ''}"
                                  f"{', ' if not (mean_ok or worst_ok) else ''}{'angle' if not worst_ok else ''})")
            if g_t > 0:
                s["ratios"].append(b["time_s"] / g_t)
        gq = f"{fmt((gc or {}).get('q_mean'))} / {fmt((gc or {}).get('q_min'))}"
        bq = f"{fmt((bc or {}).get('q_mean'))} / {fmt((bc or {}).get('q_min'))}"
        wa = f"{fmt((bc or {}).get('worst'), '{:.1f}')} / {fmt((gc or {}).get('worst'), '{:.1f}')}"
        msg = (b.get("error") or "").replace("|", "/")[:140]
        lines.append(f"| {mode} | {f} | {g['d']:.4g} | {go} | {g_t:.2f} | {gq} | {bo} | {b['time_s']:.2f} | {bq} | {wa} | {tp} | {msg} |")
    head = ["# bubblemesh and Gmsh on ../shared/realstep", "",
            "Made by `python3 bench/run_realstep.py`; see its docstring for sizes and settings. "
            f"Surfaces at diag/{DIVISOR['surf']:g}, tetrahedra at diag/{DIVISOR['tet']:g}.", ""]
    for mode, s in summary.items():
        head.append(f"- **{mode}**: {s['n']} files; Gmsh valid {s['gmsh_valid']}, bubblemesh valid {s['bm_valid']} "
                    f"(of Gmsh's valid ones: {s['bm_valid_where_gmsh_valid']}; where Gmsh is not: {s['bm_only']}); "
                    f"bubblemesh WRONG (exit 0, invalid mesh): {s['bm_wrong']}; same topology as Gmsh "
                    f"(Euler characteristic, boundary loops) on {s['same_topology']} of "
                    f"{s['same_topology'] + len(s['other_topology'])} both valid"
                    + (f" (other: {', '.join(s['other_topology'])})" if s["other_topology"] else "")
                    + f"; of those, mean quality at or above Gmsh's on {s['mean_at_least']} and smallest "
                    f"{'angle' if mode == 'surf' else 'dihedral angle'} on {s['worst_at_least']}"
                    + (f" (below: {'; '.join(s['below'])})" if s["below"] else "")
                    + (f"; time bubblemesh / Gmsh median {statistics.median(s['ratios']):.2f}, "
                       f"at most 1 on {sum(x <= 1 for x in s['ratios'])} of {len(s['ratios'])}"
                       if s["ratios"] else ""))
    text = "\n".join(head + [""] + lines) + "\n"
    open(os.path.join(OUT, "RESULTS.md"), "w").write(text)
    print("\n".join(head[4:]))


if __name__ == "__main__":
    main()
