#!/usr/bin/env python3
"""Compare bubblemesh-delaunay with scipy.spatial.Delaunay (Qhull) on the same points.

Not run in CI. Usage (from the repository root):

    python3 delaunay/bench/compare_scipy.py 100000

It builds and runs `cargo run --release -p bubblemesh-delaunay --example
throughput -- N --write DIR`, which prints our timings and writes the uniform
and FCC point sets as raw little-endian f64 triples, then times Qhull on the
same arrays (wall and process CPU time). Qhull's FCC result uses its default
'Qbb Qc Qz Q12 Qt' options: with 'Qt' degenerate (cospherical) regions are
triangulated but may contain zero-volume simplices, so only its timing is
comparable.
"""
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay


def main() -> None:
    n = sys.argv[1] if len(sys.argv) > 1 else "100000"
    with tempfile.TemporaryDirectory() as d:
        # THROUGHPUT_BIN: an already built example binary (skips cargo).
        cmd = ([os.environ["THROUGHPUT_BIN"]] if "THROUGHPUT_BIN" in os.environ else
               ["cargo", "run", "--quiet", "--release", "-p", "bubblemesh-delaunay",
                "--example", "throughput", "--"])
        out = subprocess.run(cmd + [n, "--write", d],
                             check=True, capture_output=True, text=True).stdout
        print("bubblemesh-delaunay:")
        print(out, end="")
        print("scipy.spatial.Delaunay (Qhull", end="")
        import scipy
        print(f", scipy {scipy.__version__}):")
        print(f"{'input':<8} {'points':>10} {'tets':>10} {'wall_s':>8} {'cpu_s':>8} "
              f"{'tets/s_wall':>11} {'tets/s_cpu':>11}")
        for name in ["uniform", "fcc"]:
            pts = np.fromfile(Path(d) / f"{name}.f64", dtype="<f8").reshape(-1, 3)
            c0, w0 = time.process_time(), time.perf_counter()
            tri = Delaunay(pts)
            c, w = time.process_time() - c0, time.perf_counter() - w0
            m = len(tri.simplices)
            print(f"{name:<8} {len(pts):>10} {m:>10} {w:>8.3f} {c:>8.3f} "
                  f"{m / w:>11.0f} {m / c:>11.0f}")


if __name__ == "__main__":
    main()
