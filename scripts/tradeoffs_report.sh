#!/usr/bin/env bash
# Accuracy against run time, in one place (issue 7): the settings that trade one for the other.
#   DEM time-step factor (steps per shortest contact) -> energy drift and wall time per step
#   DEM Verlet skin -> wall time per step (trajectories are bit-identical for every skin)
#   event-driven growth rate -> jamming density estimate and wall time
# Writes docs/benchmarks/tradeoffs/ (CSV, PNG, README.md with the commands). Not part of CI: about
# 10 minutes on one core.
#
#   scripts/tradeoffs_report.sh [BUILD_DIR]        (default build/)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
polydem=$build/apps/polydem
out=$here/docs/benchmarks/tradeoffs
mkdir -p "$out"
cd "$out"
md=README.md
scene=$here/examples/relax_uv10.toml

{
  echo "# Accuracy against run time"
  echo
  echo "Written by \`scripts/tradeoffs_report.sh\` on $(date -u '+%Y-%m-%d %H:%M UTC'), $(lscpu | sed -n 's/^Model name: *//p' | head -1),"
  echo "$(nproc) cores (shared: wall times scatter by tens of percent). Every setting below trades accuracy for"
  echo "speed; each table gives both so a point on the curve can be picked knowingly."
  echo
} >"$md"

run() {  # run CMD...: echo the command and its output into the report
  echo '```' >>"$md"
  echo "\$ polydem ${*:2}" >>"$md"
  "$@" 2>&1 | grep -v '^  \(step\|sweep\|compression\)' | tee -a "$md" >/dev/null
  echo '```' >>"$md"
}

echo "## DEM time step: steps per shortest contact against energy drift" >>"$md"
echo >>"$md"
echo "Elastic uniform-volume omega = 10 scene (examples/relax_uv10.toml) with 10,000 spheres; the same simulated" >>"$md"
echo "time for every factor (steps scale with the factor). Energy drift = |E_end - E_start| / E_start." >>"$md"
echo >>"$md"
run "$polydem" relax "$scene" --set particles.count=10000 --set contact.restitution=1.0 \
  --steps 1000 -q --sweep dt-factor=10,20,50,100,200
echo >>"$md"
echo '![dt factor](relax_uv10_sweep_dt-factor.png)' >>"$md"
echo >>"$md"

echo "## DEM Verlet skin against wall time" >>"$md"
echo >>"$md"
echo "Same scene, dt factor 50, 2000 steps; skins 0.05 to 1 r_min (r_min = 0.5 mm). Trajectories agree to round-off for" >>"$md"
echo "every skin (1e-11 r_min: periodic coordinates are wrapped at different rebuilds), so the skin is a pure speed setting: thin skins rebuild often, thick skins" >>"$md"
echo "test more candidate pairs every step." >>"$md"
echo >>"$md"
run "$polydem" relax "$scene" --set particles.count=10000 \
  --steps 2000 -q --sweep skin=2.5e-5,5e-5,1e-4,2.5e-4,5e-4
echo >>"$md"

echo "## Event-driven growth rate against jamming density" >>"$md"
echo >>"$md"
echo "Monodisperse, N = 2000, one growth rate from random sequential addition at 0.3 up to reduced pressure 1e6;" >>"$md"
echo "phi_J = phi / (1 - 3/p). Faster growth jams looser; slower growth costs collisions." >>"$md"
echo >>"$md"
echo "rate,phi_J,collisions_per_particle,wall_seconds" >growth_rate.csv
for rate in 1e-1 3e-2 1e-2 3e-3 1e-3; do
  log=$(mktemp)
  "$polydem" jam -n 2000 --schedule "$rate" --target-pressure 1e6 --progress 1000 >"$log" 2>&1
  phij=$(sed -n 's/^phi_J estimate *\([0-9.]*\).*/\1/p' "$log")
  coll=$(sed -n 's/^collisions .*(\([0-9.]*\) per particle).*/\1/p' "$log")
  wall=$(sed -n 's/^wall time *\([0-9.]*\) s.*/\1/p' "$log")
  echo "$rate,$phij,$coll,$wall" >>growth_rate.csv
  rm -f "$log"
done
{
  echo '```'
  echo "\$ for rate in 1e-1 3e-2 1e-2 3e-3 1e-3; do polydem jam -n 2000 --schedule \$rate --target-pressure 1e6; done"
  column -s, -t growth_rate.csv
  echo '```'
  echo
} >>"$md"
gnuplot <<'GP' && echo '![growth rate](growth_rate.png)' >>"$md"
set datafile separator ','
set terminal png size 800,560
set output 'growth_rate.png'
set logscale x
set xlabel 'wall time (s)'
set ylabel 'jamming density estimate phi_J'
set title 'Event-driven compression: growth rate (labels) against phi_J and run time'
set key off
plot 'growth_rate.csv' every ::1 using 4:2 with linespoints pt 7, '' every ::1 using 4:2:1 with labels offset 1.5,0.8
GP
rm -f relax_uv10_sweep_*.gp
echo "wrote $out/$md"
