"""C: log-polar (conformal) hex lattice around each hole + existing boundary nodes, CDT, optimise."""
import sys; from mtools import *
from scipy.spatial import cKDTree
case = "C"
alpha = float(sys.argv[1]) if len(sys.argv) > 1 else 0.6   # min dist to outer boundary / d
beta = float(sys.argv[2]) if len(sys.argv) > 2 else 0.7    # min dist between points / d
p0, t0 = load(engine_mesh("C"))
be = boundary_edges(t0); bn = np.unique(be)
pb = p0[bn]; remap = {v: i for i, v in enumerate(bn)}
seg = np.array([[remap[a], remap[b]] for a, b in be])
n = 63; phase = -3.0917261035327885; dl = 2 * np.pi / n * np.sqrt(3) / 2
pts = []
for cx in (0.5, 1.5):
    for k in range(1, 200):
        r = 0.2 * np.exp(k * dl)
        if r > 0.75: break
        th = phase + (np.arange(n) + 0.5 * k) * 2 * np.pi / n
        x = cx + r * np.cos(th); y = 0.5 + r * np.sin(th)
        ok = (np.abs(x - cx) <= 0.5) & (x > 0) & (x < 2) & (y > 0) & (y < 1)
        pts.append(np.c_[x[ok], y[ok]])
P = np.vstack(pts)
d = dfun(case, P[:, 0], P[:, 1])
dist_b = np.minimum.reduce([P[:, 0], 2 - P[:, 0], P[:, 1], 1 - P[:, 1]])
P = P[dist_b > alpha * d]
# remove points too close to each other (seam), greedy: keep those farther from seam first
order = np.argsort(-np.abs(P[:, 0] - 1.0)); P = P[order]
tree = cKDTree(P); d = dfun(case, P[:, 0], P[:, 1]); keep = np.ones(len(P), bool)
for i in range(len(P)):
    if not keep[i]: continue
    for j in tree.query_ball_point(P[i], beta * d[i]):
        if j > i: keep[j] = False
P = P[keep]
pts = np.vstack([pb, P])
t = cdt(pts, seg, HOLES[case]); p = pts
stats(p, t, case, "C lattice CDT")
for it in range(4):
    t, nf = flips(p, t); p = optimize(p, t, case, wband=10.0)
    stats(p, t, case, f"C it{it} flips {nf}")
t, nf = flips(p, t); stats(p, t, case, f"C final flips {nf}")
np.savez(f"C_lattice_a{alpha}_b{beta}.npz", p=p, t=t)
write(p, t, f"C_lattice_a{alpha}_b{beta}.msh")
