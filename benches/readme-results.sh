#!/usr/bin/env bash
# Every scientific number in the README, regenerated from seeds of your choosing.
# Builds the release binary, makes a venv with SciPy and pandas under target/, and runs
# benches/readme_results.py with any arguments given (see its --help); about two hours on two
# cores, resumable (finished steps are kept in its --out).
#
#   benches/readme-results.sh --seed 12000                 # every step
#   benches/readme-results.sh --seed 12000 --only pilot    # one step
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
python=$(benches/bench-venv.sh scipy pandas)
exec "$python" benches/readme_results.py --handover target/release/handover "$@"
