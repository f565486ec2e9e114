#!/usr/bin/env bash
# jamming_dem_scan.sh: the harmonic scaling laws above jamming, p ~ (phi - phi_J)^a and
# z - z_iso ~ (phi - phi_J)^b (O'Hern et al., PRE 68, 011306 (2003): a = 1, b = 1/2), with their spread over
# seeds. For each seed: `polydem minimise --target-pressure P0` jams N equal spheres (phi_J at p/k = P0),
# then every `--delta-phi D` compresses that packing by D and minimises; the exponents are the least-squares
# slopes of log p and log(z - z_iso) against log D. Not run in CI (minutes); CTest runs one seed at N = 256
# (PressureJamming.HarmonicScalingAboveJamming).
#
#   scripts/jamming_dem_scan.sh [-n N] [-s SEEDS] [-p P0] [-d "1e-4 3e-4 ..."] [-b BUILD] [-o OUTDIR]
set -euo pipefail
n=512; seeds=4; p0=1e-6; deltas="3e-4 1e-3 3e-3 1e-2 3e-2"; build=build; out=build/jamming-dem-scan
while getopts "n:s:p:d:b:o:" opt; do
  case "$opt" in
    n) n="$OPTARG" ;; s) seeds="$OPTARG" ;; p) p0="$OPTARG" ;; d) deltas="$OPTARG" ;; b) build="$OPTARG" ;;
    o) out="$OPTARG" ;; *) echo "usage: $0 [-n N] [-s SEEDS] [-p P0] [-d DELTAS] [-b BUILD] [-o OUTDIR]" >&2; exit 2 ;;
  esac
done
polydem="$build/apps/polydem"
[ -x "$polydem" ] || { echo "$polydem not found: build it first (scripts/build.sh)" >&2; exit 2; }
mkdir -p "$out"
table="$out/scan.csv"
echo "seed,phi_j,delta_phi,reduced_pressure,z_minus_ziso,rattler_fraction" > "$table"
for seed in $(seq 1 "$seeds"); do
  jammed="$out/jammed_n${n}_s${seed}.h5"
  log="$("$polydem" minimise -n "$n" --phi0 0.62 --seed "$seed" --target-pressure "$p0" --pressure-tolerance 0.2 \
         --progress 0 -o "$jammed")"
  phij="$(awk '/^phi_J/ {print $2}' <<<"$log")"
  [ -n "$phij" ] || { echo "seed $seed: jamming did not reach p/k = $p0:"; tail -3 <<<"$log"; continue; }
  for d in $deltas; do
    log="$("$polydem" minimise -i "$jammed" --delta-phi "$d" --progress 0)" || { echo "seed $seed dphi $d failed"; continue; }
    p="$(awk '/^final/ {for (i = 1; i < NF; ++i) if ($i == "p/k") print $(i + 1)}' <<<"$log")"
    dz="$(awk '/^z \(non-rattlers\)/ {for (i = 1; i < NF; ++i) if ($i == "z_iso") {v = $(i + 1)}} END {print v}' <<<"$log")"
    rf="$(awk '/^rattlers/ {gsub(/[(;]/, "", $5); print $5}' <<<"$log")"
    echo "$seed,$phij,$d,$p,$dz,$rf" >> "$table"
  done
  echo "seed $seed: phi_J = $phij"
done
/usr/bin/python3 - "$table" "$p0" <<'PY'
import sys
import numpy as np
rows = np.genfromtxt(sys.argv[1], delimiter=",", names=True)
a, b, phij = [], [], []
for seed in np.unique(rows["seed"]):
    r = rows[rows["seed"] == seed]
    # A compression that unjammed the packing (it rearranged into one with a higher phi_J; small N) has
    # p ~ 0: not a point of the scaling law.
    ok = (r["reduced_pressure"] > 10 * float(sys.argv[2])) & (r["z_minus_ziso"] > 0)
    if ok.sum() < len(r):
        print(f"seed {int(seed)}: {len(r) - ok.sum()} compression(s) unjammed, left out of the fit")
    x = np.log(r["delta_phi"][ok])
    a.append(np.polyfit(x, np.log(r["reduced_pressure"][ok]), 1)[0])
    b.append(np.polyfit(x, np.log(r["z_minus_ziso"][ok]), 1)[0])
    phij.append(r["phi_j"][0])
def show(name, v):
    v = np.asarray(v)
    spread = v.std(ddof=1) if len(v) > 1 else float("nan")
    print(f"{name:<28} {v.mean():.4f} +- {spread:.4f} (std over {len(v)} seeds; values {', '.join(f'{x:.3f}' for x in v)})")
show("phi_J", phij)
show("p exponent (expect 1)", a)
show("z - z_iso exponent (1/2)", b)
PY
echo "table: $table"
