#!/usr/bin/env bash
# LAMMPS `neighbor multi` with the collections of `polydem lammps-neighbor` against the hand-made doubling
# collections a LAMMPS user writes (interval bounds 2 d_min, 4 d_min, ..., d_max), on the same polydisperse
# state, contact law, dt and steps. A measurement script, not CI: LAMMPS is not a build dependency. Install
# it once with  DEBIAN_FRONTEND=noninteractive apt-get install -y lammps
#
#   scripts/lammps_neighbor_compare.sh [OMEGA ...]     uniform-volume size ratios (default: 20 50)
#
# Per OMEGA: (1) `polydem relax benchmarks/lammps/prepare.toml` writes the start (RSA at packing fraction
# 0.6, f(r) ~ r^-3, impact velocities); (2) benchmarks/lammps/polydem_to_lammps.py writes the LAMMPS data
# file, the restitution damping and the doubling collections; (3) `polydem lammps-neighbor` writes the model's
# lines; (4) REPEATS rounds, each running LAMMPS once with each set, interleaved so slow drifts in machine
# load hit both alike. Both sets use the same skin, `neigh_modify delay 0 every 1 check yes` and
# `comm_modify mode multi reduce/multi`: only the collections differ. Times are LAMMPS' "Loop time" /
# (steps N) and the "Neigh" section of its timing breakdown / (builds N), i.e. the cost of one list build;
# the summary prints the medians and doubling / model (> 1: the model's collections are faster). The
# collections change only the list builds (both sets find the same pairs), so a short run with few rebuilds
# shows little in the loop time: REBUILD=always (`check no`: a build every step) measures the builds alone.
#
# Environment: POLYDEM_BUILD (build dir, default build), LMP (lmp), COUNT (particles, 50000), STEPS (1000),
# REPEATS (5), WORKDIR (scratch, default $POLYDEM_BUILD/lammps_neighbor_compare), OUT (summary CSV, default
# docs/benchmarks/lammps_neighbor.csv; the per-run CSV goes beside it as *_runs.csv), REUSE=1 (keep a start
# already prepared in WORKDIR; the model's lines are written again), COST_RATIO (--cost-ratio of
# `polydem lammps-neighbor`, default its own), REBUILD (check: `check yes`, the default; always: `check no`).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${POLYDEM_BUILD:-$root/build}"
polydem="$build/apps/polydem"
lmp="${LMP:-lmp}"
count="${COUNT:-50000}"
steps="${STEPS:-1000}"
repeats="${REPEATS:-5}"
work="${WORKDIR:-$build/lammps_neighbor_compare}"
out="${OUT:-$root/docs/benchmarks/lammps_neighbor.csv}"
runs_csv="${out%.csv}_runs.csv"
reuse="${REUSE:-0}"
rebuild="${REBUILD:-check}"
case "$rebuild" in check|always) ;; *) echo "lammps_neighbor_compare: REBUILD must be check or always" >&2; exit 1 ;; esac
lammps_dir="$root/benchmarks/lammps"
density=2500.0
stiffness=1000.0
restitution=0.9

[ -x "$polydem" ] || { echo "lammps_neighbor_compare: $polydem not found: build polydem or set POLYDEM_BUILD" >&2; exit 1; }
command -v "$lmp" > /dev/null || {
  echo "lammps_neighbor_compare: '$lmp' not found: DEBIAN_FRONTEND=noninteractive apt-get install -y lammps" >&2; exit 1; }
omegas=("$@")
[ ${#omegas[@]} -gt 0 ] || omegas=(20 50)
for om in "${omegas[@]}"; do
  [[ "$om" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "lammps_neighbor_compare: OMEGA '$om' is not a number" >&2; exit 1; }
done
mkdir -p "$work" "$(dirname "$out")"
export OMP_NUM_THREADS=1  # one thread, one MPI rank

load() { echo "$(cut -d' ' -f1 /proc/loadavg)/$(( $(sed -n 's/^procs_running //p' /proc/stat) - 1 ))"; }
echo "omega,variant,run,collections,us_per_particle_step,loop_seconds,neigh_seconds,us_per_particle_build,particles,steps,kinetic_energy,contacts,rebuilds,load1" \
  > "$runs_csv"

# prepare OMEGA: start file, LAMMPS data, dt, skin, damping, both neighbour files (globals).
prepare() {
  local om="$1" dir="$work/uv$1"
  mkdir -p "$dir"
  start="$dir/start.txt"
  if [ "$reuse" = 1 ] && [ -s "$start" ] && grep -q "^time step" "$dir/prepare.log" 2> /dev/null; then
    echo "== omega $om: reusing $start"
  else
    echo "== omega $om: preparing $count spheres"
    "$polydem" relax "$lammps_dir/prepare.toml" -q --set particles.count="$count" \
      --set particles.distribution='"uniform-volume"' --set particles.omega="$om" \
      --set particles.packing_fraction=0.6 --set contact.restitution="$restitution" \
      --set output.final="\"$start\"" > "$dir/prepare.log"
  fi
  dt=$(sed -n 's/^time step: dt = \([0-9.e+-]*\) s.*/\1/p' "$dir/prepare.log")
  # skin 0.2 r_min, as scripts/compare_lammps.sh
  skin=$(python3 -c "import sys; rows=[l.split() for l in open(sys.argv[1]) if l.strip() and not l.startswith('#')][1:]; print(repr(0.2*min(float(r[3]) for r in rows)))" "$start")
  local info
  info=$(python3 "$lammps_dir/polydem_to_lammps.py" "$start" "$dir/start.data" --density "$density" \
           --collections --restitution "$restitution" --stiffness "$stiffness")
  damping=$(sed -n 's/.*damping=\([a-z]*\).*/\1/p' <<< "$info")
  dampcoeff=$(sed -n 's/.*dampcoeff=\([^ ]*\).*/\1/p' <<< "$info")
  "$polydem" lammps-neighbor "$start" --skin "$skin" --pair granular ${COST_RATIO:+--cost-ratio "$COST_RATIO"} \
    > "$dir/model_report.lmp"
  "$polydem" lammps-neighbor "$start" --skin "$skin" --pair granular ${COST_RATIO:+--cost-ratio "$COST_RATIO"} \
    --format lines > "$dir/neigh_model.lmp"
  # The hand-made set: the same lines with the doubling collections.
  sed "s|collection/interval .*|collection/interval $(sed -n 's/^collections=//p' <<< "$info")|" \
    "$dir/neigh_model.lmp" > "$dir/neigh_doubling.lmp"
  if [ "$rebuild" = always ]; then sed -i 's/check yes/check no/' "$dir/neigh_model.lmp" "$dir/neigh_doubling.lmp"; fi
  echo "   dt = $dt s, skin = $skin m"
  sed 's/^/   model:    /' "$dir/neigh_model.lmp" | grep collection/interval
  sed 's/^/   doubling: /' "$dir/neigh_doubling.lmp" | grep collection/interval
  grep "predicted" "$dir/model_report.lmp" | sed 's/^#/  /'
}

# run_lammps OMEGA VARIANT RUN
run_lammps() {
  local om="$1" variant="$2" run="$3" dir="$work/uv$1" log l
  log="$dir/lammps_${variant}_${run}.log"
  l=$(load)
  "$lmp" -in "$lammps_dir/in.relax" -log "$log" -screen none -nocite -var dir "$lammps_dir" \
    -var data "$dir/start.data" -var dt "$dt" -var steps "$steps" -var kn "$stiffness" -var damping "$damping" \
    -var dampcoeff "$dampcoeff" -var gamman 0 -var skin "$skin" -var pair granular -var neigh file \
    -var neighfile "$dir/neigh_${variant}.lmp" -var final "$dir/lammps_${variant}.dump"
  local secs n ke contacts rebuilds us ncoll neigh build
  read -r secs n < <(sed -n 's/^Loop time of \([0-9.e+-]*\) on 1 procs for [0-9]* steps with \([0-9]*\) atoms/\1 \2/p' "$log" | head -1)
  ke=$(sed -n 's/^FINAL ke \([^ ]*\) contacts.*/\1/p' "$log")
  contacts=$(sed -n 's/^FINAL ke .* contacts \([0-9]*\).*/\1/p' "$log")
  rebuilds=$(sed -n 's/^Neighbor list builds = \([0-9]*\).*/\1/p' "$log" | head -1)
  ncoll=$(sed -n 's/.*collection\/interval \([0-9]*\) .*/\1/p' "$dir/neigh_${variant}.lmp")
  neigh=$(sed -n 's/^Neigh *| *[0-9.e+-]* *| *\([0-9.e+-]*\) .*/\1/p' "$log" | head -1)
  us=$(python3 -c "print(f'{1e6*$secs/($steps*$n):.5f}')")
  # one build per particle; undefined (empty) when the loop rebuilt nothing
  build=$(python3 -c "print(f'{1e6*$neigh/($rebuilds*$n):.5f}' if $rebuilds > 0 else '')")
  echo "$om,$variant,$run,$ncoll,$us,$secs,$neigh,$build,$n,$steps,$ke,$contacts,$rebuilds,$l" >> "$runs_csv"
  printf '   lammps %-9s (%2s collections) run %s: %s us/particle/step, %s builds (%s us/particle/build), ke %s, contacts %s (load %s)\n' \
    "$variant" "$ncoll" "$run" "$us" "$rebuilds" "${build:-undefined}" "$ke" "$contacts" "$l"
}

for om in "${omegas[@]}"; do
  prepare "$om"
  for ((r = 1; r <= repeats; ++r)); do
    # Alternate which set goes first, so neither always runs on a warm cache.
    if ((r % 2)); then order=(model doubling); else order=(doubling model); fi
    for v in "${order[@]}"; do run_lammps "$om" "$v" "$r"; done
  done
done

python3 - "$runs_csv" "$out" <<'PY'
import csv, statistics, sys
runs, out = sys.argv[1:]
rows = list(csv.DictReader(open(runs)))
def med(rs, key):
    v = [float(r[key]) for r in rs if r[key] != ""]
    return statistics.median(v) if v else None
def fmt(x, spec):
    return "undefined" if x is None else format(x, spec)
with open(out, "w") as f:
    f.write("omega,runs,collections_model,collections_doubling,median_us_model,median_us_doubling,doubling_over_model,"
            "median_build_us_model,median_build_us_doubling,build_doubling_over_model,same_contacts\n")
    print(f"\n{'omega':>6} {'runs':>4} {'N model':>7} {'N doubl.':>8} {'us/p/step model':>15} {'doubling':>9} {'ratio':>6}"
          f" {'us/p/build model':>16} {'doubling':>9} {'ratio':>6}")
    for om in dict.fromkeys(r["omega"] for r in rows):
        m = [r for r in rows if r["omega"] == om and r["variant"] == "model"]
        d = [r for r in rows if r["omega"] == om and r["variant"] == "doubling"]
        mm, md = med(m, "us_per_particle_step"), med(d, "us_per_particle_step")
        bm, bd = med(m, "us_per_particle_build"), med(d, "us_per_particle_build")
        ratio = md / mm
        bratio = bd / bm if bm and bd else None  # undefined without rebuilds in the loop
        same = all(r["contacts"] == m[0]["contacts"] for r in m + d)
        f.write(f"{om},{len(m)},{m[0]['collections']},{d[0]['collections']},{mm:.5f},{md:.5f},{ratio:.4f},"
                f"{fmt(bm, '.5f')},{fmt(bd, '.5f')},{fmt(bratio, '.4f')},{same}\n")
        print(f"{om:>6} {len(m):>4} {m[0]['collections']:>7} {d[0]['collections']:>8} {mm:15.4f} {md:9.4f} {ratio:6.3f}"
              f" {fmt(bm, '16.4f'):>16} {fmt(bd, '9.4f'):>9} {fmt(bratio, '6.3f'):>6}")
        if bratio is None:
            print(f"   omega {om}: no list builds inside the loop: per-build cost undefined (more STEPS or REBUILD=always)")
        if not same:
            print(f"   WARNING omega {om}: the final contact counts differ between runs (physics must not depend on the lists)")
print(f"\nsummary: {out}\nruns:    {runs}")
PY
