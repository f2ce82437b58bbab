#!/usr/bin/env bash
# Run HERE (a CPU machine with the package index), before a session's first call to a GPU machine:
#
#     bash scripts/gpu/prepare.sh
#
# Fills the git-ignored folders that travel with the call (carry: [".site", ".gl"]):
#   .site/site.tar.xz  the cp312 manylinux wheels the GPU machine lacks (scripts/gpu/wheels.txt, versions
#          from scripts/constraints.txt; mani-skill and sapien repacked without unused assets by
#          scripts/gpu/repack_maniskill.py), installed into one folder and xz-packed (pack_site.sh); the
#          wheels themselves stay in .whl/ here
#   .site/dataset/biovln  the default dataset built here (deterministic), so the GPU machine checks it
#          instead of building it
#   .gl/   the Vulkan / EGL / GL loaders as Debian packages (the device docs' recipe), and in .gl/x11/
#          libX11 and its libraries (SAPIEN's libsvulkan2.so links libX11.so.6; run_all.sh unpacks them
#          into /tmp/x11root only where the machine has no libX11)
# then checks the wheels' dependency closure against the machine's package list
# (scripts/gpu/check_closure.py) and the size of what travels with the tree slimmed by slim_tree.sh
# (fails over 60 MiB).
# Originals are cached in ${BIOVLN_GPU_CACHE:-~/.cache/biovln_ms/gpu-wheels}; a second run downloads nothing.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
PY=${PYTHON:-python3}
LIMIT_MIB=${BIOVLN_GPU_TRAVEL_LIMIT_MIB:-60}
CACHE=${BIOVLN_GPU_CACHE:-$HOME/.cache/biovln_ms/gpu-wheels}
PLATFORMS=(--platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64
           --platform manylinux2014_x86_64 --platform manylinux1_x86_64)

# 1. git-ignore the carried folders (they must not be committed, and ignored paths travel only when carried)
mkdir -p "$(git rev-parse --git-path info)"
EXCLUDE=$(git rev-parse --git-path info/exclude)
touch "$EXCLUDE"
for p in /.whl/ /.gl/ /.site/; do grep -qxF "$p" "$EXCLUDE" || echo "$p" >>"$EXCLUDE"; done

# 2. wheels: name==version from constraints.txt, cp312 manylinux, no deps (the closure is checked below)
pinned() {  # the version scripts/constraints.txt pins for $1 (names compared as PEP 503 normalises them)
  "$PY" - "$1" <<'EOF'
import re, sys
norm = lambda s: re.sub(r"[-_.]+", "-", s).lower()
want = norm(sys.argv[1])
for line in open("scripts/constraints.txt"):
    name, _, version = line.strip().partition("==")
    if version and norm(name) == want:
        print(version)
        break
else:
    sys.exit(f"prepare.sh: {sys.argv[1]} is not pinned in scripts/constraints.txt")
EOF
}
mkdir -p "$CACHE" .whl
rm -f .whl/*.whl
for name in $(sed -e 's/#.*//' scripts/gpu/wheels.txt); do
  version=$(pinned "$name")
  stem=$(echo "$name" | tr '-' '_')
  pattern="^${stem}-${version}-(py3|py2\.py3|cp312)-" # not another Python's wheel (rehearse.py's cp311 ones)
  if ! ls "$CACHE" | grep -qiE "$pattern"; then
    "$PY" -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
      "${PLATFORMS[@]}" -d "$CACHE" "$name==$version" 2>&1 | grep -v "is ignored: it is neither" || true
  fi
  whl=$(ls "$CACHE" | grep -iE "$pattern" | head -1)
  [ -n "$whl" ] || { echo "prepare.sh: no cp312 wheel of $name==$version could be downloaded" >&2; exit 1; }
  case "$stem" in
    sapien|mani_skill) "$PY" scripts/gpu/repack_maniskill.py "$CACHE/$whl" --out .whl \
                         --list-dropped "$CACHE/${stem}-dropped.tsv" ;;
    *) cp "$CACHE/$whl" .whl/ ;;
  esac
done

# 3. Vulkan / EGL / GL loaders (the device docs' recipe; the NVIDIA driver's ICDs are on the machine)
if ! ls .gl/libvulkan1_*.deb .gl/x11/libx11-6_*.deb >/dev/null 2>&1; then
  mkdir -p .gl/x11 /tmp/amd64/partial
  o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
  rm -f .gl/*.deb .gl/x11/*.deb
  # shellcheck disable=SC2086
  apt-get $o update -qq
  # shellcheck disable=SC2086
  (cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
  # shellcheck disable=SC2086
  (cd .gl/x11 && apt-get $o download libx11-6 libxcb1 libxau6 libxdmcp6 libbsd0 libmd0)
fi

# 4. the dependency closure of the wheels, against the GPU machine's package list
"$PY" scripts/gpu/check_closure.py .whl

# 5. the wheels as one packed site folder, and the default dataset
bash scripts/gpu/pack_site.sh .whl .site/site.tar.xz --python-version 3.12 --implementation cp \
  --only-binary=:all: "${PLATFORMS[@]}" --platform manylinux_2_24_x86_64 --root-user-action=ignore
rm -rf .site/dataset
if data=$("$PY" -c "from biovln_ms.splits import ensure_default_dataset; print(ensure_default_dataset())" | tail -1); then
  mkdir -p .site/dataset && cp -r "$data" .site/dataset/biovln
else
  echo "prepare.sh: biovln_ms is not importable here; run_all.sh will build the dataset there (minutes)"
fi

# 6. what travels: the working tree as slim_tree.sh leaves it, and the carried folders
echo
echo "what travels to the GPU machine:"
ls -l .site/site.tar.xz .gl/*.deb .gl/x11/*.deb | awk '{printf "  %10d  %s\n", $5, $9}'
tree_b=$(bash scripts/gpu/slim_tree.sh size)
site_b=$(du -sb .site | cut -f1)
gl_b=$(du -cb .gl/*.deb .gl/x11/*.deb | tail -1 | cut -f1)
total=$((tree_b + site_b + gl_b))
mib() { awk -v b="$1" 'BEGIN{printf "%.1f MiB", b/1048576}'; }
echo "  slimmed working tree $(mib "$tree_b") + .site $(mib "$site_b") + .gl $(mib "$gl_b") = $(mib $total) (limit ${LIMIT_MIB} MiB here, 64 MiB there)"
if [ "$total" -gt $((LIMIT_MIB * 1048576)) ]; then
  echo "prepare.sh: FAIL: $(mib $total) would travel, over ${LIMIT_MIB} MiB" >&2
  exit 1
fi
echo "prepare.sh: OK. Next: bash scripts/gpu/slim_tree.sh slim, the run call in scripts/gpu/README.md"
echo "(carry [\".site\", \".gl\"]), then bash scripts/gpu/slim_tree.sh restore."
