#!/usr/bin/env bash
# The benchmarks' Python: a venv under target/ with the packages given, made on first use.
# Prints its interpreter's path.
#
#   python=$(benches/bench-venv.sh numpy)
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/bench-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv" >&2
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "$@" >&2
echo "$PWD/$venv/bin/python"
