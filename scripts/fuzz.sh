#!/usr/bin/env bash
# Fuzzes the TOML domain reader, the mesh readers (.msh .vtu .stl .obj .mesh)
# and the --size expression parser on the stable toolchain (cli/tests/fuzz.rs):
# mutated copies of the seed corpus for a time budget, no panic and no hang
# allowed. Finds are saved in target/fuzz-finds/; keep one as a regression
# test by copying it to cli/tests/fuzz_finds/<target>/ (replayed by
# `fuzz_finds_stay_fixed`, which CI runs).
#
#   scripts/fuzz.sh [SECONDS] [SEED]
set -euo pipefail
cd "$(dirname "$0")/.."
export BUBBLEMESH_FUZZ_SECS="${1:-60}"
export BUBBLEMESH_FUZZ_SEED="${2:-6842425049093631233}"
# a mutated input must not take the machine down with it
ulimit -v 8000000 2>/dev/null || true
timeout $((BUBBLEMESH_FUZZ_SECS + 600)) \
  cargo test --release -p bubblemesh-cli --test fuzz -- --ignored --nocapture fuzz_for_a_time_budget
