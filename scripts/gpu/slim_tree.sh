#!/usr/bin/env bash
# The working tree travels whole with every GPU call (64 MiB with what is carried). These tracked paths
# are not read by run_all.sh's sections (the carried dataset holds the LSAT split built from
# assets/scenes), so a call can leave them behind:
#
#     bash scripts/gpu/slim_tree.sh size      # bytes that travel with them left behind
#     bash scripts/gpu/slim_tree.sh slim      # remove them from the index and the disk (clean tree only)
#     bash scripts/gpu/slim_tree.sh restore   # put them back from the commit `slim` saw
#
# `slim` refuses a tree with changes and notes HEAD in .git/biovln-slim; `restore` refuses without that
# note or when HEAD has moved (a commit made while slimmed would record the removals), and puts back only
# the paths `slim` removed.
set -euo pipefail
cd "$(dirname "$0")/../.."
LEFT_BEHIND=(docs tests assets/perception assets/scenes) # docs, tests, detector weights, the LSAT scene
NOTE=$(git rev-parse --git-path biovln-slim)
case "${1:-}" in
  size)
    git ls-files -z --cached --others --exclude-standard -- . "${LEFT_BEHIND[@]/#/:!}" \
      | du --files0-from=- -cb 2>/dev/null | tail -1 | cut -f1 ;;
  slim)
    if [ -e "$NOTE" ]; then
      echo "slim_tree.sh: already slimmed (at $(cat "$NOTE")); run: bash scripts/gpu/slim_tree.sh restore" >&2
      exit 1
    fi
    if [ -n "$(git status --porcelain)" ]; then
      echo "slim_tree.sh: the tree has changes; commit or stash them first" >&2
      exit 1
    fi
    git rev-parse HEAD >"$NOTE"
    git rm -r -q -- "${LEFT_BEHIND[@]}"
    echo "slim_tree.sh: left behind ${LEFT_BEHIND[*]} (do not commit now); put back with: bash scripts/gpu/slim_tree.sh restore" ;;
  restore)
    if [ ! -e "$NOTE" ]; then
      echo "slim_tree.sh: nothing to restore (no slim recorded in $NOTE)" >&2
      exit 1
    fi
    at=$(cat "$NOTE")
    if [ "$(git rev-parse HEAD)" != "$at" ]; then
      echo "slim_tree.sh: HEAD moved since slim ($at); check the last commit for removals, then: git checkout $at -- ${LEFT_BEHIND[*]}" >&2
      exit 1
    fi
    git reset -q "$at" -- "${LEFT_BEHIND[@]}"
    git checkout "$at" -- "${LEFT_BEHIND[@]}"
    rm -f "$NOTE"
    echo "slim_tree.sh: restored ${LEFT_BEHIND[*]}" ;;
  *) echo "usage: slim_tree.sh size|slim|restore" >&2; exit 2 ;;
esac
