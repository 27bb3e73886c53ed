"""Common tools: load/write meshes, q, band, valence, global sum(q) optimisation, flips, CDT."""
import os
import sys
import numpy as np, meshio, triangle as tr, subprocess, json

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
# bench/run_2d.py's meshes (run it first: python3 bench/run_2d.py --cases B,C --reps 1)
MESHES = os.path.join(os.environ.get("BUBBLEMESH_BENCH_OUT", os.path.join(ROOT, "bench", "out")), "meshes")
MESHCHECK = os.path.join(ROOT, "..", "shared", "meshkit", "meshcheck.py")


# the radius ratio and its gradient: bench/bound_2d.py's
sys.path.insert(0, os.path.join(ROOT, "bench"))
from bound_2d import (  # noqa: E402
    flip_sweeps, radius_ratios as qvals, sum_and_gradient, weighted_q_gradient)


def engine_mesh(case):
    """The engine's mesh of `case` (its boundary nodes are reused)."""
    return os.path.join(MESHES, f"{case}__bubblemesh.msh")

from scipy.optimize import minimize

SPACING = {"B": "0.01 + 0.2*((x-0.5)**2 + (y-0.5)**2)",
           "C": "0.02 + 0.1*maximum(minimum(hypot(x-0.5, y-0.5), hypot(x-1.5, y-0.5)) - 0.2, 0)"}
BOX = {"B": (0, 0, 1, 1), "C": (0, 0, 2, 1)}
HOLES = {"B": [], "C": [(0.5, 0.5), (1.5, 0.5)]}

def dfun(case, x, y):
    if case == "B":
        return 0.01 + 0.2 * ((x - .5) ** 2 + (y - .5) ** 2)
    r = np.minimum(np.hypot(x - .5, y - .5), np.hypot(x - 1.5, y - .5))
    return 0.02 + 0.1 * np.maximum(r - 0.2, 0)

def load(path):
    m = meshio.read(path)
    p = m.points[:, :2].astype(float).copy()
    t = np.vstack([c.data for c in m.cells if c.type == "triangle"]).astype(np.int64)
    used = np.unique(t)
    remap = -np.ones(len(p), np.int64); remap[used] = np.arange(len(used))
    return p[used], remap[t]

def edges_of(t):
    e = np.sort(np.vstack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0, return_counts=True)

def boundary_edges(t):
    u, c = edges_of(t); return u[c == 1]

def orient_tris(p, t):
    a = p[t[:, 1]] - p[t[:, 0]]; b = p[t[:, 2]] - p[t[:, 0]]
    s = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    t = t.copy(); t[s < 0] = t[s < 0][:, [0, 2, 1]]; return t

def signed_area(p, t):
    a = p[t[:, 1]] - p[t[:, 0]]; b = p[t[:, 2]] - p[t[:, 0]]
    return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])

def band_pen(p, t, case, lo=0.76, hi=1.32, w=1.0):
    """penalty w*sum(hinge(log(L/d) outside [log lo, log hi])^2) and gradient (d frozen at midpoint)"""
    u, _ = edges_of(t)
    e = p[u[:, 1]] - p[u[:, 0]]; L = np.linalg.norm(e, axis=1)
    mid = 0.5 * (p[u[:, 0]] + p[u[:, 1]]); d = dfun(case, mid[:, 0], mid[:, 1])
    r = np.log(L / d)
    h = np.where(r > np.log(hi), r - np.log(hi), np.where(r < np.log(lo), r - np.log(lo), 0.0))
    f = w * (h ** 2).sum()
    coef = (2 * w * h / L)[:, None] * e / L[:, None]
    g = np.zeros_like(p); np.add.at(g, u[:, 1], coef); np.add.at(g, u[:, 0], -coef)
    return f, g

def free_mask(p, t, case):
    n = len(p); b = np.zeros(n, bool); b[boundary_edges(t).ravel()] = True
    x0, y0, x1, y1 = BOX[case]; tol = 1e-9
    on_x = b & ((abs(p[:, 0] - x0) < tol) | (abs(p[:, 0] - x1) < tol))
    on_y = b & ((abs(p[:, 1] - y0) < tol) | (abs(p[:, 1] - y1) < tol))
    fr = np.zeros((n, 2), bool); fr[~b] = True
    fr[on_x & ~on_y, 1] = True; fr[on_y & ~on_x, 0] = True
    return fr, b

def optimize(p, t, case, wband=0.0, maxiter=3000, fr=None):
    if fr is None:
        fr, _ = free_mask(p, t, case)
    p0 = p.copy()
    def f(x):
        pp = p0.copy(); pp[fr] = x
        s, g = sum_and_gradient(pp, t)
        if wband:
            s2, g2 = band_pen(pp, t, case, w=wband); s += s2; g = g + g2
        return s, g[fr]
    r = minimize(f, p0[fr], jac=True, method="L-BFGS-B", options={"maxiter": maxiter, "maxcor": 20})
    pp = p0.copy(); pp[fr] = r.x
    if (signed_area(pp, t) <= 0).any():
        print("  WARNING: optimisation inverted", (signed_area(pp, t) <= 0).sum(), "triangles")
    return pp

def flips(p, t):
    """q-improving flips (sum of the two q) until none: bound_2d's sweeps; returns t, count"""
    t, n = flip_sweeps(p, t)
    return orient_tris(p, t), n

def cdt(points, segments, holes):
    A = dict(vertices=points, segments=np.asarray(segments))
    if holes: A["holes"] = np.array(holes)
    B = tr.triangulate(A, "p")
    assert len(B["vertices"]) == len(points), "Steiner points inserted"
    return orient_tris(points, B["triangles"].astype(np.int64))

def stats(p, t, case, label=""):
    q = qvals(p, t)
    u, c = edges_of(t)
    mid = 0.5 * (p[u[:, 0]] + p[u[:, 1]]); L = np.linalg.norm(p[u[:, 1]] - p[u[:, 0]], axis=1)
    r = L / dfun(case, mid[:, 0], mid[:, 1])
    band = ((r >= 2 ** -.5) & (r <= 2 ** .5)).mean() * 100
    b = np.zeros(len(p), bool); b[u[c == 1].ravel()] = True
    val = np.bincount(t.ravel(), minlength=len(p))
    vi = val[~b]
    s = dict(ntri=len(t), nnode=len(p), qmean=q.mean(), qmin=q.min(), band=band,
             rmean=r.mean(), n5=int((vi == 5).sum()), n7=int((vi == 7).sum()),
             nother=int(((vi < 5) | (vi > 7)).sum()), ninner=int((~b).sum()),
             inverted=int((signed_area(p, t) <= 0).sum()))
    print(f"{label:28s} tri {s['ntri']:5d} q mean {s['qmean']:.5f} min {s['qmin']:.3f} band {band:6.2f}% "
          f"L/d mean {s['rmean']:.3f} | int {s['ninner']} v5 {s['n5']} v7 {s['n7']} other {s['nother']} inv {s['inverted']}", flush=True)
    return s

def write(p, t, path):
    meshio.write(path, meshio.Mesh(np.c_[p, np.zeros(len(p))], [("triangle", t)]), file_format="gmsh")

def meshcheck(path, case):
    out = subprocess.run(["python3", MESHCHECK, path, "--spacing", SPACING[case],
                          "--ref-area", str(1.0 if case == "B" else 2.0 - 2 * np.pi * 0.04)],
                         capture_output=True, text=True).stdout
    return json.loads(out)
