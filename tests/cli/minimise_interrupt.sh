#!/usr/bin/env bash
# minimise_interrupt.sh POLYDEM WORKDIR: SIGINT during a minimisation stops it at a FIRE step, writes the output
# marked target_reached = no / stop_reason = interrupted, and exits 130.
set -u
polydem="$1"; cd "$2" || exit 1
rm -f minimise_int.txt
"$polydem" minimise -n 4000 --phi0 0.6 --target-pressure 1e-7 --progress 0 -o minimise_int.txt >minimise_int.log 2>&1 &
pid=$!
sleep 2
kill -INT "$pid"
wait "$pid"; code=$?
cat minimise_int.log
[ "$code" = 130 ] || { echo "FAIL: exit $code, expected 130"; exit 1; }
grep -q "attribute: target_reached = no" minimise_int.txt || { echo "FAIL: output not marked"; exit 1; }
grep -q "attribute: stop_reason = interrupted" minimise_int.txt || { echo "FAIL: stop_reason"; exit 1; }
echo "PASS: interrupted, output written and marked, exit 130"
