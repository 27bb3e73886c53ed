"""B: the metric |dx|^2/d^2 of case B is exactly a round sphere (stereographic projection, radius
sqrt(125) d-units).  Take a geodesic icosphere (frequency nu), rotate, project stereographically
into the square, drop points within alpha*d of the boundary, add the existing boundary nodes, CDT, optimise."""
import sys; from mtools import *
from scipy.spatial.transform import Rotation
case = "B"
nu = int(sys.argv[1]); alpha = float(sys.argv[2]); rot = sys.argv[3] if len(sys.argv) > 3 else "vertex"
seed = int(sys.argv[4]) if len(sys.argv) > 4 else 0
def icosphere(nu):
    g = (1 + 5 ** .5) / 2
    V = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g], [0, -1, -g], [0, 1, -g],
                  [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]], float)
    F = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6],
         [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
         [8, 6, 7], [9, 8, 1]]
    P = []
    for a, b, c in F:
        for i in range(nu + 1):
            for j in range(nu + 1 - i):
                P.append(V[a] + i / nu * (V[b] - V[a]) + j / nu * (V[c] - V[a]))
    P = np.array(P); P /= np.linalg.norm(P, axis=1)[:, None]
    P = np.unique(np.round(P, 9), axis=0); return P, V / np.linalg.norm(V, axis=1)[:, None]
S, V = icosphere(nu)
# rotation: bring an icosahedron vertex / face centre to the south pole (0,0,-1), then random spin
if rot == "vertex": target = V[0]
elif rot == "face": target = (V[0] + V[11] + V[5]) / np.linalg.norm(V[0] + V[11] + V[5])
elif rot == "edge": target = (V[0] + V[11]) / np.linalg.norm(V[0] + V[11])
else: target = Rotation.random(random_state=seed).apply([0, 0, -1])
R1, _ = Rotation.align_vectors([[0, 0, -1]], [target])
R2 = Rotation.from_euler("z", np.random.default_rng(seed).uniform(0, 2 * np.pi) if seed else 0)
S = (R2 * R1).apply(S)
S = S[S[:, 2] < 0.999]
s = S[:, :2] / (1 - S[:, 2])[:, None]
P = 0.5 + s / np.sqrt(20)
p0, t0 = load(engine_mesh("B"))
be = boundary_edges(t0); bn = np.unique(be); pb = p0[bn]; remap = {v: i for i, v in enumerate(bn)}
seg = np.array([[remap[a], remap[b]] for a, b in be])
inside = (P[:, 0] > 0) & (P[:, 0] < 1) & (P[:, 1] > 0) & (P[:, 1] < 1)
P = P[inside]
d = dfun(case, P[:, 0], P[:, 1])
dist_b = np.minimum.reduce([P[:, 0], 1 - P[:, 0], P[:, 1], 1 - P[:, 1]])
P = P[dist_b > alpha * d]
pts = np.vstack([pb, P]); p = pts
t = cdt(pts, seg, [])
tag = f"B_ico_n{nu}_a{alpha}_{rot}{seed}"
stats(p, t, case, "B ico CDT")
for it in range(3):
    t, nf = flips(p, t); p = optimize(p, t, case, wband=10.0)
    stats(p, t, case, f"B it{it} flips {nf}")
np.savez(tag + ".npz", p=p, t=t); write(p, t, tag + ".msh")
