#!/usr/bin/env bash
# jam_reopen_attribute.sh POLYDEM WORKDIR: `jam -i FILE --reopen P` reads the file's reduced_pressure with
# io::numericAttribute: a malformed value is refused naming the file and the attribute (the pre-issue code
# took '10331x.2' as 10331 and ran on). The attribute strings of a jam HDF5 file are patched in place,
# same length, so the file stays valid.
set -u
polydem="$1"; work="$2/jam_reopen_attribute"; rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
fail() { echo "FAIL: $*"; exit 1; }
"$polydem" jam -n 100 --schedule 1e-2:1e2,1e-3 --target-pressure 1e5 -o good.h5 > good.log 2>&1 || fail "jam exit $?"
perl -0777 -pe 's/([0-9]{5})[0-9.]([0-9.e+-]{8,})/${1}x$2/g' good.h5 > bad.h5
out="$("$polydem" jam -i bad.h5 --reopen 1e3 --schedule 1e-3 --target-pressure 1e4 2>&1)"; code=$?
echo "$out" | tail -n 2
[ "$code" = 2 ] || fail "exit $code, expected 2"
grep -q "bad.h5: attribute reduced_pressure: '[0-9]*x[0-9.e+-]*' is not a finite number" <<<"$out" || fail "message"
"$polydem" jam -i good.h5 --reopen 1e3 --schedule 1e-3 --target-pressure 1e4 > reopen.log 2>&1 || fail "good file"
echo "PASS"
