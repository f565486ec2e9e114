#!/usr/bin/env bash
# jamming_dem_cost.sh: cost of one FIRE step against one `relax` (velocity Verlet) step on the same jammed
# soft packing, the same contact law and broad phase (issue 19 target: within 1.2x). Time it on a quiet
# machine (the numbers in docs/ come from such runs, never from a shared one).
#   scripts/jamming_dem_cost.sh [-n N] [-w OMEGA] [-s STEPS] [-b BUILD] [-o OUTDIR]
# ROUNDS (default 3) interleaved relax / FIRE pairs, medians. The jammed start (OUTDIR/soft.txt, minutes of
# FIRE at N = 50,000) is made once and reused by later calls with the same OUTDIR: make it on a busy machine
# with ROUNDS=0, time later.
set -euo pipefail
n=50000; omega=10; steps=2000; build=build; out=build/jamming-dem-cost
while getopts "n:w:s:b:o:" opt; do
  case "$opt" in n) n="$OPTARG" ;; w) omega="$OPTARG" ;; s) steps="$OPTARG" ;; b) build="$OPTARG" ;; o) out="$OPTARG" ;;
    *) exit 2 ;; esac
done
polydem="$(realpath "$build/apps/polydem")"
mkdir -p "$out"; cd "$out"
# The start: random centres at phi0 = 0.74 (just above phi_J ~ 0.741 of uniform volume omega = 10 with these
# contacts, docs/jamming_dem.md), minimised by FIRE for 20,000 steps: a packing of the same density and contact
# network as a jammed one, without the hours of the pressure bisection at N = 50,000 (the cost of a step
# depends on the contacts and the lists, not on how exactly the state is balanced). Then the same state for
# both runs, FIRE compressing it by 1e-3.
[[ -s soft.txt ]] || { "$polydem" minimise -n "$n" --dist uv --omega "$omega" --phi0 "${PHI0:-0.74}" \
  --max-iterations 20000 --broad-phase linked-cell --progress 0 -o soft.txt > jam.log || true; }
[[ -s soft.txt ]] || { echo "jamming_dem_cost: the start was not written (see $PWD/jam.log)" >&2; exit 1; }
cat > relax.toml <<TOML
[particles]
file = "soft.txt"
density = 1.0
[contact]
law = "linear"
stiffness = 1.0
stiffness_scaling = "radius"
restitution = 1.0
[velocities]
initial = "zero"
[run]
steps = $steps
broadphase = "linked-cell"
check_interval = 0
TOML
rounds=${ROUNDS:-3}
((rounds > 0)) || { echo "start ready: $PWD/soft.txt"; exit 0; }
rs=() fs=()
for _ in $(seq "$rounds"); do
  relax="$("$polydem" relax relax.toml)"
  fire="$("$polydem" minimise -i soft.txt --delta-phi 1e-3 --broad-phase linked-cell --max-iterations "$steps" \
          --force-tolerance 1e-15 --progress 0 || true)"
  rs+=("$(awk '/us\/particle\/step in the loop/ {print $2}' <<<"$relax")")
  fs+=("$(awk -v n="$n" '/^time / {gsub(/,/, "", $4); print 1e6 * $2 / ($4 * n)}' <<<"$fire")")
done
echo "relax step  ${rs[*]} us/particle/step (velocity Verlet, force loop + two kicks; rounds)"
echo "FIRE step   ${fs[*]} us/particle/step (whole minimise call, measurements included; rounds)"
echo "relax: $(grep -m1 'rebuilds' <<<"$relax")"
echo "FIRE:  $(grep -m1 '^FIRE steps' <<<"$fire")"
echo "(FIRE moves particles further per step than a relax run from rest, so it may rebuild the neighbour list"
echo " more often: the broad phase is inside both times; compare the rebuild counts)"
/usr/bin/python3 - "${rs[*]}" "${fs[*]}" <<'PY'
import statistics, sys
r = statistics.median(float(x) for x in sys.argv[1].split())
f = statistics.median(float(x) for x in sys.argv[2].split())
print(f"medians: relax {r:.4f}, FIRE {f:.4f} us/particle/step; ratio FIRE / relax = {f / r:.3f} (target <= 1.2)")
PY
