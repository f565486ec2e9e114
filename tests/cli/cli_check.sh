#!/usr/bin/env bash
# cli_check.sh EXPECTED_EXIT PASS_REGEX FAIL_REGEX PROGRAM ARGS...
# Runs PROGRAM ARGS, then fails unless the exit code is EXPECTED_EXIT, the output (stdout + stderr)
# matches PASS_REGEX (if non-empty, grep -E) and does not match FAIL_REGEX (if non-empty). A crash
# (signal) never passes, and no output may contain "nan" as a word (issue 15: no nan in any report).
set -u
expected="$1"; pass="$2"; fail="$3"; shift 3
out="$("$@" 2>&1)"; code=$?
printf '%s\n' "$out"
echo "[cli_check] exit code $code (expected $expected)"
if [ "$code" -ge 128 ] && [ "$expected" -lt 128 ]; then echo "[cli_check] FAIL: killed by a signal"; exit 1; fi
if [ "$code" != "$expected" ]; then echo "[cli_check] FAIL: exit code"; exit 1; fi
if [ -n "$pass" ] && ! grep -Eq -- "$pass" <<<"$out"; then echo "[cli_check] FAIL: output does not match: $pass"; exit 1; fi
if [ -n "$fail" ] && grep -Eq -- "$fail" <<<"$out"; then echo "[cli_check] FAIL: output matches: $fail"; exit 1; fi
if grep -Eiwq -- "-?nan" <<<"$out"; then echo "[cli_check] FAIL: output contains nan"; exit 1; fi
exit 0
