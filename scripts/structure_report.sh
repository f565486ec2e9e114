#!/usr/bin/env bash
# Structure report (issue 8, Ogarko's thesis §3.3.3-3.3.4 and ch. 4): makes N = 4096 states with `polydem jam`
# (dilute gas, dense liquid, slowly compressed crystal, fast-compressed glass, polydisperse power-law
# n = 3 packing and, with US=1, uniform-radius omega = 1.1 / 1.3 packings), runs `polydem analyze` on
# each (bond order p_c / q6 / Q6, channel-size histogram, S(k) and chi(k), rattlers) and plots with
# gnuplot. Not part of CI: ~15-20 CPU minutes, run under nice.
#
#   scripts/structure_report.sh [build-dir]        # default build/
#   US=0 scripts/structure_report.sh build-b        # skip the two uniform-radius runs
#   PART=equiv scripts/structure_report.sh build-b  # only the poly-vs-tridisperse comparison (~6 CPU min)
#   PART=main ...                                   # everything but that comparison
#
# Outputs: docs/structure/*.csv, *.png, *.log, docs/structure/summary.md and equiv.md (numbers for docs/structure.md).
# The packings themselves (HDF5, ~0.5 MB each) go to $WORK (default <build-dir>/structure-report).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$ROOT/build}" && pwd)
POLYDEM=$BUILD/apps/polydem
OUT=$ROOT/docs/structure
WORK=${WORK:-$BUILD/structure-report}
US=${US:-1}
PART=${PART:-all}   # all, main (states, channels, S(k), summary.md) or equiv (poly vs tridisperse S(k), chi(k))
N=4096
mkdir -p "$OUT" "$WORK"
[ -x "$POLYDEM" ] || { echo "no $POLYDEM: build the polydem target first" >&2; exit 1; }
command -v gnuplot >/dev/null || { echo "gnuplot is needed for the plots (apt-get install gnuplot-nox)" >&2; exit 1; }

# run NAME CMD...: run under nice, keep stdout+stderr and the elapsed/CPU time in $OUT/NAME.log
run() {
  local name=$1; shift
  echo "+ $*" | tee "$OUT/$name.log"
  local t0=$(date +%s.%N)
  /usr/bin/time -f "cpu %U s user + %S s sys, max RSS %M KB" nice -n 10 "$@" >>"$OUT/$name.log" 2>&1
  echo "wall $(echo "$(date +%s.%N) - $t0" | bc) s" >>"$OUT/$name.log"
  tail -n 3 "$OUT/$name.log"
}

# The states. Rates are growth speeds of the radius over the thermal speed (docs/edmd.md). The seed's slow
# path (Gamma = 16e-6 all the way, crystallises) is beyond this budget; a compression at 1e-4 through
# the freezing window did not crystallise N = 4096 either (phi 0.606 at p = 36, still on the glass
# branch). So the "slow" states are compressed at 1e-3 to phi = 0.56 (metastable liquid, p = 21), held
# there for 20,000 collisions per particle (nucleation and growth: p drops to ~14), then compressed fast
# (1e-2) to p = 1e9. The glass is compressed at 1.6e-2 throughout (the seed's fast path, Gamma = 16e-3).
JAM=("$POLYDEM" jam -n $N --velocities --progress 30)
SLOW="--schedule 1e-3 --target-phi 0.56 --run-collisions 20000"
FINISH="--schedule 1e-2 --target-pressure 1e9 --velocities --progress 30"
declare -A STATE_ARGS=(
  [gas]="--phi0 0.0014 --target-phi 0.0015 --seed 1"
  [liquid]="--target-phi 0.5 --seed 1"
  [crystal]="--seed 2 $SLOW"
  [glass]="--seed 3 --schedule 1.6e-2 --target-pressure 1e9"
  [poly3]="--seed 4 --dist power-law --alpha -3 --omega 3 --schedule 1e-2:1e2,1e-3:1e4,2e-3 --target-pressure 1e9"
  [us1.1]="--seed 5 --dist uniform-radius --omega 1.1 $SLOW"
  [us1.3]="--seed 6 --dist uniform-radius --omega 1.3 $SLOW"
)
STATES=(gas liquid crystal glass poly3)
[ "$US" = 1 ] && STATES+=(us1.1 us1.3)

if [ "$PART" != equiv ]; then
for s in "${STATES[@]}"; do
  if [ ! -f "$WORK/$s.h5" ]; then
    case $s in
      crystal|us*)
        # shellcheck disable=SC2086
        [ -f "$WORK/${s}_056.h5" ] || run "jam_${s}_056" "${JAM[@]}" ${STATE_ARGS[$s]} -o "$WORK/${s}_056.h5"
        run "analyze_${s}_056" "$POLYDEM" analyze "$WORK/${s}_056.h5" --structure-only --order
        # shellcheck disable=SC2086
        run "jam_$s" "$POLYDEM" jam -i "$WORK/${s}_056.h5" $FINISH -o "$WORK/$s.h5" ;;
      *)
        # shellcheck disable=SC2086
        run "jam_$s" "${JAM[@]}" ${STATE_ARGS[$s]} -o "$WORK/$s.h5" ;;
    esac
  fi
  # The gas box is ~230 diameters wide: S(k) there is capped at 2e6 wave vectors (stride > 1).
  extra=(--structure-only)
  case $s in crystal|glass|poly3|us*) extra=(--velocity-rattlers=1e-4) ;; esac
  run "analyze_$s" "$POLYDEM" analyze "$WORK/$s.h5" "${extra[@]}" --order \
    --channels-csv "$OUT/channels_$s.csv" --sk-csv "$OUT/sk_$s.csv" --sk-kmax 20
done

# Plots.
cd "$OUT"
gnuplot <<'GP'
set terminal png size 900,600
set datafile separator ','
set key top right
set output 'channels_gas.png'
set title 'Channel sizes, dilute gas (phi = 0.0015, N = 4096); seed: Gaussian, mean 15.9, sd 4'
set xlabel 'R_j / r_i'; set ylabel 'f'
plot 'channels_gas.csv' skip 1 using 2:3 with histeps title 'gas'
set output 'channels_dense.png'
set title 'Channel sizes of dense states (bin 0.01); 0.155 = 2/sqrt(3)-1, 0.414 = sqrt(2)-1, 1 = coplanar'
set xrange [0:2]; set logscale y; set yrange [1e-3:*]
set arrow 1 from 0.1547,graph 0 to 0.1547,graph 1 nohead dt 3 lc rgb 'gray'
set arrow 2 from 0.4142,graph 0 to 0.4142,graph 1 nohead dt 3 lc rgb 'gray'
set arrow 3 from 1,graph 0 to 1,graph 1 nohead dt 3 lc rgb 'gray'
plot 'channels_liquid.csv' skip 1 using 2:3 with lines title 'liquid phi 0.5', \
     'channels_crystal.csv' skip 1 using 2:3 with lines title 'slow (crystal)', \
     'channels_glass.csv' skip 1 using 2:3 with lines title 'fast (glass)', \
     'channels_poly3.csv' skip 1 using 2:3 with lines title 'power law n=3, omega 3'
unset arrow 1; unset arrow 2; unset arrow 3
unset logscale y; set autoscale y; set xrange [0:20]
set output 'sk.png'
set title 'Structure factor S(k), K = k D, D = 2<r>'
set xlabel 'K = k D'; set ylabel 'S(k)'
set logscale y
plot 'sk_gas.csv' skip 1 using 1:2 with lines title 'gas', \
     'sk_liquid.csv' skip 1 using 1:2 with lines title 'liquid', \
     'sk_crystal.csv' skip 1 using 1:2 with lines title 'slow (crystal)', \
     'sk_glass.csv' skip 1 using 1:2 with lines title 'fast (glass)', \
     'sk_poly3.csv' skip 1 using 1:2 with lines title 'power law n=3'
set output 'chi.png'
set title 'Spectral density chi(k) (length unit: smallest radius = 1 in every state)'
set ylabel 'chi'
set yrange [1e-4:*]
plot 'sk_liquid.csv' skip 1 using 1:3 with lines title 'liquid', \
     'sk_crystal.csv' skip 1 using 1:3 with lines title 'slow (crystal)', \
     'sk_glass.csv' skip 1 using 1:3 with lines title 'fast (glass)', \
     'sk_poly3.csv' skip 1 using 1:3 with lines title 'power law n=3'
GP
if [ "$US" = 1 ]; then
gnuplot <<'GP'
set terminal png size 900,600
set datafile separator ','
set output 'channels_us.png'
set title 'Channel sizes, uniform-radius packings, slow schedule'
set xlabel 'R_j / r_i'; set ylabel 'f'; set xrange [0:2]; set logscale y; set yrange [1e-3:*]
plot 'channels_us1.1.csv' skip 1 using 2:3 with lines title 'US omega 1.1', \
     'channels_us1.3.csv' skip 1 using 2:3 with lines title 'US omega 1.3', \
     'channels_crystal.csv' skip 1 using 2:3 with lines title 'mono (slow)'
GP
fi

# Summary table from the logs.
{
  echo "# Structure report numbers ($(date -u '+%Y-%m-%d %H:%M UTC'), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores)"
  echo
  echo "| state | phi | p (reduced) | p_c | mean q6 | Q6 | Delaunay nb | channel mean | channel sd | S(K_min) | S peak (K) | speed rattlers | jam CPU |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  for s in "${STATES[@]}"; do
    a=analyze_$s.log; j=jam_$s.log
    field() { grep -m1 "$1" "$2" 2>/dev/null || true; }  # an absent line is not an error
    phi=$(field '^packing fraction' "$a" | awk '{print $3}')
    p=$(field '^reduced pressure' "$a" | awk '{print $3}'); p=${p:--}
    order=$(field '^bond order' "$a")
    pc=$(echo "$order" | sed -E 's/.*p_c = ([0-9.]+).*/\1/')
    q6=$(echo "$order" | sed -E 's/.*mean q6 = ([0-9.]+).*/\1/')
    Q6=$(echo "$order" | sed -E 's/.*Q6 = ([0-9.]+).*/\1/')
    nb=$(field '^Delaunay' "$a" | awk '{print $3}')
    ch=$(field '^channels' "$a")
    cm=$(echo "$ch" | sed -E 's/.*mean ([0-9.]+).*/\1/'); cs=$(echo "$ch" | sed -E 's/.*sd ([0-9.]+).*/\1/')
    sk=$(field '^S(k)' "$a")
    s0=$(echo "$sk" | sed -E 's/.*\) = ([0-9.e+-]+), peak.*/\1/')
    sp=$(echo "$sk" | sed -E 's/.*peak S = ([0-9.e+-]+) at K = ([0-9.]+).*/\1 (\2)/')
    vr=$(field '^rattlers (|v|' "$a" | sed -E 's/.*\) ([0-9]+ \([0-9.]+%\)), volume fraction nu_r ([0-9.]+).*/\1, nu_r \2/')
    # jam CPU: both steps for the states held at phi = 0.56
    jw=$(cat "$j" "jam_${s}_056.log" 2>/dev/null | grep '^cpu' | awk '{t += $2} END {printf "%.0f s", t}' || true)
    echo "| $s | $phi | $p | $pc | $q6 | $Q6 | $nb | $cm | $cs | $s0 | $sp | ${vr:--} | ${jw:--} |"
  done
} > summary.md
cat summary.md
fi

# Polydisperse vs maximally equivalent tridisperse packings (Ogarko's thesis §3.3.4, Figs.
# 3.14-3.16; Ogarko & Luding, Soft Matter 9 (2013) 9530): S(k) and chi(k) of a jammed packing against those of
# `jam --equivalent tri` (same <a>..<a^5>, Gauss quadrature). The seed: they agree at all k for
# omega <= 3; for larger omega they differ at high k but stay similar at low k. A second polydisperse
# packing with another seed (*_poly_b) gives the sample-to-sample noise floor for the same N.
# Fast schedule (p = 1e6), not the report's p = 1e9: 17-85 CPU s per packing, ~6 CPU min for all nine.
if [ "$PART" != main ]; then
EQ_FINISH="--schedule 1e-2:1e2,1e-3 --target-pressure 1e6"
declare -A EQ_ARGS=(
  [us2_poly]="--dist uniform-radius --omega 2 --seed 7"
  [us2_tri]="--dist uniform-radius --omega 2 --seed 7 --equivalent tri"
  [us2_poly_b]="--dist uniform-radius --omega 2 --seed 9"
  [us10_poly]="--dist uniform-radius --omega 10 --seed 8"
  [us10_tri]="--dist uniform-radius --omega 10 --seed 8 --equivalent tri"
  [us10_poly_b]="--dist uniform-radius --omega 10 --seed 9"
  [uv10_poly]="--dist uniform-volume --omega 10 --seed 10"
  [uv10_tri]="--dist uniform-volume --omega 10 --seed 10 --equivalent tri"
  [uv10_poly_b]="--dist uniform-volume --omega 10 --seed 11"
)
EQ_FAMILIES=(us2 us10 uv10)
for f in "${EQ_FAMILIES[@]}"; do
  for v in poly tri poly_b; do
    s=eq_${f}_$v
    # shellcheck disable=SC2086
    [ -f "$WORK/$s.h5" ] || run "jam_$s" "$POLYDEM" jam -n $N --progress 30 ${EQ_ARGS[${f}_$v]} $EQ_FINISH -o "$WORK/$s.h5"
    [ "$OUT/sk_$s.csv" -nt "$WORK/$s.h5" ] ||
      run "analyze_$s" "$POLYDEM" analyze "$WORK/$s.h5" --structure-only --sk-csv "$OUT/sk_$s.csv" --sk-kmax 20
  done
done

cd "$OUT"
# cmp A B: mean |S_A - S_B| and mean |ln(chi_A / chi_B)| over A's shells with K < 5, 5 <= K <= 10 and
# K > 10 (and inside B's K range), with S_B and ln chi_B interpolated linearly in K to A's shell K.
# The shells are not paired by index: the boxes differ by up to 0.2% in size, which moves the shell
# edges (thickness 2 pi / L) and can add or drop a shell at low K.
cmp_sk() {
  awk -F, -v a="$1" -v b="$2" '
    FNR == 1 { next }
    NR == FNR { nb++; kb[nb] = $1; sb[nb] = $2; cb[nb] = log($3); next }
    {
      k = $1; if (k < kb[1] || k > kb[nb]) next
      j = 1; while (j < nb && kb[j + 1] < k) j++
      t = j < nb ? (k - kb[j]) / (kb[j + 1] - kb[j]) : 0
      si = sb[j] + t * (sb[j + 1] - sb[j]); ci = cb[j] + t * (cb[j + 1] - cb[j])
      ds = $2 - si; if (ds < 0) ds = -ds
      dc = log($3) - ci; if (dc < 0) dc = -dc
      r = k < 5 ? 1 : (k <= 10 ? 2 : 3); n[r]++; s[r] += ds; c[r] += dc }
    END { printf "| %s vs %s | %.3f | %.3f | %.3f | %.2f | %.2f | %.2f |\n", a, b,
          s[1]/n[1], s[2]/n[2], s[3]/n[3], c[1]/n[1], c[2]/n[2], c[3]/n[3] }' "sk_$2.csv" "sk_$1.csv"
}
{
  echo "# Poly vs equivalent tridisperse, N = $N ($(date -u '+%Y-%m-%d %H:%M UTC'))"
  echo
  echo "| pair | mean \|dS\| K<5 | 5-10 | K>10 | mean \|d ln chi\| K<5 | 5-10 | K>10 |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  for f in "${EQ_FAMILIES[@]}"; do
    cmp_sk "eq_${f}_poly" "eq_${f}_tri"
    cmp_sk "eq_${f}_poly" "eq_${f}_poly_b"
  done
  echo
  echo "| packing | phi | S(K_min) | peak S (K) | jam CPU |"
  echo "| --- | --- | --- | --- | --- |"
  for f in "${EQ_FAMILIES[@]}"; do
    for v in poly tri poly_b; do
      s=eq_${f}_$v
      phi=$(grep -m1 '^packing fraction' "analyze_$s.log" | awk '{print $3}')
      sk=$(grep -m1 '^S(k)' "analyze_$s.log")
      s0=$(echo "$sk" | sed -E 's/.*\) = ([0-9.e+-]+), peak.*/\1/')
      sp=$(echo "$sk" | sed -E 's/.*peak S = ([0-9.e+-]+) at K = ([0-9.]+).*/\1 (\2)/')
      jc=$(grep '^cpu' "jam_$s.log" 2>/dev/null | awk '{printf "%.0f s", $2}' || true)
      echo "| $s | $phi | $s0 | $sp | ${jc:--} |"
    done
  done
} > equiv.md
cat equiv.md

for f in "${EQ_FAMILIES[@]}"; do
  case $f in us*) d="uniform radius";; uv*) d="uniform volume";; esac
  gnuplot <<GP
set terminal png size 900,900
set datafile separator ','
set output 'sk_equiv_$f.png'
set multiplot layout 2,1 title '$d, omega = ${f#u?}, N = $N, jammed at p = 1e6: polydisperse vs equivalent tridisperse'
set xrange [0:20]; set key top right
set xlabel 'K = k D, D = 2<r>'; set ylabel 'S(k)'
plot 'sk_eq_${f}_poly.csv' skip 1 using 1:2 with linespoints pt 7 ps 0.5 title 'polydisperse', \
     'sk_eq_${f}_tri.csv' skip 1 using 1:2 with linespoints pt 5 ps 0.5 title 'tridisperse equivalent', \
     'sk_eq_${f}_poly_b.csv' skip 1 using 1:2 with lines dt 3 lc rgb 'gray' title 'polydisperse, other seed'
set logscale y; set ylabel 'chi(k), length unit r_{min} of the polydisperse distribution'
plot 'sk_eq_${f}_poly.csv' skip 1 using 1:3 with linespoints pt 7 ps 0.5 title 'polydisperse', \
     'sk_eq_${f}_tri.csv' skip 1 using 1:3 with linespoints pt 5 ps 0.5 title 'tridisperse equivalent', \
     'sk_eq_${f}_poly_b.csv' skip 1 using 1:3 with lines dt 3 lc rgb 'gray' title 'polydisperse, other seed'
unset multiplot
GP
done
fi
