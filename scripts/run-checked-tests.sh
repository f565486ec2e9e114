#!/usr/bin/env bash
# run-checked-tests.sh sanitize|debug|checked: the test suite in a checked build (issue 16); .ci/run runs
# `checked` after the README's test command.
#   sanitize  AddressSanitizer + UndefinedBehaviorSanitizer (every UB report fatal), -O1 -g, in build-sanitize/
#   debug     CMAKE_BUILD_TYPE=Debug (-Og -g, NDEBUG unset so assert() is live), POLYDEM_ASSERT checks on
#             (POLYDEM_ENABLE_ASSERTS) and libstdc++'s bounds checks (_GLIBCXX_ASSERTIONS), in build-debug/
#   checked   both at once: Debug at -O1 -g1 with every assert and bounds check, ASan and UBSan, in build-checked/
# Both skip the tests labelled `slow` (10 s or more each in Release; listed in tests/slow_tests.cmake and
# at their definitions) and the fuzz targets (scripts/fuzz.sh runs those). No benchmarks are built.
# Extra arguments go to ctest (e.g. -R Compression).
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-}"
shift || true
common=(-DPOLYDEM_BUILD_BENCHMARKS=OFF -DPOLYDEM_WITH_PYTHON=OFF)
case "$mode" in
  sanitize)
    dir=build-sanitize
    flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g -DNDEBUG"
           "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g -DNDEBUG" -DPOLYDEM_SANITIZE=ON)
    # Leak reports are fatal too; halt_on_error keeps the first report readable.
    export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:abort_on_error=0}"
    export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
    ;;
  debug)
    dir=build-debug
    flags=(-DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-Og -g -D_GLIBCXX_ASSERTIONS"
           "-DCMAKE_C_FLAGS_DEBUG=-Og -g" -DPOLYDEM_ENABLE_ASSERTS=ON)
    ;;
  checked)
    # Both in one build (what .ci/run uses, to stay within its time budget): Debug, asserts and bounds
    # checks on, and both sanitizers. -g1 (line tables: the sanitizers' stack traces keep file and line,
    # without variable info) compiles 25-40% faster than -g (delaunay.cpp 48 -> 34 s, relax_run.cpp 32 -> 19 s)
    # and makes objects 2-3x smaller; the build is most of .ci/run's time on a machine without a cache.
    dir=build-checked
    flags=(-DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-O1 -g1 -D_GLIBCXX_ASSERTIONS" "-DCMAKE_C_FLAGS_DEBUG=-O1 -g1"
           -DPOLYDEM_ENABLE_ASSERTS=ON -DPOLYDEM_SANITIZE=ON)
    export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:abort_on_error=0}"
    export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
    ;;
  *)
    echo "usage: scripts/run-checked-tests.sh sanitize|debug|checked [ctest arguments]" >&2
    exit 2
    ;;
esac
scripts/setup.sh
launcher=()
if command -v ccache > /dev/null && [ -z "${CCACHE_DISABLE:-}" ]; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
start=$(date +%s)
mkdir -p "$dir"
cmake -S . -B "$dir" "${flags[@]}" "${common[@]}" "${launcher[@]}" > "$dir/configure.log" 2>&1 \
  || { cat "$dir/configure.log"; exit 1; }
cmake --build "$dir" -j2
built=$(date +%s)
echo "run-checked-tests $mode: built in $((built - start)) s"
# OpenMP threads stay at 2 (the machine's cores); the sanitizers slow every test 2-4x.
(cd "$dir" && ctest -j2 --output-on-failure --timeout 900 -LE 'slow|fuzz|python' "$@")
echo "run-checked-tests $mode: tests in $(($(date +%s) - built)) s"
