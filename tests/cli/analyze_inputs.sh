#!/usr/bin/env bash
# analyze_inputs.sh POLYDEM DIR: the inputs of the analyze CLI tests (issue 15), written into DIR.
#   fcc_inflated.txt  FCC, 3^3 cells (108 spheres), radii inflated 1%: overlapping, above pi/sqrt(18)
#   empty.txt, one.txt, two.txt, one_walls.txt  N = 0, 1, 2 (text, no attributes)
#   two_v.txt         two spheres with velocities (one at rest)
#   gas.txt, gas.h5   a dilute gas (phi 0.05, RSA), no reduced_pressure attribute
#   gas_walls.txt     the same between hard walls
#   fcc_one_cell.txt  one FCC unit cell at contact (4 spheres): too small a box for the contact search
#   jam30.h5          a 30-sphere packing from `polydem jam` (has reduced_pressure)
set -eu
polydem="$1"; dir="$2"
mkdir -p "$dir"; cd "$dir"
awk 'BEGIN {
  m = 3; a = 2 * sqrt(2); r = 1.01;
  split("0 0 0 0.5 0.5 0 0.5 0 0.5 0 0.5 0.5", b, " ");
  print "# FCC, radii inflated by 1%"; printf "%d %.17g %.17g %.17g\n", 4 * m * m * m, m * a, m * a, m * a;
  for (i = 0; i < m; i++) for (j = 0; j < m; j++) for (k = 0; k < m; k++) for (s = 0; s < 4; s++)
    printf "%.17g %.17g %.17g %.17g\n", a * (i + b[3*s+1]) + 0.1, a * (j + b[3*s+2]) + 0.1, a * (k + b[3*s+3]) + 0.1, r;
}' > fcc_inflated.txt
awk 'BEGIN { a = 2 * sqrt(2); split("0 0 0 0.5 0.5 0 0.5 0 0.5 0 0.5 0.5", b, " ");
  printf "4 %.17g %.17g %.17g\n", a, a, a;
  for (s = 0; s < 4; s++) printf "%.17g %.17g %.17g 1\n", a * b[3*s+1] + 0.1, a * b[3*s+2] + 0.1, a * b[3*s+3] + 0.1;
}' > fcc_one_cell.txt
printf '# no spheres\n0 10 10 10\n' > empty.txt
printf '1 10 10 10\n5 5 5 1\n' > one.txt
printf '2 10 10 10\n2 5 5 1\n7 5 5 1\n' > two.txt
printf '# boundaries: wall wall wall\n1 10 10 10\n5 5 5 1\n' > one_walls.txt
printf '2 10 10 10\n2 5 5 1 1 0 0\n7 5 5 1 0 0 0\n' > two_v.txt
"$polydem" generate -n 100 --phi 0.05 --seed 3 -o gas.txt > /dev/null
"$polydem" generate -n 100 --phi 0.05 --seed 3 -o gas.h5 > /dev/null
"$polydem" generate -n 100 --phi 0.05 --seed 3 --boundary walls -o gas_walls.txt > /dev/null
"$polydem" jam -n 30 --seed 2 --target-pressure 1e4 -o jam30.h5 > /dev/null
echo "analyze inputs written to $dir"
