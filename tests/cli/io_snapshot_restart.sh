#!/usr/bin/env bash
# io_snapshot_restart.sh POLYDEM WORKDIR: a snapshot of a frictional relax carries the angular velocities
# and the time (text columns wx wy wz and `# time:`, HDF5 /particles/angular_velocity and /time), and a
# relax started from it with velocities.initial = "file" reads them back: its step-0 snapshot holds the
# same particles, velocities and spins bit for bit (issue 15, section 3).
set -u
polydem="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cp ../relax_small.toml .
fail() { echo "FAIL: $*"; exit 1; }
run() { echo "+ polydem $*"; "$polydem" "$@"; }

run relax relax_small.toml -q --steps 1500 --set output.snapshot=\"s.txt\" --set output.snapshot_interval=0 \
  > a.log 2>&1 || { cat a.log; fail "frictional run"; }
[ -f s.txt ] || { cat a.log; fail "no snapshot s.txt"; }
grep -q "^# columns: x y z r vx vy vz wx wy wz$" s.txt || { head -5 s.txt; fail "snapshot has no wx wy wz columns"; }
time=$(sed -n 's/^# time: //p' s.txt)
awk -v t="$time" 'BEGIN { exit !(t + 0 > 0) }' || fail "snapshot time '$time' is not positive"
# Data lines: x y z r vx vy vz wx wy wz; count the particles that spin.
spinning=$(awk '!/^#/ && NF == 10 && ($8 != 0 || $9 != 0 || $10 != 0) { n++ } END { print n + 0 }' s.txt)
[ "$spinning" -gt 0 ] || fail "no particle of the frictional snapshot has a non-zero angular velocity"

cat > restart.toml <<'TOML'
[particles]
file = "s.txt"
density = 2500.0
[contact]
stiffness = 1e4
restitution = 0.7
friction = 0.5
[velocities]
initial = "file"
[run]
steps = 1
gravity = [0.0, 0.0, -9.81]
progress_interval = 0.0
[output]
snapshot = "r_{step}.txt"
snapshot_interval = 1
TOML
run relax restart.toml -q > b.log 2>&1 || { cat b.log; fail "restart from the snapshot"; }
first=$(ls r_*0.txt 2>/dev/null | head -1)
[ -n "$first" ] || { ls; cat b.log; fail "no step-0 snapshot of the restarted run"; }
grep -v '^#' s.txt > a.data; grep -v '^#' "$first" > b.data
cmp a.data b.data || { diff a.data b.data | head; fail "the restarted run does not start from the snapshot's state"; }
# Its clock continues from the snapshot's time (the step-0 snapshot carries the same time).
rtime=$(sed -n 's/^# time: //p' "$first")
[ "$rtime" = "$time" ] || fail "the restarted run starts at time '$rtime', the snapshot was at '$time'"

# The HDF5 snapshot carries the same record.
if run relax relax_small.toml -q --steps 1500 --set output.snapshot=\"s.h5\" --set output.snapshot_interval=0 \
     > c.log 2>&1; then
  sed -i 's/file = "s.txt"/file = "s.h5"/; s/r_{step}.txt/h_{step}.txt/' restart.toml
  run relax restart.toml -q > d.log 2>&1 || { cat d.log; fail "restart from the HDF5 snapshot"; }
  hfirst=$(ls h_*0.txt 2>/dev/null | head -1)
  [ -n "$hfirst" ] || { ls; fail "no step-0 snapshot of the run restarted from HDF5"; }
  grep -v '^#' "$hfirst" > h.data
  cmp a.data h.data || { diff a.data h.data | head; fail "the run restarted from HDF5 differs"; }
  htime=$(sed -n 's/^# time: //p' "$hfirst")
  [ "$htime" = "$time" ] || fail "the run restarted from HDF5 starts at time '$htime', not '$time'"
elif grep -q "POLYDEM_WITH_HDF5=OFF" c.log; then
  echo "(built without HDF5: HDF5 snapshot not checked)"
else
  cat c.log; fail "HDF5 snapshot"
fi
echo "restart from a snapshot is faithful: $spinning spinning particles, time $time s"
