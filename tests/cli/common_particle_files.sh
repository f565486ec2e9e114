#!/usr/bin/env bash
# common_particle_files.sh POLYDEM: particle files written by the CLI (issue 15).
#  - a text file keeps the attributes, time and boundaries as `#` header comments;
#  - the same HDF5 snapshot written twice is byte-identical (cmp), XDMF sidecar too;
#  - text -> HDF5 -> text through `generate` keeps every attribute.
set -euo pipefail
polydem="$1"
dir="common_particle_files.d"
rm -rf "$dir"; mkdir -p "$dir"
fail() { echo "FAIL: $*"; exit 1; }

"$polydem" generate -n 50 --dist uv --omega 4 --boundary periodic,periodic,wall --seed 5 -o "$dir/a.txt" >/dev/null
grep -q '^# boundaries: periodic periodic wall$' "$dir/a.txt" || fail "no boundaries comment"
grep -q '^# time: 0$' "$dir/a.txt" || fail "no time comment"
grep -q '^# attribute: distribution = "uniform-volume rmin=1 omega=4"$' "$dir/a.txt" || fail "no distribution attribute"
grep -q '^# attribute: seed = 5$' "$dir/a.txt" || fail "no seed attribute"
# Metadata comments are parsed back: pairs reads the walls from the file, not from --boundary's default.
out=$("$polydem" pairs "$dir/a.txt" --repeat 1)
grep -q "box walls(z) periodic(xy)" <<<"$out" || fail "walls not read back from the text file"

"$polydem" generate -n 50 --dist uv --omega 4 --seed 5 -o "$dir/s1.h5" >/dev/null
sleep 1  # HDF5 time stamps have one-second resolution: make a stamped file differ
"$polydem" generate -n 50 --dist uv --omega 4 --seed 5 -o "$dir/s2.h5" >/dev/null
cmp "$dir/s1.h5" "$dir/s2.h5" || fail "the same snapshot written twice differs"
cmp <(sed 's/s1.h5/X/' "$dir/s1.xmf") <(sed 's/s2.h5/X/' "$dir/s2.xmf") || fail "sidecars differ"
leftover=$(find "$dir" -name '.*tmp*' | wc -l)
[ "$leftover" = 0 ] || fail "temporary files left behind"
echo "ok"
