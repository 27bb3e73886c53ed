"""python3 check.py MESH.npz CASE : stats + meshcheck verdict + defect breakdown"""
import sys, json; from mtools import *
z = np.load(sys.argv[1]); p, t = z["p"], z["t"]; case = sys.argv[2]
s = stats(p, t, case, sys.argv[1])
out = sys.argv[1].replace(".npz", ".msh"); write(p, t, out)
r = meshcheck(out, case)
def find(d, pre=""):
    for k, v in d.items():
        if isinstance(v, dict): find(v, pre + k + ".")
        elif any(w in k for w in ("q_", "radius", "valid", "conform", "water", "invert", "band", "frac", "area", "ok", "components", "unref", "dup", "valence", "min_angle")):
            print("  ", pre + k, "=", v)
find(r)
q = qvals(p, t); fr, b = free_mask(p, t, case); val = np.bincount(t.ravel(), minlength=len(p))
defect = (~b) & (val != 6); touch = defect[t].any(1); tb = b[t].any(1)
for nm, m in [("touch defect", touch & ~tb), ("touch boundary", tb), ("clean interior", ~touch & ~tb)]:
    print(f"   {nm:15s} n={m.sum():5d} deficit {(1-q[m]).sum():6.2f} mean q {q[m].mean():.4f}")
# defects within 2 d of the boundary
x0, y0, x1, y1 = BOX[case]
db = np.minimum.reduce([p[:, 0] - x0, x1 - p[:, 0], p[:, 1] - y0, y1 - p[:, 1]])
for c in HOLES[case]: db = np.minimum(db, np.hypot(p[:, 0] - c[0], p[:, 1] - c[1]) - 0.2)
near = db < 2.5 * dfun(case, p[:, 0], p[:, 1])
print(f"   defects: total {defect.sum()}, within 2.5d of boundary {(defect & near).sum()}, deeper {(defect & ~near).sum()}")
