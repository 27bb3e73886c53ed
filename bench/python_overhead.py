#!/usr/bin/env python3
"""The Python package's time against the command line's on one case of
about 100,000 elements (not run by CI).

Each repetition runs, in turn:
  cli     `bubblemesh mesh CASE -o out.msh --size S --dim 3 --quiet`, wall
          time of the process (reading, meshing, quality, writing);
  python  a fresh interpreter timing `bubblemesh.mesh(CASE, size=S,
          dim=3, progress=False)`, `m.quality()` and `m.write("out.msh")`
          (the same work; the interpreter's start and the import are not
          counted, they are printed apart).
Wall and CPU time (user + system; the CLI's includes its process start) are
both reported: on a shared machine CPU time is the steadier. Both write the
same mesh; the script checks the two files are identical.
The ratio is of the medians (and of the minima) of the repetitions.

    python3 bench/python_overhead.py --cli target/release/bubblemesh \\
        --python /path/to/venv/bin/python [--case fixtures/step/block_holes.step --size 1.0] [--reps 3]
"""
import argparse
import hashlib
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

PY_RUN = r"""
import json, resource, sys, time
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
t0 = time.perf_counter()
import bubblemesh
t_import = time.perf_counter() - t0
case, size, out, threads = sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4]
t0 = time.perf_counter()
c0 = cpu()
m = bubblemesh.mesh(case, size=size, dim=3, progress=False,
                    threads=None if threads == "all" else int(threads))
m.quality()
m.write(out)
t = time.perf_counter() - t0
c = cpu() - c0
print(json.dumps({"time": t, "cpu": c, "import": t_import, "tets": len(m.tetrahedra),
                  "triangles": len(m.triangles), "nodes": len(m.points)}))
"""


def sha(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", default=os.path.join(ROOT, "target", "release", "bubblemesh"))
    ap.add_argument("--python", default=sys.executable, help="an interpreter with bubblemesh installed")
    ap.add_argument("--case", default=os.path.join(ROOT, "fixtures", "step", "block_holes.step"))
    ap.add_argument("--size", type=float, default=1.0)
    ap.add_argument("--threads", default="all", help="'all' (the default of both) or N")
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args()
    cli, py, cli_cpu, py_cpu = [], [], [], []
    info = None
    with tempfile.TemporaryDirectory() as tmp:
        out_cli = os.path.join(tmp, "cli.msh")
        out_py = os.path.join(tmp, "py.msh")
        for rep in range(a.reps):
            cmd = [a.cli, "mesh", a.case, "-o", out_cli, "--size", str(a.size), "--dim", "3", "--quiet"]
            if a.threads != "all":
                cmd += ["--threads", a.threads]
            r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True)
            cli.append(time.perf_counter() - t0)
            r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cli_cpu.append(r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime)
            r = subprocess.run(
                [a.python, "-c", PY_RUN, a.case, str(a.size), out_py, a.threads],
                check=True, capture_output=True, text=True,
            )
            info = json.loads(r.stdout.strip().splitlines()[-1])
            py.append(info["time"])
            py_cpu.append(info["cpu"])
            print(f"rep {rep + 1}: wall cli {cli[-1]:.3f} s, python {py[-1]:.3f} s "
                  f"(import {info['import']:.3f} s); cpu cli {cli_cpu[-1]:.3f} s, "
                  f"python {py_cpu[-1]:.3f} s", flush=True)
        same = sha(out_cli) == sha(out_py)
    print(f"case {os.path.relpath(a.case, ROOT)} --size {a.size} --dim 3: "
          f"{info['tets']} tetrahedra, {info['triangles']} triangles, {info['nodes']} nodes")
    print(f"meshes identical: {same}")
    med = statistics.median(py) / statistics.median(cli)
    best = min(py) / min(cli)
    print(f"cli median {statistics.median(cli):.3f} s, python median {statistics.median(py):.3f} s")
    print(f"wall ratio python/cli: median {med:.3f}, best {best:.3f} (target <= 1.05)")
    cmed = statistics.median(py_cpu) / statistics.median(cli_cpu)
    cbest = min(py_cpu) / min(cli_cpu)
    print(f"cpu ratio python/cli: median {cmed:.3f}, best {cbest:.3f} "
          "(cpu time is less disturbed by other work on the machine)")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
