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
# relax: the report's energies at full precision, the scene text; a sweep's table as arrays.
cat > tiny.toml <<'TOML'
[particles]
count = 300
distribution = "uniform-volume"
omega = 3.0
packing_fraction = 0.4
[contact]
stiffness = 1000.0
restitution = 0.8
[run]
steps = 60
[output]
final = "tiny_final.txt"
TOML
"$polydem" relax tiny.toml -q --summary-json relax.json > relax.log 2>&1 || fail "relax exit $?: $(cat relax.log)"
kinetic=$(sed -n 's/^energy (J) *kinetic \([^,]*\),.*/\1/p' relax.log)
$py - "$kinetic" <<'PY' || fail "relax.json"
import json, sys
d = json.load(open("relax.json"))
k = d["report"]["energy"]["kinetic"]
assert abs(k - float(sys.argv[1])) <= 1e-5 * abs(k) and k > 0, (k, sys.argv[1])
assert d["report"]["steps"] == 60 and "count = 300" in d["scene"]["text"], d["report"]
assert d["outputs"]["final_state"] == "tiny_final.txt" and d["exit"]["code"] == 0
PY
"$polydem" relax tiny.toml -q --sweep dt-factor=20,40 --summary-json sweep.json > sweep.log 2>&1 || fail "sweep exit $?"
$py -c "
import json; d = json.load(open('sweep.json'))['sweep']
assert d['key'] == 'dt-factor' and d['values'] == [20, 40] and len(d['position_error']) == 2, d" || fail "sweep.json"

# jam: phi and the contact count as printed; a target not reached ends with exit code 4 in the summary.
"$polydem" jam -n 120 --seed 2 --schedule 1e-2:1e2,1e-3 --target-pressure 1e6 -o jam.h5 --summary-json jam.json \
  > jam.log 2>&1 || fail "jam exit $?"
jphi=$(sed -n 's/^packing fraction *//p' jam.log)
$py - "$jphi" <<'PY' || fail "jam.json"
import json, sys
d = json.load(open("jam.json"))
assert abs(d["report"]["packing_fraction"] - float(sys.argv[1])) < 5e-9, d["report"]
assert d["report"]["target_reached"] is True and d["report"]["reduced_pressure"] >= 1e6, d["report"]
PY
"$polydem" jam -n 120 --seed 2 --schedule 1e-2 --max-collisions 2 --target-pressure 1e6 --summary-json short.json \
  > short.log 2>&1
code=$?
$py - "$code" <<'PY' || fail "short.json (exit $code): $(tail -3 short.log)"
import json, sys
d = json.load(open("short.json"))
assert d["exit"]["code"] == int(sys.argv[1]) and d["exit"]["code"] == 4 and d["report"]["target_reached"] is False, d["exit"]
PY
# jam --run-collisions: the fixed-density run's collisions and CPU seconds (the figure scripts/edmd_vs_peer.sh
# compares with another code), consistent with each other and with the wall time of the same loop.
"$polydem" jam -n 120 --seed 2 --schedule 1e-2 --target-phi 0.4 --run-collisions 40 --summary-json fixed.json \
  > fixed.log 2>&1 || fail "jam --run-collisions exit $?: $(tail -3 fixed.log)"
$py - <<'PY' || fail "fixed.json"
import json
f = json.load(open("fixed.json"))["fixed_density"]
assert f["collisions"] >= 40 * 120, f
assert 0 < f["cpu_seconds"] <= 1.05 * f["wall_seconds"] + 1e-3, f
assert abs(f["collisions_per_cpu_second"] * f["cpu_seconds"] - f["collisions"]) <= 1e-6 * f["collisions"], f
PY
grep -q "collisions per CPU s" fixed.log || fail "no CPU rate on the fixed density line: $(grep '^fixed density' fixed.log)"
echo "summary-json: ok"
