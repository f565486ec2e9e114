#!/usr/bin/env bash
# lammps_reference.sh POLYDEM PYTHON WORKDIR LOG DIGITS [--expect-fewer] [--set KEY=VALUE ...]
# Runs `polydem relax gran_hooke_poly.toml` (the system of gran_hooke_poly.in) with the overrides, and
# compares the final kinetic energy with the one LAMMPS recorded in LOG (the thermo line of step 1000,
# column c_ke, printed with %.17g). Passes when at least DIGITS significant digits agree; with
# --expect-fewer, passes when fewer agree (a control: the predicted dashpot velocity must NOT reproduce
# LAMMPS). LAMMPS itself is not needed: only its recorded log. See docs/lammps.md.
set -u
polydem="$1"; python="$2"; work="$3"; log="$4"; digits="$5"; shift 5
expect_fewer=no
if [ "${1:-}" = "--expect-fewer" ]; then expect_fewer=yes; shift; fi
here="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$work"
final="$work/final.txt"
rm -f "$final"
reference=$(awk '/^ *Step /{table=1; next} table && $1 == 1000 {print $3; exit}' "$here/$log")
[ -n "$reference" ] || { echo "FAIL: no step-1000 kinetic energy in $here/$log"; exit 1; }
"$polydem" relax "$here/gran_hooke_poly.toml" "$@" --set "output.final=$final" > "$work/relax.log" 2>&1 ||
  { cat "$work/relax.log"; echo "FAIL: polydem relax"; exit 1; }
grep -E "^(contact|time step|energy)" "$work/relax.log"
"$python" "$here/kinetic_energy.py" "$final" 2500.0 "$reference" "$digits"
status=$?
if [ "$expect_fewer" = yes ]; then
  [ $status -eq 1 ] && { echo "PASS (control): fewer than $digits digits agree, as expected"; exit 0; }
  echo "FAIL (control): expected fewer than $digits agreeing digits"; exit 1
fi
exit $status
