#!/usr/bin/env bash
# Build the libFuzzer targets (fuzz/) with clang, AddressSanitizer and UndefinedBehaviorSanitizer in
# build-fuzz/, and run each for a bounded time through CTest (label fuzz).
#   POLYDEM_FUZZ_SECONDS   seconds per target (default 60)
#   POLYDEM_FUZZ_BUILD     build directory (default build-fuzz)
#   POLYDEM_FUZZ_JOBS      parallel build jobs (default 2)
# Needs Debian's clang and libfuzzer-14-dev (scripts/setup.sh installs both). Exit code: CTest's (non-zero
# when a target crashed, leaked, broke a property or timed out; the reproducer is in the build directory as
# crash-<target>-*; rerun with build-fuzz/fuzz_<target> FILE).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${POLYDEM_FUZZ_BUILD:-$root/build-fuzz}"
seconds="${POLYDEM_FUZZ_SECONDS:-60}"
jobs="${POLYDEM_FUZZ_JOBS:-2}"
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
cmake -S "$root/fuzz" -B "$build" -DCMAKE_BUILD_TYPE=None -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DPOLYDEM_FUZZ_SECONDS="$seconds" "${launcher[@]}" >/dev/null
cmake --build "$build" -j"$jobs" --target fuzz_text_particles fuzz_hdf5_snapshot fuzz_relax_scene
# Scratch files on tmpfs when there is one: the round-trip checks write (and fsync) a file per input.
if [ -d /dev/shm ] && [ -w /dev/shm ]; then export TMPDIR=/dev/shm; else export TMPDIR="$build/tmp"; fi
mkdir -p "$TMPDIR"
cd "$build"
# Each target uses one core: two at a time keeps the three runs near 2 x POLYDEM_FUZZ_SECONDS on 2 cores.
ctest -L fuzz -j"$jobs" --output-on-failure
