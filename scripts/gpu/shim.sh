#!/usr/bin/env bash
# Make biovln_ms importable from a checkout without installing it (no package index on a GPU machine):
#
#     bash scripts/gpu/shim.sh DEST      # then: PYTHONPATH=DEST (and PYTHONSAFEPATH=1 when run from the repo)
#
# DEST/biovln_ms holds a symlink to each entry of the repo's biovln_ms/, plus tasks, agents and assets
# linked to the repo's top-level folders: the layout pyproject.toml's package-dir gives an installed
# biovln_ms (biovln_ms.tasks = tasks/, biovln_ms.agents = agents/, biovln_ms.assets = assets/).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DEST=${1:?usage: shim.sh DEST}
rm -rf "$DEST/biovln_ms"
mkdir -p "$DEST/biovln_ms"
for e in "$ROOT"/biovln_ms/*; do
  [ "$(basename "$e")" = __pycache__ ] || ln -s "$e" "$DEST/biovln_ms/$(basename "$e")"
done
for d in tasks agents assets; do ln -sfn "$ROOT/$d" "$DEST/biovln_ms/$d"; done
