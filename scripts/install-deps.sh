#!/usr/bin/env bash
# Installs what pcl_parallel's build and tests need on Debian 12 (bookworm), with apt-get.
# Run as root, or as a user with sudo. Idempotent: when every package is already installed
# it touches nothing (no apt-get update, no network).
#
#   build-essential cmake            compilers and the build system
#   libpcl-dev                       PCL 1.13; its Depends pull in VTK 9 and, through it,
#                                    Open MPI (libopenmpi-dev, mpi-default-dev) and
#                                    pkg-config, which Debian's PCLConfig.cmake needs
#                                    (find_package(MPI COMPONENTS C) succeeds with
#                                    --no-install-recommends)
#   libflann-dev libeigen3-dev libboost-dev   PCL's public dependencies, named explicitly
#   libgtest-dev                     the test suite
#   libboost-program-options-dev     pcl_pslam's command line (subcommands, 3DTK option names)
#   libcairo2-dev                    render/ (map.png): antialiased lines, text, scale bar
#   nlohmann-json3-dev               pcl_pslam's report.json (a JSON library, not printf)
#   clang-14 libomp-14-dev libclang-rt-14-dev the ThreadSanitizer stage of scripts/test.sh:
#                                    clang, LLVM's OpenMP runtime with the Archer tool
#                                    (libarcher.so), and clang's sanitizer runtimes
#                                    (also libFuzzer's, for the fuzz stage)
#   pybind11-dev                     the Python module (src/python/); pulls in python3-dev
#   python3-numpy                    the module's arrays (points, poses) and its tests
#   python3-pytest                   the Python tests (test/python/, ctest label python)
set -euo pipefail

packages=(
  build-essential cmake
  libpcl-dev libflann-dev libeigen3-dev libboost-dev
  libgtest-dev
  libboost-program-options-dev libcairo2-dev nlohmann-json3-dev
  clang-14 libomp-14-dev libclang-rt-14-dev
  pybind11-dev python3-numpy python3-pytest
)

missing=()
for p in "${packages[@]}"; do
  if [[ "$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null)" != installed ]]; then
    missing+=("$p")
  fi
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

sudo=()
if [[ "$(id -u)" != 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: run as root (no sudo found)" >&2; exit 1; }
  sudo=(sudo)
fi

echo "install-deps: installing ${missing[*]}"
"${sudo[@]}" apt-get update -qq
"${sudo[@]}" env DEBIAN_FRONTEND=noninteractive \
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
