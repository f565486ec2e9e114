#!/usr/bin/env bash
# One command for a new user: install dependencies, build, run the built-in example scene.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
echo
build/apps/polydem example "$@"
