#!/usr/bin/env bash
# jam_interrupt.sh POLYDEM WORKDIR: SIGINT to a running jam once its first checkpoint exists: exit 130,
# the checkpoint and every output under its final name open (analyze reads the packing, the EOS CSV has
# whole rows), no temporary files are left; SIGTERM to the resumed run stops it the same way, and
# `jam --resume` then completes the run (exit 0).
set -u
polydem="$1"; work="$2/jam_interrupt"; rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
fail() { echo "FAIL: $*"; exit 1; }
"$polydem" jam -n 400 --schedule 1e-2:1e2,1e-3:1e4,3e-4 --target-pressure 1e9 --seed 2 --progress 0.5 \
  -o out.h5 --eos-csv eos.csv --checkpoint ckpt.h5 --checkpoint-interval 0.2 > run.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do [ -s ckpt.h5 ] && break; kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
[ -s ckpt.h5 ] || { cat run.log; fail "no checkpoint appeared"; }
kill -INT "$pid"
wait "$pid"; code=$?
tail -n 4 run.log
[ "$code" = 130 ] || fail "interrupted run exit $code, expected 130"
grep -q "interrupted (signal 2)" run.log || fail "no interrupt line"
grep -q "^target reached *no (interrupted)" run.log || fail "not marked interrupted"
[ -z "$(ls -a | grep '\.tmp-')" ] || fail "temporary files left: $(ls -a | grep '\.tmp-')"
"$polydem" analyze out.h5 --structure-only > analyze.log 2>&1 || { cat analyze.log; fail "out.h5 does not open"; }
grep -aq "interrupted" out.h5 || fail "out.h5 not marked interrupted"
awk -F, '!/^#/ && NR > 2 && NF != 6 { bad = 1 } END { exit bad }' eos.csv || fail "eos.csv has a partial row"
# SIGTERM to the resumed run once it has rewritten the checkpoint: the same clean stop.
before="$(stat -c %Y.%s ckpt.h5; md5sum < ckpt.h5)"
"$polydem" jam --resume ckpt.h5 --checkpoint-interval 0.2 > term.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do [ "$(stat -c %Y.%s ckpt.h5; md5sum < ckpt.h5)" != "$before" ] && break
  kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
kill -TERM "$pid"
wait "$pid"; code=$?
tail -n 2 term.log
[ "$code" = 130 ] || fail "SIGTERM: exit $code, expected 130"
grep -q "interrupted (signal 15)" term.log || fail "no SIGTERM interrupt line"
"$polydem" jam --resume ckpt.h5 --progress 5 > resume.log 2>&1 || { cat resume.log; fail "resume exit $?"; }
grep -q "^target reached *yes" resume.log || fail "resumed run did not reach its target"
"$polydem" analyze out.h5 --structure-only > analyze2.log 2>&1 || fail "final out.h5 does not open"
echo "PASS"
