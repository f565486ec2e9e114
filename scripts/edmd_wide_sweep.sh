#!/usr/bin/env bash
# Event-driven engine against size ratio (issue 24, "Done when"): fixed-density phi 0.5 collision rates and cost
# counters per collision (size-class skins, the default) for monodisperse spheres and the uniform radius (US),
# uniform volume (UV) and untruncated log-normal (LN) families, measured with build/benchmarks/polydem_edmd_counters
# (as scripts/edmd_wide_counters.sh, fixed mode only). The cases are interleaved across rounds (round 1: every case,
# round 2: every case, ...) so that a change of machine load spreads over all of them. One CSV row per run:
#
#   round,case,family,param,n,size_ratio,mode,dist,omega,sigma,skins,phi_start,phi_end,n_run,events_per_coll,
#   exits_per_coll,checks_per_coll,pairs_per_coll,neighbours,collisions,coll_per_s
#
# (size_ratio = the realised r_max / r_min of the sample; for LN it grows with N.) Then
# scripts/edmd_wide_sweep_plot.py draws OUT_DIR/rates_vs_size_ratio.png from the CSV and writes the medians over
# rounds to <CSV without .csv>_medians.csv.
#
# Usage:
#   scripts/edmd_wide_sweep.sh [BUILD_DIR] [OUT_DIR] [START_DIR]
#   defaults: build, docs/benchmarks/edmd, /work/edmd_starts
# Environment: REPEAT (rounds, default 3), FIXED (measured collisions per particle, default 20), WARMUP
# (unmeasured collisions per particle first, default 10), CASES (names from the table below; default all but
# the optional ln10n50k),
# STARTS_ONLY=1 (make the missing phi 0.5 starts and stop), PLOT=0 (no plot), CSV (default
# OUT_DIR/sweep_rates.csv; rows are appended, the header written if the file is new), TASKSET (e.g. "taskset -c 1").
#
# The phi 0.5 starts (RSA at 0.3, compressed at rate 1e-2, made by the counters tool with class skins; not timed)
# are cached as START_DIR/start_<case>_<n>.h5 (names as scripts/edmd_wide_counters.sh for mono, us100, ln075,
# uv100). Keep START_DIR outside the repository: UV omega 100 at N = 50,000 is 3 MB and takes ~12 CPU minutes.
#
# N: 10,000, except where the box cannot hold the largest sphere's neighbourhood at phi 0.5 (4 neighbourhood radii
# in the box edge, i.e. phi < 0.3 (L / (4 r_max at phi 0.3))^3; systematic sample, seed 1): UV omega = 100 allows
# phi < 0.28 at N = 10,000 and 0.41 at 20,000, so it runs at 50,000 (0.79). The others at 10,000 allow: UV omega 50
# phi < 0.66, UV 30 1.5, LN sigma 1.0 (size ratio 2848) 0.62, LN 0.75 1.7, the rest > 7. LN sigma 1.0 runs at
# N = 10,000, but there the same rule caps every skin at L/4 - r_max ~ 200 r_min (the small spheres' class floors
# ask for more), so it can also run at N = 50,000 (optional case, CASES=ln10n50k: size ratio 5949, box cap ~1700
# r_min; its start took 1,010 CPU s). There its small classes still sit at the class floor's cap 1e3 (skins
# ~200-250 r_min, 4.5 exits per collision): for LN 1.0 the floor cap, not the box, limits the skins.
# Not part of CI.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
out=${2:-$here/docs/benchmarks/edmd}
starts=${3:-/work/edmd_starts}
bin=$build/benchmarks/polydem_edmd_counters
[[ -x $bin ]] || { echo "no $bin (cmake --build $build --target polydem_edmd_counters)" >&2; exit 1; }
mkdir -p "$out" "$starts"
repeat=${REPEAT:-3}
fixed=${FIXED:-20}
warmup=${WARMUP:-10}
csv=${CSV:-$out/sweep_rates.csv}
# shellcheck disable=SC2206
runner=(${TASKSET:-})

# name|family|parameter|N|counters-tool options
TABLE=(
  "mono|mono|1|10000|--dist mono"
  "us2|US|2|10000|--dist uniform-radius --omega 2"
  "us5|US|5|10000|--dist uniform-radius --omega 5"
  "us10|US|10|10000|--dist uniform-radius --omega 10"
  "us30|US|30|10000|--dist uniform-radius --omega 30"
  "us100|US|100|10000|--dist uniform-radius --omega 100"
  "uv2|UV|2|10000|--dist uniform-volume --omega 2"
  "uv4|UV|4|10000|--dist uniform-volume --omega 4"
  "uv10|UV|10|10000|--dist uniform-volume --omega 10"
  "uv30|UV|30|10000|--dist uniform-volume --omega 30"
  "uv50|UV|50|10000|--dist uniform-volume --omega 50"
  "uv100|UV|100|50000|--dist uniform-volume --omega 100"
  "ln025|LN|0.25|10000|--dist log-normal --sigma 0.25"
  "ln05|LN|0.5|10000|--dist log-normal --sigma 0.5"
  "ln075|LN|0.75|10000|--dist log-normal --sigma 0.75"
  "ln10|LN|1.0|10000|--dist log-normal --sigma 1.0"
  "ln10n50k|LN|1.0|50000|--dist log-normal --sigma 1.0"
)
all=$(printf '%s\n' "${TABLE[@]}" | cut -d'|' -f1 | tr '\n' ' ')
optional="ln10n50k"  # not in the default CASES (see above)
cases=${CASES:-$(for c in $all; do [[ " $optional " == *" $c "* ]] || printf '%s ' "$c"; done)}
for c in $cases; do
  [[ " $all " == *" $c "* ]] || { echo "unknown case '$c' (known: $all)" >&2; exit 1; }
done
row_of() { printf '%s\n' "${TABLE[@]}" | awk -F'|' -v c="$1" '$1 == c'; }

# The starts first (not timed), so that the rounds below run back to back.
for c in $cases; do
  IFS='|' read -r name family param n opts <<<"$(row_of "$c")"
  start=$starts/start_${name}_${n}.h5
  if [[ ! -f $start ]]; then
    echo "== making $start" >&2
    # shellcheck disable=SC2086
    "$bin" $opts -n "$n" --mode fixed --start "$start" --collisions 0 --warmup 0 >/dev/null
  fi
done
[[ ${STARTS_ONLY:-0} == 1 ]] && exit 0

header="round,case,family,param,n,size_ratio,mode,dist,omega,sigma,skins,phi_start,phi_end,n_run,events_per_coll,exits_per_coll,checks_per_coll,pairs_per_coll,neighbours,collisions,coll_per_s"
[[ -f $csv ]] || echo "$header" >"$csv"
for ((round = 1; round <= repeat; ++round)); do
  for c in $cases; do
    IFS='|' read -r name family param n opts <<<"$(row_of "$c")"
    start=$starts/start_${name}_${n}.h5
    # shellcheck disable=SC2086
    res=$("${runner[@]}" "$bin" $opts -n "$n" --mode fixed --start "$start" --collisions "$fixed" --warmup "$warmup")
    ratio=$(echo "$res" | sed -n 's/^mode .* ratio \([0-9.]*\) .*/\1/p')
    row=$(echo "$res" | sed -n 's/^csv,//p')
    [[ -n $ratio && -n $row ]] || { echo "no result from $c: $res" >&2; exit 1; }
    echo "$round,$name,$family,$param,$n,$ratio,$row" | tee -a "$csv"
  done
done
if [[ ${PLOT:-1} == 1 ]]; then
  /usr/bin/python3 "$here/scripts/edmd_wide_sweep_plot.py" "$csv" "$out/rates_vs_size_ratio.png" | tee "${csv%.csv}_medians.csv"
fi
