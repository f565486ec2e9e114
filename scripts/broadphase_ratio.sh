#!/usr/bin/env bash
# Broad phase alone against equal spheres (issue 18): `polydem pairs --broadphase auto` (build + find, median
# of --repeat) on N spheres at packing PHI, uniform volume at several size ratios, for one or more polydem
# binaries, interleaved round by round. Pinned to one core. Writes CSV rows to stdout:
#   round,binary,scene,backend,build_us,find_us,total_us
# Usage: scripts/broadphase_ratio.sh OUTDIR BINARY [BINARY...]
#   env: N (200000), PHI (0.3), ROUNDS (3), REPEAT (5), OMEGAS ("1.5 2 3 5 10 20 50 100"), CPU (1)
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 OUTDIR BINARY [BINARY...]" >&2
  exit 2
fi
out=$1
shift
N=${N:-200000}
PHI=${PHI:-0.3}
ROUNDS=${ROUNDS:-3}
REPEAT=${REPEAT:-5}
OMEGAS=${OMEGAS:-"1.5 2 3 5 10 20 50 100"}
CPU=${CPU:-1}
for b in "$@"; do
  [ -x "$b" ] || { echo "$0: $b is not an executable" >&2; exit 2; }
done
mkdir -p "$out"
gen=$1
scenes="mono"
[ -f "$out/mono.h5" ] || "$gen" generate --dist mono -n "$N" --phi "$PHI" -o "$out/mono.h5" >/dev/null
for w in $OMEGAS; do
  scenes="$scenes uv$w"
  [ -f "$out/uv$w.h5" ] || "$gen" generate --dist uv --omega "$w" -n "$N" --phi "$PHI" -o "$out/uv$w.h5" >/dev/null
done
echo "round,binary,scene,backend,build_us,find_us,total_us"
for r in $(seq 1 "$ROUNDS"); do
  for s in $scenes; do
    for b in "$@"; do
      line=$(taskset -c "$CPU" "$b" pairs "$out/$s.h5" --broadphase auto --repeat "$REPEAT")
      chosen=$(echo "$line" | sed -n 's/^broad phase: auto -> \([a-z-]*\).*/\1/p')
      times=$(echo "$line" | sed -n 's/^time per particle: \([0-9.]*\) us (build \([0-9.]*\) us + find \([0-9.]*\) us.*/\2,\3,\1/p')
      echo "$r,$b,$s,$chosen,$times"
    done
  done
done
