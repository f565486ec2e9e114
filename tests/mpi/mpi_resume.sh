#!/usr/bin/env bash
# mpi_resume.sh POLYDEM MPIEXEC WORK SCENE STEPS: a checkpoint written by 2 ranks at STEPS/2 resumes on 3 ranks,
# and one written by 4 ranks resumes serially; both reach the serial run's final state byte for byte
# (the reference: WORK/<scene>/serial from mpi_compare.sh, run for STEPS steps).
set -u
polydem="$1"; mpiexec="$2"; work="$3"; scene="$4"; steps="$5"
source "$(dirname "$0")/mpi_env.sh"
name="${scene%.toml}"
ref="$work/$name/serial"
fail() { echo "FAIL: $*"; exit 1; }
[ -f "$ref/final.txt" ] || fail "no serial reference in $ref"
half=$((steps / 2))
for pair in "2 3" "4 serial"; do
  set -- $pair
  dir="$work/$name/resume_$1_$2"
  rm -rf "$dir"; mkdir -p "$dir"; cd "$dir" || exit 1
  cp "$work/$scene" scene.toml
  "$mpiexec" --oversubscribe -np "$1" "$polydem" relax scene.toml -q --steps "$half" --set output.final=\"final.txt\" \
    --set output.checkpoint=\"ck.h5\" > first.log 2>&1 || { cat first.log; fail "first half on $1 ranks"; }
  if [ "$2" = serial ]; then
    "$polydem" relax --resume ck.h5 -q --steps "$steps" > second.log 2>&1 || { cat second.log; fail "serial resume"; }
  else
    "$mpiexec" --oversubscribe -np "$2" "$polydem" relax --resume ck.h5 -q --steps "$steps" > second.log 2>&1 ||
      { cat second.log; fail "resume on $2 ranks"; }
  fi
  grep -q "resumed at step $half" second.log || { cat second.log; fail "not resumed at step $half"; }
  cmp "$ref/final.txt" final.txt || fail "$1 ranks then $2: final state differs from the serial run's"
  echo "checkpoint of $1 ranks resumed on $2: final state byte-identical to the serial run"
done
