#!/usr/bin/env bash
# Fuzzes the STEP reader (parser and conversion) for N minutes on the stable
# toolchain: adapters/truck/examples/fuzz_step.rs mutates the seed files
# (fixtures/step, and /work/shared/realstep or $STEP_CORPUS when present)
# with a fixed seed and runs each mutant through parse_step.
#
#   scripts/fuzz_step.sh [MINUTES] [SEED]      (defaults: 5 minutes, seed 1)
#
# Finds (panics, inputs slower than 10 s) go to fuzz-finds/. An abort or a
# hang (the run is killed after MINUTES + 2 minutes, under a 4 GB memory
# limit) leaves the input that caused it in fuzz-finds/current.step. Keep
# every find as a named regression test in adapters/truck/tests/.
set -uo pipefail
cd "$(dirname "$0")/.."

minutes=${1:-5}
seed=${2:-1}
corpus=${STEP_CORPUS:-/work/shared/realstep}

cargo build --release --quiet -p bubblemesh-truck --example fuzz_step || exit 2
seeds=(fixtures/step/*.step)
if [ -d "$corpus" ]; then
    # the smaller real files: more mutants per second
    while IFS= read -r f; do seeds+=("$f"); done < <(find "$corpus" -maxdepth 1 -type f \( -name '*.stp' -o -name '*.step' \) -size -400k | sort)
fi
echo "fuzzing the STEP reader for $minutes min, seed $seed, ${#seeds[@]} seed files"
(
    ulimit -v 4000000
    timeout $((minutes * 60 + 120)) target/release/examples/fuzz_step \
        --seconds $((minutes * 60)) --seed "$seed" --out fuzz-finds "${seeds[@]}"
)
status=$?
case $status in
    0) echo "no finds" ;;
    1) echo "finds in fuzz-finds/" ;;
    124) echo "hang: the input is fuzz-finds/current.step" ;;
    *) echo "abnormal exit $status: the input is fuzz-finds/current.step" ;;
esac
exit $status
