#!/usr/bin/env bash
# Tree broad phases beside the grids and the sorting backends (issue 23): build, find and update cost
# per particle and bytes per particle of every registered backend, on uniform volume (f(r) ~ r^-3)
# omega = 10, 50, 100, 1000 and bidisperse (equal volumes) omega = 10, 100, at packing 0.3 and 0.6,
# N = 10^5 and 10^6. Medians of interleaved rounds (polydem_backends_report). Writes to OUT:
#   trees.csv        one row per (scene, backend): build_us, find_us, update_<f>_us (per particle of the
#                    system) and update_<f>_us_per_moved, bytes_per_particle, pairs, configuration
#   trees_<dist>.png cost (build + find) against the size ratio, one line per backend, one panel per
#                    (N, packing); trees_update.png: update() after 1% and 10% of the spheres moved
#   trees.md         the same numbers as Markdown tables, with the machine and the command
# States are generated once and cached in STATES: random sequential addition (`polydem generate`)
# where it reaches the packing, else event-driven compression (`polydem jam --target-phi`); the dense
# 10^6 states with omega = 1000 take hours to compress, so run this on a quiet machine, overnight.
#
#   scripts/backends_report.sh [BUILD_DIR]                      (default build/)
#   COUNTS=2000 REPEAT=1 JAM_SCHEDULE=1e-2 OUT=/tmp/trees scripts/backends_report.sh   (smoke test)
# Environment: COUNTS (default "100000 1000000"), PACKINGS ("0.3 0.6"), REPEAT (5), MOVED (0.01,0.1),
# SKIN_FACTOR (0.1), BUDGET (seconds per warm-up before a backend is skipped for a scene, 300),
# BACKENDS (comma-separated, default every registered one; lbvh:B = LBVH with leaves of B spheres,
# e.g. BACKENDS=hgrid-td,lbvh:2,lbvh:4,lbvh:8 to tune the leaf size), OUT (docs/benchmarks/backends/trees),
# STATES (OUT/states), JAM_SCHEDULE (growth schedule of `polydem jam`, default its own; e.g. 1e-2 for
# a quick smoke test), SCENES ("uniform-volume:10 uniform-volume:50 uniform-volume:100
# uniform-volume:1000 bi:10 bi:100").
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
polydem=$build/apps/polydem
report=$build/benchmarks/polydem_backends_report
for exe in "$polydem" "$report"; do
  [[ -x $exe ]] || { echo "missing $exe: cmake --build $build --target polydem polydem_backends_report" >&2; exit 2; }
done
COUNTS=${COUNTS:-"100000 1000000"}
PACKINGS=${PACKINGS:-"0.3 0.6"}
REPEAT=${REPEAT:-5}
MOVED=${MOVED:-0.01,0.1}
SKIN_FACTOR=${SKIN_FACTOR:-0.1}
BUDGET=${BUDGET:-300}
BACKENDS=${BACKENDS:-}
SCENES=${SCENES:-"uniform-volume:10 uniform-volume:50 uniform-volume:100 uniform-volume:1000 bi:10 bi:100"}
OUT=${OUT:-$here/docs/benchmarks/backends/trees}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
STATES=${STATES:-$OUT/states}
mkdir -p "$STATES"
csv=$OUT/trees.csv
dat=$OUT/trees.dat
rm -f "$csv" "$dat"
backendArgs=()
[[ -n $BACKENDS ]] && backendArgs=(--backends "$BACKENDS")
IFS=, read -r -a fractions <<<"$MOVED"

# state DIST OMEGA N PHI -> prints the path of a cached (or new) particle file; fails if no method
# placed the spheres (a small N may not fit a periodic box at all: then walls are tried)
state() {
  local dist=$1 omega=$2 n=$3 phi=$4
  local file=$STATES/${dist}_w${omega}_n${n}_phi${phi}.h5
  if [[ ! -s $file ]]; then
    if "$polydem" generate --dist "$dist" --omega "$omega" -n "$n" --phi "$phi" --placement rsa --seed 1 \
      -o "$file" >"$file.log" 2>&1; then
      :
    else
      echo "  $dist omega=$omega N=$n: RSA stalled below $phi, compressing (event-driven)" >&2
      local boundary
      for boundary in periodic walls; do
        "$polydem" jam --dist "$dist" --omega "$omega" -n "$n" --phi0 0.2 --target-phi "$phi" --seed 1 \
          ${JAM_SCHEDULE:+--schedule "$JAM_SCHEDULE"} --boundary "$boundary" --progress 600 -o "$file" \
          >>"$file.log" 2>&1 && break
        rm -f "$file"
      done
    fi
  fi
  [[ -s $file ]] || { echo "  could not place $dist omega=$omega N=$n at $phi (see $file.log): skipped" >&2; return 1; }
  echo "$file"
}

start=$(date +%s)
for n in $COUNTS; do
  for phi in $PACKINGS; do
    for scene in $SCENES; do
      dist=${scene%%:*}
      omega=${scene##*:}
      file=$(state "$dist" "$omega" "$n" "$phi") || continue
      echo "== $dist omega=$omega N=$n phi=$phi ($file)" >&2
      part=$(mktemp)
      "$report" "${backendArgs[@]}" --repeat "$REPEAT" --moved "$MOVED" --skin-factor "$SKIN_FACTOR" \
        --budget "$BUDGET" --csv "$part" "$file"
      if [[ ! -s $csv ]]; then head -1 "$part" >"$csv"; fi
      tail -n +2 "$part" >>"$csv"
      # Plot table: dist N phi omega (nominal; trees.csv has the realised ones) backend build find
      # update... bytes. Unquoted fields come first in the CSV; only the trailing configuration may
      # hold commas. Skipped backends get NaN.
      tail -n +2 "$part" | awk -F, -v dist="$dist" -v nominal="$omega" -v phi="$phi" -v nf="${#fractions[@]}" '{
        status = $7; gsub(/"/, "", status)
        line = dist " " $2 " " phi " " nominal " " $6
        ok = (status == "ok")
        for (c = 8; c <= 9 + 2 * nf + 2; ++c) line = line " " (ok ? $c : "NaN")
        print line
      }' >>"$dat"
      rm -f "$part"
    done
  done
done
elapsed=$(( $(date +%s) - start ))

# Columns of trees.dat: 1 dist, 2 N, 3 nominal packing, 4 nominal omega, 5 backend, 6 build, 7 find, then per moved
# fraction update and update per moved, then build+find, bytes per particle.
bf=$((8 + 2 * ${#fractions[@]}))
bytesCol=$((bf + 1))
backends=$(awk '{print $5}' "$dat" | awk '!seen[$0]++' | tr '\n' ' ')
ncount=$(wc -w <<<"$COUNTS")
nphi=$(wc -w <<<"$PACKINGS")
series=$OUT/series
rm -rf "$series"
mkdir -p "$series"
# One file per (dist, N, packing, backend), rows in the order of SCENES (ascending omega).
awk -v dir="$series" '{ f = dir "/" $1 "_" $2 "_" sprintf("%.1f", $3) "_" $5 ".dat"; print >> f; close(f) }' "$dat"
plot_family() {  # plot_family DIST PNG COLUMN YLABEL
  local dist=$1 png=$2 col=$3 ylabel=$4
  {
    echo "set terminal png size $((560 * nphi)),$((420 * ncount))"
    echo "set output '$png'"
    echo "set termoption noenhanced"
    echo "set logscale xy"
    echo "set xlabel 'size ratio omega'"
    echo "set ylabel '$ylabel'"
    echo "set key outside right font ',8'"
    echo "set multiplot layout $ncount,$nphi title '$dist: $ylabel'"
    for n in $COUNTS; do
      for phi in $PACKINGS; do
        echo "set title 'N = $n, nominal packing $phi'"
        local items=()
        for b in $backends; do
          local f=$series/${dist}_${n}_$(printf '%.1f' "$phi")_$b.dat
          [[ -s $f ]] && items+=("'$f' using 4:$col with linespoints title '$b'")
        done
        if ((${#items[@]})); then
          (IFS=,; echo "plot ${items[*]}")
        else
          echo "plot 1/0 notitle"
        fi
      done
    done
    echo "unset multiplot"
  } >"${png%.png}.gp"
  gnuplot "${png%.png}.gp" 2>"${png%.png}.gp.log" || echo "gnuplot failed for $png (see ${png%.png}.gp.log)" >&2
}
for scene in $SCENES; do echo "${scene%%:*}"; done | awk '!seen[$0]++' | while read -r dist; do
  plot_family "$dist" "$OUT/trees_${dist}.png" "$bf" "build + findPairs, us per particle"
done
lastUpdate=$((6 + 2 * ${#fractions[@]}))
plot_family uniform-volume "$OUT/trees_update.png" "$lastUpdate" \
  "update() after ${fractions[-1]} of the spheres moved, us per particle of the system"

{
  echo "# Tree broad phases beside grids and sorting (scripts/backends_report.sh)"
  echo
  echo "- date: $(date -u '+%Y-%m-%d %H:%M UTC'), $(lscpu | sed -n 's/^Model name: *//p' | head -1), $(nproc) hardware threads"
  echo "- command: \`COUNTS=\"$COUNTS\" PACKINGS=\"$PACKINGS\" REPEAT=$REPEAT MOVED=$MOVED SKIN_FACTOR=$SKIN_FACTOR BUDGET=$BUDGET scripts/backends_report.sh\`"
  echo "- skin = $SKIN_FACTOR r_min; medians of $REPEAT interleaved rounds, thread CPU time; run time ${elapsed} s"
  echo
  echo "Each cell: build + findPairs / update after ${fractions[-1]} moved (us per particle), bytes per particle."
  echo "NaN: skipped (brute force above N = 20000, or a warm-up beyond the budget of $BUDGET s)."
  echo
  printf "| system | N | packing |"
  for b in $backends; do printf " %s |" "$b"; done
  echo
  printf "| --- | --- | --- |"
  for b in $backends; do printf " --- |"; done
  echo
  awk -v bf="$bf" -v up="$lastUpdate" -v by="$bytesCol" -v order="$backends" '
    { key = $1 " omega=" $4 " | " $2 " | " $3; if (!(key in seen)) { seen[key] = 1; keys[++nk] = key }
      cell[key, $5] = ($bf == "NaN") ? "-" : sprintf("%.3g / %.3g, %.0f B", $bf, $up, $by) }
    END { nb = split(order, names, " ")
          for (k = 1; k <= nk; ++k) { line = "| " keys[k] " |"
            for (b = 1; b <= nb; ++b) line = line " " ((keys[k], names[b]) in cell ? cell[keys[k], names[b]] : "") " |"
            print line } }' "$dat"
  echo
  for png in "$OUT"/trees_*.png; do
    [[ -s $png ]] && echo "![$(basename "$png" .png)]($(basename "$png"))"
  done
} >"$OUT/trees.md"
echo "wrote $csv, $OUT/trees.md and plots in $OUT ($elapsed s)" >&2
