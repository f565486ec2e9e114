#!/usr/bin/env bash
# summary_json.sh POLYDEM WORKDIR: --summary-json (issue 21) holds the printed figures at full precision,
# the command and the settings, says how the run ended (also for a failed run), and never overwrites an input.
set -u
polydem="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
py=/usr/bin/python3
fail() { echo "FAIL: $*"; exit 1; }
"$polydem" generate --dist uv --omega 4 -n 400 --phi 0.45 --seed 2 -o gas.txt > /dev/null || fail "generate"

# pairs: the JSON's counts are the printed ones; the times read back as numbers.
"$polydem" pairs gas.txt --skin 0.2 --repeat 2 --summary-json pairs.json > pairs.log || fail "pairs exit $?"
printed=$(sed -n 's/^candidate pairs: //p' pairs.log)
$py - "$printed" <<'PY' || fail "pairs.json"
import json, sys
d = json.load(open("pairs.json"))
assert d["command"]["subcommand"] == "pairs", d["command"]
assert d["settings"]["skin"] == "0.2", d["settings"]
assert d["pairs"]["candidate"] == int(sys.argv[1]) and d["pairs"]["candidate"] > 0, d["pairs"]
assert isinstance(d["time"]["build_seconds_median"], float)
assert d["exit"] == {"code": 0, "status": "ok"}, d["exit"]
PY

# analyze: packing fraction at full precision (the report rounds to 8 decimals), contacts as printed.
"$polydem" analyze gas.txt --contact-gap 0.01 --summary-json analyze.json > analyze.log || fail "analyze exit $?"
phi=$(sed -n 's/^packing fraction *//p' analyze.log)
contacts=$(sed -n 's/^contacts (gap <= [^)]*) \([0-9]*\) .*/\1/p' analyze.log)
$py - "$phi" "$contacts" <<'PY' || fail "analyze.json"
import json, sys
d = json.load(open("analyze.json"))
phi = d["packing"]["packing_fraction"]
assert abs(phi - float(sys.argv[1])) < 5e-9 and len(repr(phi)) > 12, phi
assert d["contacts"]["count"] == int(sys.argv[2]), d["contacts"]
# No reduced pressure in a generated file: null with the reason, never NaN.
assert d["packing"]["reduced_pressure"] is None and "no reduced_pressure" in d["packing"]["reduced_pressure_undefined"]
PY

# A run that fails still leaves its summary, with exit code 2 and the message.
"$polydem" analyze gas.txt --summary-json failed.json > /dev/null 2>&1
[ $? -eq 2 ] || fail "analyze without a pressure should exit 2"
$py -c "
import json; d = json.load(open('failed.json'))
assert d['exit']['code'] == 2 and 'reduced_pressure' in d['exit']['message'], d['exit']" || fail "failed.json"

# The summary may not overwrite the input: refused before any work, input unchanged.
sum_before=$(sha256sum gas.txt)
"$polydem" pairs gas.txt --summary-json gas.txt > out.log 2>&1
[ $? -eq 2 ] || fail "--summary-json onto the input should exit 2"
grep -q "is the input" out.log || fail "no message naming the input: $(cat out.log)"
[ "$(sha256sum gas.txt)" = "$sum_before" ] || fail "the input was changed"
echo "summary-json: ok"
