#!/usr/bin/env bash
# jamming_dem_cost.sh: cost of one FIRE step against one `relax` (velocity Verlet) step on the same jammed
# soft packing, the same contact law and broad phase (issue 19 target: within 1.2x). Time it on a quiet
# machine (the numbers in docs/ come from such runs, never from a shared one).
#   scripts/jamming_dem_cost.sh [-n N] [-w OMEGA] [-s STEPS] [-b BUILD] [-o OUTDIR]
# ROUNDS (default 3) interleaved relax / FIRE pairs, medians; BROADPHASE (default auto) for every run. The
# start (OUTDIR/soft.txt, minutes of FIRE at N = 50,000) and its compressed copy are made once and reused by
# later calls with the same OUTDIR: make them on a busy machine with ROUNDS=0, time later. Both times are
# split by phase (broad phase, force loop, the rest), so the step can be compared without the list builds,
# whose number follows how far the particles move.
set -euo pipefail
n=50000; omega=10; steps=2000; build=build; out=build/jamming-dem-cost
while getopts "n:w:s:b:o:" opt; do
  case "$opt" in n) n="$OPTARG" ;; w) omega="$OPTARG" ;; s) steps="$OPTARG" ;; b) build="$OPTARG" ;; o) out="$OPTARG" ;;
    *) exit 2 ;; esac
done
polydem="$(realpath "$build/apps/polydem")"
bp=${BROADPHASE:-auto}  # every run's broad phase (the same for both; auto = what a scene gets by default)
mkdir -p "$out"; cd "$out"
# The start: random centres at phi0 = 0.74 (just above phi_J ~ 0.741 of uniform volume omega = 10 with these
# contacts, docs/jamming_dem.md), minimised by FIRE for 20,000 steps: a packing of the same density and contact
# network as a jammed one, without the hours of the pressure bisection at N = 50,000 (the cost of a step
# depends on the contacts and the lists, not on how exactly the state is balanced). Then the same state for
# both runs, compressed by 1e-3 below.
[[ -s soft.txt ]] || { "$polydem" minimise -n "$n" --dist uv --omega "$omega" --phi0 "${PHI0:-0.74}" \
  --max-iterations 20000 --broad-phase "$bp" --progress 0 -o soft.txt > jam.log || true; }
[[ -s soft.txt ]] || { echo "jamming_dem_cost: the start was not written (see $PWD/jam.log)" >&2; exit 1; }
# The common state of both timed runs: the start compressed affinely by delta phi = 1e-3 (radii grown, centres
# fixed) and written after one FIRE step (the fewest `minimise` takes), so both integrators start from the
# same overlaps at rest and move.
[[ -s compressed.txt ]] || { "$polydem" minimise -i soft.txt --delta-phi 1e-3 --max-iterations 1 \
  --broad-phase "$bp" --progress 0 -o compressed.txt > compress.log || true; }
[[ -s compressed.txt ]] || { echo "jamming_dem_cost: the compressed state was not written (see $PWD/compress.log)" >&2; exit 1; }
cat > relax.toml <<TOML
[particles]
file = "compressed.txt"
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
broadphase = "$bp"
check_interval = 0
TOML
rounds=${ROUNDS:-3}
((rounds > 0)) || { echo "start ready: $PWD/soft.txt, $PWD/compressed.txt"; exit 0; }
: > rounds.txt
for _ in $(seq "$rounds"); do
  relax="$("$polydem" relax relax.toml)"
  fire="$("$polydem" minimise -i compressed.txt --broad-phase "$bp" --max-iterations "$steps" \
          --force-tolerance 1e-15 --progress 0 || true)"
  # relax: total, broad, force, integration + checks; FIRE: total, broad, force, update + measurements (us per
  # particle-step), then the list builds of each.
  r="$(awk '/us\/particle\/step in the loop/ {gsub(/,/, ""); print $2, $11, $13, $15 + $17}' <<<"$relax")"
  f="$(awk '/^FIRE time/ {gsub(/,/, ""); print $3, $9, $11, $13 + $15}' <<<"$fire")"
  rb="$(awk '/^neighbour list/ {print $3}' <<<"$relax")"
  fb="$(awk '/^FIRE steps/ {gsub(/[(,]/, ""); print $6}' <<<"$fire")"
  echo "$r $f ${rb:-?} ${fb:-?}" >> rounds.txt
done
echo "relax: $(grep -m1 '^neighbour list' <<<"$relax")"
echo "FIRE:  $(grep -m1 '^FIRE steps' <<<"$fire")"
echo "       $(grep -m1 '^FIRE time' <<<"$fire")"
/usr/bin/python3 - rounds.txt <<'PY'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1]) if line.strip()]
med = lambda k: statistics.median(float(r[k]) for r in rows)
rt, rbp, rf, ri, ft, fbp, ff, fu = (med(k) for k in range(8))
print(f"rounds {len(rows)}; medians in us/particle/step; list builds relax {rows[-1][8]}, FIRE {rows[-1][9]} (last round)")
print(f"  whole step        relax {rt:.4f}  FIRE {ft:.4f}  ratio {ft / rt:.3f} (target <= 1.2)")
print(f"  broad phase       relax {rbp:.4f}  FIRE {fbp:.4f}")
print(f"  force loop        relax {rf:.4f}  FIRE {ff:.4f}  ratio {ff / rf:.3f}")
print(f"  without builds    relax {rf + ri:.4f}  FIRE {ff + fu:.4f}  ratio {(ff + fu) / (rf + ri):.3f}")
print("  (without builds = force loop + integration: relax kicks, drift, checks; FIRE sums, mixing, kick, drift,")
print("   measurements; the builds follow the motion: compare the build counts)")
PY
