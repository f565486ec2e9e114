#!/usr/bin/env bash
# determinism.sh POLYDEM WORKDIR [--update]: the determinism reference (issue 16). Runs a small relax
# scene (relax_reference.toml: polydisperse, friction, walls, gravity) and a small jam run, and checks
# the SHA-256 of their final states (text files, %.17g) against reference.sha256 beside this script.
# Any change of trajectory shows up here: if it is intended (a new rounding, a changed rule), rerun with
# --update and say in the commit message why the trajectory changed. The outputs do not depend on the
# broad phase, the thread count or wall-clock timing (every backend gives bit-identical trajectories).
set -u
polydem="$1"; work="$2"; update="${3:-}"
here="$(cd "$(dirname "$0")" && pwd)"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cp "$here/relax_reference.toml" .
"$polydem" relax relax_reference.toml -q > relax.log 2>&1 || { cat relax.log; echo "FAIL: relax"; exit 1; }
"$polydem" jam -n 300 --dist uv --omega 4 --seed 5 --schedule 1e-2:1e2,1e-3:1e4,2e-4 --target-pressure 1e7 \
  -o jam_reference_final.txt > jam.log 2>&1 || { cat jam.log; echo "FAIL: jam"; exit 1; }
sha256sum relax_reference_final.txt jam_reference_final.txt > actual.sha256
if [ "$update" = "--update" ]; then
  cp actual.sha256 "$here/reference.sha256"; echo "updated $here/reference.sha256"; cat actual.sha256; exit 0
fi
if ! diff "$here/reference.sha256" actual.sha256; then
  echo "FAIL: the final states differ from the checked-in reference (a trajectory changed)."
  echo "If that is intended, run: tests/determinism/determinism.sh build/apps/polydem /tmp/det --update"
  exit 1
fi
echo "determinism reference: both final states match"
