#!/usr/bin/env python3
"""Record or check that bubblemesh writes byte-identical meshes.

A change that should not change behaviour (a refactoring, a renamed module)
must leave every mesh the benchmarks write unchanged, bit for bit. This
script runs bubblemesh with the benchmarks' own command lines, without the
peers, and stores the sha256 of each output and its wall time:

    python3 scripts/identical.py record bench/out/identical.json   # before
    python3 scripts/identical.py check  bench/out/identical.json   # after

The cases (all with `--threads 1`, written as .msh):
  2d      bench/run_2d.py's cases A-G and its --fast variant of B;
  3d      bench/run_3d.py's cases H, I and J (`--dim 3`);
  step    every fixture of fixtures/manifest.json as a surface (`--dim 2`,
          its `mesh_size`), as bench/run_step.py runs it;
  step3d  every solid fixture as tetrahedra (`--dim 3`), as
          bench/run_step_3d.py runs it.

The hashes are of the written .msh files, so a change of the MSH writer
itself changes every one: check the meshing change with the old writer
first, then record again.

`check` exits 1 when a hash differs or a case that succeeded now fails, and
prints the cases that became slower than `--slower` (default 1.25) times the
recorded wall time (a warning: timing on a shared machine is noisy, rerun
before believing one). `--groups 2d,3d` runs a subset; `--jobs N` runs N
cases at once (the times are then less comparable).
"""
import argparse
import concurrent.futures as cf
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "bench"))

GROUPS = ["2d", "3d", "step", "step3d"]


def cases(meshkit):
    """Yield (name, argv after the binary) for every case of every group."""
    import run_2d  # noqa: E402  (bench scripts: constants only at import)
    import run_3d  # noqa: E402

    rp = run_2d.import_meshkit(meshkit)
    for c in run_2d.ALL_CASES:
        dom = os.path.join(REPO, run_2d.DOMAIN[rp.CASES[c]["geom"]])
        yield "2d", c, [dom, "--size", run_2d.SIZE[c]]
        for label, flags in run_2d.VARIANTS.get(c, []):
            yield "2d", c + " " + label.split(" ", 1)[1], [dom, "--size", run_2d.SIZE[c]] + flags
    for c in ["H", "I", "J"]:
        dom = os.path.join(REPO, run_3d.DOMAIN[rp.CASES[c]["geom"]])
        yield "3d", c, [dom, "--size", run_3d.SIZE[c], "--dim", "3"]
    with open(os.path.join(REPO, "fixtures", "manifest.json")) as f:
        parts = json.load(f)["parts"]
    for p in parts:
        step = os.path.join(REPO, "fixtures", p["file"])
        yield "step", p["name"], [step, "--size", str(p["mesh_size"]), "--dim", "2"]
    for p in parts:
        if p.get("solids", 0) == 0:
            continue
        step = os.path.join(REPO, "fixtures", p["file"])
        yield "step3d", p["name"], [step, "--size", str(p["mesh_size"]), "--dim", "3"]


def run_one(binary, group, name, argv, timeout, mem_mb):
    with tempfile.TemporaryDirectory(prefix="bm-identical-") as tmp:
        out = os.path.join(tmp, "out.msh")
        cmd = ["prlimit", "--as=%d" % (mem_mb << 20), "--", binary, "mesh", argv[0], "-o", out] + \
            argv[1:] + ["--threads", "1", "--quiet"]
        t = time.perf_counter()
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"group": group, "case": name, "status": "timeout", "wall_s": timeout}
        wall = time.perf_counter() - t
        rec = {"group": group, "case": name, "wall_s": round(wall, 3)}
        if p.returncode != 0 or not os.path.exists(out):
            lines = (p.stderr or "").strip().splitlines() or ["exit %d" % p.returncode]
            rec.update(status="failed", error=lines[-1][:300])
            return rec
        with open(out, "rb") as f:
            rec.update(status="ok", sha256=hashlib.sha256(f.read()).hexdigest(),
                       bytes=os.path.getsize(out))
        return rec


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("action", choices=["record", "check"])
    ap.add_argument("file", help="the record (JSON)")
    ap.add_argument("--bin", default=os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(REPO, "target")),
                                                  "release", "bubblemesh"))
    ap.add_argument("--groups", default=",".join(GROUPS))
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=900)
    ap.add_argument("--mem-mb", type=int, default=6000)
    ap.add_argument("--slower", type=float, default=1.25)
    ap.add_argument("--meshkit", default=os.path.normpath(os.path.join(REPO, "..", "shared", "meshkit")))
    a = ap.parse_args()
    if not os.path.isfile(a.bin):
        raise SystemExit("error: no binary at %s (cargo build --release -p bubblemesh-cli)" % a.bin)
    groups = a.groups.split(",")
    todo = [c for c in cases(a.meshkit) if c[0] in groups]
    results = {}
    with cf.ThreadPoolExecutor(max_workers=a.jobs) as ex:
        futs = {ex.submit(run_one, a.bin, g, n, argv, a.timeout, a.mem_mb): (g, n) for g, n, argv in todo}
        for fut in cf.as_completed(futs):
            r = fut.result()
            key = "%s/%s" % (r["group"], r["case"])
            results[key] = r
            print("%-40s %-8s %8.2f s %s" % (key, r["status"], r["wall_s"],
                                             r.get("sha256", r.get("error", ""))[:64]), flush=True)
    if a.action == "record":
        old = {}
        if os.path.exists(a.file):
            with open(a.file) as f:
                old = json.load(f)["cases"]
        old.update(results)
        os.makedirs(os.path.dirname(os.path.abspath(a.file)), exist_ok=True)
        with open(a.file, "w") as f:
            json.dump({"binary": a.bin, "cases": dict(sorted(old.items()))}, f, indent=1)
        print("recorded %d cases in %s" % (len(results), a.file))
        return 0
    with open(a.file) as f:
        rec = json.load(f)["cases"]
    bad, slow = [], []
    for key, r in sorted(results.items()):
        o = rec.get(key)
        if o is None:
            print("note: %s is not in the record" % key)
            continue
        if o["status"] != r["status"] or o.get("sha256") != r.get("sha256"):
            bad.append("%s: was %s %s, now %s %s" % (key, o["status"], o.get("sha256", o.get("error", ""))[:16],
                                                  r["status"], r.get("sha256", r.get("error", ""))[:16]))
        if o["status"] == "ok" and r["status"] == "ok" and r["wall_s"] > a.slower * o["wall_s"] + 0.05:
            slow.append("%s: %.2f s, was %.2f s" % (key, r["wall_s"], o["wall_s"]))
    for s in slow:
        print("slower: " + s)
    for b in bad:
        print("DIFFERENT: " + b)
    print("%d cases checked: %d different, %d slower than %.2fx" % (len(results), len(bad), len(slow), a.slower))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
