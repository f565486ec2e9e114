#!/usr/bin/env bash
# polydem relax against LAMMPS (Debian package `lammps`, pair_style granular / gran/hooke) on the same
# configuration, contact law, time step and number of steps, one core each. A measurement script, not
# CI: LAMMPS is not a build dependency (not in scripts/setup.sh). Install it once with
#   DEBIAN_FRONTEND=noninteractive apt-get install -y lammps
#
#   scripts/compare_lammps.sh [SCENE ...]      SCENE: one of the list below, or "issue18" for the eight
#                                              scenes of issue 18 (default: mono uv20 uv50)
#
#   mono     monodisperse, RSA at 0.3, soft compression to packing fraction 0.6 (RSA cannot reach 0.6)
#   mono30   monodisperse, RSA at 0.3 as it is
#   bi10     bidisperse omega = 10, equal volumes of both species, RSA at 0.3 softly compressed to 0.6
#   bi10_30  the same at 0.3 as placed
#   uv10     uniform volume f(r) ~ r^-3 (power law, exponent -3), omega = 10, RSA directly at 0.6
#   uv10_30  the same at 0.3
#   uv20     uniform volume f(r) ~ r^-3, omega = 20, RSA directly at 0.6 (non-overlapping start)
#   uv20_30  the same at 0.3
#   uv50     the same with omega = 50
#   uv20c  uv20 from RSA at 0.5 softly compressed to 0.6 (starts with the small overlaps it leaves)
#   uv50c  uv50 likewise
#
# Per scene: (1) `polydem relax benchmarks/lammps/prepare.toml` writes the start (positions, radii,
# impact velocities) as a text particle file; (2) benchmarks/lammps/polydem_to_lammps.py turns it into a
# LAMMPS data file (atom_style sphere: diameter, density, velocities) and prints the damping and
# neighbor-multi arguments; (3) REPEATS rounds, each timing polydem (THREADS thread counts) and every
# LAMMPS variant once, interleaved so slow drifts in machine load hit all of them alike; (4) physics
# checks: final kinetic energy and contact count of the restitution run, and an elastic run (e = 1) of
# both codes compared particle by particle (benchmarks/lammps/compare_states.py).
#
# Times are the codes' own time-loop figures: polydem's "us/particle/step in the loop", LAMMPS' "Loop
# time" / (steps N). Both exclude setup and the initial neighbour build and include rebuilds.
#
# Environment: POLYDEM_BUILD (build dir, default build), LMP (lmp), REPEATS (3), STEPS (1000),
# THREADS (polydem thread counts, default "1 2"; the LAMMPS ratio uses 1), WORKDIR (scratch, default
# $POLYDEM_BUILD/compare_lammps), OUT (summary CSV, default docs/benchmarks/dem_vs_lammps.csv; the
# per-run CSV goes beside it as *_runs.csv, the physics checks as *_physics.csv), REUSE=1 (keep a start
# already prepared in WORKDIR), LAMMPS=0 (time polydem only, e.g. thread scaling:
#   THREADS="1 2" LAMMPS=0 REUSE=1 REPEATS=5 OUT=docs/benchmarks/dem_threads.csv scripts/compare_lammps.sh).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${POLYDEM_BUILD:-$root/build}"
polydem="$build/apps/polydem"
lmp="${LMP:-lmp}"
repeats="${REPEATS:-3}"
steps="${STEPS:-1000}"
threads_list="${THREADS:-1 2}"
work="${WORKDIR:-$build/compare_lammps}"
out="${OUT:-$root/docs/benchmarks/dem_vs_lammps.csv}"
runs_csv="${out%.csv}_runs.csv"
physics_csv="${out%.csv}_physics.csv"
lammps_dir="$root/benchmarks/lammps"
density=2500.0
stiffness=1000.0
restitution=0.9

reuse="${REUSE:-0}"
with_lammps="${LAMMPS:-1}"

[ -x "$polydem" ] || { echo "compare_lammps: $polydem not found: build polydem or set POLYDEM_BUILD" >&2; exit 1; }
[ "$with_lammps" = 0 ] || command -v "$lmp" > /dev/null || {
  echo "compare_lammps: '$lmp' not found: DEBIAN_FRONTEND=noninteractive apt-get install -y lammps" >&2; exit 1; }
all_scenes="mono mono30 bi10 bi10_30 uv10 uv10_30 uv20 uv20_30 uv50 uv20c uv50c"
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(mono uv20 uv50)
[ "${scenes[*]}" = issue18 ] && scenes=(mono mono30 bi10 bi10_30 uv10 uv10_30 uv20 uv20_30)
mkdir -p "$work" "$(dirname "$out")"
export OMP_NUM_THREADS=1  # LAMMPS: one thread, one MPI rank (the Debian binary is MPI-built: singleton)
# polydem's thread count comes from --threads. Its threads wait passively (OMP_WAIT_POLICY=passive unless
# set): with libgomp's default spinning, 2 threads ran 5-10x slower than 1 whenever another job held a
# core. Note that Linux autogroup scheduling gives each session a fair share whatever its thread count,
# so 2 threads only gain on an otherwise idle machine.

# 1-minute load average (it includes this script's previous runs) and the processes running right now
# besides this shell, as "load/running".
load() { echo "$(cut -d' ' -f1 /proc/loadavg)/$(( $(sed -n 's/^procs_running //p' /proc/stat) - 1 ))"; }
echo "scene,code,variant,threads,run,us_per_particle_step,loop_seconds,particles,steps,kinetic_energy,contacts,rebuilds,load1" \
  > "$runs_csv"
echo "scene,check,restitution,ke_polydem,ke_lammps,ke_rel_diff,contacts_polydem,contacts_lammps,max_dx_over_rmin,max_dv_over_vmax" \
  > "$physics_csv"

# prepare SCENE: the start file, dt, skin, LAMMPS arguments (globals).
prepare() {
  local scene="$1" sets=()
  case "$scene" in
    mono)  sets=(--set particles.distribution='"mono"' --set particles.packing_fraction=0.3
                 --set compression.packing_fraction=0.6) ;;
    mono30) sets=(--set particles.distribution='"mono"' --set particles.packing_fraction=0.3) ;;
    bi10)  sets=(--set particles.distribution='"bi"' --set particles.omega=10 --set particles.packing_fraction=0.3
                 --set compression.packing_fraction=0.6) ;;
    bi10_30)
           sets=(--set particles.distribution='"bi"' --set particles.omega=10 --set particles.packing_fraction=0.3) ;;
    uv10|uv20|uv50)
           sets=(--set particles.distribution='"uniform-volume"' --set particles.omega="${scene#uv}"
                 --set particles.packing_fraction=0.6) ;;
    uv10_30|uv20_30)
           local w="${scene#uv}"; w="${w%_30}"
           sets=(--set particles.distribution='"uniform-volume"' --set particles.omega="$w"
                 --set particles.packing_fraction=0.3) ;;
    uv20c|uv50c)
           local om="${scene#uv}"; om="${om%c}"
           sets=(--set particles.distribution='"uniform-volume"' --set particles.omega="$om"
                 --set particles.packing_fraction=0.5 --set compression.packing_fraction=0.6) ;;
    *) echo "compare_lammps: unknown scene '$scene' ($all_scenes)" >&2; exit 1 ;;
  esac
  start="$work/$scene/start.txt"
  mkdir -p "$work/$scene"
  if [ "$reuse" = 1 ] && [ -s "$start" ] && grep -q "^time step" "$work/$scene/prepare.log" 2> /dev/null; then
    echo "== $scene: reusing $start"
  else
    echo "== $scene: preparing ($polydem relax $lammps_dir/prepare.toml ${sets[*]})"
    "$polydem" relax "$lammps_dir/prepare.toml" -q "${sets[@]}" --set contact.restitution="$restitution" \
      --set output.final="\"$start\"" > "$work/$scene/prepare.log"
  fi
  grep -E "^soft compression|^particles:|^time step" "$work/$scene/prepare.log" | sed 's/^/   /'
  dt=$(sed -n 's/^time step: dt = \([0-9.e+-]*\) s.*/\1/p' "$work/$scene/prepare.log")
  skin=$(python3 -c "import sys; rows=[l.split() for l in open(sys.argv[1]) if l.strip() and not l.startswith('#')][1:]; print(repr(0.2*min(float(r[3]) for r in rows)))" "$start")
  local info
  info=$(python3 "$lammps_dir/polydem_to_lammps.py" "$start" "$work/$scene/start.data" --density "$density" \
           --collections --restitution "$restitution" --stiffness "$stiffness")
  collections=$(sed -n 's/^collections=//p' <<< "$info")
  damping=$(sed -n 's/.*damping=\([a-z]*\).*/\1/p' <<< "$info")
  dampcoeff=$(sed -n 's/.*dampcoeff=\([^ ]*\).*/\1/p' <<< "$info")
  gamman=$(sed -n 's/.*gamman=\([^ ]*\).*/\1/p' <<< "$info")
  case "$scene" in
    mono|mono30) variants=("granular bin" "gran_hooke bin") ;;
    *)    variants=("granular multi" "granular bin") ;;
  esac
  echo "   dt = $dt s, skin = $skin m, LAMMPS damping $damping $dampcoeff, collections $collections"
}

# run_polydem SCENE THREADS RUN E FINAL -> appends to runs CSV (RUN = check: not timed)
run_polydem() {
  local scene="$1" threads="$2" run="$3" e="$4" final="$5" log l
  log="$work/$scene/polydem_t${threads}_${run}.log"
  l=$(load)
  OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}" "$polydem" relax "$lammps_dir/polydem_run.toml" -q --set particles.file="\"$start\"" --set run.dt="$dt" \
    --skin "$skin" --steps "$steps" --threads "$threads" --set contact.restitution="$e" \
    --set output.final="\"$final\"" > "$log"
  local us secs n ke contacts rebuilds backend
  us=$(sed -n 's/^time *\([0-9.]*\) us\/particle\/step in the loop (\([0-9.]*\) s).*/\1/p' "$log")
  secs=$(sed -n 's/^time .*in the loop (\([0-9.]*\) s).*/\1/p' "$log")
  n=$(sed -n 's/^particles: \([0-9]*\) .*/\1/p' "$log")
  ke=$(sed -n 's/^energy (J) *kinetic \([^,]*\),.*/\1/p' "$log")
  contacts=$(sed -n 's/^contacts *\([0-9]*\) particle pairs.*/\1/p' "$log")
  rebuilds=$(sed -n 's/^neighbour list *\([0-9]*\) rebuilds.*/\1/p' "$log")
  backend=$(sed -n 's/^broad phase: \([^ ]*\( -> [^ ]*\)\{0,1\}\).*/\1/p' "$log")
  # loop seconds / (steps N) at full precision (the report rounds us to 4 decimals)
  us=$(python3 -c "print(f'{1e6*$secs/($steps*$n):.5f}')")
  echo "$scene,polydem,${backend// /},$threads,$run,$us,$secs,$n,$steps,$ke,$contacts,$rebuilds,$l" >> "$runs_csv"
  printf '   polydem  %-26s threads %s run %s: %s us/particle/step (load %s)\n' "$backend" "$threads" "$run" "$us" "$l"
}

# run_lammps SCENE PAIR NEIGH RUN DAMPING DAMPCOEFF FINAL
run_lammps() {
  local scene="$1" pair="$2" neigh="$3" run="$4" damp="$5" coeff="$6" final="$7" log l
  log="$work/$scene/lammps_${pair}_${neigh}_${run}.log"
  l=$(load)
  local args=(-var dir "$lammps_dir" -var data "$work/$scene/start.data" -var dt "$dt" -var steps "$steps"
              -var kn "$stiffness" -var damping "$damp" -var dampcoeff "$coeff" -var gamman "$gamman"
              -var skin "$skin" -var pair "$pair" -var neigh "$neigh" -var final "$final")
  [ "$neigh" = multi ] && args+=(-var collections "$collections")
  "$lmp" -in "$lammps_dir/in.relax" -log "$log" -screen none -nocite "${args[@]}"
  local secs n ke contacts rebuilds us
  read -r secs n < <(sed -n 's/^Loop time of \([0-9.e+-]*\) on 1 procs for [0-9]* steps with \([0-9]*\) atoms/\1 \2/p' "$log" | head -1)
  ke=$(sed -n 's/^FINAL ke \([^ ]*\) contacts.*/\1/p' "$log")
  contacts=$(sed -n 's/^FINAL ke .* contacts \([0-9]*\).*/\1/p' "$log")
  rebuilds=$(sed -n 's/^Neighbor list builds = \([0-9]*\).*/\1/p' "$log" | head -1)
  us=$(python3 -c "print(f'{1e6*$secs/($steps*$n):.5f}')")
  echo "$scene,lammps,${pair}/${neigh},1,$run,$us,$secs,$n,$steps,$ke,$contacts,$rebuilds,$l" >> "$runs_csv"
  printf '   lammps   %-26s threads 1 run %s: %s us/particle/step (load %s)\n' "$pair/$neigh" "$run" "$us" "$l"
}

for scene in "${scenes[@]}"; do
  prepare "$scene"
  for ((r = 1; r <= repeats; ++r)); do
    for t in $threads_list; do run_polydem "$scene" "$t" "$r" "$restitution" "$work/$scene/polydem_final.txt"; done
    [ "$with_lammps" = 0 ] && continue
    for v in "${variants[@]}"; do
      read -r pair neigh <<< "$v"
      if [ "$pair" = gran_hooke ] && [ -z "$gamman" ]; then continue; fi
      run_lammps "$scene" "$pair" "$neigh" "$r" "$damping" "$dampcoeff" "$work/$scene/lammps_${pair}_${neigh}.dump"
    done
  done
  [ "$with_lammps" = 0 ] && continue
  # Physics: the restitution runs (last round) and an elastic pair of runs, particle by particle.
  read -r pair neigh <<< "${variants[0]}"
  python3 - "$scene" "$runs_csv" "$physics_csv" "$restitution" "$pair/$neigh" \
    "$(python3 "$lammps_dir/compare_states.py" "$work/$scene/polydem_final.txt" "$work/$scene/lammps_${pair}_${neigh}.dump" --density "$density")" <<'EOF'
import csv, sys
scene, runs, physics, e, variant, cmp = sys.argv[1:]
rows = [r for r in csv.DictReader(open(runs)) if r["scene"] == scene]
p = [r for r in rows if r["code"] == "polydem" and r["threads"] == "1" and r["run"] != "check"][-1]
l = [r for r in rows if r["code"] == "lammps" and r["variant"] == variant and r["run"] != "check"][-1]
kv = dict(x.split("=") for x in cmp.split())
with open(physics, "a") as f:
    f.write(f"{scene},restitution run ({l['variant']}),{e},{kv['ke_polydem']},{kv['ke_lammps']},{kv['ke_rel_diff']},"
            f"{p['contacts']},{l['contacts']},{kv['max_dx_over_rmin']},{kv['max_dv_over_vmax']}\n")
EOF
  echo "   elastic check (e = 1): polydem vs LAMMPS $pair/$neigh"
  run_polydem "$scene" 1 check 1.0 "$work/$scene/polydem_elastic.txt" > /dev/null
  run_lammps "$scene" "$pair" "$neigh" check velocity 0.0 "$work/$scene/lammps_elastic.dump" > /dev/null
  python3 - "$scene" "$runs_csv" "$physics_csv" \
    "$(python3 "$lammps_dir/compare_states.py" "$work/$scene/polydem_elastic.txt" "$work/$scene/lammps_elastic.dump" --density "$density")" <<'EOF'
import csv, sys
scene, runs, physics, cmp = sys.argv[1:]
rows = [r for r in csv.DictReader(open(runs)) if r["scene"] == scene and r["run"] == "check"]
p = [r for r in rows if r["code"] == "polydem"][-1]
l = [r for r in rows if r["code"] == "lammps"][-1]
kv = dict(x.split("=") for x in cmp.split())
with open(physics, "a") as f:
    f.write(f"{scene},elastic run ({l['variant']}),1.0,{kv['ke_polydem']},{kv['ke_lammps']},{kv['ke_rel_diff']},"
            f"{p['contacts']},{l['contacts']},{kv['max_dx_over_rmin']},{kv['max_dv_over_vmax']}\n")
print("   " + cmp)
EOF
done

# Summary: medians over the timed runs, LAMMPS / polydem (1 thread) ratios, polydem thread speed-up.
python3 - "$runs_csv" "$out" <<'EOF'
import csv, statistics, sys
runs, out = sys.argv[1:]
rows = [r for r in csv.DictReader(open(runs)) if r["run"] != "check"]
groups = {}
for r in rows:
    groups.setdefault((r["scene"], r["code"], r["variant"], r["threads"]), []).append(r)
med = {k: statistics.median(float(r["us_per_particle_step"]) for r in v) for k, v in groups.items()}
with open(out, "w") as f:
    f.write("scene,code,variant,threads,runs,median_us_per_particle_step,min_us,max_us,"
            "lammps_over_polydem_1thread,speedup_over_1thread,median_load1\n")
    print(f"\n{'scene':8} {'code':8} {'variant':28} {'thr':>3} {'median us/p/step':>17} {'LAMMPS/polydem':>15} {'speed-up':>9}")
    for key in groups:
        scene, code, variant, threads = key
        v = [float(r["us_per_particle_step"]) for r in groups[key]]
        base = [m for (s, c, _, t), m in med.items() if s == scene and c == "polydem" and t == "1"]
        ratio = med[key] / base[0] if code == "lammps" and base else ""
        one = [m for (s, c, va, t), m in med.items() if s == scene and c == code and va == variant and t == "1"]
        speedup = one[0] / med[key] if code == "polydem" and one else ""
        load = statistics.median(float(r["load1"].split("/")[0]) for r in groups[key])
        f.write(f"{scene},{code},{variant},{threads},{len(v)},{med[key]:.5f},{min(v):.5f},{max(v):.5f},"
                f"{ratio if ratio == '' else f'{ratio:.3f}'},{speedup if speedup == '' else f'{speedup:.3f}'},{load}\n")
        r = "" if ratio == "" else f"{ratio:.2f}"
        su = "" if speedup == "" else f"{speedup:.2f}"
        print(f"{scene:8} {code:8} {variant:28} {threads:>3} {med[key]:17.4f} {r:>15} {su:>9}")
print(f"\nsummary: {out}\nruns:    {runs}")
EOF
if [ "$with_lammps" = 0 ]; then rm -f "$physics_csv"; exit 0; fi
echo "physics: $physics_csv"
column -s, -t < "$physics_csv"
