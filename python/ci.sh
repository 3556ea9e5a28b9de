#!/usr/bin/env bash
# The Python package's CI: a fresh virtual environment in a temporary directory,
# `pip install ./python` (maturin builds the abi3 extension), then the pytest suite
# against scipy, and reckon.dask's tests on a 2-process Dask LocalCluster. Run from
# anywhere; PYTHON picks the interpreter (default python3).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="$(mktemp -d)"
trap 'rm -rf "$venv"' EXIT
"${PYTHON:-python3}" -m venv "$venv"
"$venv/bin/python" -m pip install --quiet "$here" pytest scipy numpy "dask[distributed]"
cargo fmt --check --manifest-path "$here/Cargo.toml"
# from the tests folder, so that `import reckon` is the installed package, not ./reckon
cd "$here/tests"
"$venv/bin/python" -m pytest -q -p no:cacheprovider
