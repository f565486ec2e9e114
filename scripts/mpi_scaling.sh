#!/usr/bin/env bash
# Strong scaling of `polydem relax` on this machine (issue 20): one process with one thread pinned to a core,
# one process with two threads, and two MPI ranks with one thread each (`mpirun -np 2 --bind-to core`), on
# examples/relax_uv10.toml (uniform volume omega 10, packing 0.6) with particles.count = N. Variants are
# interleaved in every round so a drift in machine load hits them alike; the figure is the loop time of
# `--summary-json` (report.time.loop_seconds: the set-up, where every rank places the whole system, is left
# out), medians over the rounds. A measurement script, not CI: run it with nothing else on the machine.
#
#   scripts/mpi_scaling.sh [BUILD_DIR]                     (default build/)
#   COUNTS="50000 200000" STEPS="3000 600" ROUNDS=3 scripts/mpi_scaling.sh
# Environment: COUNTS (default "50000 200000 1000000"), STEPS (steps per count, same order; default
# "3000 600 150"), ROUNDS (3), OUT (directory for the JSON files and scaling.csv, default a temporary one),
# STARTS=1: place each N once (random sequential addition, a minute at 10^6) into OUT/start_N.txt and start
# every run from that file (the same state and velocities; the set-up then reads a file instead of placing).
# Prints one line per count: the three medians and the speed-ups over one thread.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
polydem="$build/apps/polydem"
[[ -x $polydem ]] || { echo "mpi_scaling: missing $polydem (scripts/build.sh)" >&2; exit 2; }
command -v mpirun >/dev/null || { echo "mpi_scaling: mpirun not found (scripts/setup.sh installs OpenMPI)" >&2; exit 2; }
read -r -a counts <<<"${COUNTS:-50000 200000 1000000}"
read -r -a steps <<<"${STEPS:-3000 600 150}"
((${#steps[@]} == ${#counts[@]})) || { echo "mpi_scaling: STEPS needs one entry per entry of COUNTS" >&2; exit 2; }
rounds="${ROUNDS:-3}"
out="${OUT:-$(mktemp -d)}"
mkdir -p "$out"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
scene="$root/examples/relax_uv10.toml"
cd "$out"  # the scene's relative outputs land here, never in the source tree

# The scene reading a start file: relax_uv10.toml without the keys that only apply when generating.
file_scene() {
  awk -v file="$1" '
    /^\[/ { section = $0 }
    section == "[particles]" && /^count *=/ { print "file = \"" file "\""; next }
    section == "[particles]" && /^(distribution|rmin|omega|sampling|packing_fraction|seed) *=/ { next }
    section == "[velocities]" && /^(initial|overlap|seed) *=/ { next }
    section == "[box]" && /^aspect *=/ { next }
    { print }' "$scene"
}

for c in "${!counts[@]}"; do
  n=${counts[$c]}
  s=${steps[$c]}
  common=(relax "$scene" -q --set "particles.count=$n" --set "run.steps=$s" --set "output.final=$out/final.txt"
    --set 'output.timeseries=""')
  if [[ -n "${STARTS:-}" ]]; then
    [[ -s $out/start_$n.txt ]] || "$polydem" "${common[@]}" --set run.steps=0 --set "output.final=$out/start_$n.txt" >/dev/null
    file_scene "$out/start_$n.txt" >"$out/scene_$n.toml"
    common=(relax "$out/scene_$n.toml" -q --set "run.steps=$s" --set "output.final=$out/final.txt"
      --set 'output.timeseries=""')
  fi
  for r in $(seq "$rounds"); do
    taskset -c 1 "$polydem" "${common[@]}" --summary-json "$out/threads1_${n}_$r.json" >/dev/null
    "$polydem" "${common[@]}" --set run.threads=2 --summary-json "$out/threads2_${n}_$r.json" >/dev/null
    mpirun -np 2 --bind-to core "$polydem" "${common[@]}" --summary-json "$out/ranks2_${n}_$r.json" >/dev/null
  done
done

/usr/bin/python3 - "$out" "${counts[@]}" <<'PY'
import glob, json, statistics, sys
out, counts = sys.argv[1], sys.argv[2:]
rows = ["N,variant,round_seconds,median_seconds,speedup_over_one_thread"]
for n in counts:
    med = {}
    for v in ("threads1", "threads2", "ranks2"):
        xs = [json.load(open(f))["report"]["time"]["loop_seconds"] for f in sorted(glob.glob(f"{out}/{v}_{n}_*.json"))]
        med[v] = (statistics.median(xs), xs)
    base = med["threads1"][0]
    for v, (m, xs) in med.items():
        rows.append(f"{n},{v},{' '.join(f'{x:.3f}' for x in xs)},{m:.3f},{base / m:.3f}")
    print(f"N = {n}: loop seconds (median) 1 thread {base:.2f}, 2 threads {med['threads2'][0]:.2f} "
          f"(x{base / med['threads2'][0]:.2f}), 2 ranks {med['ranks2'][0]:.2f} (x{base / med['ranks2'][0]:.2f})")
open(f"{out}/scaling.csv", "w").write("\n".join(rows) + "\n")
print(f"{out}/scaling.csv")
PY
