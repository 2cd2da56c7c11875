#!/usr/bin/env bash
# Install the Debian 12 packages sphaptics needs to build, test and benchmark.
# Idempotent: when every package is already installed it returns in well under a second.
set -euo pipefail

PACKAGES=(
  cmake g++ make pkg-config
  ocl-icd-opencl-dev opencl-c-headers opencl-clhpp-headers pocl-opencl-icd clinfo
  libeigen3-dev libyaml-cpp-dev libcli11-dev libtinyobjloader-dev
  libhdf5-dev libopenvdb-dev libboost-iostreams-dev libtbb-dev
  catch2 zlib1g-dev
  libglfw3-dev libgl-dev libimgui-dev libstb-dev libgl1-mesa-dri xvfb xauth
  python3-numpy python3-matplotlib python3-h5py
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
