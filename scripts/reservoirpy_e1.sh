#!/usr/bin/env bash
# Runs scripts/reservoirpy_e1.py with ReservoirPy 0.4.2 in its own venv
# (.venv-bench/, gitignored; created on first use from PyPI). Called by
# `cargo xtask bench --vs-reservoirpy` with the JSON file of E1's data; prints
# one JSON object (`--setup`: make the venv and stop). BLAS is held to one thread: on two cores, two BLAS threads
# beside the Python loop make ReservoirPy slower, not faster.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv-bench/bin/python ] || ! .venv-bench/bin/python -c "import reservoirpy, sys; sys.exit(reservoirpy.__version__ != '0.4.2')" 2>/dev/null; then
  echo "creating .venv-bench with reservoirpy 0.4.2 …" >&2
  python3 -m venv .venv-bench
  .venv-bench/bin/pip install -q "reservoirpy==0.4.2" numpy scipy >&2
fi
# `--setup` only makes the venv.
if [ "${1:-}" = "--setup" ]; then exit 0; fi
OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 exec .venv-bench/bin/python scripts/reservoirpy_e1.py "$1"
