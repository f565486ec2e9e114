#!/usr/bin/env bash
# analyze_attribute.sh POLYDEM DIR: `polydem analyze` takes the contact gap from the file's reduced_pressure
# attribute (jam30.h5 from analyze_inputs.sh), and a malformed attribute is an input error naming the file
# and the attribute (issue 15; it used to end in "error: stod"). The malformed copy is made by replacing the
# last digit of the attribute's text in the HDF5 global heap by 'x' (same length, so the file stays valid).
set -u
polydem="$(realpath "$1")"; dir="$(realpath "$2")"
command -v python3 > /dev/null || { echo "python3 not found: skipped"; exit 77; }
good="$dir/jam30.h5"; bad="$dir/jam30_bad_pressure.h5"
out="$("$polydem" analyze "$good" 2>&1)"; code=$?
echo "$out" | head -4; echo "[exit $code]"
if [ "$code" -ne 0 ] || ! grep -Eq 'reduced pressure +[0-9.e+]+ \(file attribute\)' <<<"$out"; then
  echo "FAIL: the packing's own reduced_pressure was not used"; exit 1
fi
printed="$(sed -nE 's/^reduced pressure +([0-9.e+]+) \(file attribute\).*/\1/p' <<<"$out")"
python3 - "$good" "$bad" "$printed" <<'PY' || { echo "FAIL: could not patch the attribute"; exit 1; }
import re, sys
data = bytearray(open(sys.argv[1], 'rb').read())
target = sys.argv[3]
hits = []
for m in re.finditer(rb'[0-9][0-9.e+-]{4,}', data):
    try:
        value = float(m.group())
    except ValueError:
        continue
    if '%.4g' % value == target:
        hits.append(m)
if len(hits) != 1:
    sys.exit(f'{len(hits)} candidates for the reduced_pressure text {target}')
before = hits[0].group().decode()
data[hits[0].end() - 1] = ord('x')
open(sys.argv[2], 'wb').write(data)
print('patched', before, '->', data[hits[0].start():hits[0].end()].decode())
PY
out="$("$polydem" analyze "$bad" --certify 2>&1)"; code=$?
echo "$out"; echo "[exit $code]"
if [ "$code" -ne 2 ] || ! grep -q "jam30_bad_pressure.h5: attribute reduced_pressure" <<<"$out" ||
   grep -q "packing fraction" <<<"$out"; then
  echo "FAIL: the malformed attribute was not named, or a report was printed"; exit 1
fi
# An explicit --pressure does not need the attribute.
out="$("$polydem" analyze "$bad" --pressure 1e4 2>&1)"; code=$?
echo "$out" | grep "reduced pressure"; echo "[exit $code]"
if [ "$code" -ne 0 ] || ! grep -q "(--pressure)" <<<"$out"; then echo "FAIL: --pressure was not used"; exit 1; fi
echo "ok"
