#!/usr/bin/env bash
# Install polydem's build and run dependencies from Debian packages. Idempotent: skips apt when
# everything is already installed. Needs root (or sudo) on Debian 12. clang and libfuzzer-14-dev are for
# scripts/fuzz.sh only (the default build uses g++).
set -euo pipefail

packages=(
  cmake g++ make pkg-config
  libeigen3-dev libcgal-dev libhdf5-dev libglpk-dev libsuitesparse-dev libopenblas0-pthread
  libcli11-dev libtomlplusplus-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  gnuplot-nox
  python3-meshio python3-h5py  # tests/io_readers (check tools: the tests skip without them)
  clang libfuzzer-14-dev clang-format
  python3-dev pybind11-dev python3-numpy python3-pytest python3-matplotlib
  libopenmpi-dev openmpi-bin  # MPI domain decomposition of relax (parallel/, docs/parallel.md)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
