#!/usr/bin/env bash
# Final growth rate of the Lubachevsky-Stillinger schedule against the jammed packing and its cost
# (issue 6 report: phi_J and its distance from the slow-rate limit against wall time; also the contact
# deficit of the backbone, which Donev ties to the final rate: A. Donev, "Jammed Packings of Hard
# Particles", PhD thesis, Princeton University (2006), §9.3.1 and Fig. 9.4).
# Monodisperse N spheres (default 1000), one growth rate R from the random sequential addition start at
# phi 0.3 to p = 1e12 (switching to R only at p = 1e4 leaves phi_J unchanged to 1e-8, the structure is
# set by then, and changes only the contacts; docs/edmd.md); two seeds per rate (the same seed gives the
# same start). The distance from the slow-rate limit is taken per seed. The quick scan of fast rates to
# p = 1e6 (N = 2000) stays in scripts/tradeoffs_report.sh; this one adds slow rates, p = 1e12 and contacts. Writes docs/benchmarks/final_rate/ (CSV, PNG,
# README.md). Not part of CI: about 15 minutes on one core with the defaults.
#
#   scripts/jam_final_rate.sh [BUILD_DIR] [N]        (default build/, 1000)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
n=${2:-1000}
polydem=$build/apps/polydem
out=$here/docs/benchmarks/final_rate
mkdir -p "$out"
cd "$out"
command -v gnuplot >/dev/null || { echo "gnuplot missing (scripts/setup.sh installs it)" >&2; exit 1; }
rates=(1e-3 3e-4 1e-4 3e-5)
seeds=(1 2)
csv=final_rate.csv
echo "rate,seed,phi_J,z_backbone,rattler_percent,contact_excess,collisions_per_particle,wall_seconds" >"$csv"
for rate in "${rates[@]}"; do
  for seed in "${seeds[@]}"; do
    log=$(mktemp)
    "$polydem" jam -n "$n" --schedule "$rate" --target-pressure 1e12 --seed "$seed" \
      --progress 1000 >"$log" 2>&1
    phij=$(sed -n 's/^phi_J estimate *\([0-9.]*\).*/\1/p' "$log")
    zb=$(sed -n 's/^backbone .* z = \([0-9.]*\),.*/\1/p' "$log")
    excess=$(sed -n 's/^backbone .*(3N. -2) = \(-\{0,1\}[0-9]*\).*/\1/p' "$log")
    ratt=$(sed -n 's/^rattlers .*(\([0-9.]*\)%).*/\1/p' "$log")
    coll=$(sed -n 's/^collisions .*(\([0-9.]*\) per particle).*/\1/p' "$log")
    wall=$(sed -n 's/^wall time *\([0-9.]*\) s.*/\1/p' "$log")
    echo "$rate,$seed,$phij,$zb,$ratt,$excess,$coll,$wall" >>"$csv"
    rm -f "$log"
  done
done
# Distance from the slowest rate's phi_J of the same seed.
awk -F, -v r="${rates[-1]}" 'NR == FNR { if (FNR > 1 && $1 == r) slow[$2] = $3; next }
  FNR == 1 { print $0 ",distance"; next } { printf "%s,%.3e\n", $0, $3 - slow[$2] }' "$csv" "$csv" >with_distance.csv
mv with_distance.csv "$csv"
gnuplot <<EOF
set terminal pngcairo size 900,600
set output 'final_rate.png'
set datafile separator ','
set logscale x
set xlabel 'wall time (s)'
set ylabel 'phi_J - phi_J(rate ${rates[-1]}, same seed)'
set key off
set grid
plot '$csv' every ::1 using 8:9:1 with labels offset 0,1 font ',9', \
     '' every ::1 using 8:9 with points pt 7
EOF
{
  echo "# Final growth rate against phi_J, contacts and cost"
  echo
  echo "Written by \`scripts/jam_final_rate.sh\` on $(date -u '+%Y-%m-%d %H:%M UTC'), $(lscpu | sed -n 's/^Model name: *//p' | head -1),"
  echo "$(nproc) cores (shared machine: wall times scatter). Monodisperse N = $n, for each rate R:"
  echo
  echo '```'
  echo "polydem jam -n $n --schedule R --target-pressure 1e12 --seed S"
  echo '```'
  echo
  echo "Distance = phi_J - phi_J of the same seed at the slowest rate R = ${rates[-1]}. contact excess ="
  echo "M' - (3N' - 2) on the backbone (0 = isostatic)."
  echo
  echo "| rate | seed | phi_J | distance | z backbone | rattlers % | contact excess | collisions / particle | wall s |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  awk -F, 'NR > 1 { printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, $2, $3, $9, $4, $5, $6, $7, $8 }' "$csv"
  echo
  echo '![phi_J against wall time](final_rate.png)'
} >README.md
echo "wrote $out/README.md"
