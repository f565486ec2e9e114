#!/usr/bin/env bash
# jam_marked.sh POLYDEM WORKDIR: a run stopped by its collision budget exits 4 and still writes its output,
# marked target_reached = no and stop_reason = collision budget (HDF5 attributes; read back by analyze).
set -u
polydem="$1"; work="$2"; cd "$work" || exit 1
rm -f marked.h5 marked.xmf
"$polydem" jam -n 100 --block 1000 --max-collisions 20 -o marked.h5 > marked.log 2>&1; code=$?
cat marked.log
[ "$code" = 4 ] || { echo "FAIL: exit $code, expected 4"; exit 1; }
[ -s marked.h5 ] || { echo "FAIL: no output marked.h5"; exit 1; }
# Attribute names and short string values sit verbatim in the HDF5 object header.
grep -aq "target_reached" marked.h5 || { echo "FAIL: no target_reached attribute"; exit 1; }
grep -aq "collision budget" marked.h5 || { echo "FAIL: no stop_reason collision budget"; exit 1; }
"$polydem" analyze marked.h5 --structure-only > marked_analyze.log 2>&1 || {
  cat marked_analyze.log; echo "FAIL: analyze cannot read marked.h5"; exit 1; }
echo "PASS"
