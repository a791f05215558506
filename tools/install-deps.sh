#!/usr/bin/env bash
# Installs what pointfair needs to build and test, from Debian 12's packages, if missing.
# Used by tools/demo.sh, tools/test.sh and .ci/run.
set -euo pipefail

packages=(g++ cmake ninja-build pkg-config
          libeigen3-dev libnanoflann-dev zlib1g-dev libtbb-dev libomp-dev libhdf5-dev
          hdf5-tools  # h5ls/h5dump: the container layout test
          libgtest-dev libgmock-dev libbenchmark-dev
          libproj-dev proj-data  # --crs EPSG:N: PROJ and its database
          libcli11-dev nlohmann-json3-dev  # the command line: its options and help, its --json summaries
          pybind11-dev python3-dev python3-numpy  # the Python module (python/, docs/python.md)
          clang libclang-rt-14-dev  # clang + libFuzzer: the fuzz smoke run of tools/test.sh
          libopenmpi-dev openmpi-bin libhdf5-openmpi-dev  # pointfair_mpi (-DPOINTFAIR_MPI=ON)
          shellcheck)  # the Slurm scripts, in the mpi stage of tools/test.sh

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "installing: ${missing[*]}" >&2
sudo=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "error: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  sudo=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -qq
"${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
