#!/usr/bin/env python3
"""bench/run_remesh.py -- re-meshing (thesis §4.8) against meshing from scratch.

Each case meshes a model once with `--save-state`, changes the model or the
spacing, and then meshes the changed input twice, each a fresh process with
`--threads 1`:

  warm     bubblemesh remesh STATE NEW -o warm.msh [--region R] --report warm.json
  scratch  bubblemesh mesh NEW -o scratch.msh --report scratch.json

Both meshes go through meshcheck (../shared/meshkit/meshcheck.py, --spacing
the new spacing).  Reported per case:

  time      wall time of the whole command (reading the state included), median
            of --reps runs, and its ratio warm/scratch (goal: <= 0.2); the
            engine's own timings.total_s ratio next to it;
  quality   meshcheck's q mean, q min and fraction of edges with L/d in
            [1/sqrt2, sqrt2], warm minus scratch (goal: each within 0.005,
            a warm mesh better than scratch passes);
  steps     the largest stage-2 step count of a face, warm and scratch;
  kept      with --region: the old nodes farther than 2 spacings (their old
            spacing) from the region, and how many of them are in the warm
            mesh with the same coordinates bit for bit -- counted here from
            the .msh files (the writer's floats read back exactly), not
            taken from the report.

Cases:
  a   plate 2x1 with two holes (examples/plate_two_holes.toml), d = 0.01;
      the first hole moves by 10 % of its radius (x 0.5 -> 0.52)
  a-r the same with --region sphere around the old and the new hole
  b   a CadQuery part regenerated with one hole diameter changed (8 -> 8.4
      mm): fixtures/remesh/block_hole_8.0.step and _8.4.step, written by
      fixtures/remesh/cadquery_variants.py; its surfaces, d = 0.8 mm
  b2  two hand-made TOML variants of the plate (first hole radius 0.2 ->
      0.22), graded d = 0.006 + 0.01 x
  c   the plate with its spacing refined between the holes:
      d = 0.01 -> min(0.01, 0.005 + 0.025 |x - (1, 0.5)|)
  c-r the same with --region box around the refined zone
  d   a bicubic NURBS patch (examples/nurbs_patch.toml), d = 0.01, whose
      four inner control points rise by 0.01 in each of 10 frames; frame k
      re-meshes from frame k-1's state (chained), scratch meshes each frame
      (times summed over the frames; quality: the worst frame's difference)
  e   the unit cube into tetrahedra (--dim 3), d = 0.08, one face moved
      (x max 1 -> 1.03); the volume warm-starts too (core/src/volume/warm.rs)
      and keeps its old tetrahedra among kept nodes (core/src/volume/keep.rs)
  e-r the same with --region box around the moved face (x >= 0.95); kept
      also counts the old tetrahedra whose corners are all farther than 2
      spacings from the region and how many the warm mesh has, corner for
      corner, bit for bit
  b-3 case b's part into tetrahedra, d = 1.5 mm, with --region sphere
      around the changed hole

  python3 bench/run_remesh.py [--bin target/release/bubblemesh] [--cases a,b] [--reps 3]

Writes OUT/results_remesh.json and OUT/RESULTS_remesh.md (OUT = --out, else
bench/out/remesh).  Not run in CI.
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
MESHKIT = os.path.join(os.path.dirname(REPO), "shared", "meshkit")
if not os.path.isdir(MESHKIT):
    MESHKIT = "/work/shared/meshkit"

PLATE = open(os.path.join(REPO, "examples", "plate_two_holes.toml")).read()
NURBS = """format = "bubblemesh-domain 1"

[[surface]]
name = "patch"
nurbs = {{ degree = [3, 3], points = [
  [[0, 0, 0], [0, 0.33, 0.1], [0, 0.67, 0.1], [0, 1, 0]],
  [[0.33, 0, 0.1], [0.33, 0.33, {z}], [0.33, 0.67, {z}], [0.33, 1, 0.1]],
  [[0.67, 0, 0.1], [0.67, 0.33, {z}], [0.67, 0.67, {z}], [0.67, 1, 0.1]],
  [[1, 0, 0], [1, 0.33, 0.1], [1, 0.67, 0.1], [1, 1, 0]] ] }}
holes_uv = [[[0.4, 0.4], [0.6, 0.4], [0.6, 0.6], [0.4, 0.6]]]
"""
CUBE = """format = "bubblemesh-domain 1"

[[solid]]
name = "cube"
box = {{ min = [0, 0, 0], max = [{x}, 1, 1] }}
"""


def plate(cx=0.5, r=0.2):
    return PLATE.replace("center = [0.5, 0.5], radius = 0.2",
                         "center = [%r, 0.5], radius = %r" % (cx, r))


REFINED = "min(0.01, 0.005 + 0.025*sqrt((x-1)^2 + (y-0.5)^2))"
REFINED_NP = "minimum(0.01, 0.005 + 0.025*sqrt((x-1)**2 + (y-0.5)**2))"

# name: (old model text, new model text, old size, new size (exmex, numpy), region, dim, ext)
CASES = {
    "a": (plate(), plate(0.52), "0.01", ("0.01", "0.01"), None, 2),
    "a-r": (plate(), plate(0.52), "0.01", ("0.01", "0.01"), "sphere:0.51,0.5,0,0.23", 2),
    "b": (os.path.join(REPO, "fixtures", "remesh", "block_hole_8.0.step"),
          os.path.join(REPO, "fixtures", "remesh", "block_hole_8.4.step"),
          "0.8", ("0.8", "0.8"), None, 2),
    "b2": (plate(), plate(0.5, 0.22), "0.006 + 0.01*x", ("0.006 + 0.01*x", "0.006 + 0.01*x"), None, 2),
    "c": (plate(), plate(), "0.01", (REFINED, REFINED_NP), None, 2),
    "c-r": (plate(), plate(), "0.01", (REFINED, REFINED_NP), "box:0.75,0.25,-1,1.25,0.75,1", 2),
    "e": (CUBE.format(x=1), CUBE.format(x=1.03), "0.08", ("0.08", "0.08"), None, 3),
    "e-r": (CUBE.format(x=1), CUBE.format(x=1.03), "0.08", ("0.08", "0.08"),
            "box:0.95,-1,-1,2,2,2", 3),
    "b-3": (os.path.join(REPO, "fixtures", "remesh", "block_hole_8.0.step"),
            os.path.join(REPO, "fixtures", "remesh", "block_hole_8.4.step"),
            "1.5", ("1.5", "1.5"), "sphere:-15,0,0,8", 3),
}
ALL = ["a", "a-r", "b", "b2", "c", "c-r", "d", "e", "e-r", "b-3"]


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def run(cmd, timeout=900):
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise RuntimeError("%s failed (rc %d): %s" % (" ".join(cmd), p.returncode, p.stderr[-1500:]))
    return wall


def meshcheck(mesh, spacing_np, dim):
    p = subprocess.run([sys.executable, os.path.join(MESHKIT, "meshcheck.py"), mesh,
                        "--spacing", spacing_np, "--dim", str(dim)],
                       capture_output=True, text=True, timeout=900)
    if p.returncode != 0:
        return {"error": p.stderr[-800:]}
    j = json.loads(p.stdout)
    cells = j.get("tets") if dim == 3 else j.get("triangles")
    return {
        "valid": j["validity"]["valid"],
        "q_min": cells["q_min"],
        "q_mean": cells["q_mean"],
        "in_band": j["spacing"]["frac_within_sqrt2"],
        "nodes": j["n_nodes"],
    }


def msh_nodes(path):
    import meshio
    return meshio.read(path).points


def msh_tets(path):
    """The tetrahedra of a .msh file as sorted tuples of corner coordinates."""
    import meshio
    m = meshio.read(path)
    pts = m.points.tolist()
    out = []
    for c in m.cells:
        if c.type == "tetra":
            out.extend(tuple(sorted(tuple(pts[i]) for i in t)) for t in c.data.tolist())
    return out


def region_kept(base_msh, state_report, warm_msh, region, size_np):
    """Old nodes farther than 2 spacings from a spatial region, and how many
    of them the warm mesh has at exactly the same coordinates."""
    import numpy as np
    old = msh_nodes(base_msh)
    new = msh_nodes(warm_msh)
    kind, rest = region.split(":", 1)
    v = [float(s) for s in rest.split(",")]
    x, y, z = old[:, 0], old[:, 1], old[:, 2]
    ns = {"x": x, "y": y, "z": z, "sqrt": np.sqrt, "minimum": np.minimum, "maximum": np.maximum}
    d = eval(size_np, {}, ns) * np.ones(len(old))
    if kind == "sphere":
        dist = np.maximum(np.linalg.norm(old - np.array(v[:3]), axis=1) - v[3], 0.0)
    else:
        lo, hi = np.array(v[:3]), np.array(v[3:])
        dist = np.linalg.norm(np.maximum(np.maximum(lo - old, old - hi), 0.0), axis=1)
    far = dist > 2.0 * d
    newset = set(map(tuple, new.tolist()))
    kept = sum(1 for p in old[far].tolist() if tuple(p) in newset)
    # tetrahedra whose corners are all far
    far_pts = set(map(tuple, old[far].tolist()))
    old_tets = [t for t in msh_tets(base_msh) if all(p in far_pts for p in t)]
    new_tets = set(msh_tets(warm_msh))
    tets = (len(old_tets), sum(1 for t in old_tets if t in new_tets)) if old_tets else None
    return int(far.sum()), kept, tets


def steps_of(report_path):
    j = json.load(open(report_path))
    s = [f["relax"]["steps"] for f in j["engine"]["faces"] if f.get("relax")]
    return max(s) if s else 0, j["engine"]["timings"]["total_s"], j.get("remesh")


def one_change(b, out, name, old_text, new_text, old_size, new_size, region, dim, reps, base_state=None):
    """Meshes old (unless `base_state` is given), then new warm and from
    scratch; returns the record."""
    size, size_np = new_size
    oldf, newf = os.path.join(out, name + "_old.toml"), os.path.join(out, name + "_new.toml")
    if new_text.endswith(".step"):
        oldf, newf = old_text, new_text
    else:
        open(newf, "w").write(new_text)
    state = base_state
    base_msh = os.path.join(out, name + "_base.msh")
    dimf = ["--dim", str(dim)]
    if state is None:
        if not old_text.endswith(".step"):
            open(oldf, "w").write(old_text)
        state = os.path.join(out, name + ".state")
        run([b, "mesh", oldf, "-o", base_msh, "--size", old_size, "--threads", "1", "-q",
             "--save-state", state] + dimf)
    rec = {"case": name, "region": region}
    walls = {"warm": [], "scratch": []}
    new_state = os.path.join(out, name + "_new.state")
    for _ in range(reps):
        for label in ["warm", "scratch"]:
            msh = os.path.join(out, "%s_%s.msh" % (name, label))
            rep = os.path.join(out, "%s_%s.json" % (name, label))
            if label == "warm":
                cmd = [b, "remesh", state, newf, "-o", msh, "--save-state", new_state]
                cmd += ["--region", region] if region else []
            else:
                cmd = [b, "mesh", newf, "-o", msh]
            cmd += ["--size", size, "--threads", "1", "-q", "--report", rep] + dimf
            walls[label].append(run(cmd))
    for label in ["warm", "scratch"]:
        msh = os.path.join(out, "%s_%s.msh" % (name, label))
        steps, total, remesh = steps_of(os.path.join(out, "%s_%s.json" % (name, label)))
        rec[label] = {"wall_s": statistics.median(walls[label]), "engine_s": total, "steps": steps,
                      "check": meshcheck(msh, size_np, dim)}
        if remesh:
            s = remesh["summary"]
            rec[label]["summary"] = {k: s[k] for k in ["kept", "moved", "added", "removed"]}
            rec[label]["summary"]["matched"] = len(s["matching"]["matched"])
            rec[label]["summary"]["unmatched"] = len(s["matching"]["unmatched"])
    if region and base_state is None:
        far, kept, tets = region_kept(base_msh, None, os.path.join(out, name + "_warm.msh"), region,
                                      CASES[name][2] if name in CASES else size_np)
        rec["far_from_region"], rec["far_kept_bit_for_bit"] = far, kept
        if tets:
            rec["far_tets"], rec["far_tets_kept"] = tets
    rec["new_state"] = new_state
    return rec


def case_d(b, out, reps):
    """Ten frames of a NURBS patch whose inner control points rise."""
    frames = []
    state = os.path.join(out, "d_0.state")
    z0 = 0.4
    f0 = os.path.join(out, "d_0.toml")
    open(f0, "w").write(NURBS.format(z=z0))
    run([b, "mesh", f0, "-o", os.path.join(out, "d_0.msh"), "--size", "0.01", "--threads", "1", "-q",
         "--save-state", state])
    for k in range(1, 11):
        rec = one_change(b, out, "d_%d" % k, None, NURBS.format(z=round(z0 + 0.01 * k, 6)), None,
                         ("0.01", "0.01"), None, 2, reps, base_state=state)
        state = rec["new_state"]
        frames.append(rec)
    agg = {"case": "d", "region": None, "frames": frames}
    for label in ["warm", "scratch"]:
        agg[label] = {
            "wall_s": sum(f[label]["wall_s"] for f in frames),
            "engine_s": sum(f[label]["engine_s"] for f in frames),
            "steps": max(f[label]["steps"] for f in frames),
        }
    # the worst frame for each quality measure (warm minus scratch)
    agg["diff"] = {k: min(f["warm"]["check"][k] - f["scratch"]["check"][k] for f in frames)
                   for k in ["q_mean", "q_min", "in_band"]}
    agg["valid"] = all(f["warm"]["check"]["valid"] for f in frames)
    return agg


def table(results):
    rows = ["| case | warm s | scratch s | ratio (wall) | ratio (engine) | steps warm/scratch | "
            "Δq mean | Δq min | Δ in band | valid | kept far from region | verdict |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        w, s = r["warm"], r["scratch"]
        if "diff" in r:
            dq = r["diff"]
            valid = r["valid"]
        else:
            dq = {k: w["check"][k] - s["check"][k] for k in ["q_mean", "q_min", "in_band"]}
            valid = w["check"]["valid"]
        ratio = w["wall_s"] / s["wall_s"]
        eratio = w["engine_s"] / max(s["engine_s"], 1e-9)
        kept = ("%d / %d" % (r["far_kept_bit_for_bit"], r["far_from_region"])
                if "far_from_region" in r else "–")
        if "far_tets" in r:
            kept += "; tets %d / %d" % (r["far_tets_kept"], r["far_tets"])
        ok_time = ratio <= 0.2
        ok_q = all(v >= -0.005 for v in dq.values())
        ok_kept = ("far_from_region" not in r or r["far_kept_bit_for_bit"] == r["far_from_region"]) \
            and r.get("far_tets_kept") == r.get("far_tets")
        verdict = ", ".join(x for x, ok in [("time", ok_time), ("quality", ok_q), ("kept", ok_kept),
                                             ("valid", valid)] if not ok)
        rows.append("| %s | %.3f | %.3f | %.2f | %.2f | %d / %d | %+.4f | %+.4f | %+.4f | %s | %s | %s |" % (
            r["case"], w["wall_s"], s["wall_s"], ratio, eratio, w["steps"], s["steps"],
            dq["q_mean"], dq["q_min"], dq["in_band"], valid, kept,
            "ok" if not verdict else "missed: " + verdict))
    return "\n".join(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "bubblemesh"))
    ap.add_argument("--cases", default=",".join(ALL))
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(REPO, "bench", "out", "remesh"))
    a = ap.parse_args()
    if not os.path.isfile(a.bin):
        raise SystemExit("error: no binary at %s (cargo build --release -p bubblemesh-cli)" % a.bin)
    os.makedirs(a.out, exist_ok=True)
    results = []
    for c in a.cases.split(","):
        log("case %s ..." % c)
        if c == "d":
            results.append(case_d(a.bin, a.out, a.reps))
        else:
            old, new, old_size, new_size, region, dim = CASES[c]
            r = one_change(a.bin, a.out, c, old, new, old_size, new_size, region, dim, a.reps)
            if region:
                # the spacing the old nodes were meshed with sets the band
                pass
            results.append(r)
        log(table(results[-1:]).splitlines()[-1])
    md = table(results)
    json.dump(results, open(os.path.join(a.out, "results_remesh.json"), "w"), indent=1)
    open(os.path.join(a.out, "RESULTS_remesh.md"), "w").write(md + "\n")
    print(md)


if __name__ == "__main__":
    main()
