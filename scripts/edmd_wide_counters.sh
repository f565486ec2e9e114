#!/usr/bin/env bash
# Event-driven engine on wide size distributions (issue 24): cost counters per collision and collision
# rates, one skin floor for all sizes (--global-skin, the rule before issue 24) against one floor per size
# class (the default), at fixed density phi 0.5 and for the compression 0.3 -> 0.5. One CSV row per run:
#
#   mode,dist,omega,sigma,skins,phi_start,phi_end,n,events_per_coll,exits_per_coll,checks_per_coll,
#   pairs_per_coll,neighbours,collisions,coll_per_s[,instructions_per_coll]
#
# Usage:
#   scripts/edmd_wide_counters.sh [BUILD_DIR] [OUT_DIR]            rates (time it on a quiet machine)
#   CALLGRIND=1 scripts/edmd_wide_counters.sh [BUILD_DIR] [OUT_DIR] instructions per collision (valgrind)
# Environment: REPEAT (runs per case, default 3; callgrind: 1), N (spheres, default 10000; UV omega 100
# always 50000, the smallest N whose box holds four neighbourhoods of the largest sphere), FIXED (measured
# collisions per particle at phi 0.5, default 20), COMPRESS (collision budget per particle of the
# compression, default 30: the single floor takes hours to reach phi 0.5; 1e9 = to phi 0.5), CASES (subset of: mono us100 ln075 uv100).
# The dense starts are cached in OUT_DIR/start_<case>_<n>.h5 (made once, with class skins), so both skin
# rules start from the same state. Not part of CI.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
out=${2:-$here/docs/benchmarks/edmd}
bin=$build/benchmarks/polydem_edmd_counters
mkdir -p "$out"
repeat=${REPEAT:-3}
n=${N:-10000}
fixed=${FIXED:-20}
compress=${COMPRESS:-30}
cases=${CASES:-mono us100 ln075 uv100}
[[ -n "${CALLGRIND:-}" ]] && repeat=${REPEAT:-1}

args_of() {
  case $1 in
    mono) echo "--dist mono" ;;
    us100) echo "--dist uniform-radius --omega 100" ;;
    ln075) echo "--dist log-normal --sigma 0.75" ;;
    uv100) echo "--dist uniform-volume --omega 100" ;;
  esac
}

csv=$out/wide_counters${CALLGRIND:+_callgrind}.csv
header="mode,dist,omega,sigma,skins,phi_start,phi_end,n,events_per_coll,exits_per_coll,checks_per_coll,pairs_per_coll,neighbours,collisions,coll_per_s"
[[ -n "${CALLGRIND:-}" ]] && header+=",instructions_per_coll"
[[ -f $csv ]] || echo "$header" >"$csv"

one() {  # one RUNARGS...: print the csv row (with instructions per collision under callgrind)
  if [[ -n "${CALLGRIND:-}" ]]; then
    local cg
    cg=$(mktemp "$out/callgrind.XXXXXX")
    local row
    row=$(valgrind --tool=callgrind --toggle-collect='*measuredPart*' --callgrind-out-file="$cg" "$bin" "$@" 2>/dev/null |
      sed -n 's/^csv,//p')
    local ir
    ir=$(sed -n 's/^summary: *//p' "$cg" | awk '{print $1}')
    rm -f "$cg"
    local coll
    coll=$(echo "$row" | cut -d, -f14)
    echo "$row,$(awk -v a="$ir" -v b="$coll" 'BEGIN{printf "%.0f", a / b}')"
  else
    "$bin" "$@" | sed -n 's/^csv,//p'
  fi
}

for c in $cases; do
  cn=$n
  [[ $c == uv100 ]] && cn=50000
  start=$out/start_${c}_${cn}.h5
  # shellcheck disable=SC2046
  [[ -f $start ]] || "$bin" $(args_of "$c") -n "$cn" --mode fixed --start "$start" --collisions 0 --warmup 0 >/dev/null
  for skins in "" --global-skin; do
    for ((k = 0; k < repeat; ++k)); do
      # shellcheck disable=SC2046
      one $(args_of "$c") -n "$cn" --mode fixed --start "$start" --collisions "$fixed" $skins | tee -a "$csv"
      # shellcheck disable=SC2046
      one $(args_of "$c") -n "$cn" --mode compress --collisions "$compress" $skins | tee -a "$csv"
    done
  done
done
