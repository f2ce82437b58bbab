#!/usr/bin/env bash
# The test suite (run scripts/setup_and_demo.sh once first on a fresh machine): ruff (lint with the
# configured line length, and the formatter's check), then pytest on every core, one test file per worker
# (pytest-xdist; BIOVLN_TEST_WORKERS=0 runs them in this process). import-linter's contracts run inside it.
#
#   bash scripts/test.sh          the developer's suite: every test but those marked slow
#   bash scripts/test.sh --all    every test (CI runs this); other arguments go to pytest
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/_env.sh
select=(-m "not slow")
if [[ "${1:-}" == "--all" ]]; then
  select=()
  shift
fi
"$BIOVLN_PY" -m ruff check .
"$BIOVLN_PY" -m ruff format --check .
exec "$BIOVLN_PY" -m pytest -q -n "${BIOVLN_TEST_WORKERS:-auto}" --dist loadfile "${select[@]}" "$@"
