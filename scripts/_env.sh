# Sourced by the scripts: the Python of the active virtual environment, else the repo's .venv.
if [ -n "${VIRTUAL_ENV:-}" ]; then
  BIOVLN_PY="$VIRTUAL_ENV/bin/python"
else
  BIOVLN_PY="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/.venv/bin/python"
fi
export BIOVLN_PY
