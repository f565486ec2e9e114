#!/usr/bin/env bash
# relax_compress_resume.sh POLYDEM WORKDIR: SIGINT during the soft compression ([compression]) writes a
# checkpoint of the compression (phase "compression"), exits 130, and `--resume` finishes the compression
# and the run byte-identically to a run that was never interrupted (issue 15, section 3: the checkpoint
# holds the soft-compression growth state).
set -u
polydem="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cp ../relax_small.toml .
fail() { echo "FAIL: $*"; exit 1; }
scene=(--set compression.packing_fraction=0.5 --set compression.growth_rate=2e-4 --steps 200
       --set output.timeseries_interval=20)
"$polydem" relax relax_small.toml -q "${scene[@]}" --set output.final=\"u_final.txt\" \
  --set output.timeseries=\"u.csv\" > u.log 2>&1 || { cat u.log; fail "uninterrupted run"; }

"$polydem" relax relax_small.toml -q "${scene[@]}" --set output.final=\"i_final.txt\" --set output.timeseries=\"i.csv\" \
  --set output.checkpoint=\"i.h5\" --set output.checkpoint_interval=4000 > i.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do [ -f i.h5 ] && break; sleep 0.05; done  # the first checkpoint: step 4000
kill -INT "$pid"
wait "$pid"; code=$?
cat i.log
[ "$code" -eq 130 ] || fail "exit code $code, expected 130"
grep -q "soft compression interrupted" i.log || fail "not interrupted during the compression (machine too fast?)"
grep -q "continue with polydem relax --resume i.h5" i.log || fail "no resume hint"
ls -a | grep -q '\.tmp-' && fail "temporary files left"
"$polydem" relax --resume i.h5 -q > r.log 2>&1 || { cat r.log; fail "resume"; }
grep -q "resumed the soft compression at step" r.log || { cat r.log; fail "did not resume the compression"; }
cmp i_final.txt u_final.txt || fail "final states differ"
cmp i.csv u.csv || { diff i.csv u.csv | head; fail "time series differ"; }
echo "compression interrupted, resumed: byte-identical ($(grep -o 'at step [0-9]*' r.log | head -1))"
