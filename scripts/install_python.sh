#!/usr/bin/env bash
# Creates .venv (unless a virtual environment is already active) and installs
# BioVLN-MS with its dev extras. torch==2.13.0 goes in first, on its own: a
# CPU wheel is available locally, while an unpinned torch pulled in by
# mani-skill would fetch several GB of CUDA wheels.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${VIRTUAL_ENV:-}" ]; then
  if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
  fi
  # shellcheck disable=SC1091
  source .venv/bin/activate
fi
python -m pip install -q --upgrade pip setuptools wheel
python -m pip install -q "torch==${BIOVLN_TORCH_VERSION:-2.13.0}"
# constraints.txt pins the versions the tests were run with (asset regeneration is byte-exact
# only for the same trimesh/Pillow/numpy); BIOVLN_UNPINNED=1 skips it.
if [ "${BIOVLN_UNPINNED:-0}" = "1" ]; then
  python -m pip install -q -e ".[dev]"
else
  python -m pip install -q -e ".[dev]" -c scripts/constraints.txt
fi
python -c "import biovln_ms, sys; print('[install_python] biovln_ms', biovln_ms.__version__, 'in', sys.prefix)"
