#!/usr/bin/env bash
# Runs ON a lent GPU machine (x86-64, Python 3.12, torch with CUDA, no package index), from the repo root,
# in one `run` call that carries the folders scripts/gpu/prepare.sh filled here:
#
#     bash scripts/gpu/run_all.sh [SECTIONS]      # carry: [".site", ".gl"] (and ".physx" if you have it)
#
# SECTIONS: a comma-separated list of benchmarks/gpu_speed.py's sections (default: all, in this order:
# meta,state,pickcube,equivalence,state_autoreset,rgbd,render,depth_pack,noise,cpu_ref,lighting; `ppo`, which
# trains for minutes, only when named: `bash scripts/gpu/run_all.sh meta,ppo`). Each section
# runs in its own process under `timeout`, so a crash or a hang in one still leaves the others' results;
# every figure is written to $OUT/gpu_speed.json and $OUT/gpu_speed.md as soon as it is measured.
#
# Steps: 1. unpack the Vulkan/EGL/GL loaders (.gl/*.deb) and find the NVIDIA ICDs; 2. unpack the packed
# site folder (.site/site.tar.xz) into /tmp/site, or, without it, install the wheels (.whl/*.whl) there
# with pip --no-index --no-deps --target (skipped when a warm machine already has them); 3. make
# biovln_ms importable without installing it: /tmp/biovln_shim/biovln_ms holds symlinks to the repo's
# biovln_ms/* plus tasks/, agents/, assets/ (what pyproject's package-dir maps); 4. SAPIEN's PhysX GPU
# library: from .physx/ (libPhysXGpu_64.so or linux-so.zip) when carried, else wherever the image has
# one; SAPIEN would download it, and this machine has no network; 5. GPU / Vulkan summaries into
# $OUT/system.txt; 6. the default dataset into /tmp/biovln_data (carried in .site/dataset, else built);
# 7. the sections, within $BIOVLN_GPU_BUDGET_S seconds in all (default 560, the run's limit being 600).
# Files back ($OUT): run_all.log, system.txt, gpu_speed.json, gpu_speed.md, render_check.png.
set -uo pipefail # no -e: one failing step must not stop the rest
cd "$(dirname "$0")/../.."
ROOT=$PWD
OUT=${OUT:-/tmp/gpu_out}
mkdir -p "$OUT"
exec > >(tee -a "$OUT/run_all.log") 2>&1
export PYTHONUNBUFFERED=1
# the repo root (the working directory) must not shadow the shim's biovln_ms (step 3): Python >= 3.11
# then puts neither '' nor the script's folder first on sys.path
export PYTHONSAFEPATH=1
T0=$(date +%s)
BUDGET=${BIOVLN_GPU_BUDGET_S:-560}
SECTIONS=${1:-meta,state,pickcube,equivalence,state_autoreset,rgbd,render,depth_pack,noise,cpu_ref,lighting}
left() { echo $((BUDGET - ($(date +%s) - T0))); }
stamp() { echo "[run_all +$(($(date +%s) - T0))s] $*"; }
PY=${PYTHON:-python3}
# knobs for a rehearsal on a CPU machine (scripts/gpu/rehearse.py); leave them unset on the GPU machine
WHEELS=${BIOVLN_WHEELS:-.whl}
SITE_TAR=${BIOVLN_SITE_TAR:-.site/site.tar.xz}
GL=${BIOVLN_GL:-.gl} # "none": leave the system's loaders alone
SITE=${BIOVLN_SITE:-/tmp/site}
SHIM=${BIOVLN_SHIM:-/tmp/biovln_shim}
SMOKE=()
[ "${BIOVLN_GPU_SMOKE:-0}" = 1 ] && SMOKE=(--smoke)

# section timeouts (s): what each may take at most on an H100 (make + first reset + timed steps)
declare -A LIMIT=([meta]=60 [state]=200 [pickcube]=100 [equivalence]=150 [state_autoreset]=90
                  [rgbd]=170 [render]=100 [depth_pack]=60 [noise]=90 [cpu_ref]=110 [lighting]=150 [ppo]=540)

# 1. loaders (the device docs' recipe) and the NVIDIA ICDs
stamp "loaders"
if [ "$GL" != none ]; then
  for f in "$GL"/*.deb; do [ -f "$f" ] && dpkg -x "$f" /; done
  ldconfig
fi
if ! ldconfig -p | grep -q "libX11.so.6 " && [ -d "$GL/x11" ]; then # SAPIEN's libsvulkan2.so needs it
  for f in "$GL"/x11/*.deb; do dpkg -x "$f" /tmp/x11root; done
  export LD_LIBRARY_PATH=/tmp/x11root/usr/lib/x86_64-linux-gnu:/tmp/x11root/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  echo "  libX11 from .gl/x11 (LD_LIBRARY_PATH)"
fi
ldconfig -p | grep -E "libvulkan.so.1|libEGL.so.1|libX11.so.6 " | sed 's/^/  /'
for icd in /usr/share/vulkan/icd.d/nvidia_icd.json /etc/vulkan/icd.d/nvidia_icd.json \
           /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json; do
  if [ -f "$icd" ]; then export VK_DRIVER_FILES=$icd VK_ICD_FILENAMES=$icd; break; fi
done
for egl in /usr/share/glvnd/egl_vendor.d/10_nvidia.json /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json; do
  if [ -f "$egl" ]; then export __EGL_VENDOR_LIBRARY_FILENAMES=$egl; break; fi
done
echo "  VK_DRIVER_FILES=${VK_DRIVER_FILES:-unset} __EGL_VENDOR_LIBRARY_FILENAMES=${__EGL_VENDOR_LIBRARY_FILENAMES:-unset}"

# 2. the packages the image lacks: .site/site.tar.xz (prepare.sh's packed site folder) unpacked into
# $SITE, else the wheels of .whl/ installed there; skipped when a warm machine already has them
stamp "packages"
STAMP_FILE=$SITE/.biovln_packages
if [ -f "$SITE_TAR" ]; then
  want=$(md5sum "$SITE_TAR" | cut -c1-16)
  if [ "$(cat "$STAMP_FILE" 2>/dev/null)" != "$want" ]; then
    rm -rf "$SITE" && mkdir -p "$SITE" && tar -xJf "$SITE_TAR" -C "$SITE" \
      && echo "$want" >"$STAMP_FILE" && echo "  unpacked $SITE_TAR into $SITE" || stamp "unpacking $SITE_TAR FAILED"
  else
    echo "  already unpacked in $SITE"
  fi
else
  want=$(ls "$WHEELS"/*.whl 2>/dev/null | xargs -n1 basename | sort | md5sum | cut -c1-16)
  if [ "$(cat "$STAMP_FILE" 2>/dev/null)" != "$want" ]; then
    "$PY" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target "$SITE" "$WHEELS"/*.whl \
      && echo "$want" >"$STAMP_FILE" || stamp "pip install FAILED"
  else
    echo "  already installed in $SITE"
  fi
fi

# 3. biovln_ms without installing it
bash scripts/gpu/shim.sh "$SHIM"
export PYTHONPATH=$SHIM:$SITE${PYTHONPATH:+:$PYTHONPATH}
export BIOVLN_DATA_DIR=${BIOVLN_DATA_DIR:-/tmp/biovln_data}
"$PY" -c "import biovln_ms.tasks, biovln_ms.agents.robots, biovln_ms.assets, sapien, mani_skill, torch; \
print('  imports ok: biovln_ms.tasks from', biovln_ms.tasks.__file__, '| sapien', sapien.__version__, \
'| mani_skill', mani_skill.__version__, '| torch', torch.__version__, torch.cuda.is_available())" \
  || stamp "IMPORT FAILED (the sections below will record their errors)"

# 4. SAPIEN's PhysX GPU library
stamp "physx gpu library"
PHYSX_VER=$("$PY" -c "import sapien; print(sapien.physx.version())" 2>/dev/null | tail -1)
DEST=$HOME/.sapien/physx/$PHYSX_VER
if [ -n "$PHYSX_VER" ] && [ ! -f "$DEST/libPhysXGpu_64.so" ]; then
  mkdir -p "$DEST"
  if [ -f .physx/libPhysXGpu_64.so ]; then
    cp .physx/libPhysXGpu_64.so "$DEST/"
  elif [ -f .physx/linux-so.zip ]; then
    "$PY" -m zipfile -e .physx/linux-so.zip "$DEST/"
  else
    found=$(timeout 30 find / -xdev -name libPhysXGpu_64.so 2>/dev/null | head -1)
    [ -n "$found" ] && ln -sf "$found" "$DEST/libPhysXGpu_64.so"
  fi
fi
if [ -f "$DEST/libPhysXGpu_64.so" ]; then echo "  $DEST/libPhysXGpu_64.so"; ls -l "$DEST"
else echo "  MISSING: no libPhysXGpu_64.so for PhysX $PHYSX_VER; physx_cuda sections will be marked blocked"; fi

# 5. the machine
stamp "system"
{
  echo "== nvidia-smi"; timeout 20 nvidia-smi 2>&1
  echo "== nvidia-smi query"
  timeout 20 nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>&1
  echo "== vulkan (SAPIEN's device summary)"
  timeout 60 "$PY" -c "import sapien; print(sapien.render.get_device_summary())" 2>&1
  if command -v vulkaninfo >/dev/null; then echo "== vulkaninfo --summary"; timeout 30 vulkaninfo --summary 2>&1; fi
  echo "== python"; "$PY" -c "import sys; print(sys.version)"
  echo "== packages"; "$PY" -m pip list 2>/dev/null | grep -iE "^(torch|numpy|sapien|mani|gymnasium|typing.ext|pydantic|scipy|trimesh|shapely) "
  echo "== cpu"; nproc; free -g | head -2
} >"$OUT/system.txt" 2>&1
head -40 "$OUT/system.txt"

# 6. the dataset (deterministic): prepare.sh's copy when carried, checked (rebuilt only if stale)
stamp "dataset"
if [ ! -d "$BIOVLN_DATA_DIR" ] && [ -d .site/dataset/biovln ]; then
  mkdir -p "$(dirname "$BIOVLN_DATA_DIR")" && cp -r .site/dataset/biovln "$BIOVLN_DATA_DIR"
  echo "  copied .site/dataset/biovln to $BIOVLN_DATA_DIR"
fi
timeout 180 "$PY" -c "from biovln_ms.splits import ensure_default_dataset; print(ensure_default_dataset())" \
  || stamp "dataset build failed"

# 7. the sections
IFS=',' read -r -a names <<<"$SECTIONS"
skipped=()
for s in "${names[@]}"; do
  lim=${LIMIT[$s]:-120}
  l=$(($(left) - 10))
  if [ "$l" -lt 30 ]; then
    stamp "skip $s: out of time"
    skipped+=("$s")
    "$PY" benchmarks/gpu_speed.py --out "$OUT" --section "$s" --record-error "skipped: run_all.sh budget ($BUDGET s) spent"
    continue
  fi
  [ "$lim" -gt "$l" ] && lim=$l
  stamp "section $s (timeout ${lim}s)"
  timeout -k 10 "$lim" "$PY" benchmarks/gpu_speed.py --out "$OUT" --section "$s" "${SMOKE[@]}"
  rc=$?
  if [ $rc -ne 0 ]; then
    why="exit status $rc"
    [ $rc -eq 124 ] || [ $rc -eq 137 ] && why="timed out after ${lim} s (rc $rc)"
    stamp "section $s: $why"
    "$PY" benchmarks/gpu_speed.py --out "$OUT" --section "$s" --record-error "process: $why"
  fi
done
stamp "done"
cat "$OUT/gpu_speed.md" 2>/dev/null
if [ ${#skipped[@]} -gt 0 ]; then
  echo "NOT RUN (time budget): ${skipped[*]} -- next call: bash scripts/gpu/run_all.sh meta,$(IFS=,; echo "${skipped[*]}")"
fi
