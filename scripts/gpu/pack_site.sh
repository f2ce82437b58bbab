#!/usr/bin/env bash
# Pack wheels into one compressed site folder: what `pip install --target` would make of them, as a
# .tar.xz that run_all.sh unpacks with `tar` (the wheels' own zip compression is weaker than xz over
# their contents together, and a call may carry only 64 MiB):
#
#     bash scripts/gpu/pack_site.sh WHEELS_DIR OUT.tar.xz [pip target options...]
#
# With no options the wheels must suit this machine's Python (rehearse.py); prepare.sh passes the GPU
# machine's (--python-version 3.12 --implementation cp --platform ... --only-binary=:all:). The archive
# is reproducible: names sorted, times, owners and modes fixed.
set -euo pipefail
WHEELS=${1:?usage: pack_site.sh WHEELS_DIR OUT.tar.xz [pip options]}
OUT_TAR=${2:?usage: pack_site.sh WHEELS_DIR OUT.tar.xz [pip options]}
shift 2
PY=${PYTHON:-python3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$PY" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --disable-pip-version-check \
  --target "$tmp/site" "$@" "$WHEELS"/*.whl
# the wheels' console scripts name this machine's interpreter, and pip's direct_url.json this folder's
# path: neither belongs to the packed folder (nothing runs the scripts there)
rm -rf "$tmp/site/bin"
find "$tmp/site" -path '*.dist-info/direct_url.json' -delete
find "$tmp/site" -path '*.dist-info/RECORD' -exec sed -i '/\.dist-info\/direct_url\.json,/d' {} +
mkdir -p "$(dirname "$OUT_TAR")"
tar --sort=name --mtime=@0 --owner=0 --group=0 --numeric-owner --mode=u+rwX,go+rX,go-w \
  -C "$tmp/site" -cf - . | xz -T2 -6 >"$tmp/site.tar.xz"
mv "$tmp/site.tar.xz" "$OUT_TAR"
unpacked=$(du -sb "$tmp/site" | cut -f1)
awk -v a="$unpacked" -v b="$(stat -c %s "$OUT_TAR")" -v f="$OUT_TAR" \
  'BEGIN{printf "pack_site: %s: %.1f MiB (%.1f MiB unpacked)\n", f, b/1048576, a/1048576}'
