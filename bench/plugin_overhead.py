#!/usr/bin/env python3
"""Overhead of a spacing plugin against the same spacing built in.

    python3 bench/plugin_overhead.py [--eps 1.1e-4] [--reps 3] [--input examples/torus.toml]

Meshes the torus (examples/torus.toml) with curvature-based spacing twice
per repetition, alternating: `--curvature EPS` (built in) and
`--plugin libbubblemesh_plugin_curvature.so --plugin-arg eps=EPS` (the
same formula through the plugin ABI, with the host computing the local
geometry). Both must give the same mesh (same node count: the same
spacing). Prints the node count, the engine's time (`timings.total_s` of
--report), the whole process's wall time and its CPU time (user + system)
per run, their medians and the plugin's overhead in per cent. The verdict
(exit status 0 when the overhead is at most 10 %) uses the CPU time, which
does not count time spent waiting for a core on a shared machine. The default EPS gives about 100 k nodes.

Not a test (timings depend on the machine's load): run it by hand.
Builds with `cargo build --release -p bubblemesh-cli -p
bubblemesh-plugin-curvature` into $CARGO_TARGET_DIR (default target/).
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(cmd):
    """Runs `cmd`; returns (wall s, CPU s = user + system of the child).

    CPU time is the fairer measure on a shared machine: it does not count
    the time the process waited for a core.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--eps", type=float, default=1.1e-4)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--input", default=os.path.join(ROOT, "examples/torus.toml"))
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--bin", help="bubblemesh binary (default: $CARGO_TARGET_DIR/release/bubblemesh)")
    ap.add_argument("--lib", help="the curvature plugin (default: next to the release binary)")
    a = ap.parse_args()
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    if not (a.no_build or (a.bin and a.lib)):
        subprocess.run(["cargo", "build", "--release", "-q", "-p", "bubblemesh-cli",
                        "-p", "bubblemesh-plugin-curvature"], cwd=ROOT, check=True)
    bin_ = a.bin or os.path.join(target, "release/bubblemesh")
    lib = a.lib or os.path.join(target, "release/libbubblemesh_plugin_curvature.so")
    res = {"built-in": [], "plugin": []}
    with tempfile.TemporaryDirectory() as d:
        for rep in range(a.reps):
            for kind in ("built-in", "plugin"):
                rep_json = os.path.join(d, f"{kind}.json")
                cmd = [bin_, "mesh", a.input, "-o", os.path.join(d, "out.msh"), "-q",
                       "--report", rep_json, "--threads", "1"]
                if kind == "built-in":
                    cmd += ["--curvature", str(a.eps)]
                else:
                    cmd += ["--plugin", lib, "--plugin-arg", f"eps={a.eps}"]
                wall, cpu = run(cmd)
                r = json.load(open(rep_json))
                nodes = r["engine"]["nodes"]
                eng = r["engine"]["timings"]["total_s"]
                res[kind].append((nodes, eng, wall, cpu))
                print(f"rep {rep} {kind:>8}: {nodes} nodes, engine {eng:.2f} s, process {wall:.2f} s,"
                      f" process CPU {cpu:.2f} s", flush=True)
    med = {k: tuple(statistics.median(x[i] for x in v) for i in (1, 2, 3))
           for k, v in res.items()}
    nb = {x[0] for x in res["built-in"]}
    npg = {x[0] for x in res["plugin"]}
    print(f"\nnodes: built-in {sorted(nb)}, plugin {sorted(npg)}"
          f" ({'same mesh size' if nb == npg else 'DIFFERENT'})")
    for i, what in enumerate(["engine (wall)", "process wall", "process CPU"]):
        b, p = med["built-in"][i], med["plugin"][i]
        print(f"median {what} time: built-in {b:.2f} s, plugin {p:.2f} s, overhead {100 * (p / b - 1):+.1f} %")
    # the verdict uses CPU time: robust to other load on the machine
    over = med["plugin"][2] / med["built-in"][2] - 1
    return 0 if over <= 0.10 and nb == npg else 1


if __name__ == "__main__":
    sys.exit(main())
