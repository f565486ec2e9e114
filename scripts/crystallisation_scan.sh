#!/usr/bin/env bash
# Crystallisation threshold of uniform-radius spheres (issue 8; Ogarko's thesis Figs. 3.2, 3.13: partial
# crystallisation for omega <= 1.18, none for omega >= 1.22, omega_c = 1.20 +- 0.02). N = 4096, the
# structure report's "slow" protocol: compress at rate 1e-3 to phi 0.56, hold 20,000 collisions per sphere
# at fixed density (nucleation and growth), then the crystalline fraction p_c (q6/d6 over weighted-Delaunay
# neighbours, d6 > 0.65, >= 6 bonds). Not part of CI: ~80 CPU s per omega.
#
#   scripts/crystallisation_scan.sh [BUILD_DIR] [OMEGA ...]     (default build/, 1.14 1.18 1.22 1.26)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
shift || true
omegas=("$@")
[ ${#omegas[@]} -eq 0 ] && omegas=(1.14 1.18 1.22 1.26)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "omega,p_c,mean_q6,Q6,pressure_after_hold"
for w in "${omegas[@]}"; do
  log=$work/us$w.log
  "$build/apps/polydem" jam -n 4096 --seed 5 --dist uniform-radius --omega "$w" --schedule 1e-3 --target-phi 0.56 \
    --run-collisions 20000 --progress 1000 -o "$work/us$w.h5" >"$log" 2>&1
  "$build/apps/polydem" analyze "$work/us$w.h5" --structure-only --order >>"$log" 2>&1
  pc=$(sed -n 's/.*p_c = \([0-9.]*\).*/\1/p' "$log")
  q6=$(sed -n 's/.*mean q6 = \([0-9.]*\).*/\1/p' "$log")
  Q6=$(sed -n 's/.*Q6 = \([0-9.]*\)$/\1/p' "$log")
  p=$(sed -n 's/^fixed density: .* p \([0-9.]*\) .*/\1/p' "$log")
  echo "$w,$pc,$q6,$Q6,$p"
done
