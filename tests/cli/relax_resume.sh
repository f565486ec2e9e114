#!/usr/bin/env bash
# relax_resume.sh POLYDEM WORKDIR: a run of 2N steps and a run of N steps resumed for N more from its
# checkpoint give byte-identical final states and time series (friction, walls and gravity on), and
# `--resume` refuses settings that would change the trajectory (issue 15, section 3).
set -u
polydem="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cp ../relax_small.toml .
fail() { echo "FAIL: $*"; exit 1; }
run() { echo "+ polydem $*"; "$polydem" "$@"; }
common=(--set run.check_interval=37 --set output.timeseries_interval=25)

run relax relax_small.toml -q --steps 3000 "${common[@]}" --set output.final=\"a_final.txt\" \
  --set output.timeseries=\"a.csv\" > a.log 2>&1 || { cat a.log; fail "uninterrupted run"; }
run relax relax_small.toml -q --steps 1500 "${common[@]}" --set output.final=\"b_final.txt\" \
  --set output.timeseries=\"b.csv\" --set output.checkpoint=\"b.h5\" > b.log 2>&1 || { cat b.log; fail "first half"; }
grep -q "checkpoint  *b.h5 (step 1500)" b.log || { cat b.log; fail "no checkpoint at step 400 reported"; }
cmp -s a_final.txt b_final.txt && fail "the half run already equals the whole run (test scene too static)"

# Conflicting overrides are refused before anything runs.
"$polydem" relax --resume b.h5 --set contact.friction=0.1 > c.log 2>&1; code=$?
[ "$code" -eq 2 ] && grep -q "would change the trajectory" c.log || { cat c.log; fail "conflicting override accepted ($code)"; }
"$polydem" relax --resume b.h5 --dt-factor 80 > c.log 2>&1; code=$?
[ "$code" -eq 2 ] || { cat c.log; fail "--dt-factor accepted on resume ($code)"; }
"$polydem" relax relax_small.toml --resume b.h5 > c.log 2>&1; code=$?
[ "$code" -eq 2 ] || { cat c.log; fail "scene file accepted with --resume ($code)"; }
"$polydem" relax --resume missing.h5 > c.log 2>&1; code=$?
[ "$code" -eq 2 ] || { cat c.log; fail "missing checkpoint: exit $code"; }
"$polydem" relax --resume b.h5 --steps 1000 > c.log 2>&1; code=$?
[ "$code" -eq 2 ] && grep -q "below the checkpoint's step 1500" c.log || { cat c.log; fail "--steps below the checkpoint"; }

cp b.h5 b1500.h5  # the resumed run overwrites b.h5 with its own checkpoint at step 3000
# Rows written after the checkpoint by a run that then died (one of them half-written) are dropped.
printf '1525,0.1,0.2\n1550,0.1,0.' >> b.csv
run relax --resume b.h5 -q --steps 3000 > r.log 2>&1 || { cat r.log; fail "resume"; }
grep -q "resumed at step 1500" r.log || { cat r.log; fail "not resumed at step 400"; }
cmp a_final.txt b_final.txt || fail "final states differ"
cmp a.csv b.csv || { diff a.csv b.csv | head; fail "time series differ"; }
grep -q "^3000," b.csv || fail "time series does not reach step 800"
# --threads is allowed with --resume because any thread count gives the same trajectory: check it.
if "$polydem" relax --resume b1500.h5 -q --steps 3000 --threads 2 --set output.final=\"t_final.txt\" \
     --set output.timeseries=\"\" > t.log 2>&1; then
  grep -q "resumed at step 1500" t.log || { cat t.log; fail "2 threads: not resumed at step 1500"; }
  cmp a_final.txt t_final.txt || fail "resumed on 2 threads differs"
elif grep -q "POLYDEM_WITH_OPENMP=ON" t.log; then
  echo "(serial build: --threads 2 not checked)"
else
  cat t.log; fail "resume with --threads 2"
fi
echo "resumed run is byte-identical: $(wc -l < a.csv) time-series rows, $(wc -l < a_final.txt) lines of final state"
