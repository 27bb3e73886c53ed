"""Seeds for a graded planar metric |dx|^2/d^2 by cone flattening, with no closed form of d
(linearised curvature prescription, Ben-Chen, Gotsman & Bunin 2008).  Session 10.

1. Background: the engine's mesh refined 1-to-4; cotan Laplacian L; u = -log d at its nodes.
2. Flattening: phi = u + h with L phi = kappa - K_E at the unknown nodes (K_E: Euclidean
   curvature, pi - angle sum on the boundary), so the metric exp(2 phi)|dx|^2 is flat except at
   cones kappa = +-pi/3 (the five- and seven-valent nodes to be).  The outer loop is Dirichlet
   (h = 0: exact spacing); hole loops are Neumann with zero target turning, so each hole is a
   straight line in the layout and lattice rows can run along it.
3. Cones, greedily: at the node of largest |h| among nodes more than R0 cells from every cone,
   kappa = -sign(h) pi/3, until that |h| < TOL (one sparse solve per cone, LU factored once).
4. Layout: unfold the triangles breadth-first with lengths l_ij exp((phi_i + phi_j)/2).  Around
   a cone the unfolding turns by +-60 degrees, which the hexagonal lattice does not see.
5. One unit hexagonal lattice per hole, in a layout rooted on that hole, turned so that the hole
   lies on a lattice row through its nodes and scaled so the hole's length is its node count
   (the annulus' translation holonomy is then a lattice vector); each triangle takes the
   lattice of its nearest hole (one global lattice when there is no hole).
6. Seeds: the lattice points inside each laid-out triangle, mapped back by barycentric
   coordinates; drop those within alpha*d of the boundary or within 0.6 d of an earlier one.
7. CDT with the engine's boundary nodes, then flips + L-BFGS of sum(1-q) + band term (as
   buildB.py); cleanup.py afterwards lifts the minimum.

Usage: python3 buildCones.py CASE [TOL=0.2] [alpha=0.4] [R0=3] [neumann|dirichlet]
Writes CASE_cones_t{TOL}_a{alpha}.npz/.msh."""
import sys, collections
from mtools import *
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

case = sys.argv[1]
TOL = float(sys.argv[2]) if len(sys.argv) > 2 else 0.2
alpha = float(sys.argv[3]) if len(sys.argv) > 3 else 0.4
W = np.exp(1j * np.pi / 3)


def refine(p, t):
    u, _ = edges_of(t)
    idx = {(a, b): len(p) + k for k, (a, b) in enumerate(u)}
    P = np.vstack([p, 0.5 * (p[u[:, 0]] + p[u[:, 1]])])
    T = []
    for a, b, c in t:
        ab = idx[(min(a, b), max(a, b))]; bc = idx[(min(b, c), max(b, c))]; ca = idx[(min(c, a), max(c, a))]
        T += [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
    return P, orient_tris(P, np.array(T))


p0, t0 = load(engine_mesh(case))
P, T = refine(p0, t0) if os.environ.get("NOREFINE") is None else (p0, orient_tris(p0, t0))
n = len(P)
z = P[:, 0] + 1j * P[:, 1]
E, cnt = edges_of(T)
isb = np.zeros(n, bool); isb[E[cnt == 1].ravel()] = True
# cotan Laplacian (positive semi-definite)
I, J, V = [], [], []
for k in range(3):
    i, j, o = T[:, k], T[:, (k + 1) % 3], T[:, (k + 2) % 3]
    e1 = P[i] - P[o]; e2 = P[j] - P[o]
    cot = (e1 * e2).sum(1) / np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    I += [i, j, i, j]; J += [j, i, i, j]; V += [-cot / 2, -cot / 2, cot / 2, cot / 2]
L = sp.csr_matrix((np.concatenate(V), (np.concatenate(I), np.concatenate(J))), shape=(n, n))
u = -np.log(dfun(case, P[:, 0], P[:, 1]))
# boundary nodes on the holes (Neumann: their loop is straight in the layout, so lattice rows follow it)
NEU = not (len(sys.argv) > 5 and sys.argv[5] == "dirichlet")
onhole = np.zeros(n, bool)
for hx, hy in HOLES[case]:
    onhole |= isb & (abs(np.hypot(P[:, 0] - hx, P[:, 1] - hy) - 0.2) < 1e-3)
if not NEU: onhole[:] = False
# Euclidean turning at boundary nodes: pi - sum of the corner angles
ang_sum = np.zeros(n)
for k in range(3):
    i, j, o = T[:, k], T[:, (k + 1) % 3], T[:, (k + 2) % 3]
    e1 = P[j] - P[i]; e2 = P[o] - P[i]
    np.add.at(ang_sum, i, np.arccos(np.clip((e1 * e2).sum(1) / np.linalg.norm(e1, axis=1) / np.linalg.norm(e2, axis=1), -1, 1)))
KE = np.where(isb, np.pi - ang_sum, 2 * np.pi - ang_sum)
inn = np.where(~isb | onhole)[0]
Lii = L[inn][:, inn].tocsc()
lu = spla.splu(Lii)
# L phi = kappa - KE at the unknown nodes, phi = u at the Dirichlet nodes; h = phi - u
rhs0 = -(L @ u)[inn] - KE[inn]
kappa = np.zeros(len(inn))
cones = []
dnode = dfun(case, P[inn, 0], P[inn, 1])
far = ~onhole[inn]  # nodes more than R0 cells from every cone (the log singularity near a cone is the lattice's business)
R0 = float(sys.argv[4]) if len(sys.argv) > 4 else 3.0
ctree_pts = []
while True:
    hi = lu.solve(rhs0 + kappa)
    cand = np.where(far)[0]
    k = cand[int(np.argmax(abs(hi[cand])))]
    if abs(hi[k]) < TOL or len(cones) > 500:
        break
    far &= abs(z[inn] - z[inn[k]]) > R0 * np.maximum(dnode, dnode[k])
    s = -np.sign(hi[k])
    kappa[k] += s * np.pi / 3
    cones.append((inn[k], s))
h = np.zeros(n); h[inn] = hi
phi = u + h
# Newton on the discrete conformal curvature (Springborn, Schroeder & Pinkall 2008): the layout
# lengths l*exp((phi_i+phi_j)/2) then close up exactly (angle sums 2 pi - kappa inside, pi on the
# Neumann loops), instead of to first order
theta = np.zeros(n); theta[inn] = kappa  # target curvature at the unknowns
def curv_and_lap(phi):
    l = lambda i, j: np.linalg.norm(P[i] - P[j], axis=1) * np.exp(0.5 * (phi[i] + phi[j]))
    angsum = np.zeros(n); I, J, V = [], [], []
    A, B, C = T[:, 0], T[:, 1], T[:, 2]
    la, lb, lc = l(B, C), l(C, A), l(A, B)  # opposite A, B, C
    def ang(x, y, z):  # angle opposite x
        return np.arccos(np.clip((y * y + z * z - x * x) / (2 * y * z), -1, 1))
    aA, aB, aC = ang(la, lb, lc), ang(lb, lc, la), ang(lc, la, lb)
    for v, a in ((A, aA), (B, aB), (C, aC)): np.add.at(angsum, v, a)
    for (i, j, a) in ((B, C, aA), (C, A, aB), (A, B, aC)):
        w = 0.5 / np.tan(np.clip(a, 1e-6, np.pi - 1e-6))
        I += [i, j, i, j]; J += [j, i, i, j]; V += [-w, -w, w, w]
    Lc = sp.csr_matrix((np.concatenate(V), (np.concatenate(I), np.concatenate(J))), shape=(n, n))
    Om = np.where(isb, np.pi - angsum, 2 * np.pi - angsum)
    return Om, Lc
for itn in range(int(os.environ.get("NEWTON", "4"))):
    Om, Lc = curv_and_lap(phi)
    res = (theta - Om)[inn]
    print(f"newton {itn}: max |curvature residual| {abs(res).max():.2e}")
    dphi = spla.spsolve(Lc[inn][:, inn].tocsc(), res)
    phi[inn] += dphi
h = phi - u
print(f"max|h| far from cones {abs(hi[far]).max() if far.any() else 0:.3f}; cones: {len(cones)} (+{sum(1 for c in cones if c[1] > 0)} -{sum(1 for c in cones if c[1] < 0)}), max|h| {abs(h).max():.3f}")

# layout: unfold triangles breadth-first from the triangle of largest spacing
ntri = len(T)
e2t = collections.defaultdict(list)
for ti, tri in enumerate(T):
    for k in range(3):
        e2t[(min(tri[k], tri[(k + 1) % 3]), max(tri[k], tri[(k + 1) % 3]))].append(ti)
def length(i, j):
    return abs(z[i] - z[j]) * np.exp(0.5 * (phi[i] + phi[j]))
def third(fa, fb, la, lb, lab):
    """position of c with |c-a| = la, |c-b| = lb, left of a->b (counter-clockwise triangle a b c)"""
    x = (la * la - lb * lb + lab * lab) / (2 * lab)
    y = np.sqrt(max(la * la - x * x, 1e-18))
    e = (fb - fa) / abs(fb - fa)
    return fa + e * (x + 1j * y)
def layout(root):
    """unfold the triangles breadth-first from `root` with the lengths of the flattened metric"""
    F = np.zeros((ntri, 3), complex)
    done = np.zeros(ntri, bool)
    a0, b0, c0 = T[root]
    F[root, 0] = 0; F[root, 1] = length(a0, b0)
    F[root, 2] = third(F[root, 0], F[root, 1], length(a0, c0), length(b0, c0), length(a0, b0))
    done[root] = True
    dq = collections.deque([root])
    while dq:
        ti = dq.popleft(); tri = T[ti]
        for k in range(3):
            i, j = tri[k], tri[(k + 1) % 3]
            for tj in e2t[(min(i, j), max(i, j))]:
                if done[tj]: continue
                tr2 = list(T[tj]); m = tr2.index(j)  # neighbour has edge j -> i, ccw
                o = tr2[(m + 2) % 3]
                fj, fi = F[ti, (k + 1) % 3], F[ti, k]
                fo = third(fj, fi, length(j, o), length(i, o), length(i, j))
                F[tj, m] = fj; F[tj, (m + 1) % 3] = fi; F[tj, (m + 2) % 3] = fo
                done[tj] = True; dq.append(tj)
    return F
F = layout(int(np.argmin(u[T].sum(1))))
# one lattice per hole loop, aligned with it (the loop is straight in the layout when its nodes
# are Neumann): rotation to a lattice row, the row on the loop, columns on its nodes, and a scale
# that makes the loop's length its node count; each triangle takes the lattice of the nearest hole
Fk = [F]
region = np.zeros(ntri, int)
if NEU and HOLES[case]:
    Fk = []
    cent = P[T].mean(1)
    dist = []
    for hx, hy in HOLES[case]:
        hk = isb & (abs(np.hypot(P[:, 0] - hx, P[:, 1] - hy) - 0.2) < 1e-3)
        dist.append(np.hypot(cent[:, 0] - hx, cent[:, 1] - hy))
        acc = 0j; pts = []; LF = 0.0
        F = layout(int(np.where(hk[T].sum(1) >= 2)[0][0]))
        for ti, tri in enumerate(T):
            for k in range(3):
                i, j = tri[k], tri[(k + 1) % 3]
                if hk[i] and hk[j]:
                    e = F[ti, (k + 1) % 3] - F[ti, k]; acc += (e / abs(e)) ** 6; pts.append(F[ti, k]); LF += abs(e)
        nb = int(round(hk.sum() / (1 if os.environ.get("NOREFINE") else 2)))
        rot = np.exp(-1j * np.angle(acc) / 6)
        # then the loop's line is along a lattice direction; turn that direction to the real axis
        e2 = sum(((F[ti, (k + 1) % 3] - F[ti, k]) * rot / abs(F[ti, (k + 1) % 3] - F[ti, k])) ** 2
                 for ti, tri in enumerate(T) for k in range(3) if hk[tri[k]] and hk[tri[(k + 1) % 3]])
        rot *= np.exp(-1j * np.pi / 3 * np.round(np.angle(e2) / 2 / (np.pi / 3)))
        G = F * rot * (nb / LF)
        pts = np.array(pts) * rot * (nb / LF)
        G = G - 1j * np.angle(np.exp(2j * np.pi * pts.imag / (np.sqrt(3) / 2)).mean()) / (2 * np.pi) * (np.sqrt(3) / 2)
        pts = pts - 1j * np.angle(np.exp(2j * np.pi * pts.imag / (np.sqrt(3) / 2)).mean()) / (2 * np.pi) * (np.sqrt(3) / 2)
        G = G - np.angle(np.exp(2j * np.pi * pts.real).mean()) / (2 * np.pi)
        print(f"hole ({hx},{hy}): loop length {LF:.2f} for {nb} nodes, row spread {np.std(pts.imag):.3f}")
        Fk.append(G)
    region = np.argmin(np.array(dist), axis=0)
# lattice points of the unit hexagonal lattice inside each laid-out triangle
seeds = []
for ti in range(ntri):
    f = Fk[region[ti]][ti]
    c = f / 1.0
    Bs = c.imag / np.sin(np.pi / 3); As = c.real - 0.5 * Bs
    for A in range(int(np.floor(As.min())), int(np.ceil(As.max())) + 1):
        for B in range(int(np.floor(Bs.min())), int(np.ceil(Bs.max())) + 1):
            q = A + B * W
            # barycentric coordinates in f
            M = np.array([[f[1].real - f[0].real, f[2].real - f[0].real], [f[1].imag - f[0].imag, f[2].imag - f[0].imag]])
            l1, l2 = np.linalg.solve(M, [q.real - f[0].real, q.imag - f[0].imag])
            if l1 >= -1e-9 and l2 >= -1e-9 and l1 + l2 <= 1 + 1e-9:
                tri = T[ti]
                seeds.append(z[tri[0]] + l1 * (z[tri[1]] - z[tri[0]]) + l2 * (z[tri[2]] - z[tri[0]]))
seeds = np.array(seeds)
print("lattice points", len(seeds))
S = np.c_[seeds.real, seeds.imag]
x0, y0, x1, y1 = BOX[case]
dist_b = np.minimum.reduce([S[:, 0] - x0, x1 - S[:, 0], S[:, 1] - y0, y1 - S[:, 1]])
for hx, hy in HOLES[case]:
    dist_b = np.minimum(dist_b, np.hypot(S[:, 0] - hx, S[:, 1] - hy) - 0.2)
d = dfun(case, S[:, 0], S[:, 1])
S = S[dist_b > alpha * d]
keep = np.ones(len(S), bool); tree = cKDTree(S); dS = dfun(case, S[:, 0], S[:, 1])
for i in range(len(S)):
    if not keep[i]: continue
    for j in tree.query_ball_point(S[i], 0.6 * dS[i]):
        if j > i: keep[j] = False
S = S[keep]
be = boundary_edges(t0); bn = np.unique(be); pbn = p0[bn]; remap = {v: i for i, v in enumerate(bn)}
seg = np.array([[remap[x], remap[y]] for x, y in be])
p = np.vstack([pbn, S])
t = cdt(p, seg, HOLES[case])
tag = f"{case}_cones_t{TOL}_a{alpha}"
stats(p, t, case, f"{case} cones CDT")
for it in range(3):
    t, nf = flips(p, t); p = optimize(p, t, case, wband=10.0)
    stats(p, t, case, f"{case} it{it} flips {nf}")
np.savez(tag + ".npz", p=p, t=t); write(p, t, tag + ".msh")
