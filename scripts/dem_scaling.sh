#!/usr/bin/env bash
# The DEM step against N and thread count (issue 18): per-phase cost per particle-step (broad phase =
# neighbour-list rebuilds and re-sorts, force, integration, checks), memory per particle, and this
# machine's STREAM-like copy bandwidth measured in the same run (before every round, at each thread
# count), so the lead can set each phase against the memory bandwidth. A measurement script, not CI:
# run it on a quiet machine. It writes CSV, a gnuplot PNG and a README.md with the machine and command.
#
#   scripts/dem_scaling.sh [SCENE ...]   SCENE: uv10 (default), uv50, bi10, mono
#
#   uv10 / uv50  uniform volume f(r) ~ r^-3, omega = 10 / 50, random sequential addition at packing 0.6
#   bi10         bidisperse omega = 10, equal volumes, RSA at 0.6
#   mono         monodisperse, RSA at 0.3 then soft compression to 0.6 (RSA cannot reach 0.6; slow at 1e7)
#
# Per scene and N: `polydem relax benchmarks/lammps/prepare.toml` (linear law, e = 0.9, impact velocities
# at 1% overlap) writes the start as HDF5 once; then REPEATS rounds, each one STREAM copy per thread count
# and one `polydem relax benchmarks/lammps/polydem_run.toml` per thread count from that start (interleaved
# so that drifts in machine load hit every thread count alike), figures from --summary-json.
#
# Environment: POLYDEM_BUILD (build dir, default build), COUNTS (default "50000 200000 1000000"; 1e7 fits in
# 24 GiB), THREADS ("1 2"), STEPS (300), REPEATS (3), OUT (report dir, default $POLYDEM_BUILD/dem_scaling),
# REUSE=1 (keep starts already prepared in OUT/starts), STREAM_MIB (512 per array).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${POLYDEM_BUILD:-$root/build}"
polydem="$build/apps/polydem"
stream="$build/benchmarks/polydem_stream_copy"
counts="${COUNTS:-50000 200000 1000000}"
threads_list="${THREADS:-1 2}"
steps="${STEPS:-300}"
repeats="${REPEATS:-3}"
out="${OUT:-$build/dem_scaling}"
reuse="${REUSE:-0}"
stream_mib="${STREAM_MIB:-512}"
python=/usr/bin/python3
lammps_dir="$root/benchmarks/lammps"
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(uv10)
for tool in "$polydem" "$stream"; do
  [ -x "$tool" ] || { echo "dem_scaling: $tool not found (build the polydem and polydem_stream_copy targets)" >&2; exit 2; }
done
mkdir -p "$out/starts" "$out/runs"
csv="$out/dem_scaling.csv"
echo "scene,N,threads,run,us_per_particle_step,broad_phase_us,force_us,integration_us,check_us,rebuilds,pairs_per_particle,bytes_per_particle,peak_rss_mib,copy_gb_per_s,load1,broad_phase" > "$csv"
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"  # see scripts/compare_lammps.sh
load() { cut -d' ' -f1 /proc/loadavg; }

scene_sets() {
  case "$1" in
    uv10|uv50) echo "--set particles.distribution=\"uniform-volume\" --set particles.omega=${1#uv} --set particles.packing_fraction=0.6" ;;
    bi10)      echo "--set particles.distribution=\"bi\" --set particles.omega=10 --set particles.packing_fraction=0.6" ;;
    mono)      echo "--set particles.distribution=\"mono\" --set particles.packing_fraction=0.3 --set compression.packing_fraction=0.6" ;;
    *) echo "dem_scaling: unknown scene '$1' (uv10 uv50 bi10 mono)" >&2; exit 2 ;;
  esac
}

for scene in "${scenes[@]}"; do
  read -r -a sets <<< "$(scene_sets "$scene")"
  for n in $counts; do
    start="$out/starts/${scene}_${n}.h5"
    if [ "$reuse" = 1 ] && [ -s "$start" ]; then
      echo "== $scene N = $n: reusing $start"
    else
      echo "== $scene N = $n: preparing $start"
      "$polydem" relax "$lammps_dir/prepare.toml" -q "${sets[@]}" --set particles.count="$n" \
        --set output.final="\"$start\"" > "$out/starts/${scene}_${n}.log"
    fi
    for ((r = 1; r <= repeats; ++r)); do
      for t in $threads_list; do
        "$stream" --mib "$stream_mib" --repeat 10 --threads "$t" --json "$out/runs/stream_${scene}_${n}_t${t}_${r}.json" > /dev/null
        json="$out/runs/${scene}_${n}_t${t}_${r}.json"
        l=$(load)
        "$polydem" relax "$lammps_dir/polydem_run.toml" -q --set particles.file="\"$start\"" --steps "$steps" \
          --threads "$t" --set output.final='""' --summary-json "$json" > "$out/runs/${scene}_${n}_t${t}_${r}.log"
        "$python" - "$json" "$out/runs/stream_${scene}_${n}_t${t}_${r}.json" "$scene" "$n" "$t" "$r" "$l" >> "$csv" <<'EOF'
import json, sys
summary, stream, scene, n, t, r, load = sys.argv[1:]
s = json.load(open(summary))
c = json.load(open(stream))
rep, start, model = s["report"], s["start"], s["model"]
count = start["particles"]
per = 1e6 / (rep["steps_run"] * count)  # seconds -> us per particle-step
tm = rep["time"]
print(f"{scene},{count},{t},{r},{tm['loop_seconds'] * per:.5f},{tm['broad_phase_seconds'] * per:.5f},"
      f"{tm['force_seconds'] * per:.5f},{tm['integration_seconds'] * per:.5f},{tm['check_seconds'] * per:.5f},"
      f"{rep['neighbours']['rebuilds']},{rep['neighbours']['candidate_pairs'] / count:.3f},"
      f"{rep['memory']['bytes_held'] / count:.1f},{rep['memory']['peak_rss_mib']:.1f},{c['median_gb_per_s']:.3f},"
      f"{load},\"{model['broad_phase'].split(';')[0]}\"")
EOF
        tail -n 1 "$csv" | cut -d, -f1-9,14 | sed 's/^/   /'
      done
    done
  done
done

# Medians per (scene, N, threads), the plot and the README.
"$python" - "$csv" "$out" "$steps" "$repeats" "$*" <<'EOF'
import csv, os, statistics, subprocess, sys, datetime, platform
path, out, steps, repeats, args = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
keys = sorted({(r["scene"], int(r["N"]), int(r["threads"])) for r in rows})
cols = ["us_per_particle_step", "broad_phase_us", "force_us", "integration_us", "check_us", "bytes_per_particle",
        "copy_gb_per_s"]
med = {}
for k in keys:
    sel = [r for r in rows if (r["scene"], int(r["N"]), int(r["threads"])) == k]
    med[k] = {c: statistics.median(float(r[c]) for r in sel) for c in cols}
    med[k]["pairs"] = statistics.median(float(r["pairs_per_particle"]) for r in sel)
with open(os.path.join(out, "dem_scaling_medians.csv"), "w") as f:
    f.write("scene,N,threads," + ",".join(cols) + ",pairs_per_particle\n")
    for k in keys:
        f.write(f"{k[0]},{k[1]},{k[2]}," + ",".join(f"{med[k][c]:.5g}" for c in cols) + f",{med[k]['pairs']:.4g}\n")
cpu = "unknown CPU"
try:
    cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
except (OSError, StopIteration):
    pass
md = [f"# DEM step against N and threads\n", f"- date: {datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC",
      f"- machine: {cpu}, {os.cpu_count()} logical CPUs, {platform.platform()}",
      f"- command: `scripts/dem_scaling.sh {args}` (STEPS={steps}, REPEATS={repeats})",
      "- per phase: us per particle-step (median of the rounds); copy: STREAM-like copy bandwidth (16 bytes per"
      " element) measured just before each run at the same thread count\n",
      "| scene | N | threads | us/particle/step | broad phase | force | integration | checks | bytes/particle | pairs/particle | copy GB/s | vs 1 thread |",
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
for k in keys:
    m = med[k]
    one = med.get((k[0], k[1], 1))
    speed = f"{one['us_per_particle_step'] / m['us_per_particle_step']:.2f}x" if one else "-"
    md.append(f"| {k[0]} | {k[1]} | {k[2]} | {m['us_per_particle_step']:.4f} | {m['broad_phase_us']:.4f} | "
              f"{m['force_us']:.4f} | {m['integration_us']:.4f} | {m['check_us']:.4f} | {m['bytes_per_particle']:.0f} | "
              f"{m['pairs']:.2f} | {m['copy_gb_per_s']:.2f} | {speed} |")
gp = os.path.join(out, "dem_scaling.gp")
with open(gp, "w") as f:
    f.write("set datafile separator ','\nset terminal png size 900,600\n"
            f"set output '{os.path.join(out, 'dem_scaling.png')}'\nset logscale x\nset xlabel 'N'\n"
            "set ylabel 'us per particle-step'\nset key top left\nset yrange [0:*]\nplot ")
    plots = []
    for scene in sorted({k[0] for k in keys}):
        for t in sorted({k[2] for k in keys}):
            for col, name in ((4, "total"), (5, "broad phase"), (6, "force")):
                plots.append(f"'{os.path.join(out, 'dem_scaling_medians.csv')}' using (strcol(1) eq '{scene}' && $3 == {t}"
                             f" ? $2 : 1/0):{col} with linespoints title '{scene} {t}T {name}'")
    f.write(", ".join(plots) + "\n")
ok = subprocess.run(["gnuplot", gp], capture_output=True).returncode == 0
md.append("\n![dem scaling](dem_scaling.png)\n" if ok else "\n(gnuplot failed: no plot)\n")
open(os.path.join(out, "README.md"), "w").write("\n".join(md) + "\n")
print("\n".join(md))
EOF
echo "report: $out/README.md"
