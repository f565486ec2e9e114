#!/usr/bin/env bash
# One command for the whole test suite: install dependencies, build, run every GoogleTest binary
# through CTest. CI (.ci/run) calls exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
cd build
ctest --output-on-failure -j"${POLYDEM_JOBS:-2}"
