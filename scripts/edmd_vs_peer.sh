#!/usr/bin/env bash
# edmd_vs_peer.sh PEER POLYDEM_BUILD: polydem's event-driven engine against the `Single` variant of
# Smallenburg's EDMD code (F. Smallenburg, Eur. Phys. J. E 45, 22 (2022); github.com/FSmallenburg/EDMD),
# side by side on one core (issue 17). A measurement script, not CI: run it on a quiet machine.
#
#   PEER           the peer's `Single` source folder (holding mdSingle.c and its Makefile), built outside
#                  this repository; the script compiles a small driver against it (below). Or the driver
#                  executable such a call built before ($OUT/peer_driver).
#   POLYDEM_BUILD  a polydem build directory (Release), holding apps/polydem.
#
# Settings (environment): N (10000), PHI (0.5), CPP collisions per particle per run (300), ROUNDS (5),
# CASES (mono; "bi1.2" is a 50:50-by-number binary mixture of size ratio 1.2, "uvW" uniform volume
# f(r) ~ r^-3 of size ratio W, e.g. uv10), SEED (1), CORE for
# `taskset -c` (1), OUT (edmd_vs_peer_<UTC date>), CC (gcc). N, PHI and CASES may be lists ("10000 32000"):
# every case runs at every N and PHI, one after the other, each with its own start and rounds.
#
# What it does, per case: ONE start, made by `polydem jam -n N --schedule 1e-2 --target-phi PHI` and written
# as polydem text (start.txt) and in the peer's .sph format (start.sph: lengths in units of the largest
# diameter, as the peer requires). Then ROUNDS rounds, each running both codes on that start, one after the
# other (polydem first in even rounds, the peer first in odd ones), pinned with `taskset -c CORE`:
#   polydem: jam -i start.txt --target-phi PHI_START*(1+1e-9) --run-collisions CPP: `--target-phi` must lie
#            above the start's packing fraction, so the compression is one growth of the radii by a factor
#            1 + 3e-10 taking a handful of collisions; then CPP x N collisions at fixed density. Its
#            --summary-json gives the collisions, CPU seconds (fixed_density.cpu_seconds; a build older than
#            that key gives only wall seconds, and the CSV then says clock = wall) and the reduced pressure
#            Z = PV/(NkT) of that run.
#   peer:    the driver, ceil(CPP x N) collisions from the same positions. The peer's own end-of-run report
#            gives the reduced pressure P* = beta P sigma^3 (sigma = largest diameter) over the run; the
#            script converts it, Z = P* V / N (V in sigma^3). The driver times the event loop.
# Both codes draw fresh Maxwell-Boltzmann velocities (kT = 1) with their own generators, seeded SEED + round
# (the driver's `seed=K` re-seeds the peer's generator and redraws with the peer's routine), and run at
# constant energy; the Z columns give the median and range over the rounds (the runs' statistical error); masses: polydem's are proportional to r^3; the peer's are all equal unless the driver is given
# `volume-mass`, which the script does for every case that is not monodisperse (mass (2r)^3 in units of
# the largest sphere's, then fresh velocities and a new prediction for every sphere before the timed loop).
# The timed part is the event loop at fixed density only (not reading, list building, analysis) for both.
#
# The peer needs no change to its source. It has no command line and stops at a fixed simulated time, and
# its thermostat is switched on by a compile-time constant, so the script compiles, with the CFLAGS line of
# the peer's own Makefile (-Wall -Ofast -funroll-loops -march=native in the version of 2022), a driver file
# of ours that includes the peer's mdSingle.c unchanged as one translation unit (its main renamed by a
# macro) and supplies a main that (1) puts the input file name into the peer's input-name variable and calls
# the peer's init(); (2) removes the thermostat's event from the peer's event calendar before any event
# runs (the peer calls it with kicks every 0.01 time units otherwise), so the run is microcanonical like
# polydem's; (3) with `volume-mass` and/or `seed=K`, sets the masses as above and/or re-seeds the peer's
# generator, redraws the velocities with the peer's own routine and re-predicts every sphere's event; (4) calls the peer's step() until its collision counter
# reaches ceil(CPP x N), timing that loop with CLOCK_PROCESS_CPUTIME_ID and CLOCK_MONOTONIC; (5) calls the
# peer's end-of-run report and prints one line `peer-driver: ...` with the counts and times. Everything
# else (the event calendar and its tuning constants, neighbour lists with shell 1.5, the write event
# every time unit) is the peer's as published.
#
# Wide mixtures and the peer's neighbour limit: the peer keeps each sphere's neighbours in a fixed array of
# MAXNEIGH = 24 entries (a #define in mdSingle.c) and stops with "Too many neighbors" beyond it; a sphere 10x
# larger than most has hundreds of neighbours under its rule |r_ij| < 1.5 (r_i + r_j). For every case the
# script counts, on the start, the largest number of neighbours any sphere has under that rule. Up to 20 the
# driver above runs (the peer as published); otherwise the script builds a driver from a copy of the peer's
# folder in $OUT/peer_maxneigh_M/ whose only change is that constant, M = 1.5 x that count + 8 rounded up to
# a multiple of 8 (the summary names the driver per case). That needs the peer's folder, not a prebuilt
# driver. The peer's cell list has cells of 1.5 largest diameters, so its list rebuilds cost more the wider
# the distribution: that is its design, measured as it is.
#
# Output in $OUT: runs.csv (one row per run), summary.csv (medians, ratio polydem/peer, pressures and
# their relative difference), summary.txt (the same, with machine and commands), one folder per case with
# the starts and every run's log.
set -euo pipefail

usage() {
  echo "usage: [N=10000 PHI=0.5 CPP=300 ROUNDS=5 CASES='mono bi1.2 uv10' CORE=1 OUT=dir] $0 PEER POLYDEM_BUILD" >&2
  echo "  PEER: the peer's Single/ folder (mdSingle.c, Makefile) or a driver this script built" >&2
  exit 2
}
[ $# -eq 2 ] || usage
peer=$1
build=$2
polydem=$build/apps/polydem
[ -x "$polydem" ] || { echo "error: no polydem executable at $polydem" >&2; exit 2; }
N=${N:-10000}
PHI=${PHI:-0.5}
CPP=${CPP:-300}
ROUNDS=${ROUNDS:-5}
CASES=${CASES:-mono}
SEED=${SEED:-1}
CORE=${CORE:-1}
OUT=${OUT:-edmd_vs_peer_$(date -u +%Y%m%d_%H%M)}
CC=${CC:-gcc}
py=/usr/bin/python3
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
polydem=$(cd "$(dirname "$polydem")" && pwd)/polydem

if [ -d "$peer" ]; then
  src=$(cd "$peer" && pwd)
  if [ ! -f "$src/mdSingle.c" ] || [ ! -f "$src/Makefile" ]; then
    echo "error: $peer holds no mdSingle.c and Makefile (give the peer's Single/ folder)" >&2
    exit 2
  fi
  cflags=$(sed -n 's/^CFLAGS[[:space:]]*=[[:space:]]*//p' "$src/Makefile" | head -1)
  [ -n "$cflags" ] || { echo "error: no CFLAGS line in $src/Makefile" >&2; exit 2; }
  cat > "$OUT/peer_driver.c" <<'C'
/* Driver for the peer's Single code (scripts/edmd_vs_peer.sh of polydem): the peer's source is included
   unchanged; this file only adds a main.
   Usage: peer_driver FILE.sph COLLISIONS_PER_PARTICLE [volume-mass] [seed=K] */
#define main peer_original_main
#include "mdSingle.c"
#undef main
#include <errno.h>
#include <limits.h>
#include <time.h>

static double clockSeconds(clockid_t id) {
  struct timespec t;
  clock_gettime(id, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char** argv) {
  int volumeMass = 0;
  long seed = 0; /* 0: the peer's own velocities (its fixed seed) */
  int bad = argc < 3;
  for (int k = 3; k < argc && !bad; k++) {
    char* rest = NULL;
    if (strcmp(argv[k], "volume-mass") == 0) {
      volumeMass = 1;
    } else if (strncmp(argv[k], "seed=", 5) == 0) {
      errno = 0;
      seed = strtol(argv[k] + 5, &rest, 10);
      bad = errno != 0 || rest == argv[k] + 5 || *rest != '\0' || seed < 1;
    } else {
      bad = 1;
    }
  }
  if (bad) {
    fprintf(stderr, "usage: %s FILE.sph COLLISIONS_PER_PARTICLE [volume-mass] [seed=K>=1]\n", argv[0]);
    return 2;
  }
  if (strlen(argv[1]) >= sizeof inputfilename) {
    fprintf(stderr, "peer-driver: input name longer than %zu characters: %s\n", sizeof inputfilename - 1, argv[1]);
    return 2;
  }
  char* end = NULL;
  errno = 0;
  const double perParticle = strtod(argv[2], &end);
  if (errno != 0 || end == argv[2] || *end != '\0' || !(perParticle > 0.0)) {
    fprintf(stderr, "peer-driver: collisions per particle must be a positive number, got '%s'\n", argv[2]);
    return 2;
  }
  strcpy(inputfilename, argv[1]);
  init();
  /* The thermostat event sits at particles + N + 2 when the constant switches it on: take it out. */
  if (usethermostat) removeevent(particles + N + 2);
  if (volumeMass || seed > 0) {
    if (volumeMass) {
      for (int i = 0; i < N; i++) particles[i].mass = 8.0 * pow(particles[i].radius, 3);
    }
    if (seed > 0) init_genrand((unsigned long)seed);
    randommovement();
    for (int i = 0; i < N; i++) particles[i].counter++;
    for (int i = 0; i < N; i++) {
      removeevent(particles + i);
      findcollisions(particles + i);
    }
  }
  const double target = ceil(perParticle * N);
  if (target > (double)UINT_MAX) {
    fprintf(stderr, "peer-driver: %.0f collisions overflow the peer's counter\n", target);
    return 2;
  }
  const unsigned int goal = (unsigned int)target;
  const double cpu0 = clockSeconds(CLOCK_PROCESS_CPUTIME_ID), wall0 = clockSeconds(CLOCK_MONOTONIC);
  while (colcounter < goal) step();
  const double cpu = clockSeconds(CLOCK_PROCESS_CPUTIME_ID) - cpu0, wall = clockSeconds(CLOCK_MONOTONIC) - wall0;
  printstuff();
  printf("peer-driver: particles %d collisions %u cpu_seconds %.6f wall_seconds %.6f thermostat_removed %d "
         "volume_mass %d seed %ld\n",
         N, colcounter, cpu, wall, usethermostat ? 1 : 0, volumeMass, seed);
  return 0;
}
C
  echo "building the peer driver: $CC $cflags -I$src peer_driver.c -lm"
  # shellcheck disable=SC2086  # the Makefile's flags are words
  "$CC" $cflags -I"$src" "$OUT/peer_driver.c" -o "$OUT/peer_driver" -lm
  driver=$OUT/peer_driver
  peer_build="$CC $cflags (CFLAGS of $src/Makefile) on $src/mdSingle.c via $OUT/peer_driver.c"
  PEER_SRC=$src PEER_CFLAGS=$cflags
elif [ -x "$peer" ]; then
  driver=$(cd "$(dirname "$peer")" && pwd)/$(basename "$peer")
  peer_build="prebuilt driver $driver"
else
  echo "error: $peer is neither the peer's Single/ folder nor an executable driver" >&2
  exit 2
fi

export N PHI CPP ROUNDS CASES SEED CORE OUT CC
export PEER_SRC="${PEER_SRC:-}" PEER_CFLAGS="${PEER_CFLAGS:-}"
"$py" - "$polydem" "$driver" "$peer_build" <<'PY'
import csv
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import time

polydem, driver, peer_build = sys.argv[1:4]
counts = [int(w) for w in os.environ["N"].split()]
fractions = [float(w) for w in os.environ["PHI"].split()]
cpp = float(os.environ["CPP"])
rounds = int(os.environ["ROUNDS"])
cases = os.environ["CASES"].split()
seed = os.environ["SEED"]
core = os.environ["CORE"]
out = os.environ["OUT"]
case_args = {
    "mono": [],
    "bi1.2": ["--dist", "bi", "--omega", "1.2", "--large-fraction", "0.5", "--fraction-kind", "number"],
}
for c in cases:
    if c.startswith("uv") and c not in case_args:
        try:
            omega = float(c[2:])
        except ValueError:
            omega = 0.0
        if not (1.0 < omega < 1e6):
            sys.exit(f"error: case '{c}': uvW needs a size ratio W > 1 (e.g. uv10)")
        case_args[c] = ["--dist", "uv", "--omega", c[2:]]
    if c not in case_args:
        sys.exit(f"error: unknown case '{c}' (known: mono, bi1.2, uvW with a size ratio W > 1)")
if rounds < 1 or not counts or min(counts) < 2 or not fractions or not all(0 < f < 0.74 for f in fractions) \
        or not (cpp > 0):
    sys.exit("error: need ROUNDS >= 1, N >= 2, 0 < PHI < 0.74, CPP > 0")
# Every case at every N and PHI; the label names the folder and the rows of the CSVs.
combos = [(f"{c}_n{n}_phi{f:g}", c, n, f) for c in cases for n in counts for f in fractions]
pin = ["taskset", "-c", core]


def run(cmd, log, cwd):
    """Run cmd (pinned) with stdout and stderr to log; the child's CPU and wall seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    with open(log, "w") as f:
        code = subprocess.call(pin + cmd, stdout=f, stderr=subprocess.STDOUT, cwd=cwd)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if code != 0:
        tail = "".join(open(log).readlines()[-5:])
        sys.exit(f"error: {' '.join(cmd)} exited with {code} (log {log}):\n{tail}")
    return cpu, wall


def read_text(path):
    """polydem text particle file: box lengths, rows of x y z r (the columns its writer declares)."""
    columns = None
    header = None
    rows = []
    for line in open(path):
        s = line.strip()
        if s.startswith("#"):
            words = s[1:].split()
            if words and words[0] == "columns:":
                columns = words[1:]
            continue
        s = s.split("#")[0].strip()
        if not s:
            continue
        if header is None:
            header = s.split()
            continue
        rows.append([float(w) for w in s.split()])
    count, box = int(header[0]), [float(w) for w in header[1:4]]
    columns = columns or ["x", "y", "z", "r"]
    idx = [columns.index(k) for k in ("x", "y", "z", "r")]
    if len(rows) != count:
        sys.exit(f"error: {path}: header says {count} particles, found {len(rows)} rows")
    return box, [[row[i] for i in idx] for row in rows]


def write_sph(path, box, particles):
    """The peer's format, lengths in units of the largest diameter; type letter by radius, largest 'a'."""
    scale = 2.0 * max(p[3] for p in particles)
    radii = sorted({p[3] for p in particles}, reverse=True)
    letter = {r: chr(ord("a") + min(k, 25)) for k, r in enumerate(radii)}
    with open(path, "w") as f:
        f.write(f"{len(particles)}\n{box[0] / scale:.17g} {box[1] / scale:.17g} {box[2] / scale:.17g}\n")
        for x, y, z, r in particles:
            f.write(f"{letter[r]} {x / scale:.17g} {y / scale:.17g} {z / scale:.17g} {r / scale:.17g}\n")
    scaled = [b / scale for b in box]
    # The peer's cell list needs at least 3 cells of 1.5 largest diameters per axis.
    if min(int(int(b - 0.0001) / 1.5) for b in scaled) < 3:
        sys.exit(f"error: box {scaled} (largest diameters) is too small for the peer's cell list: raise N")
    return scaled


def most_peer_neighbours(box, particles):
    """The largest number of neighbours of any sphere under the peer's rule |r_ij| < 1.5 (r_i + r_j), periodic
    minimum image: candidate pairs within 3 r_max from a periodic k-d tree (Debian's python3-scipy), else brute
    force in blocks of rows small enough to keep the scratch arrays near 100 MB."""
    import numpy as np
    p = np.asarray(particles, dtype=float)
    x, r = p[:, :3], p[:, 3]
    length = np.asarray(box, dtype=float)
    try:
        from scipy.spatial import cKDTree
    except ImportError:
        cKDTree = None
    if cKDTree is not None:
        pairs = cKDTree(np.mod(x, length), boxsize=length).query_pairs(3.0 * r.max(), output_type="ndarray")
        d = x[pairs[:, 0]] - x[pairs[:, 1]]
        d -= length * np.round(d / length)
        reach = 1.5 * (r[pairs[:, 0]] + r[pairs[:, 1]])
        near = pairs[(d * d).sum(axis=1) < reach * reach]
        counts = np.bincount(near.ravel(), minlength=len(p))
        return int(counts.max()) if len(p) else 0
    most = 0
    rows = max(1, int(4e6 // max(len(p), 1)))
    for a in range(0, len(p), rows):
        d = x[a:a + rows, None, :] - x[None, :, :]
        d -= length * np.round(d / length)
        reach = 1.5 * (r[a:a + rows, None] + r[None, :])
        near = (d * d).sum(axis=2) < reach * reach
        most = max(most, int(near.sum(axis=1).max()) - 1)  # itself
    return most


def peer_driver_for(case, most):
    """The published driver while the peer's MAXNEIGH (24) holds the start's neighbours with room; otherwise one
    built from a copy of the peer's folder whose only change is a larger MAXNEIGH (see the header)."""
    if most <= 20:
        if not os.environ["PEER_SRC"]:
            return driver, f"a prebuilt driver: its MAXNEIGH is whatever it was built with; the start needs {most}"
        return driver, "MAXNEIGH 24 (as published)"
    m = 8 * math.ceil((1.5 * most + 8) / 8)
    label = f"MAXNEIGH {m} (changed from 24: a sphere of the start has {most} neighbours under the peer's rule)"
    exe = os.path.join(out, f"peer_driver_maxneigh_{m}")
    if os.path.exists(exe):
        return exe, label
    src, cflags = os.environ["PEER_SRC"], os.environ["PEER_CFLAGS"]
    if not src:
        sys.exit(f"error: [{case}] a sphere of the start has {most} neighbours under the peer's rule, more than its "
                 "MAXNEIGH 24 holds: give the peer's Single/ folder (not a prebuilt driver) so that the script can "
                 "build a driver with a larger MAXNEIGH")
    copy = os.path.join(out, f"peer_maxneigh_{m}")
    os.makedirs(copy, exist_ok=True)
    for name in os.listdir(src):
        if name.endswith((".c", ".h")):
            text = open(os.path.join(src, name)).read()
            if name == "mdSingle.c":
                if text.count("#define MAXNEIGH 24\n") != 1:
                    sys.exit(f"error: {src}/mdSingle.c has no single '#define MAXNEIGH 24' line to change")
                text = text.replace("#define MAXNEIGH 24\n", f"#define MAXNEIGH {m}\n")
            open(os.path.join(copy, name), "w").write(text)
    # Compiled under a temporary name and renamed: a failed or interrupted build leaves no driver to reuse.
    cmd = [os.environ["CC"]] + cflags.split() + ["-I" + copy, os.path.join(out, "peer_driver.c"), "-o",
                                                 exe + ".part", "-lm"]
    print(f"[{case}] building a peer driver with MAXNEIGH {m}: {' '.join(cmd)}", flush=True)
    if subprocess.call(cmd) != 0:
        sys.exit(f"error: [{case}] building the peer with MAXNEIGH {m} failed: {' '.join(cmd)}")
    os.replace(exe + ".part", exe)
    return exe, label


def parse_peer(log, volume):
    pstar = None
    drv = None
    for line in open(log):
        if line.startswith("Measured pressure"):
            pstar = float(line.split("=")[-1])
        if line.startswith("peer-driver:"):
            w = line.split()
            drv = {w[k]: w[k + 1] for k in range(1, len(w) - 1, 2)}
    if pstar is None or drv is None:
        sys.exit(f"error: {log}: no 'Measured pressure' or 'peer-driver:' line (is {driver} the driver?)")
    count = int(drv["particles"])
    return {
        "collisions": int(drv["collisions"]),
        "clock": "cpu",
        "loop_seconds": float(drv["cpu_seconds"]),
        "loop_wall_seconds": float(drv["wall_seconds"]),
        "Z": pstar * volume / count,
        "Pstar": pstar,
    }


def parse_polydem(summary_file):
    fd = json.load(open(summary_file))["fixed_density"]
    wall = fd["wall_seconds"]
    collisions = fd.get("collisions", round(fd["collisions_per_second"] * wall))
    if "cpu_seconds" in fd:
        clock, seconds = "cpu", fd["cpu_seconds"]
    else:
        clock, seconds = "wall", wall
    return {"collisions": int(collisions), "clock": clock, "loop_seconds": seconds, "loop_wall_seconds": wall,
            "Z": fd["reduced_pressure"], "Pstar": None}


def busy_cores(seconds=2.0):
    """Cores' worth of CPU time used by every process on the machine over the next `seconds` (/proc/stat):
    what else is running now, unlike the load averages, which still carry runs that ended a minute ago."""
    def sample():
        w = open("/proc/stat").readline().split()[1:]
        ticks = [int(x) for x in w]
        return sum(ticks), ticks[3] + ticks[4]  # total, idle + iowait
    t0, i0 = sample()
    time.sleep(seconds)
    t1, i1 = sample()
    total = max(t1 - t0, 1)
    return (1.0 - (i1 - i0) / total) * (os.cpu_count() or 1)


machine = {
    "date": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
    "host": platform.node(),
    "cpu": next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?"),
    "cores": os.cpu_count(),
    "load_before": open("/proc/loadavg").read().split()[:3],
    "busy_before": busy_cores(),
}
rows = []
fields = ["case", "round", "position", "code", "n", "phi", "collisions", "clock", "loop_seconds",
          "loop_wall_seconds", "collisions_per_second", "reduced_pressure_Z", "peer_Pstar", "process_cpu_seconds",
          "process_wall_seconds"]
commands = {}
for case, kind, n, phi in combos:
    d = os.path.join(out, case)
    os.makedirs(d, exist_ok=True)
    start = os.path.join(d, "start.txt")
    make = [polydem, "jam", "-n", str(n), "--schedule", "1e-2", "--target-phi", repr(phi), "--seed", seed,
            "-o", start, "--progress", "1e9"] + case_args[kind]
    print(f"[{case}] start: {' '.join(make)}", flush=True)
    if os.path.exists(start):
        os.remove(start)
    run(make, os.path.join(d, "start.log"), d)
    box, particles = read_text(start)
    volume_fraction = sum(4.0 / 3.0 * math.pi * p[3] ** 3 for p in particles) / (box[0] * box[1] * box[2])
    sph = os.path.join(d, "start.sph")
    sbox = write_sph(sph, box, particles)
    peer_volume = sbox[0] * sbox[1] * sbox[2]
    mono = len({p[3] for p in particles}) == 1
    target = volume_fraction * (1.0 + 1e-9)
    pd_cmd = [polydem, "jam", "-i", start, "--schedule", "1e-2", "--target-phi", repr(target),
              "--run-collisions", repr(cpp), "--progress", "1e9"]
    most = most_peer_neighbours(box, particles)
    case_driver, maxneigh = peer_driver_for(case, most)
    peer_cmd = [case_driver, sph, repr(cpp)] + ([] if mono else ["volume-mass"])
    # Velocities: seed SEED + round in both codes (each round a new Maxwell-Boltzmann draw from the same
    # positions), so the spread of Z over the rounds shows its statistical error.
    commands[case] = {"start": make, "polydem": pd_cmd + ["--seed", "SEED+R", "--summary-json", "polydem_R.json"],
                      "peer": peer_cmd + ["seed=SEED+R"], "maxneigh": maxneigh}
    print(f"[{case}] {len(particles)} spheres, phi {volume_fraction:.6f}, {'mono' if mono else 'mixture'}; "
          f"{rounds} rounds of {cpp:g} collisions per particle", flush=True)
    for r in range(rounds):
        order = ["polydem", "peer"] if r % 2 == 0 else ["peer", "polydem"]
        for position, code in enumerate(order):
            log = os.path.join(d, f"{code}_{r}.log")
            if code == "polydem":
                summary = os.path.join(d, f"polydem_{r}.json")
                if os.path.exists(summary):
                    os.remove(summary)
                cpu, wall = run(pd_cmd + ["--seed", str(int(seed) + r), "--summary-json", summary], log, d)
                res = parse_polydem(summary)
            else:
                cpu, wall = run(peer_cmd + [f"seed={int(seed) + r}"], log, d)
                res = parse_peer(log, peer_volume)
            rate = res["collisions"] / res["loop_seconds"]
            row = {"case": case, "round": r, "position": position, "code": code, "n": len(particles),
                   "phi": f"{volume_fraction:.8f}", "collisions": res["collisions"], "clock": res["clock"],
                   "loop_seconds": f"{res['loop_seconds']:.6f}", "loop_wall_seconds": f"{res['loop_wall_seconds']:.6f}",
                   "collisions_per_second": f"{rate:.6g}", "reduced_pressure_Z": f"{res['Z']:.8g}",
                   "peer_Pstar": "" if res["Pstar"] is None else f"{res['Pstar']:.8g}",
                   "process_cpu_seconds": f"{cpu:.3f}", "process_wall_seconds": f"{wall:.3f}"}
            rows.append(row)
            print(f"[{case}] round {r} {code:7s}: {res['collisions']} collisions in {res['loop_seconds']:.3f} "
                  f"{res['clock']} s = {rate:.4g}/s, Z {res['Z']:.6g} (process {cpu:.2f} CPU s, {wall:.2f} s)",
                  flush=True)
            with open(os.path.join(out, "runs.csv"), "w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=fields)
                w.writeheader()
                w.writerows(rows)
machine["load_after"] = open("/proc/loadavg").read().split()[:3]

summary_fields = ["case", "n", "phi", "rounds", "polydem_median", "polydem_min", "polydem_max", "polydem_clock",
                  "peer_median", "peer_min", "peer_max", "ratio_polydem_over_peer", "Z_polydem", "Z_polydem_min",
                  "Z_polydem_max", "Z_peer", "Z_peer_min", "Z_peer_max",
                  "Z_relative_difference", "Z_within_0.5%"]
summaries = []
for case, kind, n, phi in combos:
    mine = [r for r in rows if r["case"] == case]
    rate = {c: [float(r["collisions_per_second"]) for r in mine if r["code"] == c] for c in ("polydem", "peer")}
    zs = {c: [float(r["reduced_pressure_Z"]) for r in mine if r["code"] == c] for c in ("polydem", "peer")}
    z = {c: statistics.median(zs[c]) for c in zs}
    clocks = sorted({r["clock"] for r in mine if r["code"] == "polydem"})
    rel = z["polydem"] / z["peer"] - 1.0
    summaries.append({
        "case": case, "n": mine[0]["n"], "phi": mine[0]["phi"], "rounds": rounds,
        "polydem_median": f"{statistics.median(rate['polydem']):.4g}", "polydem_min": f"{min(rate['polydem']):.4g}",
        "polydem_max": f"{max(rate['polydem']):.4g}", "polydem_clock": "/".join(clocks),
        "peer_median": f"{statistics.median(rate['peer']):.4g}", "peer_min": f"{min(rate['peer']):.4g}",
        "peer_max": f"{max(rate['peer']):.4g}",
        "ratio_polydem_over_peer": f"{statistics.median(rate['polydem']) / statistics.median(rate['peer']):.3f}",
        "Z_polydem": f"{z['polydem']:.6g}", "Z_peer": f"{z['peer']:.6g}",
        "Z_polydem_min": f"{min(zs['polydem']):.6g}", "Z_polydem_max": f"{max(zs['polydem']):.6g}",
        "Z_peer_min": f"{min(zs['peer']):.6g}", "Z_peer_max": f"{max(zs['peer']):.6g}",
        "Z_relative_difference": f"{rel:+.4%}", "Z_within_0.5%": "yes" if abs(rel) <= 0.005 else "NO"})
with open(os.path.join(out, "summary.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=summary_fields)
    w.writeheader()
    w.writerows(summaries)

lines = [f"edmd_vs_peer: {machine['date']}, {machine['host']}, {machine['cpu']}, {machine['cores']} cores, "
         f"load {' '.join(machine['load_before'])} before, {' '.join(machine['load_after'])} after (these include "
         f"this script's own runs); {machine['busy_before']:.2f} cores busy in the 2 s before the first run; "
         f"taskset -c {core}",
         f"peer: {peer_build}",
         f"polydem: {polydem}",
         "collisions per second of the event loop at fixed density (CPU seconds unless polydem_clock says wall); "
         "Z = PV/(NkT)", ""]
if machine["busy_before"] > 0.2:
    lines.insert(1, f"WARNING: {machine['busy_before']:.2f} cores were busy before the first run: the machine was not "
                    "quiet, so these rates are not figures")
for case, kind, n, phi in combos:
    counts_seen = {int(r["collisions"]) for r in rows if r["case"] == case}
    if len(counts_seen) != 1:
        lines.insert(1, f"WARNING: {case}: the runs did not all make the same number of collisions: {sorted(counts_seen)}")
header = ["case", "N", "phi", "polydem (min-max)", "peer (min-max)", "polydem/peer", "Z polydem", "Z peer",
          "dZ"]
lines.append(" | ".join(header))
for s in summaries:
    lines.append(" | ".join([
        s["case"], str(s["n"]), s["phi"],
        f"{s['polydem_median']} ({s['polydem_min']}-{s['polydem_max']}, {s['polydem_clock']})",
        f"{s['peer_median']} ({s['peer_min']}-{s['peer_max']})", s["ratio_polydem_over_peer"],
        f"{s['Z_polydem']} ({s['Z_polydem_min']}-{s['Z_polydem_max']})",
        f"{s['Z_peer']} ({s['Z_peer_min']}-{s['Z_peer_max']})", f"{s['Z_relative_difference']} ({'within' if s['Z_within_0.5%'] == 'yes' else 'NOT within'} 0.5%)"]))
lines.append("")
for case, c in commands.items():
    lines.append(f"[{case}] start:   {' '.join(c['start'])}")
    lines.append(f"[{case}] polydem: {' '.join(c['polydem'])}")
    lines.append(f"[{case}] peer:    {' '.join(c['peer'])}  ({c['maxneigh']})")
text = "\n".join(lines) + "\n"
open(os.path.join(out, "summary.txt"), "w").write(text)
print()
print(text, end="")
print(f"wrote {out}/runs.csv, {out}/summary.csv, {out}/summary.txt")
PY
