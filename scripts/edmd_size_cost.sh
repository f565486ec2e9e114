#!/usr/bin/env bash
# edmd_size_cost.sh POLYDEM [OUT]: the event-driven engine's cost per collision for uniform-volume size
# distributions (f(r) ~ r^-3) against equal spheres, at fixed density, one core (issue 17's target: at most
# 1.5x the monodisperse cost at omega 10 and 2x at omega 50). A measurement script, not CI: run it on a quiet
# machine.
#
# Settings (environment): N ("10000 20000"), OMEGAS ("10 50"), PHI (0.5), CPP collisions per particle per run
# (300), ROUNDS (5), CORE for `taskset -c` (1).
#
# Per N, PHI and case (mono and each omega) ONE start, `polydem jam -n N --schedule 1e-2 --target-phi PHI --seed 1
# [--dist uv --omega W]`, kept in OUT and reused by a later call. Then ROUNDS rounds; in each, every case runs
# once, one after the other: `jam -i START --schedule 1e-2 --target-phi PHI(1 + 1e-9) --run-collisions CPP
# --seed ROUND --summary-json`, and its fixed-density collisions per CPU second is recorded. Output in OUT:
# runs.csv (one row per run), summary.csv and summary.txt (medians, min, max, and the cost per collision
# relative to the monodisperse case of the same N).
set -euo pipefail
[ $# -ge 1 ] && [ $# -le 2 ] || { echo "usage: [N=.. OMEGAS=.. PHI=.. CPP=.. ROUNDS=.. CORE=..] $0 POLYDEM [OUT]" >&2; exit 2; }
polydem=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
[ -x "$polydem" ] || { echo "error: no polydem executable at $1" >&2; exit 2; }
OUT=${2:-edmd_size_cost_$(date -u +%Y%m%d_%H%M)}
N=${N:-10000 20000} OMEGAS=${OMEGAS:-10 50} PHI=${PHI:-0.5} CPP=${CPP:-300} ROUNDS=${ROUNDS:-5} CORE=${CORE:-1}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
export N OMEGAS PHI CPP ROUNDS CORE OUT
/usr/bin/python3 - "$polydem" <<'PY'
import csv
import json
import os
import statistics
import subprocess
import sys
import time

polydem = sys.argv[1]
out = os.environ["OUT"]
try:
    counts = [int(w) for w in os.environ["N"].split()]
    omegas = [w for w in os.environ["OMEGAS"].split()]
    for w in omegas:
        if not float(w) > 1.0:
            sys.exit(f"error: OMEGAS: size ratio {w} is not above 1")
    phi = float(os.environ["PHI"])
    cpp = float(os.environ["CPP"])
    rounds = int(os.environ["ROUNDS"])
except ValueError as e:
    sys.exit(f"error: N, OMEGAS (each > 1), PHI, CPP and ROUNDS must be numbers: {e}")
if not counts or min(counts) < 2 or not (0 < phi < 0.74) or not (cpp > 0) or rounds < 1:
    sys.exit("error: need N >= 2, 0 < PHI < 0.74, CPP > 0, ROUNDS >= 1")
pin = ["taskset", "-c", os.environ["CORE"]]
cases = ["mono"] + [f"uv{w}" for w in omegas]


def write_atomically(name, text):
    """OUT/name written beside itself and renamed over it: an interrupted call leaves the old file or the new."""
    path = os.path.join(out, name)
    with open(path + ".part", "w", newline="") as f:
        f.write(text)
    os.replace(path + ".part", path)


def csv_text(rows):
    import io
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def call(cmd, log):
    with open(log, "w") as f:
        code = subprocess.call(pin + cmd, stdout=f, stderr=subprocess.STDOUT)
    if code != 0:
        sys.exit(f"error: {' '.join(cmd)} exited with {code} (log {log})")


starts = {}
for n in counts:
    for c in cases:
        start = os.path.join(out, f"{c}_n{n}_phi{phi:g}.txt")
        extra = [] if c == "mono" else ["--dist", "uv", "--omega", c[2:]]
        if not os.path.exists(start):
            print(f"start {c} N={n}", flush=True)
            call([polydem, "jam", "-n", str(n), "--schedule", "1e-2", "--target-phi", repr(phi), "--seed", "1",
                  "-o", start + ".part", "--progress", "1e9"] + extra, start + ".log")
            os.replace(start + ".part", start)
        starts[(c, n)] = start
rows = []
summary_json = os.path.join(out, "last_run.json")
for r in range(1, rounds + 1):
    for n in counts:
        for c in cases:
            cmd = [polydem, "jam", "-i", starts[(c, n)], "--schedule", "1e-2", "--target-phi",
                   repr(phi * (1 + 1e-9)), "--run-collisions", repr(cpp), "--progress", "1e9", "--seed", str(r),
                   "--summary-json", summary_json]
            if os.path.exists(summary_json):
                os.remove(summary_json)
            call(cmd, os.path.join(out, "last_run.log"))
            fd = json.load(open(summary_json))["fixed_density"]
            rows.append({"round": r, "n": n, "case": c, "collisions": fd["collisions"],
                         "cpu_seconds": fd["cpu_seconds"], "collisions_per_cpu_second": fd["collisions_per_cpu_second"],
                         "reduced_pressure": fd["reduced_pressure"]})
            print(f"round {r} N={n} {c}: {fd['collisions_per_cpu_second']:.4g} collisions per CPU second, "
                  f"Z {fd['reduced_pressure']:.6g}", flush=True)
write_atomically("runs.csv", csv_text(rows))
summary = []
for n in counts:
    rate = {c: [x["collisions_per_cpu_second"] for x in rows if x["n"] == n and x["case"] == c] for c in cases}
    mono = statistics.median(rate["mono"])
    for c in cases:
        med = statistics.median(rate[c])
        summary.append({"n": n, "case": c, "rounds": rounds, "median": f"{med:.4g}", "min": f"{min(rate[c]):.4g}",
                        "max": f"{max(rate[c]):.4g}", "cost_over_mono": f"{mono / med:.3f}"})
write_atomically("summary.csv", csv_text(summary))
lines = [f"edmd_size_cost: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {polydem}, phi {phi:g}, "
         f"{cpp:g} collisions per particle per run, {rounds} rounds, taskset -c {os.environ['CORE']}",
         "N | case | collisions per CPU second, median (min-max) | cost per collision / mono"]
lines += [f"{s['n']} | {s['case']} | {s['median']} ({s['min']}-{s['max']}) | {s['cost_over_mono']}" for s in summary]
write_atomically("summary.txt", "\n".join(lines) + "\n")
print("\n".join(lines))
PY
