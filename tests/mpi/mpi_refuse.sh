#!/usr/bin/env bash
# mpi_refuse.sh POLYDEM MPIEXEC WORK: what a parallel run does not support is refused on 2 ranks with exit
# code 2 and a message naming it, before anything runs (never run silently wrong).
set -u
polydem="$1"; mpiexec="$2"; work="$3"
source "$(dirname "$0")/mpi_env.sh"
dir="$work/refuse"; rm -rf "$dir"; mkdir -p "$dir"; cd "$dir" || exit 1
cp "$work/mpi_walls.toml" scene.toml
fail() { echo "FAIL: $*"; exit 1; }
expect() {  # expect REGEX ARGS...: mpirun -np 2 polydem ARGS exits 2 with REGEX in its output, writes no final state
  local regex="$1"; shift
  "$mpiexec" --oversubscribe -np 2 "$polydem" "$@" > out.log 2>&1; local code=$?
  cat out.log
  [ "$code" -eq 2 ] || fail "polydem $* on 2 ranks: exit $code, expected 2"
  grep -Eq -- "$regex" out.log || fail "polydem $* on 2 ranks: no message matching '$regex'"
  [ -e final.txt ] && fail "polydem $* on 2 ranks wrote a final state"
  return 0
}
expect "--sweep runs on one process" relax scene.toml -q --sweep dt-factor=50,100
expect "polydem jam runs on one process.*only .polydem relax. and .polydem minimise." jam -n 50 -o final.txt
# A fault on ranks gives the serial run's message and exit code (3), not the time loop's: a dense random start
# in a walled box that pushes a centre through a wall.
fault=(minimise -n 900 --dist bi --omega 3 --phi0 0.6 --boundary walls --law hertz --seed 5 --progress 0)
"$polydem" "${fault[@]}" > fault_serial.log 2>&1; code=$?
[ "$code" -eq 3 ] || { cat fault_serial.log; fail "serial fault scene: exit $code, expected 3"; }
"$mpiexec" --oversubscribe -np 2 "$polydem" "${fault[@]}" > fault_np2.log 2>&1; code=$?
want=$(grep '^polydem:' fault_serial.log); got=$(grep '^polydem:' fault_np2.log)
[ -n "$want" ] && [ "$want" = "$got" ] || { cat fault_np2.log; fail "the fault on 2 ranks says '$got', the serial run '$want'"; }
echo "the fault on 2 ranks: $got"
# --decomposition means nothing without several ranks: refused, not ignored.
"$polydem" relax scene.toml -q --steps 10 --decomposition brick > serial.log 2>&1; code=$?
[ "$code" -eq 2 ] && grep -q "applies to runs on several MPI ranks" serial.log || { cat serial.log; fail "serial --decomposition: exit $code"; }
# The same scene serially and on one rank is fine (the serial code).
"$mpiexec" -np 1 "$polydem" relax scene.toml -q --steps 10 > one.log 2>&1 || { cat one.log; fail "-np 1"; }
echo "unsupported features refused on 2 ranks"
