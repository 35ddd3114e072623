#!/usr/bin/env bash
# Exact mutual-information selection, `handover research score` against NumPy, side by side in one run.
# Builds the release binary, makes a venv with NumPy (and JAX, with --jax) under target/, and
# runs benches/score_vs_numpy.py with any arguments given (see its --help).
#
#   benches/score-vs-numpy.sh                      # 5000 × 8 × 2000, both on every core
#   benches/score-vs-numpy.sh --jax                # and JAX, float64 and float32
#   RAYON_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 benches/score-vs-numpy.sh   # one core each
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
packages=(numpy)
for arg in "$@"; do
  if [ "$arg" = --jax ]; then
    packages+=("jax[cpu]")
  fi
done
python=$(benches/bench-venv.sh "${packages[@]}")
exec "$python" benches/score_vs_numpy.py --handover target/release/handover "$@"
