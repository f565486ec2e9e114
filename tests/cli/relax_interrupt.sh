#!/usr/bin/env bash
# relax_interrupt.sh POLYDEM WORKDIR: SIGINT to a running relax writes a checkpoint, the final state and
# the time series under their final names (no temporary left), exits 130, and the checkpoint resumes to
# the same bytes as a run that was never interrupted (issue 15, sections 3 and 6).
set -u
polydem="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cp ../relax_small.toml .
fail() { echo "FAIL: $*"; exit 1; }
outs=(--set output.final=\"i_final.txt\" --set output.timeseries=\"i.csv\" --set output.checkpoint=\"i.h5\"
      --set output.snapshot=\"i_{step}.h5\" --set output.snapshot_interval=500 --set output.timeseries_interval=50)
"$polydem" relax relax_small.toml -q --steps 100000000 "${outs[@]}" > i.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do  # wait until the time loop runs (rows appear), at most 60 s
  [ -f i.csv ] && [ "$(wc -l < i.csv)" -ge 4 ] && break
  sleep 0.1
done
kill -INT "$pid"
wait "$pid"; code=$?
cat i.log
[ "$code" -eq 130 ] || fail "exit code $code, expected 130"
step=$(sed -n 's/^INTERRUPTED .* at step \([0-9]*\) of .*/\1/p' i.log)
[ -n "$step" ] || fail "no INTERRUPTED line"
ls -a | grep -q '\.tmp-' && fail "temporary files left: $(ls -a | grep '\.tmp-')"
[ -s i.h5 ] && [ -s i_final.txt ] || fail "checkpoint or final state missing"
# Every file opens: the final state runs as an input, every time-series row is complete.
awk -F, 'NR > 1 && NF != 12 { exit 1 }' i.csv || fail "incomplete time-series row"
printf '[particles]\nfile = "i_final.txt"\n[contact]\nstiffness = 1e4\n[velocities]\ninitial = "file"\n[run]\nsteps = 1\n' > reread.toml
"$polydem" relax reread.toml -q > reread.log 2>&1 || { cat reread.log; fail "final state does not read back"; }
for s in i_*.h5; do
  [ "$s" = "i.h5" ] && continue
  printf '[particles]\nfile = "%s"\n[contact]\nstiffness = 1e4\n[velocities]\ninitial = "file"\n[run]\nsteps = 1\n' "$s" > snap.toml
  "$polydem" relax snap.toml -q > snap.log 2>&1 || { cat snap.log; fail "snapshot $s does not read back"; }
done

total=$((step + 300))
"$polydem" relax --resume i.h5 -q --steps "$total" > r.log 2>&1 || { cat r.log; fail "resume"; }
"$polydem" relax relax_small.toml -q --steps "$total" --set output.final=\"u_final.txt\" \
  --set output.timeseries=\"u.csv\" --set output.timeseries_interval=50 > u.log 2>&1 || { cat u.log; fail "reference run"; }
cmp i_final.txt u_final.txt || fail "interrupted + resumed differs from the uninterrupted run"
cmp i.csv u.csv || { diff i.csv u.csv | head; fail "time series differ"; }
echo "interrupted at step $step, resumed to $total: byte-identical"
