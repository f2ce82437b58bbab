#!/usr/bin/env bash
# One command on a fresh Debian bookworm machine: install everything, check it, run the demo.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_system.sh
bash scripts/install_python.sh
source scripts/_env.sh
"$BIOVLN_PY" -m biovln_ms.cli doctor
"$BIOVLN_PY" -m biovln_ms.cli demo --out "${BIOVLN_DEMO_OUT:-outputs/demo}"
