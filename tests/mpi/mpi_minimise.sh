#!/usr/bin/env bash
# mpi_minimise.sh POLYDEM MPIEXEC WORK SCENE NP [minimise options...]: runs the minimise scene WORK/SCENE in its
# own folder WORK/<scene>/<np> with `mpirun -np NP` (NP = serial: without mpirun, the reference) and checks that
# the packing file (HDF5: positions, radii, ids and every attribute: phi, pressure, energy, iterations, stop
# reason) and the report's result lines are byte-identical to the serial run's (docs/parallel.md). With NP > 1
# the report must show the ranks, and particles must have migrated between them.
set -u
polydem="$1"; mpiexec="$2"; work="$3"; scene="$4"; np="$5"; shift 5
source "$(dirname "$0")/mpi_env.sh"
name="${scene%.toml}"
tag=$(printf '%s' "$*" | tr -cs 'A-Za-z0-9' '_')
# The serial reference of these options: the same options but --threads (threads change no bit).
reftag=$(printf '%s' "$*" | sed -E 's/--threads +[0-9]+//g; s/^ +| +$//g' | tr -cs 'A-Za-z0-9' '_')
dir="$work/$name/$np$tag"
[ "$np" = serial ] && dir="$work/$name/serial$reftag"
rm -rf "$dir"; mkdir -p "$dir"; cd "$dir" || exit 1
cp "$work/$scene" scene.toml
fail() { echo "FAIL: $*"; exit 1; }
# The lines that state the result (not the times).
results() { grep -E '^(initial|delta phi|step |minimisations|FIRE steps|final|contacts|z \(|rattlers|phi_J|result)' "$1" | sed 's/  *[0-9.]* s$//'; }
if [ "$np" = serial ]; then
  echo "+ polydem minimise scene.toml $* (serial reference)"
  "$polydem" minimise scene.toml -o packing.h5 "$@" > run.log 2>&1 || { cat run.log; fail "serial run"; }
  cat run.log
  results run.log > results.txt
  [ -s results.txt ] || fail "no result lines in the serial report"
  exit 0
fi
ref="$work/$name/serial$reftag"
[ -f "$ref/packing.h5" ] || fail "no serial reference in $ref"
echo "+ mpirun -np $np polydem minimise scene.toml $*"
"$mpiexec" --oversubscribe -np "$np" "$polydem" minimise scene.toml -o packing.h5 "$@" > run.log 2>&1 ||
  { cat run.log; fail "mpirun -np $np"; }
cat run.log
if [ "$np" -gt 1 ]; then
  grep -q "^parallel (start) $np MPI ranks" run.log || fail "the run did not report $np ranks"
  moved=$(sed -n 's/^parallel (end) .* \([0-9][0-9]*\) migrated.*/\1/p' run.log)
  [ -n "$moved" ] && [ "$moved" -gt 0 ] || fail "no particle migrated between ranks (the scene does not test migration)"
fi
results run.log > results.txt
diff "$ref/results.txt" results.txt || fail "the report's results differ from the serial run's"
cmp "$ref/packing.h5" packing.h5 || fail "packing.h5 differs from the serial run's"
cmp "$ref/packing.xmf" packing.xmf || fail "packing.xmf differs from the serial run's"
echo "mpirun -np $np: packing.h5 and the results are the serial run's byte for byte"
