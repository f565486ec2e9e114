#!/usr/bin/env bash
# relax_options.sh POLYDEM WORKDIR: every numeric command-line option of `polydem relax` refuses NaN,
# trailing garbage and out-of-range values with a message naming the option, and a non-zero exit code
# that is not a crash (issue 15, section 5).
set -u
polydem="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cp ../relax_gas.toml .
failures=0
expect_refused() {  # OPTION VALUE
  out="$("$polydem" relax relax_gas.toml -q "$1" "$2" 2>&1)"; code=$?
  if [ "$code" -ne 2 ]; then
    echo "FAIL: relax $1 $2 exited $code"; failures=$((failures + 1)); return
  fi
  if ! grep -q -- "$1" <<<"$out"; then
    echo "FAIL: relax $1 $2: message does not name $1: $out"; failures=$((failures + 1)); return
  fi
  if grep -q "relax report" <<<"$out"; then echo "FAIL: relax $1 $2 ran"; failures=$((failures + 1)); return; fi
  echo "ok: relax $1 $2 -> exit $code: $(head -1 <<<"$out")"
}
for v in nan -5 20x 1e30 ""; do expect_refused --steps "$v"; done
for v in nan 4 inf 50x -1; do expect_refused --dt-factor "$v"; done
for v in nan -1e-4 1e-4m inf; do expect_refused --skin "$v"; done
for v in 0 -1 nan 2x 5000; do expect_refused --threads "$v"; done
# The accepted forms still work.
if ! "$polydem" relax relax_gas.toml -q --steps 20 --dt-factor 60 --skin 2e-4 --threads 1 > ok.log 2>&1; then
  echo "FAIL: valid options refused"; cat ok.log; failures=$((failures + 1))
fi
# --print-defaults is a scene that runs as printed (section 4).
"$polydem" relax --print-defaults > defaults.toml || { echo "FAIL: --print-defaults"; failures=$((failures + 1)); }
if ! "$polydem" relax defaults.toml -q --steps 10 > defaults.log 2>&1; then
  echo "FAIL: the printed defaults do not run"; cat defaults.log; failures=$((failures + 1))
fi
grep -q "broad phase: auto" defaults.log || { echo "FAIL: default broad phase is not auto"; failures=$((failures + 1)); }
[ "$failures" -eq 0 ] && echo "all refused as expected; the printed defaults run"
exit "$failures"
