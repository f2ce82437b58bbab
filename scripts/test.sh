#!/usr/bin/env bash
# The whole test suite (run scripts/setup_and_demo.sh once first on a fresh machine): ruff (lint with the
# configured line length, and the formatter's check), then pytest (import-linter's layer contracts run inside it).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/_env.sh
"$BIOVLN_PY" -m ruff check .
"$BIOVLN_PY" -m ruff format --check .
exec "$BIOVLN_PY" -m pytest -q "$@"
