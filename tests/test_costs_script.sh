#!/usr/bin/env bash
# scripts/test-costs.sh: refuses missing or empty timings with exit 2 and leaves its output as it was; from
# valid timings it writes the tests of 2 s or more (Release-only ones at 5x) and nothing else.
set -uo pipefail
script="$1"
work="$2"
rm -rf "$work" && mkdir -p "$work/checked/Testing/Temporary" "$work/release/Testing/Temporary" "$work/empty/Testing/Temporary"
fail() { echo "FAIL: $*" >&2; exit 1; }
out="$work/costs.cmake"
echo "previous hints" > "$out"

"$script" "$work/missing" "$work/release" "$out" 2> "$work/err"
[ $? -eq 2 ] || fail "a missing build directory should exit 2"
grep -q "cannot read $work/missing/Testing/Temporary/CTestCostData.txt" "$work/err" || fail "no file named: $(cat "$work/err")"
[ "$(cat "$out")" = "previous hints" ] || fail "the output changed on a failed run"

: > "$work/empty/Testing/Temporary/CTestCostData.txt"
"$script" "$work/empty" "" "$out" 2> "$work/err"
[ $? -eq 2 ] || fail "an empty timings file should exit 2"
grep -q "holds no test timings" "$work/err" || fail "no reason given: $(cat "$work/err")"
[ "$(cat "$out")" = "previous hints" ] || fail "the output changed on a failed run"

printf 'Long.Test 1 30.4\nShort.Test 1 0.5\nshared 1 3\n---\n' > "$work/checked/Testing/Temporary/CTestCostData.txt"
printf 'Long.Test 1 6\nslow_only 1 12\ntiny_only 1 0.1\nshared 1 1\n---\n' > "$work/release/Testing/Temporary/CTestCostData.txt"
"$script" "$work/checked" "$work/release" "$out" > /dev/null || fail "valid timings should succeed"
entries="$(grep '^  ' "$out" | tr -s ' ' | sed 's/^ //')"
expected="slow_only 60
Long.Test 30
shared 3"
[ "$entries" = "$expected" ] || fail "entries: $entries"
grep -q '^set(POLYDEM_TEST_COST_DATA$' "$out" && tail -n 1 "$out" | grep -q '^)$' || fail "not a cmake list"
[ -z "$(ls -A "$work" | grep '^\.test_cost_data')" ] || fail "a temporary file was left behind"
echo "test-costs.sh checks passed"
