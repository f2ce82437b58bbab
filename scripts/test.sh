#!/usr/bin/env bash
# The whole test suite (run scripts/setup_and_demo.sh once first on a fresh machine).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/_env.sh
exec "$BIOVLN_PY" -m pytest -q "$@"
