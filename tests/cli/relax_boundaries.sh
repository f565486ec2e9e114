#!/usr/bin/env bash
# relax_boundaries.sh POLYDEM WORKDIR: box.boundaries with a particle file (issue 15, section 4). A file
# that states its boundaries (HDF5 always, text with a "# boundaries:" header) must agree with the key,
# or the run is refused as a conflict; a text file without the header takes the key's value.
set -u
polydem="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
cp ../relax_n2.txt .
fail() { echo "FAIL: $*"; exit 1; }
scene() {  # FILE [BOUNDARIES]
  printf '[particles]\nfile = "%s"\n' "$1"
  [ -n "${2:-}" ] && printf '[box]\nboundaries = "%s"\n' "$2"
  printf '[contact]\nstiffness = 1e4\n[velocities]\ninitial = "zero"\n[run]\nsteps = 5\nprogress_interval = 0.0\n'
}
scene relax_n2.txt > walls.toml
printf '[output]\nfinal = "n2.h5"\n' >> walls.toml
"$polydem" relax walls.toml -q > a.log 2>&1 || { cat a.log; fail "writing n2.h5"; }
[ -s n2.h5 ] || fail "n2.h5 not written"

scene n2.h5 periodic > conflict.toml
"$polydem" relax conflict.toml -q > b.log 2>&1; code=$?
[ "$code" -eq 2 ] && grep -q 'box.boundaries = "periodic,periodic,periodic" conflicts with .*n2.h5, which stores boundaries wall,wall,wall' b.log \
  || { cat b.log; fail "HDF5 conflict not refused ($code)"; }
scene n2.h5 walls > agree.toml
"$polydem" relax agree.toml -q > c.log 2>&1 || { cat c.log; fail "agreeing boundaries refused"; }
scene n2.h5 > none.toml
"$polydem" relax none.toml -q > d.log 2>&1 || { cat d.log; fail "file's own boundaries"; }
grep -q "box walled" d.log || { cat d.log; fail "the file's walls were not used"; }

# Text without a header: the key takes effect.
grep -v '^#' relax_n2.txt > bare.txt
scene bare.txt walls > bare.toml
"$polydem" relax bare.toml -q > e.log 2>&1 || { cat e.log; fail "bare text with box.boundaries"; }
grep -q "box walled" e.log || { cat e.log; fail "box.boundaries did not take effect"; }
echo "box.boundaries: conflicts refused, agreement and headerless text accepted"
