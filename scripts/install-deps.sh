#!/usr/bin/env bash
# Installs every build and test dependency of libvox from Debian 12 packages.
# Idempotent: packages already present are skipped, so both README commands can call it.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libopenvdb-dev libboost-iostreams-dev libtbb-dev libblosc-dev
  libtinygltf-dev nlohmann-json3-dev libstb-dev
  libdraco-dev draco
  libopenimageio-dev openimageio-tools
  libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libembree-dev  # bench/raycast_peer's Embree peer (optional: bench/CMakeLists.txt skips it when missing)
  libegl-dev libopengl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri libglx-mesa0
  libglfw3-dev xvfb xauth
  assimp-testmodels
  clang libclang-rt-14-dev
  python3                # scripts/voxelize-slurm, the bench scripts
  slurm-wlm munge        # tests/slurm: scripts/voxelize-slurm on a real one-node Slurm cluster
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
