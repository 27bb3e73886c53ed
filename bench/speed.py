#!/usr/bin/env python3
"""bench/speed.py -- bubblemesh on one thread against Gmsh on one thread (issue 24).

One run measures, case by case, in fresh processes:

  bubblemesh 1 thread   the whole process `bubblemesh mesh IN -o OUT.msh ARGS --quiet
                        --threads 1` (read, mesh, write), wall seconds;
  bubblemesh all cores  the same command without --threads (every core), wall
                        seconds, and the speed-up 1 thread / all cores; the two .msh
                        files are compared byte for byte (the mesh must not depend
                        on the thread count);
  Gmsh                  a worker subprocess per run (this script, --gmsh-worker) with
                        General.NumThreads = Mesh.MaxNumThreads1D/2D/3D = 1,
                        Mesh.Algorithm = 6 (Frontal-Delaunay), Mesh.Algorithm3D = 10
                        (HXT, default optimiser), MeshSizeFromPoints =
                        MeshSizeFromCurvature = MeshSizeExtendFromBoundary = 0;
                        perf_counter around the import (OpenCascade importShapes +
                        synchronize for STEP files; building meshkit's OCC geometry
                        for the anchor cases), generate(dim) ("mesh") and
                        gmsh.write(OUT.msh) (binary .msh 4.1).  "import+mesh+write"
                        is their sum: interpreter start, `import gmsh` and
                        gmsh.initialize() are not counted (the whole worker's wall
                        time is in results.json);
  ratio                 bubblemesh 1-thread wall / Gmsh import+mesh+write (< 1:
                        bubblemesh is faster);
  quality               meshcheck.py (../shared/meshkit) on both .msh files with the
                        case's spacing: mean and minimum radius ratio, smallest angle
                        (surfaces) or dihedral angle (tetrahedra), the share of
                        edges with L/d in [1/sqrt2, sqrt2], element count, validity;
  peak memory           the largest resident size of each process, from GNU time's
                        %M (/usr/bin/time; without it, the wait4 value, which
                        includes this script's own size and is marked >=): for
                        Gmsh the whole Python worker, i.e. the interpreter, numpy
                        for the anchor cases (meshkit's run_peers imports it) and
                        libgmsh -- its resident size before meshing is in
                        results.json as rss_before_mesh_MB.

Times are medians of --reps runs (Gmsh, bubblemesh 1 thread and all cores
interleaved, so that load changes hit all three); peaks are the largest of the
runs; the meshes of the last run are checked.  Every process runs under --timeout
and, if prlimit is installed, an address-space limit of --mem-mb: a crash, a hang
or running out of memory is a failed case, reported, never dropped.

The cases are those of the other bench scripts, imported from them (nothing is
copied), in five groups:

  2d        run_2d.py:    meshkit's A-G (planar A-E, surfaces F, G), the domain
                          files and --size expressions of run_2d.DOMAIN / SIZE;
  3d        run_3d.py:    meshkit's H-K (tetrahedra), run_3d.DOMAIN / SIZE, --dim 3;
  step      run_step.py:  every part of fixtures/manifest.json at its mesh_size,
                          surfaces (--dim 2);
  step3d    run_step_3d.py: the parts with a solid, at mesh_size, --dim 3;
  realstep  run_realstep.py: every file of ../shared/realstep, surfaces at
                          d = diag/25 ("surf:NAME") and tetrahedra at d = diag/20
                          ("tet:NAME"), diag from Gmsh's OpenCascade import with
                          Geometry.OCCBoundsUseStl = 1 as there (found by an untimed
                          Gmsh probe, so the timed runs do not pay for it).

Gmsh's size: the constant d (MeshSizeMin = MeshSizeMax = d) for uniform cases and
every STEP case; for the graded anchor cases B, C, I meshkit's d as a MathEval
background field (evaluated in C++), or with --gmsh-callback meshkit's Python
setSizeCallback (as run_2d.py and run_3d.py do; slower, Gmsh then pays for Python).
bubblemesh gets the same d through --size.

  python3 bench/speed.py --groups 2d --cases A,B,D      # a minute
  python3 bench/speed.py --groups step --cases torus,cube
  python3 bench/speed.py --groups realstep --cases 'surf:as_wavy-cube'
  python3 bench/speed.py --groups 3d,step3d --reps 3 --timeout 900
  python3 bench/speed.py                               # everything (hours on 2 cores)

Options: --groups (comma list of the five), --cases (comma list of names or shell
patterns, matched against case names, STEP file stems and, for realstep, with or
without the surf:/tet: prefix), --reps N (median of N, default 1), --timeout S
(per process, default 600), --out DIR (default bench/out/speed), --skip-all-cores,
--gmsh-callback, --bin (default $BUBBLEMESH_BIN, else target/release/bubblemesh;
never built here), --meshkit DIR (default ../shared/meshkit), --mem-mb (8000; 0 =
no limit), --fresh (forget the earlier results in OUT/results.json; by default a
run replaces only the cases it ran).

Writes OUT/results.json (every run, meshcheck reports included; rewritten after
each case), OUT/RESULTS_speed.md (one table per group and a summary line with the
median and worst ratio; also on stdout) and the meshes in OUT/meshes/GROUP/.
Timings on a loaded machine are loose: the load average is recorded per case.
Exit status 0 when the benchmark ran, 2 on set-up errors.
"""
import argparse
import fnmatch
import hashlib
import json
import math
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
GROUPS = ["2d", "3d", "step", "step3d", "realstep"]
GROUP_TITLE = {
    "2d": "meshkit's 2D and surface cases A-G (run_2d.py)",
    "3d": "meshkit's volume cases H-K (run_3d.py)",
    "step": "STEP fixtures, surfaces at mesh_size (run_step.py)",
    "step3d": "STEP fixtures with a solid, tetrahedra at mesh_size (run_step_3d.py)",
    "realstep": "../shared/realstep: surfaces at diag/25, tetrahedra at diag/20 (run_realstep.py)",
}

def log(msg):
    print(msg, file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- #
# the Gmsh worker (a fresh process per run; imports nothing but gmsh, and meshkit
# for the anchor cases)
# --------------------------------------------------------------------------- #
def gmsh_worker(spec):
    """Mesh one case with Gmsh; print a JSON line after each phase (the last one wins)."""
    res = {}

    def emit(**kw):
        res.update(kw)
        print(json.dumps(res), flush=True)

    run_peers = None
    if "meshkit_case" in spec:
        sys.path.insert(0, spec["meshkit"])
        import run_peers  # noqa: F401  (CASES, gmsh_geometry, dfun_py)
    import gmsh
    gmsh.initialize(["-noenv"], readConfigFiles=False)
    opt = gmsh.option.setNumber
    opt("General.Terminal", 0)
    opt("General.NumThreads", 1)
    for k in ("1D", "2D", "3D"):
        opt("Mesh.MaxNumThreads" + k, 1)
    if spec.get("probe"):
        opt("Geometry.OCCBoundsUseStl", 1)      # run_realstep's tight box
    gmsh.model.add("speed")
    t = time.perf_counter()
    if run_peers is not None:
        run_peers.gmsh_geometry(gmsh, spec["meshkit_case"])       # includes synchronize()
    else:
        gmsh.model.occ.importShapes(spec["step"])
        gmsh.model.occ.synchronize()
    import_s = time.perf_counter() - t
    if spec.get("probe"):
        x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(-1, -1)
        emit(probe_import_s=import_s, diag=math.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2 + (z1 - z0) ** 2),
             n_volumes=len(gmsh.model.getEntities(3)), n_faces=len(gmsh.model.getEntities(2)))
        gmsh.finalize()
        return
    for k in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
        opt("Mesh." + k, 0)
    size = spec["size"]
    if "const" in size:
        opt("Mesh.MeshSizeMin", size["const"])
        opt("Mesh.MeshSizeMax", size["const"])
    elif "field" in size:
        f = gmsh.model.mesh.field.add("MathEval")
        gmsh.model.mesh.field.setString(f, "F", size["field"])
        gmsh.model.mesh.field.setAsBackgroundMesh(f)
    else:
        d = run_peers.dfun_py(spec["meshkit_case"])
        gmsh.model.mesh.setSizeCallback(lambda dim, tag, x, y, z, lc: d(x, y, z))
    opt("Mesh.Algorithm", 6)
    opt("Mesh.Algorithm3D", 10)
    rss = None
    try:
        with open("/proc/self/status") as fh:
            for ln in fh:
                if ln.startswith("VmRSS:"):
                    rss = int(ln.split()[1]) / 1024.0
    except OSError:
        pass
    emit(import_s=import_s, rss_before_mesh_MB=rss, gmsh_version=gmsh.__version__)
    t = time.perf_counter()
    gmsh.model.mesh.generate(spec["dim"])
    emit(mesh_s=time.perf_counter() - t)
    opt("Mesh.Binary", 1)
    t = time.perf_counter()
    gmsh.write(spec["out"])
    emit(write_s=time.perf_counter() - t)
    gmsh.finalize()


# --------------------------------------------------------------------------- #
# processes
# --------------------------------------------------------------------------- #
TIME = "/usr/bin/time"      # GNU time: -f %M = the command's own peak resident size


def run_proc(cmd, timeout, mem_mb):
    """Run cmd in a fresh process (its own session) -> dict with rc, wall, cpu, peak RSS.

    The peak comes from GNU time's %M: the kernel carries the resident size of the
    process before execve() into its ru_maxrss, and this script, forked, is already
    some 70 MB (numpy, gmsh), so os.wait4 on a child of ours (or RUSAGE_CHILDREN)
    would report at least that; a child of the small `time` process reports its own.
    Without /usr/bin/time the wait4 value is kept, flagged as a bound from above.
    prlimit execs the command (same process).  A timer kills the process group at
    the timeout.  cpu = user + system seconds of the command (wait4 includes the
    children a process waited for).
    """
    if mem_mb and os.path.exists("/usr/bin/prlimit"):
        cmd = ["/usr/bin/prlimit", "--as=%d" % (mem_mb << 20), "--"] + list(cmd)
    use_time = os.access(TIME, os.X_OK)
    rss_file = None
    if use_time:
        fd, rss_file = tempfile.mkstemp(prefix="speed_rss_")
        os.close(fd)
        cmd = [TIME, "-q", "-f", "%M", "-o", rss_file] + list(cmd)
    killed = threading.Event()
    done = threading.Lock()
    with tempfile.TemporaryFile() as fo, tempfile.TemporaryFile() as fe:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=fo, stderr=fe, stdin=subprocess.DEVNULL,
                             start_new_session=True)

        def kill():
            with done:
                if p.returncode is None:
                    killed.set()
                    try:
                        os.killpg(p.pid, signal.SIGKILL)
                    except (ProcessLookupError, PermissionError):
                        pass

        timer = threading.Timer(timeout, kill)
        timer.daemon = True
        timer.start()
        try:
            _, status, ru = os.wait4(p.pid, 0)
        except BaseException:
            kill()
            os.wait4(p.pid, 0)
            raise
        finally:
            timer.cancel()
        wall = time.perf_counter() - t0
        with done:
            p.returncode = os.waitstatus_to_exitcode(status)
        fo.seek(0)
        fe.seek(0)
        out = fo.read().decode(errors="replace")
        err = fe.read().decode(errors="replace")
    rc, maxrss, exact = p.returncode, ru.ru_maxrss / 1024.0, False
    if use_time:
        if rc > 128:                      # time -q exits 128 + the signal that ended the command
            rc = 128 - rc
        try:
            with open(rss_file) as fh:
                maxrss, exact = int(fh.read().split()[-1]) / 1024.0, True
        except (OSError, ValueError, IndexError):
            maxrss = None                 # killed with time itself at the timeout
        os.remove(rss_file)
    return {"rc": rc, "wall": wall, "cpu": ru.ru_utime + ru.ru_stime, "maxrss_MB": maxrss,
            "maxrss_exact": exact, "stdout": out, "stderr": err, "timed_out": killed.is_set()}


def last_line(text):
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1][:300] if lines else ""


def why_failed(r, timeout):
    if r["timed_out"]:
        return "timeout", "timeout %g s" % timeout
    rc = r["rc"]
    if rc < 0:
        try:
            name = signal.Signals(-rc).name
        except ValueError:
            name = "signal %d" % -rc
        msg = last_line(r["stderr"])
        return "failed", "%s%s" % (name, (": " + msg) if msg else "")
    return "failed", "exit %d: %s" % (rc, last_line(r["stderr"]) or last_line(r["stdout"]) or "no output")


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def load_avg():
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


# --------------------------------------------------------------------------- #
# cases (imported from the other bench scripts)
# --------------------------------------------------------------------------- #
def gmsh_size_anchor(cd, case, callback):
    """Gmsh's size for a meshkit case: constant d, a MathEval field, or the callback."""
    if cd.get("uniform"):
        return {"const": cd["uniform"]}, "uniform cases: MeshSizeMin = MeshSizeMax = d"
    expr = cd.get("dgmsh") or cd["dpy"]
    if callback or "**" in expr or "hypot" in expr:
        return {"callback": case}, "graded cases: meshkit's setSizeCallback (Python)"
    return {"field": expr}, "graded cases: d as a MathEval background field"


def cases_anchor(group, rp, a):
    sys.path.insert(0, HERE)
    import run_2d as r2
    mod = r2
    if group == "3d":
        import run_3d as r3
        mod = r3
    out = []
    for c in mod.ALL_CASES:
        cd = rp.CASES[c]
        dim = 3 if group == "3d" else 2
        size, gdesc = gmsh_size_anchor(cd, c, a.gmsh_callback)
        out.append({
            "group": group, "name": c, "aliases": [c], "title": cd["title"],
            "input": os.path.join(REPO, mod.DOMAIN[cd["geom"]]),
            "bm_args": ["--size", mod.SIZE[c]] + (["--dim", "3"] if dim == 3 else []),
            "d": mod.SIZE[c], "spacing": cd["d"], "dim": dim,
            "ref_area": cd.get("ref_area"), "ref_volume": cd.get("ref_volume"),
            "gmsh": {"meshkit_case": c, "meshkit": a.meshkit, "dim": dim, "size": size},
            "gmsh_size": gdesc, "translation_check": mod.check_translations})
    return out


def cases_step(group, a):
    sys.path.insert(0, HERE)
    import run_step
    import run_step_3d  # noqa: F401  (its selection: parts with a solid, mesh_size, --dim 3)
    with open(os.path.join(run_step.ROOT, "fixtures", "manifest.json")) as f:
        man = json.load(f)
    dim = 3 if group == "step3d" else 2
    out = []
    for part in man["parts"]:
        if dim == 3 and part.get("solids", 0) == 0:      # as run_step_3d.main
            continue
        size = part["mesh_size"]
        out.append({
            "group": group, "name": part["name"], "aliases": [part["name"]],
            "title": part.get("description", "")[:120],
            "input": os.path.join(run_step.ROOT, "fixtures", part["file"]),
            "bm_args": ["--size", str(size), "--dim", str(dim)],
            "d": str(size), "spacing": str(size), "dim": dim,
            "ref_area": part.get("area") if dim == 2 else None,
            "ref_volume": part.get("volume") if dim == 3 else None,
            "gmsh": {"step": os.path.join(run_step.ROOT, "fixtures", part["file"]), "dim": dim,
                     "size": {"const": size}},
            "gmsh_size": "MeshSizeMin = MeshSizeMax = d"})
    return out


def cases_realstep(a):
    sys.path.insert(0, HERE)
    import run_realstep as rr
    files = sorted(f for f in os.listdir(rr.REALSTEP) if f.lower().endswith((".stp", ".step")))
    out = []
    for mode in ("surf", "tet"):
        for f in files:
            stem = os.path.splitext(f)[0]
            step = os.path.join(rr.REALSTEP, f)
            out.append({
                "group": "realstep", "name": "%s:%s" % (mode, stem), "aliases": ["%s:%s" % (mode, stem), stem, f],
                "title": f, "input": step, "divisor": rr.DIVISOR[mode], "dim": rr.DIM[mode],
                "ref_area": None, "ref_volume": None,
                "gmsh": {"step": step, "dim": rr.DIM[mode]},
                "gmsh_size": "MeshSizeMin = MeshSizeMax = d"})
    return out


def select(cases, patterns):
    if not patterns:
        return cases, []
    pats = [p.lower() for p in patterns]
    used = set()
    out = []
    for c in cases:
        hit = [p for p in pats if any(fnmatch.fnmatchcase(al.lower(), p) for al in c["aliases"])]
        used.update(hit)
        if hit:
            out.append(c)
    return out, [p for p in patterns if p.lower() not in used]


# --------------------------------------------------------------------------- #
# measuring one case
# --------------------------------------------------------------------------- #
def meshcheck(a, path, case):
    cmd = [sys.executable, os.path.join(a.meshkit, "meshcheck.py"), path, "--spacing", case["spacing"],
           "--dim", str(case["dim"])]
    if case.get("ref_area"):
        cmd += ["--ref-area", repr(case["ref_area"])]
    if case.get("ref_volume"):
        cmd += ["--ref-volume", repr(case["ref_volume"])]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=max(a.timeout, 300))
    except subprocess.TimeoutExpired:
        return {"error": "meshcheck exceeded %g s" % max(a.timeout, 300)}
    try:
        rep = json.loads(p.stdout)
    except ValueError:
        return {"error": "meshcheck failed (rc %d): %s" % (p.returncode, last_line(p.stderr or p.stdout))}
    rep["command"] = " ".join(cmd[1:])
    return rep


def gmsh_cmd(spec):
    return [sys.executable, os.path.abspath(__file__), "--gmsh-worker", json.dumps(spec)]


def parse_worker(stdout):
    info = {}
    for ln in stdout.splitlines():
        if ln.startswith("{"):
            try:
                info = json.loads(ln)
            except ValueError:
                pass
    return info


def probe_realstep(case, a):
    """d = diag / divisor, diag from Gmsh's OCC import with OCCBoundsUseStl (untimed)."""
    spec = dict(case["gmsh"], probe=True)
    r = run_proc(gmsh_cmd(spec), a.timeout, a.mem_mb)
    info = parse_worker(r["stdout"])
    if r["rc"] != 0 or "diag" not in info:
        return None, why_failed(r, a.timeout)[1] if r["rc"] != 0 else "no bounding box"
    return info, None


def new_side():
    return {"status": "ok", "runs": []}


def side_failed(side, status, error, run):
    side.update(status=status, error=error)
    side["runs"].append(run)


def run_gmsh_once(case, a, out, side):
    if os.path.exists(out):
        os.remove(out)
    spec = dict(case["gmsh"], out=out)
    r = run_proc(gmsh_cmd(spec), a.timeout, a.mem_mb)
    info = parse_worker(r["stdout"])
    run = {"process_wall_s": r["wall"], "cpu_s": r["cpu"], "maxrss_MB": r["maxrss_MB"],
           "maxrss_exact": r["maxrss_exact"], **info}
    if r["rc"] != 0 or "write_s" not in info or not os.path.exists(out):
        st, err = why_failed(r, a.timeout) if r["rc"] != 0 or r["timed_out"] else \
            ("failed", "worker ended without writing a mesh: " + last_line(r["stderr"]))
        phase = "import" if "import_s" not in info else ("mesh" if "mesh_s" not in info else "write")
        side_failed(side, st, "%s (during %s)" % (err, phase), run)
        return False
    run["total_s"] = info["import_s"] + info["mesh_s"] + info["write_s"]
    side["runs"].append(run)
    return True


def run_bm_once(binary, case, a, out, threads1, side):
    if os.path.exists(out):
        os.remove(out)
    cmd = [binary, "mesh", case["input"], "-o", out] + case["bm_args"] + ["--quiet"]
    if threads1:
        cmd += ["--threads", "1"]
    r = run_proc(cmd, a.timeout, a.mem_mb)
    run = {"wall_s": r["wall"], "cpu_s": r["cpu"], "maxrss_MB": r["maxrss_MB"],
           "maxrss_exact": r["maxrss_exact"]}
    warns = [ln for ln in r["stderr"].splitlines() if "warning" in ln.lower()]
    if warns:
        run["warnings"] = warns[:5]
    if r["rc"] != 0 or r["timed_out"] or not os.path.exists(out):
        st, err = why_failed(r, a.timeout) if r["rc"] != 0 or r["timed_out"] else \
            ("failed", "exit 0 without an output file")
        side_failed(side, st, err, run)
        return False
    side["runs"].append(run)
    side["command"] = " ".join(os.path.relpath(x, REPO) if x.startswith(REPO + os.sep) else x for x in cmd)
    return True


def finish_side(side, keys):
    ok = [r for r in side["runs"] if "error" not in r and all(k in r for k in keys)]
    for k in keys:
        if ok:
            side[k] = statistics.median(r[k] for r in ok)
    peaks = [r["maxrss_MB"] for r in side["runs"] if r.get("maxrss_MB") is not None]
    if peaks:
        side["maxrss_MB"] = max(peaks)
        side["maxrss_exact"] = all(r.get("maxrss_exact") for r in side["runs"])
    side["reps"] = len(ok)


def run_case(case, binary, a, meshdir):
    rec = {"group": case["group"], "name": case["name"], "title": case["title"], "run": a.run_date,
           "date": time.strftime("%Y-%m-%d %H:%M:%S %z"), "loadavg_start": load_avg(),
           "gmsh_size": case["gmsh_size"], "dim": case["dim"]}
    stem = case["name"].replace(":", "__").replace("/", "_")
    g_out = os.path.join(meshdir, stem + "__gmsh.msh")
    b_out = os.path.join(meshdir, stem + "__bm.msh")
    ball_out = os.path.join(meshdir, stem + "__bm_all.msh")
    gm, b1, ball = new_side(), new_side(), new_side()
    rec.update(gmsh=gm, bm1=b1, bm_all=ball)
    if case["group"] == "realstep":
        info, err = probe_realstep(case, a)
        if info is None:
            gm.update(status="failed", error="Gmsh's import (probe) failed: " + err)
            b1.update(status="not run", error="no d: Gmsh could not read the file for its bounding box")
            ball.update(status="not run", error=b1["error"])
            rec["loadavg_end"] = load_avg()
            return rec
        d = info["diag"] / case["divisor"]            # as run_realstep: unrounded, repr() to bubblemesh
        rec["probe"] = info
        # Gmsh's OpenCascade import converts every file to millimetres
        bm_args = ["--size", repr(d), "--dim", str(case["dim"]), "--unit", "mm"]
        case = dict(case, d=repr(d), spacing=repr(d), bm_args=bm_args)
        case["gmsh"] = dict(case["gmsh"], size={"const": d})
    rec["d"], rec["spacing"] = case["d"], case["spacing"]
    if a.skip_all_cores:
        ball.update(status="skipped")
    for _ in range(a.reps):
        if gm["status"] == "ok":
            run_gmsh_once(case, a, g_out, gm)
        if b1["status"] == "ok":
            run_bm_once(binary, case, a, b_out, True, b1)
        if ball["status"] == "ok":
            run_bm_once(binary, case, a, ball_out, False, ball)
    finish_side(gm, ["import_s", "mesh_s", "write_s", "total_s", "process_wall_s"])
    finish_side(b1, ["wall_s", "cpu_s"])
    finish_side(ball, ["wall_s", "cpu_s"])
    if gm["status"] == "ok":
        gm["check"] = meshcheck(a, g_out, case)
        gm["mesh_file"] = os.path.relpath(g_out, REPO)
    if b1["status"] == "ok":
        b1["check"] = meshcheck(a, b_out, case)
        b1["mesh_file"] = os.path.relpath(b_out, REPO)
    if ball["status"] == "ok":
        if b1["status"] == "ok" and os.path.exists(b_out):
            ball["same_mesh_as_1_thread"] = sha256(ball_out) == sha256(b_out)
        os.remove(ball_out)                  # its quality is the 1-thread mesh's when identical
    if b1["status"] == "ok" and ball["status"] == "ok":
        rec["speedup"] = b1["wall_s"] / ball["wall_s"]
    if b1["status"] == "ok" and gm["status"] == "ok" and not no_elements(b1) and not no_elements(gm):
        rec["ratio"] = b1["wall_s"] / gm["total_s"]
        qb, qg = quality(b1, case["dim"]), quality(gm, case["dim"])
        if qb and qg and qb["n"] and qg["n"]:
            # the same ratio per element: the meshers do not make the same number of elements
            rec["ratio_per_element"] = rec["ratio"] * qg["n"] / qb["n"]
    rec["loadavg_end"] = load_avg()
    return rec


# --------------------------------------------------------------------------- #
# report
# --------------------------------------------------------------------------- #
def f(v, nd=3):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "–"
    return ("%." + str(nd) + "f") % v if isinstance(v, float) else str(v)


def fs(v):
    """seconds with about three significant digits"""
    if v is None:
        return "–"
    return "%.3f" % v if v < 10 else ("%.2f" % v if v < 100 else "%.1f" % v)


def no_elements(side):
    """meshcheck found no element of the case's dimension (e.g. Gmsh's --dim 3 of a shell)."""
    err = (side.get("check") or {}).get("error") or ""
    return err in ("no tetra cells", "no triangle cells")


def quality(side, dim):
    ck = side.get("check") or {}
    el = ck.get("tets" if dim == 3 else "triangles")
    if side.get("status") != "ok" or "error" in ck or not el:
        return None
    return {"n": el.get("count"), "q_mean": el.get("q_mean"), "q_min": el.get("q_min"),
            "angle": el.get("dihedral_min" if dim == 3 else "min_angle_min"),
            "band": ck.get("spacing", {}).get("frac_within_sqrt2"),
            "valid": bool(ck.get("validity", {}).get("valid"))}


DEFECT_KEYS = ("edges_shared_by_gt2", "n_inconsistent_orientation_edges", "n_zero_area", "n_zero_volume",
               "n_inverted", "n_folded_faces", "unreferenced_nodes", "duplicate_node_pairs",
               "boundary_vertices_not_deg2")


def validity(side, dim):
    st = side.get("status")
    if st in ("skipped",):
        return "–"
    if st != "ok":
        return "**%s**" % ("TIMEOUT" if st == "timeout" else "FAIL" if st == "failed" else st)
    ck = side.get("check") or {}
    if "error" in ck:
        return ("**no tetrahedra**" if dim == 3 else "**no triangles**") if no_elements(side) else "**unchecked**"
    if not ck.get("tets" if dim == 3 else "triangles"):
        return "**no %s**" % ("tetrahedra" if dim == 3 else "triangles")
    v = ck.get("validity", {})
    if v.get("valid"):
        return "valid"
    bad = [k for k in ("conforming", "watertight", "boundary_closed") if v.get(k) is False]
    bad += ["%s=%s" % (k, v[k]) for k in DEFECT_KEYS if v.get(k)]
    return "**INVALID** (%s)" % ", ".join(bad or ["meshcheck"])


def time_cell(side, key):
    st = side.get("status")
    if st == "skipped":
        return "–"
    if st != "ok":
        return "**%s**" % ("TIMEOUT" if st == "timeout" else "FAIL" if st == "failed" else st)
    return fs(side.get(key))


def peak(side):
    if side.get("maxrss_MB") is None:
        return "–"
    return ("" if side.get("maxrss_exact") else "≥") + "%.0f" % side["maxrss_MB"]


def qcell(q, dim):
    if q is None:
        return "–"
    return "%s / %s / %s° / %s" % (f(q["q_mean"]), f(q["q_min"]), f(q["angle"], 1), f(q["band"]))


def group_rows(recs):
    L = ["| case | d | bm 1 thread s | bm all cores s | speed-up | gmsh mesh s | gmsh import+mesh+write s | "
         "ratio bm/gmsh | elements bm / gmsh | bm q mean / min / angle / L/d band | "
         "gmsh q mean / min / angle / L/d band | peak MB bm / gmsh | valid bm / gmsh |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    notes = []
    for r in recs:
        dim = r["dim"]
        b1, ba, gm = r["bm1"], r["bm_all"], r["gmsh"]
        qb, qg = quality(b1, dim), quality(gm, dim)
        d = r.get("d") or "–"
        try:
            d = "%.4g" % float(d)
        except ValueError:
            pass
        if len(d) > 12:
            notes.append("%s: d = `%s`" % (r["name"], d))
            d = "graded"
        sp = f(r.get("speedup"), 2)
        if ba.get("same_mesh_as_1_thread") is False:
            sp += " (mesh differs!)"
        L.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s / %s | %s | %s | %s / %s | %s / %s |" % (
            r["name"], d, time_cell(b1, "wall_s"), time_cell(ba, "wall_s"), sp,
            time_cell(gm, "mesh_s"), time_cell(gm, "total_s"),
            ("**%.2f**" % r["ratio"] if r["ratio"] < 1 else "%.2f" % r["ratio"]) if r.get("ratio") else "–",
            (qb or {}).get("n", "–"), (qg or {}).get("n", "–"), qcell(qb, dim), qcell(qg, dim),
            peak(b1), peak(gm), validity(b1, dim), validity(gm, dim)))
        for who, s in (("bubblemesh 1 thread", b1), ("bubblemesh all cores", ba), ("Gmsh", gm)):
            if s.get("error"):
                notes.append("%s: %s: %s" % (r["name"], who, s["error"].replace("|", "/")[:300]))
            ck = s.get("check") or {}
            if "error" in ck:
                notes.append("%s: %s: meshcheck: %s" % (r["name"], who, ck["error"][:300]))
    return L, notes


def summary(group, recs):
    both = [r for r in recs if r.get("ratio") is not None]
    valid = [r for r in both if (quality(r["bm1"], r["dim"]) or {}).get("valid")
             and (quality(r["gmsh"], r["dim"]) or {}).get("valid")]

    def med_worst(rs):
        if not rs:
            return "–"
        w = max(rs, key=lambda r: r["ratio"])
        return "median **%.2f**, worst %.2f (%s); bubblemesh faster on %d of %d" % (
            statistics.median(r["ratio"] for r in rs), w["ratio"], w["name"],
            sum(1 for r in rs if r["ratio"] < 1), len(rs))

    fail_b = sum(1 for r in recs if r["bm1"].get("status") != "ok")
    fail_g = sum(1 for r in recs if r["gmsh"].get("status") != "ok")
    inv_b = sum(1 for r in recs if quality(r["bm1"], r["dim"]) and not quality(r["bm1"], r["dim"])["valid"])
    inv_g = sum(1 for r in recs if quality(r["gmsh"], r["dim"]) and not quality(r["gmsh"], r["dim"])["valid"])
    nochk_b = sum(1 for r in recs if r["bm1"].get("status") == "ok" and not quality(r["bm1"], r["dim"]))
    nochk_g = sum(1 for r in recs if r["gmsh"].get("status") == "ok" and not quality(r["gmsh"], r["dim"]))
    sps = [r["speedup"] for r in recs if r.get("speedup")]
    diff = sum(1 for r in recs if r["bm_all"].get("same_mesh_as_1_thread") is False)
    s = ("**%s** (%d cases): ratio bm 1 thread / gmsh import+mesh+write over the %d where both meshed: %s; "
         "over the %d where both meshes are valid: %s. Failed: bubblemesh %d, Gmsh %d; invalid meshes: "
         "bubblemesh %d, Gmsh %d." % (group, len(recs), len(both), med_worst(both), len(valid), med_worst(valid),
                                      fail_b, fail_g, inv_b, inv_g))
    if nochk_b or nochk_g:
        s += (" Exit 0 without a checkable mesh (no elements of the dimension, or meshcheck failed): "
              "bubblemesh %d, Gmsh %d." % (nochk_b, nochk_g))
    pe = [r["ratio_per_element"] for r in both if r.get("ratio_per_element")]
    if pe:
        s += " Ratio per element (bm s/element over gmsh s/element): median %.2f." % statistics.median(pe)
    if sps:
        s += " All-cores speed-up: median %.2f." % statistics.median(sps)
    if diff:
        s += " **%d all-cores meshes differ from the 1-thread mesh.**" % diff
    return s


def build_report(res, order):
    meta = res["meta"]
    recs = res["cases"]
    dates = sorted({r.get("run", r["date"]) for r in recs.values()})
    bins = sorted({r.get("binary_sha256", "")[:12] for r in recs.values()} - {""})
    L = ["# bubblemesh on one thread against Gmsh on one thread (issue 24)", "",
         "Made by `python3 bench/speed.py` (see its docstring). Last run %s on %s; load average at its "
         "start %s (timings are only meaningful on an otherwise idle machine; each case's load is in "
         "results.json). Versions: %s. bubblemesh `%s` (sha256 %s, built %s), repository %s%s." % (
             meta["date"], meta["machine"], meta.get("loadavg_start"),
             ", ".join("%s %s" % kv for kv in sorted(meta["versions"].items())), meta["binary"],
             meta["binary_sha256"][:12], meta["binary_mtime"], meta["git"]["commit"][:12],
             " + %d modified tracked files" % meta["git"]["dirty_files"] if meta["git"]["dirty_files"] else ""),
         ""]
    if len(dates) > 1:
        L += ["Rows from the runs started %s (a run replaces the rows of the cases it ran)." % ", ".join(dates), ""]
    if len(bins) > 1:
        L += ["**Rows measured with %d different bubblemesh binaries (%s).**" % (len(bins), ", ".join(bins)), ""]
    L += ["Columns: *bm 1 thread* = wall seconds of the whole `bubblemesh mesh ... --threads 1` process "
          "(read, mesh, write .msh); *bm all cores* = the same with every core (%d here), *speed-up* = their "
          "ratio; *gmsh mesh* = `generate(dim)` alone; *gmsh import+mesh+write* = OpenCascade import (or "
          "meshkit's geometry) + generate + `write` (binary .msh), measured inside Gmsh's worker, one thread, "
          "Frontal-Delaunay / HXT; *ratio* = bm 1 thread / gmsh import+mesh+write (bold: bubblemesh "
          "faster). Medians of `--reps` runs (%s in the last run; each row's count is in results.json). "
          "Quality from meshcheck.py: radius ratio mean / min, smallest angle (surfaces) or dihedral angle "
          "(tetrahedra), share of edges with L/d in [1/√2, √2]. *peak MB* = largest resident size of the "
          "process (Gmsh: the Python worker with libgmsh). The meshers do not make the same number of "
          "elements (Gmsh's tetrahedra are larger than d: L/d about 1.36 in meshkit); the summary lines give "
          "the ratio per element too." % (
              os.cpu_count() or 0, meta.get("reps")), ""]
    sums = []
    for g in GROUPS:
        if g not in order:
            continue
        grp = [recs[k] for k in sorted(recs, key=lambda k: order[g].get(k, 1 << 30))
               if recs[k]["group"] == g]
        if not grp:
            continue
        L += ["## %s — %s" % (g, GROUP_TITLE[g]), ""]
        sizes = sorted({r["gmsh_size"] for r in grp})
        L += ["Gmsh's size: %s." % "; ".join(sizes), ""]
        rows, notes = group_rows(grp)
        L += rows + [""]
        if notes:
            L += ["- " + n for n in notes] + [""]
        s = summary(g, grp)
        L += [s, ""]
        sums.append(s)
    L += ["## Summary", ""] + ["- " + s for s in sums] + [""]
    return "\n".join(L)


# --------------------------------------------------------------------------- #
def git_info():
    def g(*args):
        try:
            return subprocess.run(["git", "-C", REPO] + list(args), capture_output=True, text=True,
                                  timeout=30).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""
    return {"commit": g("rev-parse", "HEAD"),
            "dirty_files": len([ln for ln in g("status", "--porcelain", "--untracked-files=no").splitlines()
                                if ln.strip()])}


def versions():
    v = {"python": sys.version.split()[0]}
    for mod in ("gmsh", "meshio", "numpy"):
        try:
            v[mod] = __import__(mod).__version__
        except Exception:  # noqa: BLE001
            pass
    return v


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--groups", default=",".join(GROUPS), help="comma list out of " + ",".join(GROUPS))
    ap.add_argument("--cases", default="", help="comma list of case names or shell patterns")
    ap.add_argument("--reps", type=int, default=1, help="runs per mesher, median reported (default 1)")
    ap.add_argument("--timeout", type=float, default=600, help="per process, seconds (default 600)")
    ap.add_argument("--out", default=os.path.join(HERE, "out", "speed"), help="default bench/out/speed")
    ap.add_argument("--skip-all-cores", action="store_true", help="no all-cores bubblemesh run")
    ap.add_argument("--gmsh-callback", action="store_true",
                    help="graded anchor cases: Gmsh's size from meshkit's Python callback, not a MathEval field")
    ap.add_argument("--bin", default=os.environ.get("BUBBLEMESH_BIN"),
                    help="bubblemesh binary (default $BUBBLEMESH_BIN, else target/release/bubblemesh)")
    ap.add_argument("--meshkit", default=os.path.normpath(os.path.join(REPO, "..", "shared", "meshkit")))
    ap.add_argument("--mem-mb", type=int, default=8000, help="address-space limit per process (0: none)")
    ap.add_argument("--fresh", action="store_true", help="forget the earlier results in OUT/results.json")
    ap.add_argument("--gmsh-worker", metavar="SPEC", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.gmsh_worker:
        gmsh_worker(json.loads(a.gmsh_worker))
        return 0

    groups = [g.strip() for g in a.groups.split(",") if g.strip()]
    bad = [g for g in groups if g not in GROUPS]
    if bad or not groups:
        ap.error("--groups: out of %s (got %s)" % (",".join(GROUPS), a.groups))
    if a.reps < 1:
        ap.error("--reps must be >= 1")
    a.meshkit = os.path.abspath(a.meshkit)
    if not os.path.isfile(os.path.join(a.meshkit, "meshcheck.py")):
        log("error: no meshcheck.py in %s (--meshkit DIR)" % a.meshkit)
        return 2
    binary = os.path.abspath(a.bin or os.path.join(REPO, "target", "release", "bubblemesh"))
    if not os.access(binary, os.X_OK):
        log("error: %s is not an executable (cargo build --release -p bubblemesh-cli, or --bin)" % binary)
        return 2
    try:
        import gmsh  # noqa: F401
    except ImportError:
        log("error: the gmsh Python module is missing (pip install -r bench/requirements.txt)")
        return 2

    sys.path.insert(0, HERE)
    import run_2d as r2
    rp = r2.import_meshkit(a.meshkit) if ("2d" in groups or "3d" in groups) else None
    patterns = [p.strip() for p in a.cases.split(",") if p.strip()]
    todo, order, unused = [], {}, set(patterns)
    for g in GROUPS:
        if g not in groups:
            continue
        cs = cases_anchor(g, rp, a) if g in ("2d", "3d") else cases_step(g, a) if g in ("step", "step3d") \
            else cases_realstep(a)
        order[g] = {"%s/%s" % (g, c["name"]): i for i, c in enumerate(cs)}
        sel, left = select(cs, patterns)
        unused &= set(left)
        todo += sel
    if unused:
        log("warning: --cases %s matched no case of the groups %s" % (",".join(sorted(unused)), ",".join(groups)))
    if not todo:
        log("error: no case selected")
        return 2
    for g in ("2d", "3d"):
        cs = [c["name"] for c in todo if c["group"] == g]
        if cs:
            next(c for c in todo if c["group"] == g)["translation_check"](rp, cs)

    os.makedirs(a.out, exist_ok=True)
    res_path = os.path.join(a.out, "results.json")
    old = {}
    if not a.fresh and os.path.exists(res_path):
        try:
            with open(res_path) as fh:
                old = json.load(fh).get("cases", {})
        except (OSError, ValueError):
            old = {}
    bin_sha, bin_mtime = sha256(binary), os.path.getmtime(binary)
    try:
        bver = subprocess.run([binary, "--version"], capture_output=True, text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        bver = "?"
    a.run_date = time.strftime("%Y-%m-%d %H:%M:%S %z")
    meta = {"date": a.run_date,
            "machine": "%s, %d cores, %s" % (platform.machine(), os.cpu_count() or 0, platform.platform()),
            "versions": versions(), "binary": os.path.relpath(binary, REPO) if binary.startswith(REPO) else binary,
            "binary_version": bver, "binary_sha256": bin_sha,
            "binary_mtime": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(bin_mtime)),
            "git": git_info(), "argv": sys.argv[1:], "reps": a.reps, "timeout_s": a.timeout,
            "mem_mb": a.mem_mb, "loadavg_start": load_avg(), "meshkit": a.meshkit}
    res = {"meta": meta, "cases": old}
    log("%d cases; bubblemesh %s (%s); load %s" % (len(todo), binary, bver, meta["loadavg_start"]))
    for case in todo:
        mtime = os.path.getmtime(binary)
        if mtime != bin_mtime:
            log("note: %s was rebuilt during the run" % binary)
            bin_sha, bin_mtime = sha256(binary), mtime
        meshdir = os.path.join(a.out, "meshes", case["group"])
        os.makedirs(meshdir, exist_ok=True)
        rec = run_case(case, binary, a, meshdir)
        rec["binary_sha256"] = bin_sha
        res["cases"]["%s/%s" % (case["group"], case["name"])] = rec
        q1, qg = quality(rec["bm1"], rec["dim"]), quality(rec["gmsh"], rec["dim"])
        log("%-8s %-40s bm %s (all %s)  gmsh %s/%s  ratio %s  q %s / %s  valid %s / %s" % (
            case["group"], case["name"][:40], time_cell(rec["bm1"], "wall_s"), time_cell(rec["bm_all"], "wall_s"),
            time_cell(rec["gmsh"], "mesh_s"), time_cell(rec["gmsh"], "total_s"), f(rec.get("ratio"), 2),
            f((q1 or {}).get("q_mean")), f((qg or {}).get("q_mean")),
            validity(rec["bm1"], rec["dim"]), validity(rec["gmsh"], rec["dim"])))
        for who, s in (("bm", rec["bm1"]), ("bm all", rec["bm_all"]), ("gmsh", rec["gmsh"])):
            if s.get("error"):
                log("         %s: %s" % (who, s["error"][:200]))
        res["meta"]["loadavg_end"] = load_avg()
        tmp = res_path + ".tmp"
        with open(tmp, "w") as fh:
            json.dump(res, fh, indent=1, sort_keys=True)
        os.replace(tmp, res_path)
    # the order of the rows: every group's own order, also for cases of earlier runs
    for g in GROUPS:
        if g not in order:
            cs = cases_anchor(g, rp or r2.import_meshkit(a.meshkit), a) if g in ("2d", "3d") else \
                cases_step(g, a) if g in ("step", "step3d") else cases_realstep(a)
            order[g] = {"%s/%s" % (g, c["name"]): i for i, c in enumerate(cs)}
    text = build_report(res, order)
    with open(os.path.join(a.out, "RESULTS_speed.md"), "w") as fh:
        fh.write(text)
    print(text)
    log("wrote %s and %s" % (res_path, os.path.join(a.out, "RESULTS_speed.md")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
