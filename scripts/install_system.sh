#!/usr/bin/env bash
# Installs the system packages BioVLN-MS needs on Debian bookworm.
# SAPIEN needs a Vulkan driver with VK_KHR_external_semaphore_fd. When no GPU
# driver is present we install Mesa's CPU driver (lavapipe) from
# bookworm-backports: bookworm's own Mesa 22.3 lacks that extension.
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

have_gpu_icd() {
  # An NVIDIA (or other non-lavapipe) Vulkan ICD already installed means a GPU driver is present.
  ls /usr/share/vulkan/icd.d/ /etc/vulkan/icd.d/ 2>/dev/null | grep -v -q -E 'lvp|^$' && \
    ls /usr/share/vulkan/icd.d/ /etc/vulkan/icd.d/ 2>/dev/null | grep -q -i nvidia
}

mesa_ok() {
  # Mesa >= 24.3 provides what SAPIEN needs.
  local v
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  [ -n "$v" ] && dpkg --compare-versions "$v" ge 24.3
}

export DEBIAN_FRONTEND=noninteractive
pkgs="libvulkan1 ffmpeg libgl1 libegl1 libglib2.0-0 git"
if have_gpu_icd; then
  echo "[install_system] GPU Vulkan driver found; not installing lavapipe"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq $pkgs
elif mesa_ok; then
  echo "[install_system] Mesa lavapipe >= 24.3 already installed"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq $pkgs
else
  if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
    echo "[install_system] adding the bookworm-backports suite"
    $SUDO tee /etc/apt/sources.list.d/bookworm-backports.sources >/dev/null <<'SRC'
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
  fi
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers libvulkan1
  $SUDO apt-get install -y -qq $pkgs
fi
echo "[install_system] done"
