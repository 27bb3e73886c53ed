#!/usr/bin/env bash
# The Python package's CI (called by .ci/run; runnable by hand from any
# directory): builds the abi3 wheel with maturin, installs it into a fresh
# virtual environment with the test dependencies (numpy, pytest, meshio,
# CadQuery, build123d: pinned), and runs python/tests with pytest.
#
# With CI set, the CadQuery and build123d tests must run (a failed install
# fails); without it they skip with a printed reason where the packages are
# missing. BUBBLEMESH_PY_NO_CAD=1 skips installing them (a quick local run).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
work="$(mktemp -d "${TMPDIR:-/tmp}/bubblemesh-py-ci.XXXXXX")"
trap 'rm -rf "$work"' EXIT

# the crate's own checks (it is a workspace of its own, outside the main
# one's `cargo fmt --all` and `cargo clippy --workspace`)
cargo fmt --manifest-path "$here/Cargo.toml" -- --check
cargo clippy --manifest-path "$here/Cargo.toml" --features extension-module --all-targets -- -D warnings

# build: maturin in a venv of its own
python3 -m venv "$work/build"
"$work/build/bin/pip" install --quiet --disable-pip-version-check maturin==1.15.0
"$work/build/bin/maturin" build --release --manifest-path "$here/Cargo.toml" --out "$work/dist"
ls -l "$work/dist"

# install into a fresh venv and test
python3 -m venv "$work/test"
pip="$work/test/bin/pip"
cad=(cadquery==2.8.0 build123d==0.12.0)
if [ "${BUBBLEMESH_PY_NO_CAD:-}" = 1 ]; then
  cad=()
fi
# cadquery 2.8 and build123d 0.13 need different OCP builds; build123d 0.12
# shares cadquery's (about 2 GB installed, about 5 minutes)
"$pip" install --quiet --disable-pip-version-check "$work"/dist/bubblemesh-*.whl \
  numpy==2.4.6 pytest==8.4.2 meshio==5.3.5 "${cad[@]}"
cd "$work"
"$work/test/bin/python" -m pytest "$here/tests" -v -p no:cacheprovider -rs
