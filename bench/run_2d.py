#!/usr/bin/env python3
"""bench/run_2d.py -- bubblemesh against Gmsh Frontal-Delaunay on the 2D anchor cases A-E.

The cases, spacing functions and the Gmsh set-up are those of the independent
measuring kit (meshkit: run_peers.py + meshcheck.py, by default ../shared/meshkit
relative to the repository root):

  A  unit square, d = 0.02                      examples/square.toml
  B  unit square, d = 0.01 + 0.2 r^2 (graded)   examples/square.toml   (+ a --fast run)
  C  2x1 plate with two holes, graded d         examples/plate_two_holes.toml
  D  regular hexagon side 1, d = 0.1            examples/hexagon.toml
  E  unit square, d = 0.002 (large)             examples/square.toml
  F  sphere r = 1, d = 0.05 (surface)           examples/sphere.toml
  G  torus R = 1, r = 0.3, d = 0.03 (surface)   examples/torus.toml

Every run is a fresh process.  bubblemesh: `bubblemesh mesh IN -o OUT --size EXPR
--report REP` (default stages; case B also with --fast = stage 1 alone); its time is
the engine's timings.total_s (meshing only: no reading, no file output), and the
whole command's wall time is reported next to it.  Gmsh: run_peers.run_gmsh(case,
"gmsh-2d-6") imported from meshkit and run in a worker subprocess (OCC geometry,
Mesh.Algorithm=6, NumThreads=1, MeshSizeExtendFromBoundary=MeshSizeFromPoints=
MeshSizeFromCurvature=0, setSizeCallback with the case's d); its time is
perf_counter around gmsh.model.mesh.generate(2).  Times are medians over --reps
runs.  The mesh of the last run of every mesher is checked with
`python3 meshcheck.py MESH --spacing D --ref-area A --dim 2`.

  python3 bench/run_2d.py                    # A-E, bubblemesh and gmsh (about a minute)
  python3 bench/run_2d.py --cases A,B,C,D    # skip the large case
  python3 bench/run_2d.py --skip-gmsh --reps 1
  python3 bench/run_2d.py --bin target/release/bubblemesh --out /tmp/bench

Writes OUT/results_2d.json, OUT/RESULTS_2d.md and OUT/meshes/ (OUT = --out, else
$BUBBLEMESH_BENCH_OUT, else bench/out/).  Exit status 0 when the benchmark ran
(whatever the targets say; --strict: 1 if any target FAILs), 2 on set-up errors.
"""
import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SQ2 = math.sqrt(2.0)

ALL_CASES = ["A", "B", "C", "D", "E", "F", "G"]

# The domain file of each meshkit geometry.
DOMAIN = {
    "square": "examples/square.toml",
    "plate": "examples/plate_two_holes.toml",
    "hexagon": "examples/hexagon.toml",
    "sphere": "examples/sphere.toml",
    "torus": "examples/torus.toml",
}

# meshkit's CASES[c]["d"] (numpy syntax) written in bubblemesh's --size syntax
# (exmex: + - * / ^, sqrt abs min max exp ln log sin cos).  Uniform cases are given
# as plain numbers (meshkit writes "0.02 + 0*x" only so that numpy broadcasts).
# check_translations() verifies these against meshkit's expressions on a grid.
SIZE = {
    "A": "0.02",
    "B": "0.01 + 0.2*((x-0.5)^2 + (y-0.5)^2)",
    "C": "0.02 + 0.1*max(min(sqrt((x-0.5)^2 + (y-0.5)^2), sqrt((x-1.5)^2 + (y-0.5)^2)) - 0.2, 0)",
    "D": "0.1",
    "E": "0.002",
    "F": "0.05",
    "G": "0.03",
}

# Extra bubblemesh variants: case -> [(mesher label, extra CLI flags)].
VARIANTS = {"B": [("bubblemesh --fast", ["--fast"])]}

GMSH_PEER = "gmsh-2d-6"          # run_peers' name for Frontal-Delaunay + size callback
BM = "bubblemesh"

# D: a perfect hexagonal packing of the hexagon of side 1 at d = 0.1 exists.
D_NODES, D_TRIANGLES, D_QMIN = 331, 600, 0.9995
Q_MEAN_TARGET, Q_MIN_TARGET = 0.99, 0.80
SPACING_TARGET = 0.995
SPEED_TARGET = 10.0


# --------------------------------------------------------------------------- #
# helpers
# --------------------------------------------------------------------------- #
def log(msg):
    print(msg, file=sys.stderr, flush=True)


def import_meshkit(meshkit):
    if not os.path.isfile(os.path.join(meshkit, "run_peers.py")) or \
            not os.path.isfile(os.path.join(meshkit, "meshcheck.py")):
        raise SystemExit("error: meshkit not found at %s (need run_peers.py and meshcheck.py; "
                         "use --meshkit DIR)" % meshkit)
    if meshkit not in sys.path:
        sys.path.insert(0, meshkit)
    import run_peers  # no side effects at import: constants and functions only
    return run_peers


def exmex_to_numpy(expr):
    """Evaluator for our --size syntax, to compare it with meshkit's numpy expression."""
    code = compile(expr.replace("**", "^").replace("^", "**"), "<size>", "eval")
    ns = {"sqrt": np.sqrt, "abs": np.abs, "min": np.minimum, "max": np.maximum,
          "exp": np.exp, "ln": np.log, "log": np.log, "sin": np.sin, "cos": np.cos,
          "tan": np.tan, "PI": math.pi, "E": math.e}

    def d(x, y, z):
        return np.broadcast_to(np.asarray(eval(code, {"__builtins__": {}}, dict(ns, x=x, y=y, z=z)),
                                          dtype=np.float64), x.shape)
    return d


def check_translations(rp, cases):
    """Our size expressions must equal meshkit's d on the case's bounding box."""
    for c in cases:
        lo, hi = rp.bbox(c)
        g = np.linspace(0.0, 1.0, 201)
        X, Y = np.meshgrid(lo[0] + g * (hi[0] - lo[0]), lo[1] + g * (hi[1] - lo[1]), indexing="ij")
        x, y = X.ravel(), Y.ravel()
        z = np.zeros_like(x)
        ref = rp.dfun_np(c)(x, y, z)
        ours = exmex_to_numpy(SIZE[c])(x, y, z)
        err = float(np.max(np.abs(ours - ref) / np.abs(ref)))
        if err > 1e-12:
            raise SystemExit("error: case %s: --size %r differs from meshkit's d %r (rel. err %.3g)"
                             % (c, SIZE[c], rp.CASES[c]["d"], err))


def run_meshcheck(meshkit, mesh, case_def, timeout):
    cmd = [sys.executable, os.path.join(meshkit, "meshcheck.py"), mesh, "--spacing", case_def["d"],
           "--dim", "2"]
    if case_def.get("ref_area"):
        cmd += ["--ref-area", repr(case_def["ref_area"])]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": "meshcheck exceeded %d s" % timeout}
    try:
        rep = json.loads(p.stdout)
    except ValueError:
        return {"error": "meshcheck failed (rc %d): %s" % (p.returncode, (p.stderr or p.stdout)[-800:])}
    rep["command"] = " ".join(cmd[1:])
    return rep


def git_info():
    def g(*a):
        try:
            return subprocess.run(["git", "-C", REPO] + list(a), capture_output=True, text=True,
                                  timeout=30).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""
    return {"commit": g("rev-parse", "HEAD"),
            "dirty_files": len([ln for ln in g("status", "--porcelain", "--untracked-files=no")
                                .splitlines() if ln.strip()])}


def versions():
    v = {"python": sys.version.split()[0]}
    for mod in ("gmsh", "meshio", "numpy", "scipy"):
        try:
            v[mod] = __import__(mod).__version__
        except Exception:
            pass
    return v


def load_avg():
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def ensure_binary(bin_arg, build):
    if bin_arg:
        b = os.path.abspath(bin_arg)
        if not os.access(b, os.X_OK):
            raise SystemExit("error: --bin %s is not an executable file" % bin_arg)
        return b
    b = os.path.join(REPO, "target", "release", "bubblemesh")
    if build or not os.access(b, os.X_OK):
        log("building: cargo build --release -p bubblemesh-cli")
        p = subprocess.run(["cargo", "build", "--release", "-p", "bubblemesh-cli"], cwd=REPO)
        if p.returncode != 0 or not os.access(b, os.X_OK):
            raise SystemExit("error: cargo build --release -p bubblemesh-cli failed")
    return b


# --------------------------------------------------------------------------- #
# runs
# --------------------------------------------------------------------------- #
def slim_engine(engine):
    """The engine report without the per-step energy history."""
    e = dict(engine)
    faces = []
    for f in e.get("faces", []):
        f = dict(f)
        if isinstance(f.get("relax"), dict):
            r = dict(f["relax"])
            en = r.pop("energy", None)
            if isinstance(en, list):
                r["energy_records"] = len(en)
            f["relax"] = r
        faces.append(f)
    e["faces"] = faces
    return e


def run_bubblemesh(binary, case, label, flags, rp, a, meshdir):
    c = rp.CASES[case]
    tag = label.replace(" --", "-").replace(" ", "-")
    out = os.path.join(meshdir, "%s__%s.msh" % (case, tag))
    repf = os.path.join(meshdir, "%s__%s.report.json" % (case, tag))
    cmd = [binary, "mesh", os.path.join(REPO, DOMAIN[c["geom"]]), "-o", out, "--size", SIZE[case],
           "--report", repf, "--threads", "1"] + flags
    rec = {"case": case, "mesher": label, "status": "ok", "command": " ".join(
        [os.path.relpath(cmd[0], REPO)] + [os.path.relpath(x, REPO) if os.path.isabs(x) else x
                                           for x in cmd[1:]]),
           "times": [], "wall_times": [], "time_mesh_s": [], "time_write_s": []}
    reps = a.reps if a.reps else (1 if c.get("large") else 3)
    counts = set()
    for r in range(reps):
        for fn in (out, repf):
            if os.path.exists(fn):
                os.remove(fn)
        t0 = time.perf_counter()
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=a.timeout)
        except subprocess.TimeoutExpired:
            rec.update(status="timeout", error="bubblemesh exceeded %d s" % a.timeout)
            break
        wall = time.perf_counter() - t0
        if p.returncode != 0 or not os.path.exists(repf) or not os.path.exists(out):
            rec.update(status="failed", returncode=p.returncode,
                       error="exit %d: %s" % (p.returncode, (p.stderr or p.stdout or "no output")[-1500:]))
            break
        with open(repf) as f:
            rj = json.load(f)
        eng = rj["engine"]
        rec["times"].append(float(eng["timings"]["total_s"]))
        rec["wall_times"].append(wall)
        rec["time_mesh_s"].append(float(rj.get("time_mesh_s", float("nan"))))
        rec["time_write_s"].append(float(rj.get("time_write_s", float("nan"))))
        counts.add((eng.get("nodes"), eng.get("triangles")))
        rec["engine"] = slim_engine(eng)
        rec["stderr_tail"] = p.stderr[-1500:]
    if not rec["times"]:
        return rec
    rec["status"] = "ok"
    rec["reps"] = len(rec["times"])
    rec["time"] = statistics.median(rec["times"])
    rec["wall"] = statistics.median(rec["wall_times"])
    rec["timings_last"] = rec["engine"]["timings"]
    rec["deterministic_counts"] = len(counts) == 1
    rec["mesh_file"] = os.path.relpath(out, REPO)
    rec["report_file"] = os.path.relpath(repf, REPO)
    rec["check"] = run_meshcheck(a.meshkit, out, c, a.timeout)
    return rec


def gmsh_worker(case, outfile, jsonfile, meshkit):
    """Runs inside a fresh subprocess: meshkit's own gmsh back-end, unchanged."""
    import resource
    rp = import_meshkit(meshkit)
    t, info = rp.run_gmsh(case, GMSH_PEER, outfile)
    info["maxrss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    with open(jsonfile, "w") as f:
        json.dump({"time": t, "info": info}, f)


def run_gmsh(case, rp, a, meshdir):
    c = rp.CASES[case]
    out = os.path.join(meshdir, "%s__%s.msh" % (case, GMSH_PEER))
    jsonfile = os.path.join(meshdir, "%s__%s.worker.json" % (case, GMSH_PEER))
    label = "gmsh Frontal-Delaunay"
    rec = {"case": case, "mesher": label, "peer": GMSH_PEER, "status": "ok", "times": [],
           "wall_times": []}
    reps = a.reps if a.reps else (1 if c.get("large") else 3)
    cmd = [sys.executable, os.path.abspath(__file__), "--gmsh-worker", case, out, jsonfile,
           "--meshkit", a.meshkit]
    for r in range(reps):
        for fn in (out, jsonfile):
            if os.path.exists(fn):
                os.remove(fn)
        t0 = time.perf_counter()
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=a.timeout)
        except subprocess.TimeoutExpired:
            rec.update(status="timeout", error="gmsh worker exceeded %d s" % a.timeout)
            break
        wall = time.perf_counter() - t0
        if p.returncode != 0 or not os.path.exists(jsonfile):
            rec.update(status="failed", returncode=p.returncode,
                       error="exit %d: %s" % (p.returncode, (p.stderr or p.stdout or "no output")[-1500:]))
            break
        with open(jsonfile) as f:
            w = json.load(f)
        rec["times"].append(float(w["time"]))
        rec["wall_times"].append(wall)
        rec["info"] = w["info"]
    if os.path.exists(jsonfile):
        os.remove(jsonfile)
    if not rec["times"]:
        return rec
    rec["status"] = "ok"
    rec["reps"] = len(rec["times"])
    rec["time"] = statistics.median(rec["times"])
    rec["wall"] = statistics.median(rec["wall_times"])
    rec["mesh_file"] = os.path.relpath(out, REPO)
    rec["check"] = run_meshcheck(a.meshkit, out, c, a.timeout)
    return rec


# --------------------------------------------------------------------------- #
# evaluation
# --------------------------------------------------------------------------- #
def ok_check(rec):
    return rec and rec.get("status") == "ok" and "error" not in rec.get("check", {"error": 1}) \
        and "triangles" in rec["check"]


def tri(rec):
    return rec["check"]["triangles"]


def spacing_frac(rec):
    return rec["check"].get("spacing", {}).get("frac_within_sqrt2")


def evaluate(case, recs):
    """Targets of the issue for one case -> list of dicts (name, status, detail)."""
    bm = recs.get(BM)
    gm = recs.get("gmsh Frontal-Delaunay")
    out = []

    def add(name, status, detail):
        out.append({"case": case, "target": name, "status": status, "detail": detail})

    if not ok_check(bm):
        why = (bm or {}).get("error") or (bm or {}).get("check", {}).get("error") or "not run"
        add("bubblemesh ran and its mesh was checked", "FAIL", why.strip().splitlines()[-1][:200])
        return out
    t = tri(bm)
    v = bm["check"]["validity"]
    add("valid mesh (meshcheck)", "PASS" if v.get("valid") else "FAIL",
        "conforming=%s boundary_closed=%s inverted=%s unreferenced=%s duplicates=%s" % (
            v.get("conforming"), v.get("boundary_closed"), v.get("n_inverted"),
            v.get("unreferenced_nodes"), v.get("duplicate_node_pairs")))
    if case in ("F", "G"):
        add("surface q mean >= 0.99", "PASS" if t["q_mean"] >= 0.99 else "FAIL", "q mean = %.4f" % t["q_mean"])
        add("surface q min >= 0.85", "PASS" if t["q_min"] >= 0.85 else "FAIL", "q min = %.4f" % t["q_min"])
    if case in ("A", "B", "C"):
        add("q mean >= %.2f" % Q_MEAN_TARGET, "PASS" if t["q_mean"] >= Q_MEAN_TARGET else "FAIL",
            "q mean = %.4f" % t["q_mean"])
        add("q min >= %.2f" % Q_MIN_TARGET, "PASS" if t["q_min"] >= Q_MIN_TARGET else "FAIL",
            "q min = %.4f" % t["q_min"])
    sf = spacing_frac(bm)
    add(">= %.1f %% of edges with L/d in [1/sqrt2, sqrt2]" % (100 * SPACING_TARGET),
        "PASS" if sf is not None and sf >= SPACING_TARGET else "FAIL",
        "%.2f %%" % (100 * sf) if sf is not None else "no spacing report")
    if case == "D":
        n, nt = bm["check"].get("n_nodes"), t["count"]
        hist = t.get("valence_hist", {})
        add("D: nodes == %d" % D_NODES, "PASS" if n == D_NODES else "FAIL", "nodes = %s" % n)
        add("D: triangles == %d" % D_TRIANGLES, "PASS" if nt == D_TRIANGLES else "FAIL",
            "triangles = %s" % nt)
        add("D: q min >= %.4f" % D_QMIN, "PASS" if t["q_min"] >= D_QMIN else "FAIL",
            "q min = %.6f" % t["q_min"])
        add("D: every interior vertex has valence 6",
            "PASS" if hist and set(hist) == {"6"} else "FAIL",
            "interior valence histogram %s" % json.dumps(hist, sort_keys=True))
    if case == "E":
        name = "E: gmsh time / bubblemesh time >= %g at equal or better quality" % SPEED_TARGET
        if not ok_check(gm):
            add(name, "SKIP" if gm is None else "FAIL",
                "gmsh not run (--skip-gmsh)" if gm is None else "gmsh run failed")
        else:
            g = tri(gm)
            ratio = gm["time"] / bm["time"]
            # "equal" = equal as printed (3 decimals)
            qm = round(t["q_mean"], 3) >= round(g["q_mean"], 3)
            qn = round(t["q_min"], 3) >= round(g["q_min"], 3)
            valid = bool(v.get("valid"))
            ok = ratio >= SPEED_TARGET and qm and qn and valid
            add(name, "PASS" if ok else "FAIL",
                "ratio %.2f (gmsh %.3f s / bubblemesh %.3f s; %s); q mean %.4f vs gmsh %.4f (%s); "
                "q min %.4f vs gmsh %.4f (%s); valid %s" % (
                    ratio, gm["time"], bm["time"], ">= %g" % SPEED_TARGET if ratio >= SPEED_TARGET
                    else "< %g" % SPEED_TARGET, t["q_mean"], g["q_mean"],
                    "ok" if qm else "worse", t["q_min"], g["q_min"], "ok" if qn else "worse", valid))
    return out


# --------------------------------------------------------------------------- #
# report
# --------------------------------------------------------------------------- #
def f3(v, nd=3):
    if v is None:
        return "-"
    if isinstance(v, float):
        if math.isnan(v):
            return "-"
        return ("%." + str(nd) + "f") % v
    return str(v)


def valid_str(ck):
    v = ck.get("validity", {})
    if v.get("valid"):
        return "yes"
    bad = [k for k in ("conforming", "boundary_closed") if v.get(k) is False]
    for k in ("n_inverted", "n_zero_area", "unreferenced_nodes", "duplicate_node_pairs"):
        if v.get(k):
            bad.append("%s=%s" % (k, v[k]))
    return "NO (" + ", ".join(bad) + ")"


def case_table(case, title, recs):
    L = ["## Case %s: %s" % (case, title), "",
         "| mesher | nodes | triangles | time s | process wall s | reps | q min | q mean | q p1 | "
         "min angle | max angle | val6 | spacing | L/d | valid |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, r in recs.items():
        if r.get("status") != "ok":
            err = (r.get("error") or "").strip().splitlines()
            L.append("| %s | %s: %s |" % (label, r.get("status", "?").upper(),
                                          (err[-1] if err else "")[:150].replace("|", "/")))
            continue
        ck = r["check"]
        if "error" in ck or "triangles" not in ck:
            L.append("| %s | - | - | %s | %s | %d | CHECK FAILED: %s |" % (
                label, f3(r["time"]), f3(r["wall"]), r["reps"],
                str(ck.get("error", "no triangles"))[:150].replace("|", "/").replace("\n", " ")))
            continue
        t = ck["triangles"]
        sp = ck.get("spacing", {})
        L.append("| %s | %d | %d | %s | %s | %d | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            label, ck["n_nodes"], t["count"], f3(r["time"]), f3(r["wall"]), r["reps"],
            f3(t["q_min"]), f3(t["q_mean"]), f3(t["q_p1"]), f3(t["min_angle_min"], 1),
            f3(t["max_angle_max"], 1), f3(t.get("valence6_fraction")),
            f3(sp.get("frac_within_sqrt2"), 4),
            "%.3f±%.3f" % (sp.get("ratio_mean", float("nan")), sp.get("ratio_std", float("nan"))),
            valid_str(ck)))
    return L


def details(case, recs, peer_ref):
    L = []
    for label, r in recs.items():
        if r.get("status") != "ok":
            continue
        x = []
        if label.startswith(BM):
            tm = r.get("timings_last", {})
            x.append("engine (last run): edges %.3f s, stage 1 %.3f s, stage 2 %.3f s, connect %.3f s"
                     % tuple(tm.get(k, float("nan")) for k in ("edges_s", "stage1_s", "stage2_s",
                                                                 "connect_s")))
            x.append("time_mesh_s (incl. reading input) %.3f s, time_write_s %.3f s" % (
                statistics.median(r["time_mesh_s"]), statistics.median(r["time_write_s"])))
            for i, f in enumerate(r.get("engine", {}).get("faces", [])):
                rl = f.get("relax")
                if rl:
                    x.append("face %d: stage-1 bubbles %s, final bubbles %s, relax steps %s, "
                             "converged %s, deleted %s, added %s" % (
                                 i + 1, f.get("stage1_bubbles"), f.get("bubbles"), rl.get("steps"),
                                 rl.get("converged"), rl.get("deleted"), rl.get("added")))
                else:
                    x.append("face %d: stage-1 bubbles %s, final bubbles %s, no relaxation" % (
                        i + 1, f.get("stage1_bubbles"), f.get("bubbles")))
            if not r.get("deterministic_counts", True):
                x.append("node/triangle counts differed between repetitions")
        else:
            i = r.get("info", {})
            if "callback_calls" in i:
                x.append("%d size-callback calls" % i["callback_calls"])
            if "maxrss_MB" in i:
                x.append("peak RSS %.0f MB" % i["maxrss_MB"])
            if peer_ref:
                x.append("meshkit results.json %s: %.3f s (reps %s), %s triangles" % (
                    GMSH_PEER, peer_ref["time"], peer_ref.get("reps"), peer_ref.get("elements")))
        if len(r["times"]) > 1:
            x.append("times " + "/".join("%.3f" % v for v in r["times"]))
        ae = r["check"].get("area_rel_error")
        if ae is not None:
            x.append("area rel. error %.1e" % ae)
        L.append("- %s: %s" % (label, "; ".join(x)))
    return L


def comparison_e(recs, peer_ref=None):
    bm, gm = recs.get(BM), recs.get("gmsh Frontal-Delaunay")
    if not (ok_check(bm) and ok_check(gm)):
        return []
    t, g = tri(bm), tri(gm)
    L = ["", "Case E comparison (bubblemesh vs gmsh Frontal-Delaunay):", "",
         "| measure | bubblemesh | gmsh | bubblemesh better or equal? |", "|---|---|---|---|"]
    rows = [("time s (mesher only)", bm["time"], gm["time"], bm["time"] <= gm["time"], 3),
            ("process wall s", bm["wall"], gm["wall"], bm["wall"] <= gm["wall"], 3),
            ("q min", t["q_min"], g["q_min"], round(t["q_min"], 3) >= round(g["q_min"], 3), 4),
            ("q mean", t["q_mean"], g["q_mean"], round(t["q_mean"], 3) >= round(g["q_mean"], 3), 4),
            ("q p1", t["q_p1"], g["q_p1"], round(t["q_p1"], 3) >= round(g["q_p1"], 3), 4),
            ("min angle", t["min_angle_min"], g["min_angle_min"],
             t["min_angle_min"] >= g["min_angle_min"], 2),
            ("max angle", t["max_angle_max"], g["max_angle_max"],
             t["max_angle_max"] <= g["max_angle_max"], 2),
            ("val6", t.get("valence6_fraction"), g.get("valence6_fraction"),
             (t.get("valence6_fraction") or 0) >= (g.get("valence6_fraction") or 0), 4),
            ("spacing frac", spacing_frac(bm), spacing_frac(gm),
             (spacing_frac(bm) or 0) >= (spacing_frac(gm) or 0), 4)]
    for name, x, y, b, nd in rows:
        L.append("| %s | %s | %s | %s |" % (name, f3(x, nd), f3(y, nd), "yes" if b else "no"))
    L += ["", "Speed ratio gmsh_time / bubblemesh_time = %.2f (mesher time); %.2f (whole process wall)."
          % (gm["time"] / bm["time"], gm["wall"] / bm["wall"])]
    if peer_ref:
        L[-1] += (" With meshkit's stored gmsh time for this case (%.3f s, results.json) instead: %.2f."
                  % (peer_ref["time"], peer_ref["time"] / bm["time"]))
    return L


def build_report(res):
    meta = res["meta"]
    L = ["# bubblemesh vs Gmsh Frontal-Delaunay, 2D cases", "",
         "Machine: %s. Versions: %s. bubblemesh: `%s` (%s), repository %s%s." % (
             meta["machine"], ", ".join("%s %s" % kv for kv in sorted(meta["versions"].items())),
             meta["binary"], meta.get("binary_version", "?"), meta["git"]["commit"][:12],
             " + %d modified tracked files" % meta["git"]["dirty_files"]
             if meta["git"]["dirty_files"] else ""),
         "",
         "Run %s; load average (1/5/15 min) %s at the start, %s at the end (timings are only "
         "meaningful on an otherwise idle machine)." % (
             meta["date"], meta.get("loadavg_start"), meta.get("loadavg_end")),
         "",
         "`time s` = meshing only: bubblemesh's engine `timings.total_s` (boundary edges + stage 1 + "
         "stage 2 + connection; no input reading, no file output); gmsh: perf_counter around "
         "`gmsh.model.mesh.generate(2)` (meshkit run_peers `%s`: OCC geometry, Mesh.Algorithm=6, "
         "NumThreads 1, size from setSizeCallback). Median of `reps` fresh processes. "
         "`process wall s` = the whole process (bubblemesh: the CLI command incl. reading, writing "
         "the .msh and its own quality report; gmsh: the Python worker incl. interpreter start, "
         "imports, geometry and writing the .msh). Quality from meshcheck.py: q = 2 r_in/r_circ; "
         "`val6` = fraction of interior vertices of valence 6; `spacing` = fraction of edges with "
         "L/d(midpoint) in [1/√2, √2]; `L/d` = mean±std." % GMSH_PEER, ""]
    for case in res["cases"]:
        cr = res["cases"][case]
        L += case_table(case, cr["title"], cr["runs"])
        L += ["", "bubblemesh `--size %s`; meshcheck `--spacing \"%s\"`." % (cr["size"], cr["d"])]
        dl = details(case, cr["runs"], cr.get("meshkit_reference"))
        if dl:
            L += [""] + dl
        if case == "E":
            L += comparison_e(cr["runs"], cr.get("meshkit_reference"))
        L += ["", "Targets (bubblemesh, default stages):", ""]
        for t in cr["targets"]:
            L.append("- **%s** %s — %s" % (t["status"], t["target"], t["detail"]))
        L.append("")
    L += ["## Summary of targets", "", "| case | target | result | detail |", "|---|---|---|---|"]
    for t in res["targets"]:
        L.append("| %s | %s | %s | %s |" % (t["case"], t["target"], t["status"], t["detail"]))
    n = {s: sum(1 for t in res["targets"] if t["status"] == s) for s in ("PASS", "FAIL", "SKIP")}
    L += ["", "%d PASS, %d FAIL, %d SKIP." % (n["PASS"], n["FAIL"], n["SKIP"]), ""]
    return "\n".join(L)


# --------------------------------------------------------------------------- #
def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(ALL_CASES), help="comma list out of A,B,C,D,E,F,G")
    ap.add_argument("--skip-gmsh", action="store_true", help="run bubblemesh only")
    ap.add_argument("--reps", type=int, default=0,
                    help="timing runs per mesher, median reported (default 3; 1 for E)")
    ap.add_argument("--bin", help="bubblemesh binary (default target/release/bubblemesh, built if missing)")
    ap.add_argument("--build", action="store_true", help="run cargo build --release first anyway")
    ap.add_argument("--out", help="output directory (default $BUBBLEMESH_BENCH_OUT or bench/out)")
    ap.add_argument("--meshkit", default=os.path.normpath(os.path.join(REPO, "..", "shared", "meshkit")),
                    help="directory with meshcheck.py and run_peers.py (default ../shared/meshkit)")
    ap.add_argument("--timeout", type=int, default=900, help="per process, seconds")
    ap.add_argument("--strict", action="store_true", help="exit 1 if any target FAILs")
    ap.add_argument("--gmsh-worker", nargs=3, metavar=("CASE", "OUT", "JSON"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    a.meshkit = os.path.abspath(a.meshkit)
    if a.gmsh_worker:
        gmsh_worker(*a.gmsh_worker, a.meshkit)
        return 0

    cases = [c.strip().upper() for c in a.cases.split(",") if c.strip()]
    bad = [c for c in cases if c not in ALL_CASES]
    if bad or not cases:
        ap.error("--cases: only A, B, C, D, E are 2D cases (got %s)" % a.cases)
    if a.reps < 0:
        ap.error("--reps must be >= 1 (0 = the default)")
    rp = import_meshkit(a.meshkit)
    check_translations(rp, cases)
    binary = ensure_binary(a.bin, a.build)
    outdir = os.path.abspath(a.out or os.environ.get("BUBBLEMESH_BENCH_OUT") or os.path.join(HERE, "out"))
    meshdir = os.path.join(outdir, "meshes")
    os.makedirs(meshdir, exist_ok=True)

    try:
        bver = subprocess.run([binary, "--version"], capture_output=True, text=True,
                              timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        bver = "?"
    peer_results = {}
    try:
        with open(os.path.join(a.meshkit, "results.json")) as f:
            peer_results = json.load(f).get("runs", {})
    except (OSError, ValueError):
        pass
    res = {"meta": {
        "machine": "%s, %d cores, %s" % (platform.machine(), os.cpu_count() or 0, platform.platform()),
        "date": time.strftime("%Y-%m-%d %H:%M:%S %z"),
        "versions": versions(), "binary": os.path.relpath(binary, REPO), "binary_version": bver,
        "binary_mtime": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(os.path.getmtime(binary))),
        "git": git_info(), "meshkit": a.meshkit, "reps_option": a.reps or "default (3; 1 for E)",
        "skip_gmsh": a.skip_gmsh, "loadavg_start": load_avg()},
        "cases": {}, "targets": []}

    for case in cases:
        c = rp.CASES[case]
        log("case %s: %s" % (case, c["title"]))
        runs = {}
        for label, flags in [(BM, [])] + VARIANTS.get(case, []):
            r = run_bubblemesh(binary, case, label, flags, rp, a, meshdir)
            runs[label] = r
            log("  %-22s %s" % (label, ("%.3f s (wall %.3f s), %d nodes" % (
                r["time"], r["wall"], r["check"].get("n_nodes", -1))) if r["status"] == "ok"
                else r["status"] + ": " + (r.get("error") or "")[-300:]))
        if not a.skip_gmsh:
            r = run_gmsh(case, rp, a, meshdir)
            runs[r["mesher"]] = r
            log("  %-22s %s" % (r["mesher"], ("%.3f s (wall %.3f s), %d nodes" % (
                r["time"], r["wall"], r["check"].get("n_nodes", -1))) if r["status"] == "ok"
                else r["status"] + ": " + (r.get("error") or "")[-300:]))
        ref = peer_results.get("%s__%s" % (case, GMSH_PEER))
        ref = ({"time": ref["time"], "reps": ref.get("reps"), "elements": ref.get("elements")}
               if ref and ref.get("status") == "ok" else None)
        tg = evaluate(case, runs)
        res["cases"][case] = {"title": c["title"], "domain": DOMAIN[c["geom"]], "size": SIZE[case],
                              "d": c["d"], "ref_area": c.get("ref_area"), "runs": runs,
                              "targets": tg, "meshkit_reference": ref}
        res["targets"] += tg

    res["meta"]["loadavg_end"] = load_avg()
    with open(os.path.join(outdir, "results_2d.json"), "w") as f:
        json.dump(res, f, indent=1, sort_keys=True)
    text = build_report(res)
    with open(os.path.join(outdir, "RESULTS_2d.md"), "w") as f:
        f.write(text)
    print(text)
    log("wrote %s and %s" % (os.path.join(outdir, "results_2d.json"), os.path.join(outdir, "RESULTS_2d.md")))
    if a.strict and any(t["status"] == "FAIL" for t in res["targets"]):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
