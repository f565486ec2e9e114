#!/usr/bin/env bash
# jamming_dem_runs.sh: the target runs of issue 19, to be launched on a quiet machine (hours; not in CI).
#   big    10^6 frictionless spheres, f(r) ~ r^-3 (uniform-volume), size ratio 100, jammed at p/k = 1e-6
#   scan   N = 10^5, size ratio 1, 3, 10, 30, 100 (same exponent), jammed at p/k = 1e-6
#   starts N = 10^4, size ratio 30 (at 10^4 spheres a periodic box is too short for size ratio 100): the event-driven start (`polydem jam`) against independent random centres,
#          to say which reaches the jammed state faster for wide distributions
# Every run logs its command, wall time and peak memory (/usr/bin/time -v) next to its output.
#
#   scripts/jamming_dem_runs.sh big|scan|starts|all [-b BUILD] [-o OUTDIR] [-t THREADS] [-m fire|cg]
#                               [-n SCAN_COUNT] [-s edmd|random] [-w "1 3 10 30 100"]
# -m: the minimiser (default cg: 1.5x fewer force evaluations than FIRE near jamming at 10^4,
# docs/jamming_dem.md); -n: spheres per scan run (default 10^5); -s: the scan's start, a hard-sphere
# `jam` packing (edmd, default) or independent random centres just above the expected phi_J (random); -w: the
# scan's size ratios. A periodic box must be longer than twice the largest cutoff (2 r_max + skin): at size
# ratio 100 that needs N >~ 7 x 10^4 spheres, at 30 N >~ 6000.
set -euo pipefail
what="${1:-}"; shift || true
build=build; out=build/jamming-dem-runs; threads=2; method=cg; scan_count=100000; scan_start=edmd; ratios="1 3 10 30 100"
while getopts "b:o:t:m:n:s:w:" opt; do
  case "$opt" in
    b) build="$OPTARG" ;; o) out="$OPTARG" ;; t) threads="$OPTARG" ;; m) method="$OPTARG" ;;
    n) scan_count="$OPTARG" ;; s) scan_start="$OPTARG" ;; w) ratios="$OPTARG" ;; *) exit 2 ;;
  esac
done
case "$scan_start" in edmd|random) ;; *) echo "-s must be edmd or random, got $scan_start" >&2; exit 2 ;; esac
polydem="$build/apps/polydem"
[ -x "$polydem" ] || { echo "$polydem not found: build it first (scripts/build.sh)" >&2; exit 2; }
mkdir -p "$out"

# run NAME ARGS...: polydem ARGS with wall time and peak memory in NAME.log (exit code kept).
run() {
  local name="$1"; shift
  echo "+ polydem $*" | tee "$out/$name.log"
  set +e
  /usr/bin/time -v "$polydem" "$@" >>"$out/$name.log" 2>"$out/$name.time"; local code=$?
  set -e
  grep -E "Elapsed \(wall|Maximum resident" "$out/$name.time" | tee -a "$out/$name.log"
  grep -E "^(phi_J|rattlers|z \(non|result|time) " "$out/$name.log" || true
  echo "exit $code" | tee -a "$out/$name.log"
}

# Shared settings: harmonic radius-scaled contacts (k_ij = k R_eff, p/k dimensionless), FIRE to a residual of
# 1e-7 of the mean contact force: the round-off floor eps L / delta of fire_minimiser.hpp is ~1e-7 for the
# smallest spheres of the 10^6, 1:100 box (L ~ 10^3 r_min, delta ~ 1e-6 r_min at p/k = 1e-6).
common=(--target-pressure 1e-6 --force-tolerance 1e-7 --threads "$threads" --broad-phase auto --progress 60
        --method "$method")

big() {
  # Event-driven start: hard spheres compressed to reduced pressure 1e3 (phi within ~0.3% of jamming), then
  # the soft protocol from there (overlap-free, so FIRE starts near the answer).
  run big_edmd jam -n 1000000 --dist uniform-volume --omega 100 --schedule 1e-2:1e2,1e-3 --target-pressure 1e3 \
      --broad-phase hgrid-td -o "$out/big_hs.h5"
  run big_soft minimise -i "$out/big_hs.h5" "${common[@]}" --initial-step 1e-4 --size-classes 10 -o "$out/big_soft.h5"
}

scan() {
  # Random starts: phi0 a little above the phi_J expected at each size ratio (the protocol decompresses).
  declare -A phi0=([1]=0.66 [3]=0.70 [10]=0.76 [30]=0.80 [100]=0.84)
  for omega in $ratios; do
    if [ "$scan_start" = edmd ]; then
      run "scan_edmd_w$omega" jam -n "$scan_count" --dist uniform-volume --omega "$omega" --schedule 1e-2:1e2,1e-3 \
          --target-pressure 1e3 -o "$out/scan_hs_w$omega.h5"
      run "scan_soft_w$omega" minimise -i "$out/scan_hs_w$omega.h5" "${common[@]}" --initial-step 1e-4 \
          --size-classes 10 -o "$out/scan_soft_w$omega.h5"
    else
      run "scan_soft_w$omega" minimise -n "$scan_count" --dist uniform-volume --omega "$omega" --placement random \
          --phi0 "${phi0[$omega]}" "${common[@]}" --size-classes 10 -o "$out/scan_soft_w$omega.h5"
    fi
  done
  echo "omega,phi_J,rattler_fraction,z_nonrattlers" > "$out/scan.csv"
  for omega in $ratios; do
    awk -v w="$omega" '/^phi_J/ {p = $2} /^rattlers/ {gsub(/[(;]/, "", $5); r = $5}
         /^z \(non-rattlers\)/ {gsub(/;/, "", $3); z = $3} END {print w "," p "," r "," z}' "$out/scan_soft_w$omega.log" \
      >> "$out/scan.csv"
  done
  /usr/bin/python3 - "$out/scan.csv" "$out/scan.png" <<'PY'
import sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
d = np.genfromtxt(sys.argv[1], delimiter=",", names=True)
fig, ax = plt.subplots(1, 2, figsize=(9, 3.5))
ax[0].semilogx(d["omega"], d["phi_J"], "o-"); ax[0].set_xlabel("size ratio"); ax[0].set_ylabel("phi_J (p/k = 1e-6)")
ax[1].semilogx(d["omega"], d["rattler_fraction"], "o-"); ax[1].set_xlabel("size ratio"); ax[1].set_ylabel("rattler fraction")
fig.tight_layout(); fig.savefig(sys.argv[2], dpi=120)
print("wrote", sys.argv[2])
PY
}

starts() {
  run starts_edmd jam -n 10000 --dist uniform-volume --omega 30 --schedule 1e-2:1e2,1e-3 --target-pressure 1e3 \
      -o "$out/starts_hs.h5"
  run starts_from_edmd minimise -i "$out/starts_hs.h5" "${common[@]}" --initial-step 1e-4
  run starts_random minimise -n 10000 --dist uniform-volume --omega 30 --placement random --phi0 0.8 "${common[@]}"
}

case "$what" in
  big) big ;; scan) scan ;; starts) starts ;; all) starts; scan; big ;;
  *) echo "usage: $0 big|scan|starts|all [-b BUILD] [-o OUTDIR] [-t THREADS] [-m fire|cg] [-n SCAN_COUNT]" \
          "[-s edmd|random] [-w RATIOS]" >&2; exit 2 ;;
esac
