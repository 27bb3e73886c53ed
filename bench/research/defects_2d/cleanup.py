"""Greedy topological cleanup: try flip / collapse / split(+local flips) on edges near defects or
bad triangles, each followed by local L-BFGS of F = sum(1-q) + Wmin*sum(max(0,QMIN-q)^2) + band
penalty over the 2-ring patch; accept if the mesh's mean F (per triangle) decreases."""
import sys, time
from mtools import *
from scipy.optimize import minimize

QMIN, WMIN, WBAND = 0.85, 20.0, 10.0

def energy_grad(p, t, case, need_grad=True):
    q = qvals(p, t)
    h = np.maximum(0, QMIN - q)
    F = (1 - q).sum() + WMIN * (h ** 2).sum()
    if WBAND:
        fb, gb = band_pen(p, t, case, w=WBAND); F += fb
    if not need_grad: return F
    # d/dx of sum(1 - q) + WMIN*sum(h^2) = -sum((1 + 2 WMIN h) dq/dx)
    g = -weighted_q_gradient(p, t, 1 + 2 * WMIN * h)[1]
    if WBAND: g += gb
    return F, g

def opt_local(p, t, case, fr, maxiter=200):
    if not fr.any(): return p
    p0 = p.copy()
    def f(x):
        pp = p0.copy(); pp[fr] = x
        F, g = energy_grad(pp, t, case); return F, g[fr]
    r = minimize(f, p0[fr], jac=True, method="L-BFGS-B", options={"maxiter": maxiter, "maxcor": 10})
    pp = p0.copy(); pp[fr] = r.x; return pp

class Mesh:
    def __init__(self, p, t, case):
        self.case = case; self.p = p.copy(); self.t = orient_tris(p, t)
        self.fr, self.bnd = free_mask(self.p, self.t, case)
        # ideal triangle count per node: interior 6, straight/circle boundary 3, box corner 1.5
        x0, y0, x1, y1 = BOX[case]; P = self.p
        corner = self.bnd & (np.isclose(P[:, 0], x0) | np.isclose(P[:, 0], x1)) & (np.isclose(P[:, 1], y0) | np.isclose(P[:, 1], y1))
        self.ideal = np.where(self.bnd, 3.0, 6.0); self.ideal[corner] = 1.5
        self.rebuild()
    def rebuild(self):
        n = len(self.p); self.n2t = [[] for _ in range(n)]
        for i, tri in enumerate(self.t):
            for v in tri: self.n2t[v].append(i)
        self.e2t = {}
        for i, tri in enumerate(self.t):
            for k in range(3):
                self.e2t.setdefault((min(tri[k], tri[(k+1)%3]), max(tri[k], tri[(k+1)%3])), []).append(i)
        self.val = np.array([len(x) for x in self.n2t])
        q = qvals(self.p, self.t); self.q = q
        self.D = energy_grad(self.p, self.t, self.case, need_grad=False)  # total F
    def nbrs(self, v):
        return {u for i in self.n2t[v] for u in self.t[i]} - {v}
    def ring(self, nodes, k):
        s = set(nodes)
        for _ in range(k):
            s = s | {u for v in s if v < len(self.n2t) for u in self.nbrs(v)}
        return s
    def topo(self, counts, nodes):
        return sum((counts.get(v, self.val[v] if v < len(self.val) else 6) - self.ideal[v]) ** 2 for v in nodes)

    def try_op(self, op, a, b, rings=2):
        """returns (gain, newp, newt) or None. gain>0 means better."""
        p, t = self.p, self.t
        ts = self.e2t.get((min(a, b), max(a, b)))
        if ts is None: return None
        new_p = p
        if op == "flip":
            if len(ts) != 2: return None
            t1, t2 = t[ts[0]], t[ts[1]]
            c = [v for v in t1 if v not in (a, b)][0]; d = [v for v in t2 if v not in (a, b)][0]
            if (min(c, d), max(c, d)) in self.e2t: return None
            rem = list(ts); add = [[c, d, a], [d, c, b]]; aff = [a, b, c, d]
        elif op == "collapse":
            if len(ts) != 2: return None
            if self.bnd[a] and self.bnd[b]: return None
            if self.bnd[a]: a, b = b, a          # a interior is removed, b kept
            common = self.nbrs(a) & self.nbrs(b)
            if len(common) != 2: return None
            rem = list(set(self.n2t[a]))
            add = []
            for i in self.n2t[a]:
                if i in ts: continue
                add.append([b if v == a else v for v in t[i]])
            new_p = p.copy()
            if not self.bnd[b]: new_p[b] = 0.5 * (p[a] + p[b])
            aff = [b] + list(self.nbrs(a) | self.nbrs(b))
            removed_node = a
        elif op == "split":
            if len(ts) != 2: return None
            t1, t2 = t[ts[0]], t[ts[1]]
            c = [v for v in t1 if v not in (a, b)][0]; d = [v for v in t2 if v not in (a, b)][0]
            m = len(p); new_p = np.vstack([p, 0.5 * (p[a] + p[b])])
            rem = list(ts); add = [[a, m, c], [m, b, c], [b, m, d], [m, a, d]]; aff = [a, b, c, d, m]
        # assemble new local configuration
        patchnodes = self.ring([v for v in aff if v < len(p)], rings - 1) | set(aff)
        if op == "collapse": patchnodes.discard(removed_node)
        oldtris = set()
        for v in patchnodes:
            if v < len(p): oldtris.update(self.n2t[v])
        oldtris.update(rem)
        remset = set(rem)
        keep = [i for i in oldtris if i not in remset]
        T_old = t[sorted(oldtris)]
        T_new = np.vstack([t[keep], np.array(add, dtype=np.int64)]) if keep else np.array(add)
        T_new = orient_tris(new_p, T_new) if op != "flip" else orient_tris(new_p, T_new)
        if op == "collapse" and (signed_area(new_p, T_new) <= 0).any():
            pass  # may be fixed by optimisation
        # free nodes: interior nodes in patch (not on the patch's outer rim)
        fr = np.zeros((len(new_p), 2), bool)
        inner = [v for v in patchnodes if v < len(p) and v not in ()]  # all patch nodes
        # rim = nodes of T_new not in patchnodes -> fixed
        fmask = np.zeros(len(new_p), bool); fmask[list(patchnodes)] = True
        frfull = np.zeros((len(new_p), 2), bool); frfull[:len(p)] = self.fr
        if op == "split": frfull[len(p)] = True
        fr = frfull & fmask[:, None]
        # restrict optimisation to the sub-problem
        used = np.unique(T_new); loc = -np.ones(len(new_p), np.int64); loc[used] = np.arange(len(used))
        pl = new_p[used]; tl = loc[T_new]; frl = fr[used]
        pl = opt_local(pl, tl, self.case, frl)
        if (signed_area(pl, tl) <= 0).any(): return None
        # local flips in patch, then re-opt
        tl2, nf = flips(pl, tl)
        if nf:
            pl = opt_local(pl, tl2, self.case, frl); tl = tl2
            if (signed_area(pl, tl) <= 0).any(): return None
        F_new = energy_grad(pl, tl, self.case, need_grad=False)
        F_old = energy_grad(self.p, T_old, self.case, need_grad=False)
        dN = len(tl) - len(T_old)
        gain = -(F_new - F_old - dN * self.D / len(self.t))
        if gain <= 1e-4: return None
        P2 = new_p.copy(); P2[used] = pl
        used_set = set(used.tolist())
        T2 = np.vstack([np.delete(t, sorted(oldtris), axis=0), used[tl]])
        return gain, P2, T2, (removed_node if op == "collapse" else None)

    def accept(self, P2, T2, removed):
        if removed is not None:  # compact
            keep = np.ones(len(P2), bool); keep[removed] = False
            m = -np.ones(len(P2), np.int64); m[keep] = np.arange(keep.sum())
            P2 = P2[keep]; T2 = m[T2]
            self.fr = self.fr[keep]; self.bnd = self.bnd[keep]; self.ideal = self.ideal[keep]
        elif len(P2) > len(self.p):
            self.fr = np.vstack([self.fr, [[True, True]]]); self.bnd = np.r_[self.bnd, False]; self.ideal = np.r_[self.ideal, 6.0]
        self.p, self.t = P2, T2; self.rebuild()

    def candidates(self):
        bad = set(np.where(np.abs(self.val - self.ideal) > 0.6)[0])
        for i in np.where(self.q < 0.9)[0]: bad.update(self.t[i])
        cand = set()
        for v in bad:
            for u in self.nbrs(v): cand.add((min(u, v), max(u, v)))
        return sorted(cand)

def run(p, t, case, label, max_sweeps=4, ops=("flip", "collapse", "split"), log=None):
    M = Mesh(p, t, case)
    M.p = opt_local(M.p, M.t, case, M.fr, maxiter=3000); M.rebuild()
    stats(M.p, M.t, case, label + " start")
    for sw in range(max_sweeps):
        t0 = time.time(); acc = {o: 0 for o in ops}; tried = 0
        for (a, b) in M.candidates():
            if (a, b) not in M.e2t or max(a, b) >= len(M.p): continue
            best = None
            for op in ops:
                r = M.try_op(op, a, b); tried += 1
                if r and (best is None or r[0] > best[1][0]): best = (op, r)
            if best:
                M.accept(*best[1][1:]); acc[best[0]] += 1
        M.p = opt_local(M.p, M.t, case, M.fr, maxiter=3000); M.rebuild()
        s = stats(M.p, M.t, case, f"{label} sweep{sw} {acc}")
        print(f"   tried {tried} in {time.time()-t0:.0f}s", flush=True)
        if sum(acc.values()) == 0: break
    return M

if __name__ == "__main__":
    src, case, out = sys.argv[1], sys.argv[2], sys.argv[3]
    if src.endswith(".npz"):
        z = np.load(src); p, t = z["p"], z["t"]
    else:
        p, t = load(src)
    M = run(p, t, case, case)
    np.savez(out + ".npz", p=M.p, t=M.t); write(M.p, M.t, out + ".msh")
