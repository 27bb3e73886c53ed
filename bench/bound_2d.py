#!/usr/bin/env python3
"""bench/bound_2d.py -- how far node moves alone can raise a planar mesh's mean radius ratio.

Issue 2 asks for a mean radius ratio >= 0.99 on the graded cases B and C; the
engine reaches 0.985 and 0.982.  This script measures the ceiling of any
smoothing at the mesh's connectivity: it maximises the sum of the triangles'
radius ratios q = 2 r_in / r_circ over every interior node position (L-BFGS with
the exact gradient), boundary nodes on the axis-aligned sides of the bounding box
sliding along them (corners and other boundary nodes fixed), then tries every
edge flip that raises the sum of its two triangles.  If the result stays below
the target, no smoother can reach it: the connectivity (its five/seven-valent
nodes) has to change.

  python3 bench/run_2d.py --cases B,C --reps 1     # writes bench/out/meshes/
  python3 bench/bound_2d.py bench/out/meshes/B__bubblemesh.msh bench/out/meshes/C__bubblemesh.msh

Prints, per mesh: triangles, interior nodes of valence 5 / 7 / other, the mean
and minimum q as given, after the optimisation, and after the flips.  Needs
numpy, scipy and meshio (bench/requirements.txt).  Not run in CI.
"""
import argparse
import sys

import meshio
import numpy as np
from scipy.optimize import minimize


def radius_ratios(p, t):
    a = np.linalg.norm(p[t[:, 1]] - p[t[:, 2]], axis=1)
    b = np.linalg.norm(p[t[:, 0]] - p[t[:, 2]], axis=1)
    c = np.linalg.norm(p[t[:, 0]] - p[t[:, 1]], axis=1)
    return (b + c - a) * (c + a - b) * (a + b - c) / (a * b * c)


def sum_and_gradient(p, t):
    """-sum(q) and its gradient with respect to every node position."""
    q, g = weighted_q_gradient(p, t)
    return -q.sum(), -g


def weighted_q_gradient(p, t, w=None):
    """The radius ratios q and the gradient of sum(w * q) (w per triangle,
    1 if None) with respect to every node position."""
    ea, eb, ec = p[t[:, 1]] - p[t[:, 2]], p[t[:, 0]] - p[t[:, 2]], p[t[:, 0]] - p[t[:, 1]]
    a, b, c = (np.linalg.norm(e, axis=1) for e in (ea, eb, ec))
    x1, x2, x3 = b + c - a, c + a - b, a + b - c
    den = a * b * c
    q = x1 * x2 * x3 / den
    dqa = (-x2 * x3 + x1 * x3 + x1 * x2) / den - q / a
    dqb = (x2 * x3 - x1 * x3 + x1 * x2) / den - q / b
    dqc = (x2 * x3 + x1 * x3 - x1 * x2) / den - q / c
    g = np.zeros_like(p)
    for dq, e, (i, j) in ((dqa, ea / a[:, None], (1, 2)), (dqb, eb / b[:, None], (0, 2)),
                          (dqc, ec / c[:, None], (0, 1))):
        if w is not None:
            dq = w * dq
        np.add.at(g, t[:, i], dq[:, None] * e)
        np.add.at(g, t[:, j], -dq[:, None] * e)
    return q, g


def orient(p, a, b, c):
    return (p[b, 0] - p[a, 0]) * (p[c, 1] - p[a, 1]) - (p[b, 1] - p[a, 1]) * (p[c, 0] - p[a, 0])


def flip_sweeps(p, t):
    """Flips every interior edge whose flip raises its two triangles' sum of q."""
    t = [list(x) for x in t]

    def q1(tri):
        return radius_ratios(p, np.array([tri]))[0]

    total = 0
    while True:
        edges = {}
        for ti, tri in enumerate(t):
            for k in range(3):
                edges.setdefault(tuple(sorted((tri[k], tri[(k + 1) % 3]))), []).append(ti)
        done, flips = set(), 0
        for (a, b), ts in edges.items():
            if len(ts) != 2 or ts[0] in done or ts[1] in done:
                continue
            t1, t2 = t[ts[0]], t[ts[1]]
            c = next(v for v in t1 if v not in (a, b))
            d = next(v for v in t2 if v not in (a, b))
            if orient(p, c, d, a) * orient(p, c, d, b) >= 0:
                continue  # not a convex quadrilateral
            n1 = [c, d, a] if orient(p, c, d, a) > 0 else [d, c, a]
            n2 = [c, d, b] if orient(p, c, d, b) > 0 else [d, c, b]
            if q1(n1) + q1(n2) > q1(t1) + q1(t2) + 1e-12:
                t[ts[0]], t[ts[1]] = n1, n2
                done.update(ts)
                flips += 1
        total += flips
        if flips == 0:
            return np.array(t), total


def analyse(path):
    m = meshio.read(path)
    p0 = m.points[:, :2].astype(float)
    t = np.vstack([c.data for c in m.cells if c.type == "triangle"])
    n = len(p0)
    e = np.sort(np.vstack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    u, cnt = np.unique(e, axis=0, return_counts=True)
    boundary = np.zeros(n, bool)
    boundary[u[cnt == 1].ravel()] = True
    used = np.zeros(n, bool)
    used[t.ravel()] = True
    inner = used & ~boundary
    val = np.bincount(t.ravel(), minlength=n)[inner]
    # free coordinates: interior nodes; boundary nodes on a side of the box slide along it
    lo, hi = p0[used].min(axis=0), p0[used].max(axis=0)
    tol = 1e-9 * max(hi - lo)
    on_x = boundary & ((abs(p0[:, 0] - lo[0]) < tol) | (abs(p0[:, 0] - hi[0]) < tol))
    on_y = boundary & ((abs(p0[:, 1] - lo[1]) < tol) | (abs(p0[:, 1] - hi[1]) < tol))
    free = np.zeros((n, 2), bool)
    free[inner] = True
    free[on_x & ~on_y, 1] = True
    free[on_y & ~on_x, 0] = True

    def f(x):
        p = p0.copy()
        p[free] = x
        s, g = sum_and_gradient(p, t)
        return s, g[free]

    r = minimize(f, p0[free], jac=True, method="L-BFGS-B", options={"maxiter": 5000})
    p = p0.copy()
    p[free] = r.x
    inverted = int((np.sign(orient(p, t[:, 0], t[:, 1], t[:, 2]))
                    != np.sign(orient(p0, t[:, 0], t[:, 1], t[:, 2]))).sum())
    q0, q1 = radius_ratios(p0, t), radius_ratios(p, t)
    t2, flips = flip_sweeps(p, t)
    q2 = radius_ratios(p, t2)
    print(f"{path}")
    print(f"  {len(t)} triangles; interior nodes {inner.sum()}: valence 5 {(val == 5).sum()}, "
          f"7 {(val == 7).sum()}, other {((val != 5) & (val != 6) & (val != 7)).sum()}")
    print(f"  as given          q mean {q0.mean():.4f}  min {q0.min():.3f}")
    print(f"  best positions    q mean {q1.mean():.4f}  min {q1.min():.3f}  "
          f"({free.sum()} free coordinates, {inverted} triangles inverted, {r.message})")
    print(f"  then {flips:4d} flips   q mean {q2.mean():.4f}  min {q2.min():.3f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("meshes", nargs="+", help="triangle meshes meshio reads (.msh, .vtu, ...)")
    args = ap.parse_args()
    for path in args.meshes:
        analyse(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
