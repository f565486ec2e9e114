#!/usr/bin/env bash
# One command for a new user: install dependencies, build, run the built-in example scene:
#  1. `polydem example`: 20,000 uniform-volume spheres (size ratio 10), every broad phase side by side;
#  2. `polydem relax examples/relax_uv10.toml`: a DEM relaxation of 50,000 such spheres at packing
#     fraction 0.6 with the automatically chosen broad phase, reporting time per particle per step.
# Outputs (time series, final state) go to build/example-run/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
mkdir -p build/example-run
cd build/example-run
echo
../apps/polydem example "$@"
echo
../apps/polydem relax ../../examples/relax_uv10.toml
