#!/usr/bin/env python3
"""bench/run_3d.py -- bubblemesh against Gmsh on meshkit's volume cases H-K (issue 5).

The volume counterpart of run_2d.py (shared helpers are imported from it).  The
cases, spacing functions and the Gmsh set-ups are those of the independent
measuring kit (meshkit: run_peers.py + meshcheck.py, by default ../shared/meshkit
relative to the repository root):

  H  unit cube, d = 0.05                  examples/cube.toml
  I  unit cube, d = 0.02 + 0.1 x (graded) examples/cube.toml
  J  ball r = 1, d = 0.08                 examples/ball.toml
  K  unit cube, d = 0.015 (large)         examples/cube.toml

Every run is a fresh process.  bubblemesh: `bubblemesh mesh IN -o OUT --size EXPR
--dim 3 --report REP`; its time is the engine's timings.total_s (surface and volume
meshing: no reading, no file output), the whole command's wall time is reported
next to it.  Gmsh: run_peers.run_gmsh(case, PEER, out) imported from meshkit and
run in a worker subprocess, by default for
  gmsh-3d-10-opt1  HXT (Mesh.Algorithm3D=10), default optimiser, one thread
  gmsh-3d-1-optN   Delaunay (Algorithm3D=1) + Gmsh and Netgen optimisers, one thread
(OCC geometry, surfaces by Frontal-Delaunay, size from setSizeCallback with the
case's d); its time is perf_counter around generate(2) + generate(3), as in
meshkit.  Times are medians over --reps runs.  The mesh of the last run of every
mesher is checked with
  python3 meshcheck.py MESH --spacing D --ref-volume V --dim 3
and, here, for boundary conformity: the boundary faces of the tetrahedra must be
exactly the surface triangles in the file, and the tetrahedra's volume must equal
the volume enclosed by those surface triangles (oriented on their own, not from
the tetrahedra) to 1e-9 relative.

  python3 bench/run_3d.py                    # H-K, bubblemesh and gmsh (K is long)
  python3 bench/run_3d.py --cases H,I,J      # skip the large case
  python3 bench/run_3d.py --skip-gmsh --reps 1
  python3 bench/run_3d.py --bin target/release/bubblemesh --out /tmp/bench

Writes OUT/results_3d.json, OUT/RESULTS_3d.md and OUT/meshes/ (OUT = --out, else
$BUBBLEMESH_BENCH_OUT, else bench/out/).  Exit status 0 when the benchmark ran
(whatever the targets say; --strict: 1 if any target FAILs), 2 on set-up errors.
"""
import argparse
import contextlib
import io
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from collections import defaultdict, deque

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import run_2d as r2  # noqa: E402  (shared helpers: meshkit import, versions, git, load, binary, ...)

REPO = r2.REPO
log, f3 = r2.log, r2.f3

ALL_CASES = ["H", "I", "J", "K"]

DOMAIN = {"cube": "examples/cube.toml", "ball": "examples/ball.toml"}

# meshkit's CASES[c]["d"] (numpy syntax) in bubblemesh's --size syntax; checked on a
# 3D grid against meshkit's expressions before anything runs.
SIZE = {"H": "0.05", "I": "0.02 + 0.1*x", "J": "0.08", "K": "0.015"}

BM = "bubblemesh"
HXT = "gmsh-3d-10-opt1"
# run_peers peer name -> label in the tables.
GMSH_LABELS = {
    "gmsh-3d-10-opt1": "gmsh HXT 1 thread",
    "gmsh-3d-1-optN": "gmsh Delaunay+Netgen opt",
}
DEFAULT_PEERS = ["gmsh-3d-10-opt1", "gmsh-3d-1-optN"]

# Issue 5 targets.
Q_MEAN_TARGET, Q_MIN_TARGET = 0.90, 0.45
DIH_MIN_TARGET, DIH_MAX_TARGET = 25.0, 140.0
SPACING_TARGET = 0.95
LD_MEAN_TOL = 0.05
VOLUME_TOL = 1e-9
SPEED_TARGET = 1.5      # case K: bubblemesh time <= 1.5 x gmsh HXT one thread


def gmsh_label(peer):
    return GMSH_LABELS.get(peer, "gmsh " + peer)


# --------------------------------------------------------------------------- #
# set-up checks
# --------------------------------------------------------------------------- #
def check_translations(rp, cases):
    """Our --size expressions must equal meshkit's d on the case's bounding box (3D grid)."""
    for c in cases:
        lo, hi = rp.bbox(c)
        g = np.linspace(0.0, 1.0, 41)
        X, Y, Z = np.meshgrid(*[lo[i] + g * (hi[i] - lo[i]) for i in range(3)], indexing="ij")
        x, y, z = X.ravel(), Y.ravel(), Z.ravel()
        ref = rp.dfun_np(c)(x, y, z)
        ours = r2.exmex_to_numpy(SIZE[c])(x, y, z)
        err = float(np.max(np.abs(ours - ref) / np.abs(ref)))
        if err > 1e-12:
            raise SystemExit("error: case %s: --size %r differs from meshkit's d %r (rel. err %.3g)"
                             % (c, SIZE[c], rp.CASES[c]["d"], err))


def check_peers(rp, cases, peers):
    for c in cases:
        known = rp.peers_for(c)
        bad = [p for p in peers if p not in known or not p.startswith("gmsh-3d-")]
        if bad:
            raise SystemExit("error: case %s: %s not among meshkit's gmsh-3d-* peers (run_peers.py --list)"
                             % (c, ", ".join(bad)))


# --------------------------------------------------------------------------- #
# checks
# --------------------------------------------------------------------------- #
def run_meshcheck(meshkit, mesh, case_def, timeout):
    cmd = [sys.executable, os.path.join(meshkit, "meshcheck.py"), mesh, "--spacing", case_def["d"],
           "--ref-volume", repr(case_def["ref_volume"]), "--dim", "3"]
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


def _orient_component_volumes(tris, pts):
    """Volumes enclosed by the closed components of a triangle soup.

    Each edge-connected component is oriented consistently on its own (breadth-first,
    a neighbour must run the shared edge the other way), then |sum of signed
    volumes of (0, a, b, c)| is its enclosed volume.  Returns None when an edge is not
    shared by exactly two triangles (not a closed 2-manifold).  Written by hand: no
    installed package orients a raw triangle list without pulling in a mesh library.
    """
    edge_tris = defaultdict(list)
    for t, (a, b, c) in enumerate(tris):
        for u, v in ((a, b), (b, c), (c, a)):
            edge_tris[(min(u, v), max(u, v))].append(t)
    if any(len(v) != 2 for v in edge_tris.values()):
        return None
    tris = [list(t) for t in tris]
    seen = [False] * len(tris)
    vols = []

    def directed(t):
        a, b, c = tris[t]
        return {(a, b), (b, c), (c, a)}

    for s in range(len(tris)):
        if seen[s]:
            continue
        seen[s] = True
        comp = [s]
        q = deque([s])
        while q:
            t = q.popleft()
            a, b, c = tris[t]
            for u, v in ((a, b), (b, c), (c, a)):
                for n in edge_tris[(min(u, v), max(u, v))]:
                    if n == t or seen[n]:
                        continue
                    if (u, v) in directed(n):      # same direction: flip the neighbour
                        tris[n][1], tris[n][2] = tris[n][2], tris[n][1]
                    seen[n] = True
                    comp.append(n)
                    q.append(n)
        T = np.asarray([tris[t] for t in comp])
        A, B, C = pts[T[:, 0]], pts[T[:, 1]], pts[T[:, 2]]
        vols.append(abs(float(np.einsum("ij,ij->i", A, np.cross(B, C)).sum()) / 6.0))
    return vols


def surface_check(mesh):
    """Boundary conformity: tet boundary faces == surface triangles; volume == enclosed volume."""
    import meshio
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            m = meshio.read(mesh)      # meshio prints a stray empty line for .msh files
    except Exception as e:  # noqa: BLE001 -- report, do not abort the benchmark
        return {"error": "meshio could not read %s: %s" % (mesh, e)}
    pts = np.asarray(m.points, dtype=np.float64)
    tets = [b.data for b in m.cells if b.type == "tetra"]
    trs = [b.data for b in m.cells if b.type == "triangle"]
    if not tets:
        return {"error": "no tetrahedra in %s" % mesh}
    T = np.concatenate(tets).astype(np.int64)
    faces = np.sort(np.concatenate([T[:, [1, 2, 3]], T[:, [0, 3, 2]], T[:, [0, 1, 3]],
                                    T[:, [0, 2, 1]]]), axis=1)
    uf, cnt = np.unique(faces, axis=0, return_counts=True)
    bnd = uf[cnt == 1]
    P = pts[T]
    tet_vol = float(np.abs(np.einsum("ij,ij->i", P[:, 1] - P[:, 0],
                                     np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]))).sum() / 6.0)
    out = {"tet_volume": tet_vol, "tet_boundary_faces": int(len(bnd))}
    if not trs:
        out["error"] = "no surface triangles in the file"
        return out
    S = np.concatenate(trs).astype(np.int64)
    Ss = np.unique(np.sort(S, axis=1), axis=0)
    out["surface_triangles"] = int(len(S))
    out["surface_triangles_duplicated"] = int(len(S) - len(Ss))
    view = lambda a: np.ascontiguousarray(a).view([("", a.dtype)] * 3).ravel()  # noqa: E731
    out["tet_boundary_faces_not_in_surface"] = int((~np.isin(view(bnd), view(Ss))).sum())
    out["surface_triangles_not_tet_faces"] = int((~np.isin(view(Ss), view(uf))).sum())
    out["surface_triangles_interior"] = int(np.isin(view(Ss), view(uf[cnt == 2])).sum())
    out["boundary_conforming"] = (out["tet_boundary_faces_not_in_surface"] == 0
                                  and out["surface_triangles_not_tet_faces"] == 0)
    vols = _orient_component_volumes(S.tolist(), pts)
    if vols is None:
        out["enclosed_volume"] = None
        out["volume_note"] = "surface triangles are not a closed 2-manifold"
    else:
        out["surface_components"] = len(vols)
        # One component per closed shell; for the solids here (H-K) there is exactly one.
        # Several shells (voids, several volumes) would need nesting: not evaluated.
        if len(vols) == 1:
            out["enclosed_volume"] = vols[0]
            out["volume_rel_error_surface"] = (tet_vol - vols[0]) / vols[0]
        else:
            out["enclosed_volume"] = None
            out["volume_note"] = "%d surface components: enclosed volume not evaluated" % len(vols)
    out["seconds"] = time.perf_counter() - t0
    return out


def check_mesh(a, mesh, c):
    ck = run_meshcheck(a.meshkit, mesh, c, a.timeout)
    try:
        ck["surface_check"] = surface_check(mesh)
    except Exception as e:  # noqa: BLE001
        ck["surface_check"] = {"error": "%s: %s" % (type(e).__name__, e)}
    return ck


# --------------------------------------------------------------------------- #
# runs
# --------------------------------------------------------------------------- #
def slim_engine(engine):
    """The engine report without the per-step energy histories (faces and volumes)."""
    e = r2.slim_engine(engine)
    vols = []
    for v in e.get("volumes", []):
        v = dict(v)
        if isinstance(v.get("relax"), dict):
            r = dict(v["relax"])
            en = r.pop("energy", None)
            if isinstance(en, list):
                r["energy_records"] = len(en)
            v["relax"] = r
        vols.append(v)
    e["volumes"] = vols
    return e


def timed_run(cmd, timeout):
    """subprocess.run with wall time and the child's CPU time (user + sys)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        p = None        # run() has killed and reaped the child: its CPU time is counted below
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return p, wall, cpu


def reps_for(a, c):
    return a.reps if a.reps else (1 if c.get("large") else 3)


def finish(rec, out, a, c):
    rec["status"] = "ok"
    rec["reps"] = len(rec["times"])
    rec["time"] = statistics.median(rec["times"])
    rec["wall"] = statistics.median(rec["wall_times"])
    rec["cpu"] = statistics.median(rec["cpu_times"])
    rec["mesh_file"] = os.path.relpath(out, REPO)
    rec["check"] = check_mesh(a, out, c)
    return rec


def run_bubblemesh(binary, case, rp, a, meshdir):
    c = rp.CASES[case]
    out = os.path.join(meshdir, "%s__%s.msh" % (case, BM))
    repf = os.path.join(meshdir, "%s__%s.report.json" % (case, BM))
    cmd = [binary, "mesh", os.path.join(REPO, DOMAIN[c["geom"]]), "-o", out, "--size", SIZE[case],
           "--dim", "3", "--report", repf, "--threads", "1"]
    rec = {"case": case, "mesher": BM, "status": "ok", "command": " ".join(
        [os.path.relpath(cmd[0], REPO)] + [os.path.relpath(x, REPO) if os.path.isabs(x) else x
                                           for x in cmd[1:]]),
           "times": [], "wall_times": [], "cpu_times": [], "time_mesh_s": [], "time_write_s": []}
    counts = set()
    for _ in range(reps_for(a, c)):
        for fn in (out, repf):
            if os.path.exists(fn):
                os.remove(fn)
        p, wall, cpu = timed_run(cmd, a.timeout)
        if p is None:
            rec.update(status="timeout", error="bubblemesh exceeded %d s (%.0f s CPU)" % (a.timeout, cpu))
            break
        if p.returncode != 0 or not os.path.exists(repf) or not os.path.exists(out):
            rec.update(status="failed", returncode=p.returncode,
                       error="exit %d: %s" % (p.returncode, (p.stderr or p.stdout or "no output")[-1500:]))
            break
        with open(repf) as f:
            rj = json.load(f)
        eng = rj["engine"]
        rec["times"].append(float(eng["timings"]["total_s"]))
        rec["wall_times"].append(wall)
        rec["cpu_times"].append(cpu)
        rec["time_mesh_s"].append(float(rj.get("time_mesh_s", float("nan"))))
        rec["time_write_s"].append(float(rj.get("time_write_s", float("nan"))))
        counts.add((eng.get("nodes"), eng.get("tetrahedra")))
        rec["engine"] = slim_engine(eng)
        rec["stderr_tail"] = p.stderr[-1500:]
    if not rec["times"]:
        return rec
    rec["timings_last"] = rec["engine"]["timings"]
    rec["deterministic_counts"] = len(counts) == 1
    rec["report_file"] = os.path.relpath(repf, REPO)
    return finish(rec, out, a, c)


def gmsh_worker(case, peer, outfile, jsonfile, meshkit):
    """Runs inside a fresh subprocess: meshkit's own gmsh back-end, unchanged."""
    rp = r2.import_meshkit(meshkit)
    t, info = rp.run_gmsh(case, peer, outfile)
    info["maxrss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    with open(jsonfile, "w") as f:
        json.dump({"time": t, "info": info}, f)


def run_gmsh(case, peer, rp, a, meshdir):
    c = rp.CASES[case]
    out = os.path.join(meshdir, "%s__%s.msh" % (case, peer))
    jsonfile = os.path.join(meshdir, "%s__%s.worker.json" % (case, peer))
    rec = {"case": case, "mesher": gmsh_label(peer), "peer": peer, "status": "ok", "times": [],
           "wall_times": [], "cpu_times": []}
    cmd = [sys.executable, os.path.abspath(__file__), "--gmsh-worker", case, peer, out, jsonfile,
           "--meshkit", a.meshkit]
    for _ in range(reps_for(a, c)):
        for fn in (out, jsonfile):
            if os.path.exists(fn):
                os.remove(fn)
        p, wall, cpu = timed_run(cmd, a.timeout)
        if p is None:
            rec.update(status="timeout", error="gmsh worker exceeded %d s (%.0f s CPU)" % (a.timeout, cpu))
            break
        if p.returncode != 0 or not os.path.exists(jsonfile):
            rec.update(status="failed", returncode=p.returncode,
                       error="exit %d: %s" % (p.returncode, (p.stderr or p.stdout or "no output")[-1500:]))
            break
        with open(jsonfile) as f:
            w = json.load(f)
        rec["times"].append(float(w["time"]))
        rec["wall_times"].append(wall)
        rec["cpu_times"].append(cpu)
        rec["info"] = w["info"]
    if os.path.exists(jsonfile):
        os.remove(jsonfile)
    if not rec["times"]:
        return rec
    return finish(rec, out, a, c)


# --------------------------------------------------------------------------- #
# evaluation
# --------------------------------------------------------------------------- #
def ok_check(rec):
    return bool(rec) and rec.get("status") == "ok" and "error" not in rec.get("check", {"error": 1}) \
        and "tets" in rec["check"]


def hxt_rec(recs):
    return recs.get(gmsh_label(HXT))


def evaluate(case, recs):
    """Issue 5's targets for one case -> list of dicts (case, target, status, detail)."""
    bm = recs.get(BM)
    out = []

    def add(name, ok, detail, status=None):
        out.append({"case": case, "target": name, "status": status or ("PASS" if ok else "FAIL"),
                    "detail": detail})

    if not ok_check(bm):
        why = (bm or {}).get("error") or (bm or {}).get("check", {}).get("error") or "not run"
        add("bubblemesh ran and its mesh was checked", False, why.strip().splitlines()[-1][:200])
        return out
    ck = bm["check"]
    t, v, sc = ck["tets"], ck["validity"], ck.get("surface_check", {})
    add("valid mesh (meshcheck: conforming, watertight, no inverted/zero-volume tet)",
        bool(v.get("valid")),
        "conforming=%s watertight=%s inverted=%s zero_volume=%s unreferenced=%s duplicates=%s" % (
            v.get("conforming"), v.get("watertight"), v.get("n_inverted"), v.get("n_zero_volume"),
            v.get("unreferenced_nodes"), v.get("duplicate_node_pairs")))
    add("tet boundary faces = the surface triangles", sc.get("boundary_conforming") is True,
        sc.get("error") or "%s boundary faces, %s surface triangles; %s faces not in the surface, "
        "%s triangles not tet faces (%s interior)" % (
            sc.get("tet_boundary_faces"), sc.get("surface_triangles"),
            sc.get("tet_boundary_faces_not_in_surface"), sc.get("surface_triangles_not_tet_faces"),
            sc.get("surface_triangles_interior")))
    ve = sc.get("volume_rel_error_surface")
    add("tet volume = volume enclosed by the surface mesh to %g" % VOLUME_TOL,
        ve is not None and abs(ve) <= VOLUME_TOL,
        ("rel. error %.1e (tets %.9f, enclosed %.9f)" % (ve, sc["tet_volume"], sc["enclosed_volume"]))
        if ve is not None else (sc.get("error") or sc.get("volume_note") or "not evaluated"))
    add("q mean >= %.2f" % Q_MEAN_TARGET, t["q_mean"] >= Q_MEAN_TARGET, "q mean = %.4f" % t["q_mean"])
    add("q min >= %.2f" % Q_MIN_TARGET, t["q_min"] >= Q_MIN_TARGET, "q min = %.4f" % t["q_min"])
    add("dihedral min >= %g deg" % DIH_MIN_TARGET, t["dihedral_min"] >= DIH_MIN_TARGET,
        "min %.2f deg" % t["dihedral_min"])
    add("dihedral max <= %g deg" % DIH_MAX_TARGET, t["dihedral_max"] <= DIH_MAX_TARGET,
        "max %.2f deg" % t["dihedral_max"])
    sp = ck.get("spacing", {})
    sf, lm = sp.get("frac_within_sqrt2"), sp.get("ratio_mean")
    add(">= %g %% of edges with L/d in [1/sqrt2, sqrt2]" % (100 * SPACING_TARGET),
        sf is not None and sf >= SPACING_TARGET,
        "%.2f %%" % (100 * sf) if sf is not None else "no spacing report")
    add("mean L/d within 1 +- %g" % LD_MEAN_TOL, lm is not None and abs(lm - 1.0) <= LD_MEAN_TOL,
        "mean L/d = %.4f" % lm if lm is not None else "no spacing report")
    if case == "K":
        name = "K: bubblemesh time <= %g x gmsh HXT one thread" % SPEED_TARGET
        gm = hxt_rec(recs)
        if gm is None:
            add(name, False, "gmsh HXT not run (--skip-gmsh or --peers)", status="SKIP")
        elif gm.get("status") != "ok":
            add(name, False, "gmsh HXT run failed: %s" % gm.get("error", "")[-200:])
        else:
            ratio = bm["time"] / gm["time"]
            add(name, ratio <= SPEED_TARGET, "ratio %.2f (bubblemesh %.3f s / gmsh HXT %.3f s); "
                "process wall ratio %.2f, process CPU ratio %.2f" % (
                    ratio, bm["time"], gm["time"], bm["wall"] / gm["wall"], bm["cpu"] / gm["cpu"]))
    return out


# --------------------------------------------------------------------------- #
# report
# --------------------------------------------------------------------------- #
def valid_str(ck):
    v = ck.get("validity", {})
    sc = ck.get("surface_check", {})
    bad = [k for k in ("conforming", "watertight") if v.get(k) is False]
    for k in ("n_inverted", "n_zero_volume", "n_folded_faces", "unreferenced_nodes",
              "duplicate_node_pairs"):
        if v.get(k):
            bad.append("%s=%s" % (k, v[k]))
    if sc.get("boundary_conforming") is False:
        bad.append("boundary != surface")
    if not bad and v.get("valid"):
        return "yes"
    return "NO (" + ", ".join(bad or ["meshcheck: not valid"]) + ")"


def e1(v):
    return "-" if v is None else "%.1e" % v


def case_table(case, title, recs):
    L = ["## Case %s: %s" % (case, title), "",
         "| mesher | nodes | tets | time s | ×HXT | process wall s | cpu s | reps | q min | q mean | "
         "q p1 | dih min | dih max | %<20° | spacing | L/d | vol err ref | vol err surf | valid |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    hx = hxt_rec(recs)
    hxt_time = hx["time"] if hx and hx.get("status") == "ok" else None
    for label, r in recs.items():
        if r.get("status") != "ok":
            err = (r.get("error") or "").strip().splitlines()
            L.append("| %s | %s: %s |" % (label, r.get("status", "?").upper(),
                                          (err[-1] if err else "")[:150].replace("|", "/")))
            continue
        ratio = f3(r["time"] / hxt_time, 2) if hxt_time else "-"
        ck = r["check"]
        if "error" in ck or "tets" not in ck:
            L.append("| %s | - | - | %s | %s | %s | %s | %d | CHECK FAILED: %s |" % (
                label, f3(r["time"]), ratio, f3(r["wall"]), f3(r["cpu"]), r["reps"],
                str(ck.get("error", "no tetrahedra"))[:150].replace("|", "/").replace("\n", " ")))
            continue
        t = ck["tets"]
        sp = ck.get("spacing", {})
        sc = ck.get("surface_check", {})
        L.append("| %s | %d | %d | %s | %s | %s | %s | %d | %s | %s | %s | %s | %s | %s | %s | %s | "
                 "%s | %s | %s |" % (
                     label, ck["n_nodes"], t["count"], f3(r["time"]), ratio, f3(r["wall"]),
                     f3(r["cpu"]), r["reps"], f3(t["q_min"]), f3(t["q_mean"]), f3(t["q_p1"]),
                     f3(t["dihedral_min"], 1), f3(t["dihedral_max"], 1),
                     f3(t.get("pct_min_dihedral_lt20"), 2), f3(sp.get("frac_within_sqrt2"), 4),
                     "%.3f±%.3f" % (sp.get("ratio_mean", float("nan")), sp.get("ratio_std", float("nan"))),
                     e1(ck.get("volume_rel_error")), e1(sc.get("volume_rel_error_surface")),
                     valid_str(ck)))
    return L


def details(recs, peer_refs):
    L = []
    for label, r in recs.items():
        if r.get("status") != "ok":
            continue
        x = []
        if label == BM:
            tm = r.get("timings_last", {})
            x.append("engine timings (last run): " + ", ".join(
                "%s %.3f s" % (k[:-2] if k.endswith("_s") else k, v) for k, v in tm.items()
                if isinstance(v, (int, float))))
            x.append("time_mesh_s (incl. reading input) %.3f s, time_write_s %.3f s" % (
                statistics.median(r["time_mesh_s"]), statistics.median(r["time_write_s"])))
            eng = r.get("engine", {})
            if tm.get("connect_s") and eng.get("tetrahedra"):
                x.append("connection throughput %.3f Mtet/s (all of connect_s: Delaunay, recovery, "
                         "sliver removal; not the kernel alone)" % (
                             eng["tetrahedra"] / tm["connect_s"] / 1e6))
            for v in eng.get("volumes", []):
                rl = v.get("relax") or {}
                sl = v.get("slivers") or {}
                x.append("volume %s: stage-1 bubbles %s, final %s (+%s boundary), relax steps %s "
                         "converged %s deleted %s added %s; ODT iterations %s; recovery removed %s; "
                         "slivers bad %s -> %s, q min %s -> %s, %s moves" % (
                             v.get("name"), v.get("stage1_bubbles"), v.get("bubbles"),
                             v.get("boundary_bubbles"), rl.get("steps"), rl.get("converged"),
                             rl.get("deleted"), rl.get("added"), v.get("odt_iterations"),
                             v.get("recovery_removed"), sl.get("bad_before"), sl.get("bad_after"),
                             f3(sl.get("min_q_before")), f3(sl.get("min_q_after")), sl.get("moves")))
            nf = len(eng.get("faces", []))
            if nf:
                conv = sum(1 for f in eng["faces"] if (f.get("relax") or {}).get("converged"))
                x.append("%d faces (%d relaxations converged), %s surface triangles" % (
                    nf, conv, eng.get("triangles")))
            if not r.get("deterministic_counts", True):
                x.append("node/tet counts differed between repetitions")
        else:
            i = r.get("info", {})
            if "t_surface" in i:
                x.append("surface %.3f s + volume %.3f s (last run)" % (i["t_surface"], i["t_volume"]))
            if "callback_calls" in i:
                x.append("%d size-callback calls" % i["callback_calls"])
            if "maxrss_MB" in i:
                x.append("peak RSS %.0f MB" % i["maxrss_MB"])
            ref = peer_refs.get(r.get("peer"))
            if ref:
                x.append("meshkit results.json: %.3f s (reps %s), %s tets" % (
                    ref["time"], ref.get("reps"), ref.get("elements")))
        if len(r["times"]) > 1:
            x.append("times " + "/".join("%.3f" % v for v in r["times"]))
        sc = r["check"].get("surface_check", {})
        if sc.get("enclosed_volume") is not None:
            x.append("tet volume %.9f, enclosed by surface %.9f" % (sc["tet_volume"], sc["enclosed_volume"]))
        elif sc:
            x.append("surface check: %s" % (sc.get("error") or sc.get("volume_note")))
        if r.get("loadavg") is not None:
            x.append("load before run %s" % r["loadavg"])
        L.append("- %s: %s" % (label, "; ".join(x)))
    return L


def best_peer_line(best):
    if not best:
        return []
    return ["", "Best meshkit peer per measure (results.json, valid single-thread meshes): "
            "q mean %.3f (%s), q min %.3f (%s), dihedral min %.1f° (%s), dihedral max %.1f° (%s), "
            "spacing %.3f (%s), L/d closest to 1 %.3f (%s)." % (
                best["q_mean"][0], best["q_mean"][1], best["q_min"][0], best["q_min"][1],
                best["dih_min"][0], best["dih_min"][1], best["dih_max"][0], best["dih_max"][1],
                best["spacing"][0], best["spacing"][1], best["ld"][0], best["ld"][1])]


def meshkit_best(peer_results, case):
    """Per-measure best among meshkit's valid, single-thread runs of a case."""
    best = {}

    def upd(k, val, peer, better):
        if val is not None and (k not in best or better(val, best[k][0])):
            best[k] = (val, peer)
    for key, r in peer_results.items():
        cs, _, peer = key.partition("__")
        if cs != case or r.get("status") != "ok" or "mt2" in peer:
            continue
        ck = r.get("check", {})
        if not ck.get("validity", {}).get("valid") or "tets" not in ck:
            continue
        t, sp = ck["tets"], ck.get("spacing", {})
        upd("q_mean", t.get("q_mean"), peer, lambda a, b: a > b)
        upd("q_min", t.get("q_min"), peer, lambda a, b: a > b)
        upd("dih_min", t.get("dihedral_min"), peer, lambda a, b: a > b)
        upd("dih_max", t.get("dihedral_max"), peer, lambda a, b: a < b)
        upd("spacing", sp.get("frac_within_sqrt2"), peer, lambda a, b: a > b)
        upd("ld", sp.get("ratio_mean"), peer, lambda a, b: abs(a - 1) < abs(b - 1))
    return best if len(best) == 6 else None


def build_report(res):
    meta = res["meta"]
    L = ["# bubblemesh vs Gmsh, volume cases (issue 5)", "",
         "Machine: %s. Versions: %s. bubblemesh: `%s` (%s, built %s), repository %s%s." % (
             meta["machine"], ", ".join("%s %s" % kv for kv in sorted(meta["versions"].items())),
             meta["binary"], meta.get("binary_version", "?"), meta.get("binary_mtime", "?"),
             meta["git"]["commit"][:12],
             " + %d modified tracked files" % meta["git"]["dirty_files"]
             if meta["git"]["dirty_files"] else ""),
         "",
         ] + (["**The binary was rebuilt during the run (now %s): rows may come from different "
               "builds.**" % meta["binary_mtime_end"], ""]
              if meta.get("binary_mtime_end", meta.get("binary_mtime")) != meta.get("binary_mtime")
              else []) + [
         "Run %s; load average (1/5/15 min) %s at the start, %s at the end, on %d cores (timings "
         "are only meaningful on an otherwise idle machine; `cpu s` is less sensitive to load "
         "than the wall times)." % (meta["date"], meta.get("loadavg_start"), meta.get("loadavg_end"),
                                    os.cpu_count() or 0),
         "",
         "`time s` = meshing only: bubblemesh's engine `timings.total_s` (surface and volume "
         "meshing; no input reading, no file output); gmsh: perf_counter around "
         "`generate(2)` + `generate(3)` in meshkit's run_peers back-end (OCC geometry, surfaces by "
         "Frontal-Delaunay, size from setSizeCallback, one thread; HXT = `%s`, Delaunay+Netgen = "
         "`gmsh-3d-1-optN`: Mesh.Optimize=1 + OptimizeNetgen=1). Median of `reps` fresh processes. "
         "`×HXT` = time / gmsh HXT time of this run. `process wall s` = the whole process "
         "(bubblemesh: the CLI incl. reading, writing the .msh and its own quality report; gmsh: "
         "the Python worker incl. interpreter start, geometry and writing); `cpu s` = user+sys "
         "CPU time of that process. Quality from meshcheck.py `--dim 3`: q = 3 r_in/r_circ; dihedral "
         "angles in degrees; `%%<20°` = %% of tets with min dihedral < 20°; `spacing` = fraction of "
         "edges with L/d(midpoint) in [1/√2, √2]; `L/d` = mean±std; `vol err ref` = (tet volume − "
         "exact solid volume)/exact (meshcheck `--ref-volume`); `vol err surf` = (tet volume − "
         "volume enclosed by the file's surface triangles)/enclosed (this script); `valid` = "
         "meshcheck's validity and the tets' boundary faces being exactly the surface triangles."
         % HXT, ""]
    for case in res["cases"]:
        cr = res["cases"][case]
        L += case_table(case, cr["title"], cr["runs"])
        L += ["", "bubblemesh `--size %s --dim 3` on `%s`; meshcheck `--spacing \"%s\" --ref-volume %r`."
              % (cr["size"], cr["domain"], cr["d"], cr["ref_volume"])]
        L += best_peer_line(cr.get("meshkit_best"))
        dl = details(cr["runs"], cr.get("meshkit_reference", {}))
        if dl:
            L += [""] + dl
        L += ["", "Targets (issue 5, bubblemesh):", ""]
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
def fmt_run(r):
    if r["status"] != "ok":
        return r["status"] + ": " + (r.get("error") or "")[-300:]
    return "%.3f s (wall %.3f s), %d nodes, %d tets" % (
        r["time"], r["wall"], r["check"].get("n_nodes", -1), r["check"].get("tets", {}).get("count", -1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(ALL_CASES), help="comma list out of H,I,J,K")
    ap.add_argument("--skip-gmsh", action="store_true", help="run bubblemesh only")
    ap.add_argument("--peers", default=",".join(DEFAULT_PEERS),
                    help="meshkit gmsh peers to run (run_peers.py --list; default %(default)s)")
    ap.add_argument("--reps", type=int, default=0,
                    help="timing runs per mesher, median reported (default 3; 1 for K)")
    ap.add_argument("--bin", help="bubblemesh binary (default target/release/bubblemesh, built if missing)")
    ap.add_argument("--build", action="store_true", help="run cargo build --release first anyway")
    ap.add_argument("--out", help="output directory (default $BUBBLEMESH_BENCH_OUT or bench/out)")
    ap.add_argument("--meshkit", default=os.path.normpath(os.path.join(REPO, "..", "shared", "meshkit")),
                    help="directory with meshcheck.py and run_peers.py (default ../shared/meshkit)")
    ap.add_argument("--timeout", type=int, default=1800, help="per process, seconds")
    ap.add_argument("--strict", action="store_true", help="exit 1 if any target FAILs")
    ap.add_argument("--gmsh-worker", nargs=4, metavar=("CASE", "PEER", "OUT", "JSON"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    a.meshkit = os.path.abspath(a.meshkit)
    if a.gmsh_worker:
        gmsh_worker(*a.gmsh_worker, a.meshkit)
        return 0

    cases = [c.strip().upper() for c in a.cases.split(",") if c.strip()]
    bad = [c for c in cases if c not in ALL_CASES]
    if bad or not cases:
        ap.error("--cases: the volume cases are H, I, J, K (got %s)" % a.cases)
    if a.reps < 0:
        ap.error("--reps must be >= 1 (0 = the default)")
    peers = [] if a.skip_gmsh else [p.strip() for p in a.peers.split(",") if p.strip()]
    rp = r2.import_meshkit(a.meshkit)
    check_translations(rp, cases)
    check_peers(rp, cases, peers)
    binary = r2.ensure_binary(a.bin, a.build)
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
        "versions": r2.versions(), "binary": os.path.relpath(binary, REPO), "binary_version": bver,
        "binary_mtime": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(os.path.getmtime(binary))),
        "git": r2.git_info(), "meshkit": a.meshkit, "reps_option": a.reps or "default (3; 1 for K)",
        "skip_gmsh": a.skip_gmsh, "peers": peers, "loadavg_start": r2.load_avg()},
        "cases": {}, "targets": []}

    for case in cases:
        c = rp.CASES[case]
        log("case %s: %s (load %s)" % (case, c["title"], r2.load_avg()))
        runs = {}
        load = r2.load_avg()
        r = run_bubblemesh(binary, case, rp, a, meshdir)
        r["loadavg"] = load
        runs[BM] = r
        log("  %-26s %s" % (BM, fmt_run(r)))
        for peer in peers:
            load = r2.load_avg()
            r = run_gmsh(case, peer, rp, a, meshdir)
            r["loadavg"] = load
            runs[r["mesher"]] = r
            log("  %-26s %s" % (r["mesher"], fmt_run(r)))
        refs = {}
        for peer in peers:
            ref = peer_results.get("%s__%s" % (case, peer))
            if ref and ref.get("status") == "ok":
                refs[peer] = {"time": ref["time"], "reps": ref.get("reps"), "elements": ref.get("elements")}
        tg = evaluate(case, runs)
        res["cases"][case] = {"title": c["title"], "domain": DOMAIN[c["geom"]], "size": SIZE[case],
                              "d": c["d"], "ref_volume": c.get("ref_volume"), "runs": runs,
                              "targets": tg, "meshkit_reference": refs,
                              "meshkit_best": meshkit_best(peer_results, case)}
        res["targets"] += tg
        # Written after every case, so that a long run (K) leaves partial results behind.
        with open(os.path.join(outdir, "results_3d.json"), "w") as f:
            json.dump(res, f, indent=1, sort_keys=True)

    res["meta"]["loadavg_end"] = r2.load_avg()
    res["meta"]["binary_mtime_end"] = time.strftime("%Y-%m-%d %H:%M:%S",
                                                    time.localtime(os.path.getmtime(binary)))
    with open(os.path.join(outdir, "results_3d.json"), "w") as f:
        json.dump(res, f, indent=1, sort_keys=True)
    text = build_report(res)
    with open(os.path.join(outdir, "RESULTS_3d.md"), "w") as f:
        f.write(text)
    print(text)
    log("wrote %s and %s" % (os.path.join(outdir, "results_3d.json"), os.path.join(outdir, "RESULTS_3d.md")))
    if a.strict and any(t["status"] == "FAIL" for t in res["targets"]):
        return 1
    return 0


if __name__ == "__main__":
    try:
        rc = main()
    except SystemExit as e:
        if not isinstance(e.code, str):
            raise
        print(e.code, file=sys.stderr)      # set-up error (message from us or run_2d)
        rc = 2
    sys.exit(rc)
