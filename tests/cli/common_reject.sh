#!/usr/bin/env bash
# common_reject.sh PASS_REGEX PROGRAM ARGS...: a command line that must be refused before any work, with
# exit code 2 and a message matching PASS_REGEX (naming the option). Unlike cli_check.sh it allows the word
# "nan" in the output: the refusal of `--phi nan` quotes the value it refuses.
set -u
pass="$1"; shift
out="$("$@" 2>&1)"; code=$?
printf '%s\n' "$out"
echo "[common_reject] exit code $code (expected 2)"
if [ "$code" != 2 ]; then echo "[common_reject] FAIL: exit code"; exit 1; fi
if ! grep -Eq -- "$pass" <<<"$out"; then echo "[common_reject] FAIL: output does not match: $pass"; exit 1; fi
exit 0
