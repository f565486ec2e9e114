#!/usr/bin/env bash
# polydem lammps-neighbor (issue 21): the printed LAMMPS lines parse, the collection bounds ascend and cover
# the largest diameter, a monodisperse file gives one collection, the text report is a valid LAMMPS include
# (report lines are comments) and carries both predictions.
#   lammps_neighbor.sh POLYDEM WORKDIR
set -euo pipefail
polydem="$1"
work="$2"
mkdir -p "$work"
cd "$work"

# Polydisperse: 3000 radii log-uniform over a factor 20 (0.05 .. 1), random centres (overlaps allowed), box
# of packing fraction about 0.3. Monodisperse: 500 spheres of radius 0.5.
awk 'BEGIN { srand(7); n = 3000; L = 11.0; print n, L, L, L;
             for (i = 0; i < n; ++i) printf "%.6f %.6f %.6f %.9g\n", L*rand(), L*rand(), L*rand(), 0.05*exp(log(20)*rand()) }' \
  > poly.txt
awk 'BEGIN { srand(3); n = 500; L = 8.0; print n, L, L, L;
             for (i = 0; i < n; ++i) printf "%.6f %.6f %.6f 0.5\n", L*rand(), L*rand(), L*rand() }' > mono.txt

check_lines() {  # FILE-WITH-LINES MAX-DIAMETER EXPECTED-N(or any)
  python3 - "$1" "$2" "$3" <<'PY'
import sys
lines = [l.split() for l in open(sys.argv[1]) if l.strip() and not l.startswith("#")]
dmax, expect = float(sys.argv[2]), sys.argv[3]
assert len(lines) == 3, f"expected 3 LAMMPS lines, got {len(lines)}"
nb, nm, cm = lines
assert nb[0] == "neighbor" and nb[2] == "multi" and float(nb[1]) > 0, nb
assert nm[0] == "neigh_modify" and "collection/interval" in nm, nm
k = nm.index("collection/interval")
assert nm[1:k] == ["delay", "0", "every", "1", "check", "yes"], nm
n = int(nm[k + 1])
bounds = [float(x) for x in nm[k + 2:]]
assert n >= 1 and len(bounds) == n, f"N = {n} but {len(bounds)} bounds"
assert all(a < b for a, b in zip(bounds, bounds[1:])), f"bounds not ascending: {bounds}"
assert bounds[-1] >= dmax, f"last bound {bounds[-1]} below the largest diameter {dmax}"
assert bounds[-1] <= dmax * (1 + 1e-6), f"last bound {bounds[-1]} far above the largest diameter {dmax}"
assert expect == "any" or n == int(expect), f"expected {expect} collections, got {n}"
assert cm == ["comm_modify", "mode", "multi", "reduce/multi"], cm
print(f"ok: {n} collections {bounds}")
PY
}
dmax=$(awk 'NR > 1 && $4 > m { m = $4 } END { printf "%.9g", 2*m }' poly.txt)

"$polydem" lammps-neighbor poly.txt --format lines > poly.lines
cat poly.lines
check_lines poly.lines "$dmax" any
n=$(sed -n 's/.*collection\/interval \([0-9]*\) .*/\1/p' poly.lines)
[ "$n" -ge 2 ] || { echo "FAIL: a size ratio of 20 should give at least 2 collections, got $n"; exit 1; }

"$polydem" lammps-neighbor poly.txt --skin 0.01 --pair gran/hooke > poly.report
cat poly.report
check_lines poly.report "$dmax" any
grep -q "^neighbor 0.01 multi$" poly.report || { echo "FAIL: --skin 0.01 not in the neighbor line"; exit 1; }
grep -q "^# chosen: .* predicted cost [0-9.e+-]* per particle" poly.report || { echo "FAIL: no chosen prediction"; exit 1; }
grep -q "^# hand-made doubling: .* predicted cost [0-9.e+-]* per particle" poly.report ||
  { echo "FAIL: no doubling prediction"; exit 1; }
# The chosen collections are the model's optimum: never predicted dearer than doubling (1e-9 slack).
python3 - poly.report <<'PY'
import re, sys
t = open(sys.argv[1]).read()
c = float(re.search(r"# chosen: .* predicted cost (\S+) per", t).group(1))
d = float(re.search(r"# hand-made doubling: .* predicted cost (\S+) per", t).group(1))
assert c <= d * (1 + 1e-9), f"chosen {c} dearer than doubling {d}"
counts = [int(x) for x in re.findall(r"# +c_\d+ = \S+: diameters .*?, (\d+) particles", t.split("# hand-made")[0])]
assert sum(counts) == 3000, f"chosen collections hold {sum(counts)} particles, not 3000"
print(f"ok: chosen {c} <= doubling {d}, counts {counts}")
PY

# One level allowed: the doubling collections are predicted cheaper and become the recommendation.
"$polydem" lammps-neighbor poly.txt --max-levels 1 > poly_one_level.report
grep -q "^# the doubling collections are predicted cheaper .* than the optimiser's choice (1 level," \
  poly_one_level.report || { echo "FAIL: --max-levels 1 does not fall back to doubling"; cat poly_one_level.report; exit 1; }
check_lines poly_one_level.report "$dmax" 5

"$polydem" lammps-neighbor mono.txt --format lines > mono.lines
cat mono.lines
check_lines mono.lines 1.0 1

# Bad files: exit 2 and the file named (an unparsable number; no particles; a negative radius).
printf '2 1 1 1\n0 0 0 0.1\n0.5 0.5 x 0.1\n' > bad_number.txt
printf '0 1 1 1\n' > empty.txt
printf '1 1 1 1\n0.5 0.5 0.5 -0.1\n' > negative.txt
for f in bad_number.txt empty.txt negative.txt; do
  set +e
  "$polydem" lammps-neighbor "$f" > "$f.out" 2>&1
  rc=$?
  set -e
  cat "$f.out"
  [ "$rc" = 2 ] || { echo "FAIL: $f: exit $rc, expected 2"; exit 1; }
  grep -q "$f" "$f.out" || { echo "FAIL: $f: the error does not name the file"; exit 1; }
done
echo "lammps_neighbor: all checks passed"
