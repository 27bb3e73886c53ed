#!/bin/sh
# Reproduces the research meshes of README.md (python3 with numpy, scipy,
# meshio and `pip install triangle`). About 5 min for B and 8 min for C.
# Needs the engine's meshes first: python3 bench/run_2d.py --cases B,C --reps 1
set -e
cd "$(dirname "$0")"
python3 buildB.py 13 0.4 face     # icosphere nu=13 projected stereographically -> B_ico_n13_a0.4_face0.npz
python3 cleanup.py B_ico_n13_a0.4_face0.npz B B_ico_clean
python3 buildC.py 0.5 0.6         # log-polar rings of 63 nodes -> C_lattice_a0.5_b0.6.npz
python3 cleanup.py C_lattice_a0.5_b0.6.npz C C_clean2
python3 buildCones.py B; python3 buildCones.py C   # the general construction (engine::conformal)
python3 check.py B_ico_clean.npz B; python3 check.py C_clean2.npz C
python3 bndcheck.py B_ico_clean.npz B; python3 bndcheck.py C_clean2.npz C
