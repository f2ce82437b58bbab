#!/usr/bin/env bash
# Creates .venv-blender: Blender as a Python module (the `bpy` wheel from the package index, ~375 MB)
# plus what the LSAT part of biovln_ms needs, for the headless add-on test
# (tests/test_blender_addon.py). bpy pins numpy 1.26, which the simulator stack does not accept, so
# Blender gets its own environment; biovln_ms is installed into it without dependencies.
set -euo pipefail
cd "$(dirname "$0")/.."
PY="${BIOVLN_BLENDER_BASE_PYTHON:-python3.11}"
command -v "$PY" >/dev/null || PY=python3
if [ ! -x .venv-blender/bin/python ]; then
  "$PY" -m venv .venv-blender
fi
.venv-blender/bin/python -m pip install -q --upgrade pip
.venv-blender/bin/python -m pip install -q bpy gymnasium pydantic rapidfuzz scipy shapely trimesh pyyaml usd-core pillow numba \
  -c scripts/constraints-blender.txt
.venv-blender/bin/python -m pip install -q --no-deps -e .
.venv-blender/bin/python -c "import bpy, biovln_ms.lsat.importer, biovln_ms.lsat.markers; print('[install_blender] Blender', bpy.app.version_string)"
