#!/usr/bin/env bash
# jam_resume_sessions.sh POLYDEM WORKDIR: a run stopped twice and resumed (three sessions) reports this
# session's time and rate beside the time over all sessions, the checkpoint carrying the earlier sessions'
# time; the EOS table's wall-clock column keeps rising across the resumes; --summary-json may be given with
# --resume but may not name the checkpoint; an impossible session record in the checkpoint is refused.
# (Before session 33 the report divided every session's collisions by the last session's time, and
# --summary-json was refused with --resume.)
set -u
polydem="$1"; work="$2/jam_resume_sessions"; rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
run=(jam -n 300 --schedule 1e-2:1e2,1e-3 --target-pressure 1e5 --seed 4 --progress 0)
fail() { echo "FAIL: $*"; exit 1; }
"$polydem" "${run[@]}" -o b.txt --eos-csv b.csv --checkpoint b.ckpt.h5 --stop-after-blocks 10 > b1.log 2>&1
code=$?; [ "$code" = 130 ] || { tail -n 5 b1.log; fail "first session exit $code, expected 130"; }
grep -q "^wall time  *[0-9.]* s (" b1.log || fail "first session: no plain wall-time line"
"$polydem" jam --resume b.ckpt.h5 --summary-json b.ckpt.h5 > bad.log 2>&1
code=$?; [ "$code" = 2 ] || fail "--summary-json naming the checkpoint: exit $code, expected 2"
grep -q "input 'b.ckpt.h5'" bad.log || { cat bad.log; fail "no message naming the checkpoint"; }
# A checkpoint whose session record is impossible is refused, naming the entry (Debian's h5py, scripts/setup.sh).
cp b.ckpt.h5 bad.ckpt.h5
/usr/bin/python3 - bad.ckpt.h5 <<'PY' || fail "could not edit the checkpoint copy (python3-h5py)"
import sys, h5py
with h5py.File(sys.argv[1], "r+") as f:
    f["/checkpoint/real/wall_seconds_before"][0] = -5.0
PY
"$polydem" jam --resume bad.ckpt.h5 > bad2.log 2>&1
code=$?; [ "$code" = 2 ] || { tail -n 3 bad2.log; fail "negative wall_seconds_before: exit $code, expected 2"; }
grep -q "bad.ckpt.h5: checkpoint entry wall_seconds_before is -5" bad2.log || { cat bad2.log; fail "no message naming the entry"; }
"$polydem" jam --resume b.ckpt.h5 --stop-after-blocks 20 --summary-json s2.json > b2.log 2>&1
code=$?; [ "$code" = 130 ] || { tail -n 5 b2.log; fail "second session exit $code, expected 130"; }
grep -q "over all 2 sessions" b2.log || { grep "wall time" b2.log; fail "second session: no total over 2 sessions"; }
"$polydem" jam --resume b.ckpt.h5 --summary-json s3.json > b3.log 2>&1 || { tail -n 5 b3.log; fail "third session exit $?"; }
line=$(grep "^wall time" b3.log)
echo "$line"
[[ "$line" == *"in this session ("*"over all 3 sessions"* ]] || fail "third session: wall-time line '$line'"
# The session's collisions in the line are those of the summary, and fewer than the whole run's.
session=$(grep -o '"session_collisions": *[0-9]*' s3.json | grep -o '[0-9]*$')
total=$(grep -o '"collisions": *[0-9]*' s3.json | head -n 1 | grep -o '[0-9]*$')
sessions=$(grep -o '"sessions": *[0-9]*' s3.json | grep -o '[0-9]*$')
[ -n "$session" ] && [ -n "$total" ] || fail "summary lacks report.session_collisions or report.collisions"
[ "$sessions" = 3 ] || fail "report.sessions = '$sessions', expected 3"
[[ "$line" == *"($session collisions:"* ]] || fail "the line's collisions are not report.session_collisions ($session)"
[ "$session" -lt "$total" ] || fail "session collisions $session not below the run's $total"
grep -q '"wall_seconds_all_sessions": *[0-9]' s3.json || fail "summary lacks report.wall_seconds_all_sessions"
# Wall seconds in the EOS table (column 6) never fall, across both resumes.
awk -F, 'NR > 2 { if ($6 + 0 < last) { print "row " NR ": " $6 " after " last; bad = 1 } last = $6 + 0 }
         END { exit bad }' b.csv || fail "EOS wall seconds fall across a resume"
echo "PASS: three sessions, session rate over session time, totals over all sessions"
