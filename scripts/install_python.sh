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
# Python 3.13+: mani-skill pins mplib==0.1.1 (used only by ManiSkill's motion-planning examples), which has
# no wheel beyond CPython 3.12 and no source release; so every tested pin but mplib goes in without
# dependency resolution (BIOVLN_WITHOUT_MPLIB=1 forces this route, =0 forbids it), and pip check may miss
# nothing else.
without_mplib="${BIOVLN_WITHOUT_MPLIB:-$(python -c 'import sys; print(int(sys.version_info >= (3, 13)))')}"
if [ "$without_mplib" = "1" ]; then
  echo "[install_python] installing every tested pin but mplib (no wheel for this Python)"
  pins="$(mktemp)"
  grep -v -i -E '^(mplib|torch)==' scripts/constraints.txt | grep -v -E '^[[:space:]]*(#|$)' >"$pins"
  python -m pip install -q --no-deps -r "$pins"
  rm -f "$pins"
  python -m pip install -q --no-deps -e ".[dev]"
  broken="$(python -m pip check 2>&1 | grep -v -E 'requires mplib, which is not installed|^No broken requirements' || true)"
  if [ -n "$broken" ]; then
    echo "$broken" >&2
    exit 1
  fi
elif [ "${BIOVLN_UNPINNED:-0}" = "1" ]; then
  python -m pip install -q -e ".[dev]"
else
  python -m pip install -q -e ".[dev]" -c scripts/constraints.txt
fi
python -c "import biovln_ms, sys; print('[install_python] biovln_ms', biovln_ms.__version__, 'in', sys.prefix)"
