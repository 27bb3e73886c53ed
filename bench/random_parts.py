#!/usr/bin/env python3
"""bench/random_parts.py -- seeded random machined parts as STEP files, for
robustness sweeps of bubblemesh against Gmsh on parts nobody tuned for.

    python3 bench/random_parts.py --count 40 --seed 1 --out bench/out/random_parts
    python3 bench/run_realstep.py --dir bench/out/random_parts   # mesh them all

Each part is built with Gmsh's OpenCascade kernel (`pip install gmsh`) from a
recipe drawn with `random.Random(seed + k)`, so part k is the same on every
machine with the same Gmsh: a base (a box, a cylinder, or a plate), then two
to five features from through holes, blind pockets, bosses, counterbores, a
spherical dimple or void, a slot, a rib, then fillets or chamfers on a random
subset of the edges (radii from far below to about the spacing the benchmark
uses, diag/20: where bubble packing meets features smaller than its
spacing). A feature whose Boolean or blend OpenCascade refuses is skipped
(the recipe says so). Written by OpenCascade's STEP writer, in millimetres;
`recipes.json` beside the files lists what each part is made of.

The parts are not in the repository (they are made in seconds); the sweep's
findings are, as named fixtures and regression tests.
"""
import argparse, json, math, os, random, sys


def build(gmsh, rng):
    """One part in the current Gmsh model; returns its recipe (a list of
    strings) or None when OpenCascade gave no single solid."""
    occ = gmsh.model.occ
    recipe = []
    kind = rng.choice(["box", "box", "plate", "cylinder"])
    if kind == "box":
        dx, dy, dz = (rng.uniform(20, 80) for _ in range(3))
    elif kind == "plate":
        dx, dy, dz = rng.uniform(40, 120), rng.uniform(30, 80), rng.uniform(3, 10)
    else:
        r, h = rng.uniform(10, 40), rng.uniform(10, 60)
        dx = dy = 2 * r
        dz = h
    if kind == "cylinder":
        vol = occ.addCylinder(0, 0, 0, 0, 0, dz, dx / 2)
        x0, y0 = -dx / 2, -dy / 2
    else:
        vol = occ.addBox(0, 0, 0, dx, dy, dz)
        x0, y0 = 0.0, 0.0
    recipe.append(f"{kind} {dx:.3g} x {dy:.3g} x {dz:.3g}")
    size = min(dx, dy, dz)

    def inside_xy(margin):
        return (x0 + rng.uniform(margin, dx - margin), y0 + rng.uniform(margin, dy - margin))

    def apply(op, tool, what):
        nonlocal vol
        try:
            if op == "cut":
                out, _ = occ.cut([(3, vol)], [(3, tool)])
            else:
                out, _ = occ.fuse([(3, vol)], [(3, tool)])
            occ.synchronize()
        except Exception as e:  # OpenCascade refused: skip the feature
            recipe.append(f"skipped {what}: {str(e)[:60]}")
            return
        solids = [t for d, t in out if d == 3]
        if len(solids) != 1:
            recipe.append(f"skipped {what}: {len(solids)} solids")
            occ.remove(out, recursive=True)
            return
        vol = solids[0]
        recipe.append(what)

    for _ in range(rng.randint(2, 5)):
        f = rng.choice(["hole", "hole", "pocket", "boss", "cbore", "dimple", "slot", "rib", "void"])
        m = 0.15 * min(dx, dy)
        x, y = inside_xy(m)
        if f == "hole":
            r = rng.uniform(0.03, 0.15) * min(dx, dy)
            apply("cut", occ.addCylinder(x, y, -1, 0, 0, dz + 2, r), f"hole r={r:.3g}")
        elif f == "pocket":
            a, b, c = rng.uniform(0.1, 0.4) * dx, rng.uniform(0.1, 0.4) * dy, rng.uniform(0.2, 0.7) * dz
            apply("cut", occ.addBox(x - a / 2, y - b / 2, dz - c, a, b, c + 1), f"pocket {a:.3g}x{b:.3g}x{c:.3g}")
        elif f == "boss":
            r, h = rng.uniform(0.05, 0.15) * min(dx, dy), rng.uniform(0.1, 0.5) * size
            apply("fuse", occ.addCylinder(x, y, dz - 0.01 * size, 0, 0, h, r), f"boss r={r:.3g} h={h:.3g}")
        elif f == "cbore":
            r = rng.uniform(0.03, 0.08) * min(dx, dy)
            R, depth = r * rng.uniform(1.4, 2.0), rng.uniform(0.1, 0.4) * dz
            apply("cut", occ.addCylinder(x, y, -1, 0, 0, dz + 2, r), f"cbore hole r={r:.3g}")
            apply("cut", occ.addCylinder(x, y, dz - depth, 0, 0, depth + 1, R), f"cbore R={R:.3g} depth={depth:.3g}")
        elif f == "dimple":
            r = rng.uniform(0.05, 0.2) * min(dx, dy)
            apply("cut", occ.addSphere(x, y, dz + rng.uniform(-0.5, 0.5) * r, r), f"dimple r={r:.3g}")
        elif f == "void":
            r = rng.uniform(0.05, 0.2) * size
            if r < 0.4 * dz:
                apply("cut", occ.addSphere(x, y, dz / 2, r), f"void r={r:.3g}")
        elif f == "slot":
            w, l = rng.uniform(0.03, 0.1) * min(dx, dy), rng.uniform(0.2, 0.5) * dx
            apply("cut", occ.addBox(x - l / 2, y - w / 2, -1, l, w, dz + 2), f"slot {l:.3g}x{w:.3g}")
        elif f == "rib":
            t, h = rng.uniform(0.01, 0.05) * max(dx, dy), rng.uniform(0.1, 0.5) * size
            apply("fuse", occ.addBox(x0 + 0.1 * dx, y - t / 2, dz - 0.01 * size, 0.8 * dx, t, h), f"rib t={t:.3g} h={h:.3g}")
    # blends on a random subset of the edges
    diag = math.sqrt(dx * dx + dy * dy + dz * dz)
    occ.synchronize()
    curves = sorted(t for _, t in gmsh.model.getEntities(1))
    if curves and rng.random() < 0.8:
        pick = rng.sample(curves, max(1, int(len(curves) * rng.uniform(0.1, 0.6))))
        r = diag / 20 * rng.choice([0.05, 0.15, 0.3, 0.6, 1.0])
        blend = rng.choice(["fillet", "fillet", "chamfer"])
        try:
            if blend == "fillet":
                out = occ.fillet([vol], pick, [r], removeVolume=False)
            else:
                # a chamfer needs, per edge, the face its distance is measured on
                faces = [gmsh.model.getAdjacencies(1, c)[0][0] for c in pick]
                out = occ.chamfer([vol], pick, faces, [r], removeVolume=False)
            occ.synchronize()
            solids = [t for d, t in out if d == 3]
            if len(solids) == 1:
                occ.remove([(3, vol)], recursive=True)
                occ.synchronize()
                vol = solids[0]
                recipe.append(f"{blend} r={r:.3g} on {len(pick)} of {len(curves)} edges")
            else:
                occ.remove(out, recursive=True)
                occ.synchronize()
                recipe.append(f"skipped {blend}: {len(solids)} solids")
        except Exception as e:
            recipe.append(f"skipped {blend} r={r:.3g}: {str(e)[:60]}")
    occ.synchronize()
    vols = gmsh.model.getEntities(3)
    if len(vols) != 1:
        return None
    return recipe


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "out", "random_parts"))
    a = ap.parse_args()
    try:
        import gmsh
    except ImportError:
        sys.exit("random_parts.py needs Gmsh's Python package: pip install gmsh")
    os.makedirs(a.out, exist_ok=True)
    recipes = {}
    for k in range(a.count):
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(f"part{k}")
        rng = random.Random(a.seed * 100003 + k)
        name = f"rp_{a.seed}_{k:03d}.step"
        try:
            recipe = build(gmsh, rng)
        except Exception as e:  # OpenCascade gave up on the part as a whole
            recipe = None
            print(f"{name}: OpenCascade failed ({str(e)[:60]}), skipped")
        if recipe is None:
            print(f"{name}: not a single solid, skipped")
        else:
            # OpenCascade's STEP writer prints its statistics on fd 1
            sys.stdout.flush()
            saved = os.dup(1)
            with open(os.devnull, "w") as null:
                os.dup2(null.fileno(), 1)
                try:
                    gmsh.write(os.path.join(a.out, name))
                finally:
                    os.dup2(saved, 1)
                    os.close(saved)
            recipes[name] = recipe
            print(f"{name}: {'; '.join(recipe)}")
        gmsh.finalize()
    with open(os.path.join(a.out, "recipes.json"), "w") as f:
        json.dump(recipes, f, indent=1)


if __name__ == "__main__":
    main()
