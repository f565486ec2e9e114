#!/usr/bin/env bash
# mpi_reference.sh POLYDEM MPIEXEC WORK NP: the determinism reference scene (tests/determinism: friction, walls
# across gravity, size ratio 4, 1500 steps) on NP ranks ends on the final state whose SHA-256 is checked in.
set -u
polydem="$1"; mpiexec="$2"; work="$3"; np="$4"
source "$(dirname "$0")/mpi_env.sh"
here="$(cd "$(dirname "$0")/../determinism" && pwd)"
dir="$work/reference_np$np"; rm -rf "$dir"; mkdir -p "$dir"; cd "$dir" || exit 1
cp "$here/relax_reference.toml" .
"$mpiexec" --oversubscribe -np "$np" "$polydem" relax relax_reference.toml -q > run.log 2>&1 ||
  { cat run.log; echo "FAIL: mpirun -np $np"; exit 1; }
grep " relax_reference_final.txt" "$here/reference.sha256" > expected.sha256
sha256sum -c expected.sha256 || { echo "FAIL: the final state on $np ranks is not the checked-in reference"; exit 1; }
echo "the determinism reference on $np ranks: the checked-in SHA-256"
