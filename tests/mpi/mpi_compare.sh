#!/usr/bin/env bash
# mpi_compare.sh POLYDEM MPIEXEC WORK SCENE NP [relax options...]: runs the relax scene WORK/SCENE in its own
# folder WORK/<scene>/<np> with `mpirun -np NP` (NP = serial: without mpirun, the reference) and checks that the
# final state, the time series, the snapshots and the final checkpoint are byte-identical to the serial run's
# (docs/parallel.md). With NP > 1 the report must show the parallel run, and particles must have migrated.
set -u
polydem="$1"; mpiexec="$2"; work="$3"; scene="$4"; np="$5"; shift 5
source "$(dirname "$0")/mpi_env.sh"
name="${scene%.toml}"
tag=$(printf '%s' "$*" | tr -cs 'A-Za-z0-9' '_')  # runs of one scene with other options get their own folder
dir="$work/$name/$np$tag"
[ "$np" = serial ] && dir="$work/$name/serial"
rm -rf "$dir"; mkdir -p "$dir"; cd "$dir" || exit 1
cp "$work/$scene" scene.toml
fail() { echo "FAIL: $*"; exit 1; }
outs=(--set output.final=\"final.txt\" --set output.timeseries=\"series.csv\" --set output.checkpoint=\"ck.h5\"
  --set output.snapshot=\"snap_{step}.txt\" --set output.snapshot_interval=400)
if [ "$np" = serial ]; then
  echo "+ polydem relax scene.toml $* (serial reference)"
  "$polydem" relax scene.toml "${outs[@]}" "$@" > run.log 2>&1 || { cat run.log; fail "serial run"; }
  cat run.log
  exit 0
fi
ref="$work/$name/serial"
[ -f "$ref/final.txt" ] || fail "no serial reference in $ref"
echo "+ mpirun -np $np polydem relax scene.toml $*"
"$mpiexec" --oversubscribe -np "$np" "$polydem" relax scene.toml "${outs[@]}" "$@" > run.log 2>&1 ||
  { cat run.log; fail "mpirun -np $np"; }
cat run.log
if [ "$np" -gt 1 ]; then
  grep -q "^parallel: $np MPI ranks" run.log || fail "the run did not report $np ranks"
  moved=$(sed -n 's/^migrations *\([0-9]*\) particles.*/\1/p' run.log)
  [ -n "$moved" ] && [ "$moved" -gt 0 ] || fail "no particle migrated between ranks (the scene does not test migration)"
  # The report's split of the loop is the ranks' own (it showed rank 0's serial copy's zeros before session 26).
  grep -q "^time .*(mean over the ranks" run.log || fail "the time line does not give the ranks' phase times"
  force=$(sed -n 's/^time .* force \([0-9.]*\),.*/\1/p' run.log)
  awk -v f="$force" 'BEGIN { exit !(f > 0) }' || fail "the force phase is '$force' us/particle/step, not > 0"
  grep -q "^phases per rank .*forces [0-9.]* ([0-9.]*)" run.log || fail "no per-rank phase line in the report"
fi
# The re-sorts of the storage order (they renumber the slots the ranks key their particles by): as many as
# the serial run's, and some where the scene says it expects them.
resorts() { sed -n 's/^neighbour list .* \([0-9][0-9]*\) re-sorts.*/\1/p' "$1"; }
want=$(resorts "$ref/run.log"); got=$(resorts run.log)
[ -n "$want" ] && [ "$want" = "$got" ] || fail "re-sorts: $got, the serial run's: $want"
if grep -q "^# expects re-sorts" scene.toml; then
  [ "$want" -gt 0 ] || fail "the serial run did not re-sort (the scene does not test re-sorting)"
fi
files=(final.txt series.csv)
for f in "$ref"/snap_*.txt; do files+=("$(basename "$f")"); done
[ "${#files[@]}" -gt 3 ] || fail "the reference wrote no snapshots"
for f in "${files[@]}"; do
  cmp "$ref/$f" "$f" || fail "$f differs from the serial run's"
done
# The checkpoint: every dataset and attribute bit for bit, except the start's description, which states the
# generation's wall time ("... (0.04 s)"), and (with --threads) the overrides, which record run.threads = 2.
skip=(origin)
case " $* " in *" --threads "*) skip+=(overrides) ;; esac
if /usr/bin/python3 -c "import h5py" 2> /dev/null; then
  /usr/bin/python3 "$(dirname "$0")/compare_h5.py" "$ref/ck.h5" ck.h5 "${skip[@]}" || fail "ck.h5 differs from the serial run's"
  files+=(ck.h5)
else
  echo "(no h5py for /usr/bin/python3: the checkpoint is not compared)"
fi
echo "np $np: ${files[*]} byte-identical to the serial run's"
