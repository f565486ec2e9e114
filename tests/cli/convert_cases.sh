#!/usr/bin/env bash
# convert_cases.sh POLYDEM WORKDIR: polydem convert between text, HDF5, LAMMPS data and dump (issue 21):
# round trips keep every value (text <-> HDF5 <-> data <-> dump, %.17g), inputs are never overwritten,
# bad inputs exit 2 naming the file and line.
set -u
polydem="$1"; work="$2"
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
"$polydem" generate --dist uv --omega 4 -n 50 --phi 0.3 -o g.txt > /dev/null || fail "generate"
# Velocities and angular velocities: add them to the text file (columns x y z r vx vy vz wx wy wz).
awk 'BEGIN { srand(3) } /^#/ { if ($0 ~ /^# columns:/) next; print; next } NF == 4 && !h { h = 1; print "# columns: x y z r vx vy vz wx wy wz"; print; next }
     { printf "%s %s %s %s %.17g %.17g %.17g %.17g %.17g %.17g\n", $1, $2, $3, $4, rand() - 0.5, rand() - 0.5, rand() - 0.5, rand(), rand(), rand() }' g.txt > v.txt
"$polydem" convert v.txt a.h5 > /dev/null || fail "text -> hdf5"
"$polydem" convert a.h5 b.data > /dev/null || fail "hdf5 -> lammps data"
"$polydem" convert b.data c.dump > /dev/null || fail "lammps data -> dump"
"$polydem" convert c.dump d.txt > /dev/null || fail "dump -> text"
"$polydem" convert d.txt e.txt --to text > /dev/null || fail "text -> text"
# The values survive: compare the particle lines of v.txt and d.txt.
grep -v '^#' v.txt > v.rows; grep -v '^#' d.txt > d.rows
cmp v.rows d.rows || { diff v.rows d.rows | head -5; fail "text -> hdf5 -> data -> dump -> text changed values"; }
grep -q '^Atoms # sphere' b.data || fail "no 'Atoms # sphere' section"
grep -q '^Velocities' b.data || fail "no Velocities section"
grep -q '^ITEM: ATOMS id type radius x y z vx vy vz omegax omegay omegaz$' c.dump || fail "dump columns"
# Multi-frame dump from several inputs; one frame picked back out.
"$polydem" convert v.txt a.h5 multi.dump > /dev/null || fail "two inputs -> dump"
[ "$(grep -c 'ITEM: TIMESTEP' multi.dump)" = 2 ] || fail "multi.dump should hold 2 frames"
out=$("$polydem" convert multi.dump one.txt 2>&1) || fail "dump of 2 frames -> text"
echo "$out" | grep -q "holds 2 frames; converting the last" || fail "no note on the frame chosen: $out"
"$polydem" convert multi.dump --frame 5 x.txt > err.txt 2>&1; [ $? = 2 ] || fail "--frame 5 of 2 frames should exit 2"
grep -q "frames 0 .. 1" err.txt || fail "--frame message: $(cat err.txt)"
# --series over HDF5 snapshots; refused for text.
"$polydem" convert v.txt b.h5 > /dev/null || fail "text -> b.h5"
"$polydem" convert --series s.xmf a.h5 b.h5 > /dev/null || fail "--series"
[ "$(grep -c '<Time ' s.xmf)" = 4 ] || fail "s.xmf: 2 frames x (box + particles) Time elements expected"
"$polydem" convert --series t.xmf v.txt > err.txt 2>&1; [ $? = 2 ] || fail "--series of a text file should exit 2"
grep -q "'v.txt' is not an HDF5 snapshot" err.txt || fail "--series message: $(cat err.txt)"
# Never overwrite an input.
cp v.txt keep.txt
"$polydem" convert v.txt v.txt > err.txt 2>&1; [ $? = 2 ] || fail "convert v.txt v.txt should exit 2"
cmp v.txt keep.txt || fail "the input was changed"
# Bad inputs: exit 2, the message names file and line.
expect_bad() {  # FILE CONTENT REGEX
  printf '%b' "$2" > "$1"
  "$polydem" convert "$1" out.h5 > err.txt 2>&1; code=$?
  [ $code = 2 ] || fail "$1: exit $code, expected 2: $(cat err.txt)"
  grep -Eq "$3" err.txt || fail "$1: message '$(cat err.txt)' does not match '$3'"
}
hdr='LAMMPS\n\n2 atoms\n1 atom types\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n'
expect_bad tilted.data "${hdr}0 0 0 xy xz yz\n" "tilted.data:8: a tilted \\(triclinic\\) box"
expect_bad style.data "${hdr}\nAtoms # atomic\n\n1 1 0.5 0.5 0.5\n" "style.data:9: Atoms section of atom_style 'atomic'"
expect_bad short.data "${hdr}\nAtoms # sphere\n\n1 1 0.1 1 0.5 0.5 0.5\n" "short.data:11: Atoms section ends after 1 of 2"
expect_bad word.data "${hdr}\nAtoms # sphere\n\n1 1 0.1 1 0.5 0.5 0.5\n2 1 0.1 1 0.5 oops 0.5\n" "word.data:12: y: 'oops' is not a finite number"
expect_bad twice.data "${hdr}\nAtoms # sphere\n\n1 1 0.1 1 0.5 0.5 0.5\n1 1 0.1 1 0.2 0.5 0.5\n" "twice.data:12: atom id 1 appears twice"
expect_bad nobox.data "LAMMPS\n\n2 atoms\n0 1 xlo xhi\n" "nobox.data: the header has no 'ylo yhi' line"
expect_bad cols.dump "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp pp\n0 1\n0 1\n0 1\nITEM: ATOMS id x y z\n1 0.5 0.5 0.5\n" "cols.dump:9: the ATOMS columns need id, x, y, z and radius"
expect_bad trunc.dump "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n0 1\n0 1\n0 1\nITEM: ATOMS id radius x y z\n1 0.1 0.5 0.5 0.5\n" "trunc.dump:10: the file ends where 'an atom line' was expected"
expect_bad tilt.dump "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS xy xz yz pp pp pp\n" "tilt.dump:5: .*tilted box"
echo "convert: conversions, round trip and bad inputs as expected"
