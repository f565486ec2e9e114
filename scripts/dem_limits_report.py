#!/usr/bin/python3
"""Where the DEM step's time goes against this machine's memory bandwidth (issue 18).

Runs `polydem relax examples/relax_uv10.toml` (frictionless, linear spring-dashpot, one thread) for each scene
and particle count, and `polydem_stream_copy` (a STREAM-like copy) in the same run, before and after the
relax runs, with arrays far above the last-level cache (DRAM) and with arrays that fit in it (L3). For each
phase of the step it divides the phase's *compulsory* traffic (every array the phase must read or write once
per step, counted as STREAM counts: bytes read plus bytes written, no write-allocate) by the phase's measured
time, and compares that with the copy bandwidth of the memory level the run's data live in. A phase at 100%
is bandwidth-bound; at 10% it is bound by something else (arithmetic, latency, branches) and the headroom
column says how much faster it would be if only its compulsory traffic limited it.

The traffic model (frictionless, no rotation, the restitution dashpot with the predicted velocity, the
joined kick of DemSimulation, double = 8 bytes, Index = 4 bytes; c = candidate pairs per particle in the
Verlet list, k = steps per rebuild):
  integration  opening pass (previous closing half kick + opening half kick + drift + displacement check):
               reads v, F, 1/m, x, x_ref (104 B), writes v, x, v_pred (72 B): 176 B/particle-step.
  force        reads x, r, 1/m, v_pred (64 B), the row offset and c neighbour indices (4 + 4 c B), writes F
               (24 B): 92 + 4 c B/particle-step.
  broad phase  per rebuild: the grid build reads x, r (32 B), writes and reads a packed copy (64 B), the
               cell index and slot arrays (16 B); the search writes 8 B per candidate, the Verlet fill reads the
               candidates twice and writes 4 B each (28 B per candidate) and the row offsets (8 B); the build
               copies x and r as the reference (64 B): 184 + 28 c B per rebuild, divided by k.
The model counts each array once per step; real kernels move more (neighbours' data read once per pair
when it left the cache, write-allocate), so the fractions are lower bounds of the bandwidth the phases use.

Starts: by default each run generates its spheres (RSA, `particles.count`), which at 10^7 takes longer than
the run (many minutes at packing 0.6). With --starts DIR each scene and count is generated once by
`polydem generate` into DIR/<scene>_<N>.h5 (kept: a later report reuses it) and every run reads it
(`particles.file`, the example's other settings, impact velocities); generation time is not run time.

Usage: /usr/bin/python3 scripts/dem_limits_report.py [--polydem build/apps/polydem]
       [--stream build/benchmarks/polydem_stream_copy] [--out docs/benchmarks/dem_limits] [--rounds 3]
       [--counts 50000,1000000] [--scenes mono,uv10] [--starts DIR]
Writes OUT/runs.csv (every run), OUT/summary.csv, OUT/scaling.png (cost per particle-step and per phase
against N, needs Debian's matplotlib) and OUT/README.md (tables, machine, command). Each count's cost is
also given relative to the smallest count of its scene (issue 18: 10^6 within 1.15x, 10^7 within 1.3x of
5 x 10^4).
"""
import argparse
import csv
import io
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile

SCENES = {
    # name: (settings, description, `polydem generate` options for the same spheres)
    "mono": (['particles.distribution="mono"', "particles.packing_fraction=0.3"],
             "equal spheres, RSA at packing 0.3", ["--dist", "mono", "--phi", "0.3"]),
    "uv10": ([], "uniform volume f(r) ~ r^-3, omega 10, RSA at packing 0.6 (the example scene)",
             ["--dist", "uv", "--omega", "10", "--phi", "0.6"]),
    "uv50": (["particles.omega=50"], "uniform volume, omega 50, RSA at packing 0.6",
             ["--dist", "uv", "--omega", "50", "--phi", "0.6"]),
}
# The example's keys that generate spheres; dropped from the scene file when the spheres come from --starts.
GENERATION_KEYS = {("[particles]", k) for k in ("count", "distribution", "rmin", "omega", "sampling",
                                                 "packing_fraction", "seed")} | {("[box]", "aspect")}


NOTES_MARKER = "<!-- notes: kept when the report is made again -->"


def cpu_model():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def write_atomic(path, text):
    """Write the whole file beside its final name, then rename it over: a reader never sees half a report."""
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        f.write(text)
    os.replace(tmp, path)


def csv_text(rows, fields, fmt=lambda v: v):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields)
    w.writeheader()
    for r in rows:
        w.writerow({k: fmt(v) for k, v in r.items()})
    return buf.getvalue()


def steps_for(count):
    """Steps per run: about 10^8 particle-steps, at least 100."""
    return max(100, min(3000, int(1e8 / count)))


def run_stream(stream, mib, repeat):
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        subprocess.run([stream, "--mib", str(mib), "--repeat", str(repeat), "--json", f.name], check=True,
                       stdout=subprocess.DEVNULL)
        return json.load(open(f.name))["median_gb_per_s"]


def writable_dir(path):
    """Create `path` if needed; exit with a message when that fails or it cannot be written."""
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as e:
        sys.exit(f"dem_limits_report: cannot create {path}: {e.strerror}")
    if not os.access(path, os.W_OK):
        sys.exit(f"dem_limits_report: cannot write to {path}")


def start_file(polydem, starts, scene, count):
    """DIR/<scene>_<N>.h5, generated (atomically: temporary name, then rename) when missing."""
    path = os.path.join(starts, f"{scene}_{count}.h5")
    if not os.path.exists(path):
        tmp = os.path.join(starts, f".{scene}_{count}.tmp.h5")
        print(f"generating {path}", flush=True)
        gen = subprocess.run([polydem, "generate", "-n", str(count), "--rmin", "0.5e-3", "--seed", "1", "-o", tmp]
                             + SCENES[scene][2], stdout=subprocess.DEVNULL)
        if gen.returncode != 0:
            sys.exit(f"dem_limits_report: polydem generate failed for {path} (exit {gen.returncode}; its message "
                     "is above)")
        os.replace(tmp, path)
        if os.path.exists(tmp[:-3] + ".xmf"):
            os.remove(tmp[:-3] + ".xmf")  # the sidecar names the temporary file
    return path


def scene_reading(root, tmp, start):
    """The example scene with its generation keys replaced by `file = start`."""
    out, section = [], ""
    for line in open(os.path.join(root, "examples/relax_uv10.toml")):
        stripped = line.strip()
        if stripped.startswith("["):
            section = stripped
            out.append(line)
            if section == "[particles]":
                out.append(f'file = "{start}"\n')
            continue
        key = stripped.split("=", 1)[0].strip()
        if (section, key) in GENERATION_KEYS:
            continue
        out.append(line)
    path = os.path.join(tmp, "scene.toml")
    with open(path, "w") as f:
        f.writelines(out)
    return path


def run_relax(polydem, root, scene, count, steps, cpu, start=None):
    with tempfile.TemporaryDirectory() as tmp:
        if start:
            scene_file = scene_reading(root, tmp, start)
            sets = ['velocities.initial="impact"']
        else:
            scene_file = os.path.join(root, "examples/relax_uv10.toml")
            sets = SCENES[scene][0] + [f"particles.count={count}"]
        summary = os.path.join(tmp, "s.json")
        cmd = ["taskset", "-c", str(cpu), polydem, "relax", scene_file, "-q",
               "--threads", "1", "--steps", str(steps), "--summary-json", summary,
               "--set", f'output.final="{os.path.join(tmp, "final.txt")}"',
               "--set", f'output.timeseries="{os.path.join(tmp, "series.csv")}"']
        for s in sets:
            cmd += ["--set", s]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, cwd=tmp)
        return json.load(open(summary))["report"]


def plot(summary, scenes, path):
    """Cost per particle-step against N: the loop relative to the smallest N (left), each phase (right)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for scene in scenes:
        rows = sorted((s for s in summary if s["scene"] == scene and s["phase"] == "force"),
                      key=lambda s: s["particles"])
        ns = [s["particles"] for s in rows]
        left.plot(ns, [s["loop_relative"] for s in rows], "o-", label=scene)
        line = right.plot(ns, [s["loop_us"] for s in rows], "o-", label=f"{scene} step")[0]
        for phase, style in (("force", "s--"), ("integration", "^:"), ("broad_phase", "v-.")):
            ph = sorted((s for s in summary if s["scene"] == scene and s["phase"] == phase),
                        key=lambda s: s["particles"])
            right.plot(ns, [s["us_per_particle_step"] for s in ph], style, color=line.get_color(), alpha=0.7,
                       label=f"{scene} {phase.replace('_', ' ')}")
    for y, text in ((1.15, "1.15x (10^6 target)"), (1.3, "1.3x (10^7 target)")):
        left.axhline(y, color="grey", lw=0.8, ls="--")
        left.text(min(s["particles"] for s in summary), y, text, fontsize=8, va="bottom", color="grey")
    left.set_xscale("log")
    left.set_xlabel("particles N")
    left.set_ylabel("step cost per particle / cost at the smallest N")
    left.legend()
    right.set_xscale("log")
    right.set_yscale("log")
    right.set_xlabel("particles N")
    right.set_ylabel("us per particle-step (one thread)")
    right.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)


def traffic(c, k):
    """Compulsory bytes per particle-step per phase (see the module docstring)."""
    return {"integration": 176.0, "force": 92.0 + 4.0 * c, "broad_phase": (184.0 + 28.0 * c) / k}


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--polydem", default=os.path.join(root, "build/apps/polydem"))
    ap.add_argument("--stream", default=os.path.join(root, "build/benchmarks/polydem_stream_copy"))
    ap.add_argument("--out", default=os.path.join(root, "docs/benchmarks/dem_limits"))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--counts", default="50000,1000000")
    ap.add_argument("--scenes", default="mono,uv10")
    ap.add_argument("--cpu", type=int, default=1)
    ap.add_argument("--starts", default="", help="directory of generated starts (made and reused)")
    a = ap.parse_args()
    for exe in (a.polydem, a.stream):
        if not os.access(exe, os.X_OK):
            sys.exit(f"dem_limits_report: {exe} is not an executable (build it first: scripts/build.sh)")
    try:
        counts = [int(x) for x in a.counts.split(",")]
    except ValueError:
        sys.exit(f"dem_limits_report: --counts must be comma-separated integers, got '{a.counts}'")
    scenes = a.scenes.split(",")
    for s in scenes:
        if s not in SCENES:
            sys.exit(f"dem_limits_report: unknown scene '{s}' (known: {', '.join(SCENES)})")
    if a.rounds < 1 or any(n < 1000 for n in counts):
        sys.exit("dem_limits_report: --rounds must be >= 1 and every count >= 1000")
    writable_dir(a.out)  # checked before the runs, not after them

    starts = {}
    if a.starts:
        writable_dir(a.starts)
        for scene in scenes:
            for n in counts:
                starts[(scene, n)] = os.path.abspath(start_file(a.polydem, a.starts, scene, n))

    rows = []
    stream = {"dram": [], "l3": []}
    for r in range(1, a.rounds + 1):
        stream["dram"].append(run_stream(a.stream, 512, 10))
        stream["l3"].append(run_stream(a.stream, 4, 50))
        for scene in scenes:
            for n in counts:
                steps = steps_for(n)
                rep = run_relax(a.polydem, root, scene, n, steps, a.cpu, starts.get((scene, n)))
                t = rep["time"]
                ps = float(n) * rep["steps_run"]
                rows.append({
                    "round": r, "scene": scene, "particles": n, "steps": rep["steps_run"],
                    "loop_us": 1e6 * t["loop_seconds"] / ps,
                    "broad_phase_us": 1e6 * t["broad_phase_seconds"] / ps,
                    "force_us": 1e6 * t["force_seconds"] / ps,
                    "integration_us": 1e6 * t["integration_seconds"] / ps,
                    "candidates_per_particle": rep["neighbours"]["candidate_pairs"] / n,
                    "contacts_per_particle": rep["contacts"] / n,
                    "steps_per_rebuild": rep["steps_run"] / max(1, rep["neighbours"]["rebuilds"]),
                    "bytes_held": rep["memory"]["bytes_held"],
                })
                print(f"round {r} {scene} N={n}: {rows[-1]['loop_us']:.4f} us/particle-step", flush=True)
        stream["dram"].append(run_stream(a.stream, 512, 10))
        stream["l3"].append(run_stream(a.stream, 4, 50))

    write_atomic(os.path.join(a.out, "runs.csv"), csv_text(rows, list(rows[0].keys())))
    dram = statistics.median(stream["dram"])
    l3 = statistics.median(stream["l3"])
    l3_bytes = 16 * 2**20  # a run whose data exceed half the 32 MiB L3 streams from DRAM

    summary = []
    for scene in scenes:
        base_loop = None
        for n in sorted(counts):
            rs = [x for x in rows if x["scene"] == scene and x["particles"] == n]
            med = {k: statistics.median(x[k] for x in rs) for k in rs[0] if k not in ("round", "scene")}
            if base_loop is None:
                base_loop = med["loop_us"]
            level, bw = ("L3", l3) if med["bytes_held"] < l3_bytes else ("DRAM", dram)
            bytes_ = traffic(med["candidates_per_particle"], med["steps_per_rebuild"])
            for phase in ("broad_phase", "force", "integration"):
                us = med[f"{phase}_us"]
                gbs = bytes_[phase] / (us * 1e3) if us > 0 else float("nan")
                summary.append({
                    "scene": scene, "particles": n, "phase": phase, "us_per_particle_step": us,
                    "compulsory_bytes": bytes_[phase], "gb_per_s": gbs, "level": level, "stream_gb_per_s": bw,
                    "fraction_of_stream": gbs / bw, "headroom": bw / gbs,
                    "candidates_per_contact": med["candidates_per_particle"] / max(1e-12, med["contacts_per_particle"]),
                    "loop_us": med["loop_us"], "loop_relative": med["loop_us"] / base_loop,
                    "bytes_held_per_particle": med["bytes_held"] / n,
                })
    plot(summary, scenes, os.path.join(a.out, "scaling.png"))
    write_atomic(os.path.join(a.out, "summary.csv"),
                 csv_text(summary, list(summary[0].keys()), lambda v: f"{v:.5g}" if isinstance(v, float) else v))

    cmd = "/usr/bin/python3 scripts/dem_limits_report.py " + " ".join(sys.argv[1:])
    readme = os.path.join(a.out, "README.md")
    notes = ""  # hand-written reading of an earlier report, kept below the marker
    if os.path.exists(readme):
        old = open(readme).read()
        if NOTES_MARKER in old:
            notes = old[old.index(NOTES_MARKER):]
    f = io.StringIO()
    f.write("# The DEM step against this machine's memory bandwidth\n\n")
    f.write(f"Command: `{cmd}` ({a.rounds} rounds; every run in [runs.csv](runs.csv), the table in "
            "[summary.csv](summary.csv)). Machine: " + cpu_model() +
            f", {os.cpu_count()} CPUs; one thread pinned to CPU {a.cpu}.\n\n")
    f.write(f"STREAM-like copy (`polydem_stream_copy`, medians of {2 * a.rounds} calls around the runs): "
            f"DRAM (2 x 512 MiB) **{dram:.1f} GB/s**, L3-resident (2 x 4 MiB) **{l3:.1f} GB/s**. A run whose "
            "data (`bytes held`) fit in half the 32 MiB L3 is compared with the L3 figure, a larger one with "
            "DRAM.\n\n")
    f.write("The traffic model is in the script's header: the bytes each phase must move per particle "
            "and step if it touched every array once. `achieved` = those bytes / the phase's time; "
            "`headroom` = how much faster the phase would be if that traffic at the copy bandwidth were its only "
            "limit.\n\n")
    f.write("| scene | N | phase | us/particle-step | compulsory B | achieved GB/s | level | % of copy | headroom |\n")
    f.write("| --- | ---: | --- | ---: | ---: | ---: | --- | ---: | ---: |\n")
    for s in summary:
        f.write(f"| {s['scene']} | {s['particles']} | {s['phase']} | {s['us_per_particle_step']:.4f} | "
                f"{s['compulsory_bytes']:.0f} | {s['gb_per_s']:.1f} | {s['level']} | "
                f"{100 * s['fraction_of_stream']:.0f}% | {s['headroom']:.1f}x |\n")
    f.write("\n| scene | N | loop us/particle-step | relative to the smallest N | Verlet candidates per contact "
            "| bytes held per particle |\n")
    f.write("| --- | ---: | ---: | ---: | ---: | ---: |\n")
    for s in summary:
        if s["phase"] != "force":
            continue
        f.write(f"| {s['scene']} | {s['particles']} | {s['loop_us']:.4f} | {s['loop_relative']:.2f}x | "
                f"{s['candidates_per_contact']:.2f} | {s['bytes_held_per_particle']:.0f} |\n")
    f.write("\n![cost per particle-step against N](scaling.png)\n")
    f.write("\nScenes: " + "; ".join(f"{s}: {SCENES[s][1]}" for s in scenes) + ".")
    f.write(" Starts generated once by `polydem generate` (rmin 0.5 mm, seed 1) and read by every run.\n"
            if a.starts else " Each run generates its spheres.\n")
    if notes:
        f.write("\n" + notes)
    write_atomic(readme, f.getvalue())
    print(f"wrote {a.out}/README.md, summary.csv, runs.csv")


if __name__ == "__main__":
    main()
