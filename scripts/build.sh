#!/usr/bin/env bash
# Configure and build polydem (Release, -O3) in ./build. Extra arguments go to cmake's configure step,
# e.g. scripts/build.sh -DPOLYDEM_NATIVE=ON.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs="${POLYDEM_JOBS:-2}"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j"$jobs"
