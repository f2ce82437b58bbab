#!/usr/bin/env bash
# The working tree travels whole with every GPU call (64 MiB with what is carried). These tracked paths
# are not read by run_all.sh's sections, so a call can leave them behind:
#
#     bash scripts/gpu/slim_tree.sh size      # bytes that travel with them left behind
#     bash scripts/gpu/slim_tree.sh slim      # remove them from the index and the disk (clean tree only)
#     bash scripts/gpu/slim_tree.sh restore   # put them back from HEAD
#
# `slim` refuses a tree with changes, so `restore` gives back exactly what was there.
set -euo pipefail
cd "$(dirname "$0")/../.."
LEFT_BEHIND=(docs tests assets/perception) # documentation, the test suite, the detector's weights
case "${1:-}" in
  size)
    git ls-files -z --cached --others --exclude-standard -- . "${LEFT_BEHIND[@]/#/:!}" \
      | du --files0-from=- -cb 2>/dev/null | tail -1 | cut -f1 ;;
  slim)
    if [ -n "$(git status --porcelain)" ]; then
      echo "slim_tree.sh: the tree has changes; commit or stash them first (restore checks out HEAD)" >&2
      exit 1
    fi
    git rm -r -q -- "${LEFT_BEHIND[@]}"
    echo "slim_tree.sh: left behind ${LEFT_BEHIND[*]}; put back with: bash scripts/gpu/slim_tree.sh restore" ;;
  restore)
    git reset -q HEAD -- "${LEFT_BEHIND[@]}"
    git checkout -- "${LEFT_BEHIND[@]}"
    echo "slim_tree.sh: restored ${LEFT_BEHIND[*]}" ;;
  *) echo "usage: slim_tree.sh size|slim|restore" >&2; exit 2 ;;
esac
