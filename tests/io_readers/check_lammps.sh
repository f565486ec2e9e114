#!/usr/bin/env bash
# check_lammps.sh POLYDEM WORKDIR: LAMMPS itself reads what polydem writes (issue 21). read_data of a
# data file polydem wrote, write_data back, read_dump of a polydem dump; polydem then reads LAMMPS's
# write_data and both must hold the same spheres (ids, radii, positions, velocities to 1e-15 relative).
# Exit 77 (skipped) when `lmp` is not installed: LAMMPS is a reference tool, not a dependency.
set -u
polydem="$1"; work="$2"
command -v lmp > /dev/null || { echo "SKIP: lmp (LAMMPS) not installed"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cat > scene.toml <<'TOML'
[particles]
count = 150
distribution = "uniform-volume"
rmin = 0.5e-3
omega = 4.0
packing_fraction = 0.4
[contact]
law = "linear"
stiffness = 1000.0
friction = 0.3
[run]
steps = 100
[output]
final = "final.h5"
TOML
"$polydem" relax scene.toml -q > relax.log 2>&1 || { cat relax.log; fail "relax"; }
"$polydem" convert final.h5 polydem.data > /dev/null || fail "convert to LAMMPS data"
"$polydem" convert final.h5 polydem.dump > /dev/null || fail "convert to LAMMPS dump"
step=$(grep -A1 'ITEM: TIMESTEP' polydem.dump | tail -1)
cat > roundtrip.in <<LMP
units si
atom_style sphere
boundary p p p
read_data polydem.data
write_data lammps.data
read_dump polydem.dump $step x y z vx vy vz box yes format native
write_data lammps_after_dump.data
LMP
lmp -in roundtrip.in -log lammps.log > lammps.out 2>&1 || { tail -20 lammps.out; fail "LAMMPS refused polydem's files"; }
grep -q "150 atoms in snapshot" lammps.out || { cat lammps.out; fail "read_dump did not see 150 atoms"; }
for f in lammps.data lammps_after_dump.data; do
  "$polydem" convert "$f" "back_$f.h5" > /dev/null || fail "polydem cannot read LAMMPS's $f"
  "$polydem" convert "back_$f.h5" "back_$f.txt" > /dev/null || fail "convert back_$f.h5"
done
"$polydem" convert final.h5 final.txt > /dev/null || fail "convert final.h5"
# Same spheres, to round-off (LAMMPS writes %.16g-like values): compare numerically, not by bytes.
for f in back_lammps.data.txt back_lammps_after_dump.data.txt; do
  awk 'NR==FNR { if ($0 !~ /^#/) a[FNR_a++] = $0; next } $0 !~ /^#/ { split(a[n++], x); m = split($0, y);
        for (k = 1; k <= m; k++) { d = x[k] - y[k]; if (d < 0) d = -d; s = (x[k] < 0 ? -x[k] : x[k]);
          if (d > 1e-14 * (s + 1e-300) && d > 1e-300) { print "differs: line " n ": " a[n-1] " vs " $0; bad = 1; exit } } }
       END { exit bad }' final.txt "$f" || fail "$f: the spheres LAMMPS wrote back differ from polydem's"
done
echo "LAMMPS read_data, write_data and read_dump agree with polydem's files"
