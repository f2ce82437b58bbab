#!/usr/bin/env bash
# The env's smoke tests against ManiSkill's nightly (dist mani-skill-nightly, import name mani_skill) in a
# separate virtual environment, so that the pinned .venv stays on mani-skill 3.0.1. The adapter that
# absorbs the differences is biovln_ms/sim/maniskill_compat.py; the table of differences is in
# docs/guides/envs-and-variants/maniskill.md.
#
#   bash scripts/check_maniskill_nightly.sh              overlay venv (CI): the nightly over .venv's packages
#   BIOVLN_NIGHTLY_MODE=full bash scripts/...            a venv of its own: torch, the package, the nightly
#   BIOVLN_MS_NIGHTLY=latest bash scripts/...            the newest nightly instead of the tested one
#
# overlay: a venv without pip whose site-packages holds only the nightly (no dependencies: they are 3.0.1's,
# bar sapien>=3.0.3, which the pins meet) and a .pth that adds .venv's site-packages after it, so
# mani_skill imports from the nightly and everything else from .venv. full: the whole install, as
# scripts/install_python.sh does it, with the pins minus mani_skill's (much slower: every package again).
# Environment: BIOVLN_NIGHTLY_VENV (default /tmp/ms-nightly[-full]), BIOVLN_NIGHTLY_PYTHON (full mode's
# interpreter; default python3.11, else python3), BIOVLN_TORCH_VERSION (default 2.13.0).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/_env.sh
repo="$(pwd)"
mode="${BIOVLN_NIGHTLY_MODE:-overlay}"
nightly="${BIOVLN_MS_NIGHTLY:-2026.8.2.400}"
spec="mani-skill-nightly==$nightly"
[ "$nightly" = "latest" ] && spec="mani-skill-nightly"
# CI runs the adapter and the env-structure smoke (make, reset, step with an episode source); BIOVLN_NIGHTLY_FULL=1
# adds the env's fast tests (several minutes more)
smoke=(tests/test_maniskill_compat.py tests/test_env_structure.py)
[ "${BIOVLN_NIGHTLY_FULL:-0}" = "1" ] && smoke+=(tests/test_nav_env.py)

installed() {  # the nightly's version in the venv of interpreter $1, or nothing
  "$1" -c "import importlib.metadata as m; print(m.version('mani-skill-nightly'))" 2>/dev/null || true
}

case "$mode" in
  overlay)
    venv="${BIOVLN_NIGHTLY_VENV:-/tmp/ms-nightly}"
    [ -x "$venv/bin/python" ] || "$BIOVLN_PY" -m venv --without-pip "$venv"
    # written on every run: the venv may have been made over another checkout's .venv
    base="$("$BIOVLN_PY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
    own="$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
    echo "import site; site.addsitedir('$base')" >"$own/zz_biovln_base.pth"
    if [ "$(installed "$venv/bin/python")" != "$nightly" ]; then
      "$BIOVLN_PY" -m pip --python "$venv/bin/python" install -q --upgrade --no-deps --no-compile "$spec"
    fi
    ;;
  full)
    venv="${BIOVLN_NIGHTLY_VENV:-/tmp/ms-nightly-full}"
    py="${BIOVLN_NIGHTLY_PYTHON:-}"
    for candidate in python3.11 python3; do  # a pyenv shim is on PATH but runs only selected versions
      [ -z "$py" ] && command -v "$candidate" >/dev/null && "$candidate" -c "" 2>/dev/null && py="$candidate" || true
    done
    [ -x "$venv/bin/python" ] || "$py" -m venv "$venv"
    vpy="$venv/bin/python"
    if [ "$(installed "$vpy")" != "$nightly" ]; then
      # torch first, on its own (scripts/install_python.sh); the package with the tested pins minus
      # mani_skill's; then the nightly in place of mani-skill (both install the import package mani_skill)
      cons="$(mktemp)"
      trap 'rm -f "$cons"' EXIT
      grep -v -i -E '^mani[-_]skill==' scripts/constraints.txt >"$cons"
      "$vpy" -m pip install -q --upgrade pip
      "$vpy" -m pip install -q --no-compile "torch==${BIOVLN_TORCH_VERSION:-2.13.0}"
      "$vpy" -m pip install -q --no-compile -e "$repo[dev]" -c "$cons"
      "$vpy" -m pip uninstall -q -y mani-skill
      "$vpy" -m pip install -q --upgrade --no-compile "$spec" -c "$cons"
    fi
    ;;
  *)
    echo "BIOVLN_NIGHTLY_MODE must be overlay or full, got '$mode'" >&2
    exit 2
    ;;
esac
"$venv/bin/python" -c "from biovln_ms.sim.maniskill_compat import maniskill_distribution as d
import mani_skill; print('[nightly]', *d(), 'from', mani_skill.__file__)"
exec "$venv/bin/python" -m pytest -q -p no:cacheprovider -m "not slow" "${smoke[@]}" "$@"
