#!/usr/bin/env bash
# mpi_reference.sh POLYDEM MPIEXEC WORK NP: the determinism reference scene (tests/determinism: friction, walls
# across gravity, size ratio 4, 1500 steps) on NP ranks ends on the final state whose SHA-256 is checked in.
set -u
polydem="$1"; mpiexec="$2"; work="$3"; np="$4"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none  # containers often forbid the cross-memory attach
export OMPI_MCA_mpi_yield_when_idle=1 OMP_WAIT_POLICY=PASSIVE  # more ranks (and threads) than cores: waiting ones yield
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
here="$(cd "$(dirname "$0")/../determinism" && pwd)"
dir="$work/reference_np$np"; rm -rf "$dir"; mkdir -p "$dir"; cd "$dir" || exit 1
cp "$here/relax_reference.toml" .
"$mpiexec" --oversubscribe -np "$np" "$polydem" relax relax_reference.toml -q > run.log 2>&1 ||
  { cat run.log; echo "FAIL: mpirun -np $np"; exit 1; }
grep " relax_reference_final.txt" "$here/reference.sha256" > expected.sha256
sha256sum -c expected.sha256 || { echo "FAIL: the final state on $np ranks is not the checked-in reference"; exit 1; }
echo "the determinism reference on $np ranks: the checked-in SHA-256"
