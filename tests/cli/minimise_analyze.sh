#!/usr/bin/env bash
# minimise_analyze.sh POLYDEM WORKDIR: the hand-off both ways. A `jam` packing (hard spheres) is jammed soft
# at p/k = 1e-5 by `minimise -i`, and `polydem analyze` reads the result with no extra option.
set -eu
polydem="$1"; cd "$2"
"$polydem" jam -n 128 --seed 3 --schedule 1e-2:1e2,1e-3 --target-pressure 1e4 -o minimise_hs.h5 >/dev/null
out="$("$polydem" minimise -i minimise_hs.h5 --target-pressure 1e-5 --progress 0 -o minimise_soft.h5 2>&1)"
printf '%s\n' "$out"
grep -q "result                  target reached" <<<"$out"
grep -q "^phi_J" <<<"$out"
# the hard-sphere phi_J estimate of the input sets the first secant of the protocol
grep -q "^phi_J estimate          0\.6[0-9]* (the input.s phi_j_estimate from polydem jam" <<<"$out"
ana="$("$polydem" analyze minimise_soft.h5 2>&1)"
printf '%s\n' "$ana"
grep -q "no overlap beyond the contact tolerance" <<<"$ana"
grep -q "^backbone " <<<"$ana"
echo "PASS: jam -> minimise --target-pressure -> analyze"
