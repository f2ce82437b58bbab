#!/usr/bin/env bash
# Installs BioVLN-MS into a fresh virtual environment per Python version and runs the fast tests there
# (docs/quickstart.md lists the versions checked and the dependency that blocks the others).
#
#   bash scripts/check_python_versions.sh                 3.11, 3.12 and 3.13, the fast suite on each
#   bash scripts/check_python_versions.sh 3.12            one version
#   BIOVLN_PYCHECK_TESTS="tests/test_a.py tests/test_b.py" bash scripts/check_python_versions.sh 3.12
#
# An interpreter is python3.X on PATH, else pyenv's newest 3.X. The venvs are kept in
# ${BIOVLN_PYCHECK_DIR:-/tmp}/biovln-py3.X (a second run reuses them). A version whose install fails is
# reported with pip's "no matching distribution" line (the dependency that blocks it) and the script goes on
# to the next; the exit status is non-zero if any version failed to install or to pass. pyproject's
# requires-python is ignored here, so that a version outside it shows what still blocks it. 3.13+ takes
# scripts/install_python.sh's route without mplib (mani-skill pins it; it has no wheel there).
set -uo pipefail
cd "$(dirname "$0")/.."
repo="$(pwd)"
versions=("$@")
[ ${#versions[@]} -eq 0 ] && versions=(3.11 3.12 3.13)
root="${BIOVLN_PYCHECK_DIR:-/tmp}"
# the tested pins, except that torch's local label (+cpu) is dropped: PyPI's torch 2.13.0 wheels for
# 3.12+ have none, and ==2.13.0 still matches the +cpu wheel where one is found
cons="$(mktemp)"
trap 'rm -f "$cons"' EXIT
sed -E 's/^torch==([0-9.]+)\+[a-z0-9]+$/torch==\1/' scripts/constraints.txt >"$cons"
status=0
summary=()

find_python() {
  local v="$1" p
  p="$(command -v "python$v" || true)"
  # a pyenv shim is on PATH for every version but runs only the selected ones
  [ -n "$p" ] && ! "$p" -c "" >/dev/null 2>&1 && p=""
  if [ -z "$p" ] && [ -d "${PYENV_ROOT:-$HOME/.pyenv}/versions" ]; then
    p="$(ls -d "${PYENV_ROOT:-$HOME/.pyenv}/versions/$v".* 2>/dev/null | sort -V | tail -1)"
    [ -n "$p" ] && p="$p/bin/python"
  fi
  echo "$p"
}

for v in "${versions[@]}"; do
  py="$(find_python "$v")"
  if [ -z "$py" ] || [ ! -x "$py" ]; then
    summary+=("$v: no interpreter (python$v on PATH or pyenv $v.*)")
    status=1
    continue
  fi
  venv="$root/biovln-py$v"
  log="$venv.install.log"
  [ -x "$venv/bin/python" ] || "$py" -m venv "$venv"
  vpy="$venv/bin/python"
  echo "[pycheck] $v: installing into $venv ($("$py" --version))"
  start=$SECONDS
  route="pinned"
  if "$vpy" -c 'import sys; sys.exit(sys.version_info < (3, 13))'; then
    # mani-skill's mplib==0.1.1 has no wheel here: install_python.sh's route without it
    route="every pin but mplib"
    if ! VIRTUAL_ENV="$venv" PATH="$venv/bin:$PATH" BIOVLN_WITHOUT_MPLIB=1 bash scripts/install_python.sh >"$log" 2>&1; then
      summary+=("$v: install without mplib failed: see $log")
      status=1
      continue
    fi
  # a dry run first: it resolves every dependency from the registry's metadata without installing, so a
  # version that a dependency blocks is told in seconds, not after torch's download
  elif ! {
    "$vpy" -m pip install -q --upgrade pip setuptools wheel &&
      "$vpy" -m pip install --dry-run --ignore-installed --ignore-requires-python "torch==${BIOVLN_TORCH_VERSION:-2.13.0}" \
        -e "$repo[dev]" -c "$cons" &&
      "$vpy" -m pip install -q --no-compile "torch==${BIOVLN_TORCH_VERSION:-2.13.0}" -c "$cons" &&
      "$vpy" -m pip install -q --no-compile --ignore-requires-python -e "$repo[dev]" -c "$cons"
  } >"$log" 2>&1; then
    blocker="$(grep -h -m1 'No matching distribution found for' "$log" || true)"
    if [ -z "$blocker" ] && grep -q 'no matching distributions available' "$log"; then
      # a resolution conflict: the package that has no distribution for this Python, and who asks for it
      blocker="no distribution of $(grep -h -A1 'no matching distributions available' "$log" | tail -1 | xargs)"
      blocker+=" for this Python ($(grep -h -A2 'The conflict is caused by' "$log" | sed 1d | xargs))"
    fi
    summary+=("$v: install failed: ${blocker:-see $log}")
    status=1
    continue
  fi
  echo "[pycheck] $v: installed ($route) in $((SECONDS - start)) s"
  # shellcheck disable=SC2206
  tests=(${BIOVLN_PYCHECK_TESTS:-})
  start=$SECONDS
  if "$vpy" -m pytest -q -p no:cacheprovider -n "${BIOVLN_TEST_WORKERS:-1}" --dist loadfile -m "not slow" \
    "${tests[@]}"; then
    summary+=("$v: installed ($route), fast tests passed (${tests[*]:-the whole fast suite}) in $((SECONDS - start)) s")
  else
    summary+=("$v: installed, fast tests FAILED (${tests[*]:-the whole fast suite})")
    status=1
  fi
done
printf '[pycheck] %s\n' "${summary[@]}"
exit $status
