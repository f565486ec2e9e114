#!/usr/bin/python3
"""The cost of calling a broad phase from Python against the same call from C++ (issue 22: within 5%).

Both sides run build() + findPairs() of the same backend on the same particle file: C++ through
`polydem pairs FILE --repeat R` (median build + median find over R runs after a warm-up), Python through
polydem.BroadPhase.build() + find_pairs(sort=False) (the same medians, the pairs copied into numpy arrays as
a Python user gets them). The two are interleaved ROUNDS times, so drift of a shared machine hits both; the
report gives the median of each side over the rounds and their ratio. Time on a quiet machine only.

  PYTHONPATH=build/python /usr/bin/python3 scripts/python_overhead.py --cli build/apps/polydem \
      [--count 1000000] [--backend hgrid-td] [--dist uv --omega 10] [--repeat 5] [--rounds 5]
"""
import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

import polydem


def python_side(backend, data, skin, repeat):
    bp = polydem.BroadPhase(backend)
    build, find = [], []
    pairs = 0
    for k in range(repeat + 1):
        t0 = time.perf_counter()
        bp.build(data["positions"], data["radii"], data["box"], skin=skin)
        t1 = time.perf_counter()
        i, _ = bp.find_pairs(sort=False)
        t2 = time.perf_counter()
        if k > 0:  # the first run warms caches and sizes buffers, as in polydem pairs
            build.append(t1 - t0)
            find.append(t2 - t1)
        pairs = len(i)
    assert bp.zero_copy, "the positions should be read without a copy"
    return statistics.median(build) + statistics.median(find), pairs


def cli_side(cli, path, backend, skin, repeat, count):
    out = subprocess.run([cli, "pairs", path, "--broadphase", backend, "--skin", str(skin), "--repeat", str(repeat)],
                         check=True, capture_output=True, text=True).stdout
    per_particle = float(re.search(r"^time per particle: ([0-9.]+) us", out, re.MULTILINE).group(1))
    pairs = int(re.search(r"^candidate pairs: (\d+)$", out, re.MULTILINE).group(1))
    return per_particle * 1e-6 * count, pairs


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cli", default="build/apps/polydem", help="the polydem binary")
    parser.add_argument("--count", type=int, default=1_000_000)
    parser.add_argument("--backend", default="hgrid-td")
    parser.add_argument("--dist", default="uv")
    parser.add_argument("--omega", type=float, default=10.0)
    parser.add_argument("--phi", type=float, default=0.3)
    parser.add_argument("--skin", type=float, default=0.1)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as work:
        path = os.path.join(work, "spheres.txt")
        subprocess.run([args.cli, "generate", "--dist", args.dist, "--omega", str(args.omega), "-n", str(args.count),
                        "--phi", str(args.phi), "--seed", "1", "-o", path], check=True, capture_output=True)
        data = polydem.read_particles(path)
        py_times, cli_times = [], []
        for r in range(args.rounds):
            # Alternate which side goes first, so neither always runs on a warmer machine.
            order = ["python", "cli"] if r % 2 == 0 else ["cli", "python"]
            for side in order:
                if side == "python":
                    seconds, py_pairs = python_side(args.backend, data, args.skin, args.repeat)
                    py_times.append(seconds)
                else:
                    seconds, cli_pairs = cli_side(args.cli, path, args.backend, args.skin, args.repeat, args.count)
                    cli_times.append(seconds)
            if py_pairs != cli_pairs:
                print(f"FAIL: Python finds {py_pairs} pairs, the CLI {cli_pairs}")
                return 1
    py_median, cli_median = statistics.median(py_times), statistics.median(cli_times)
    n = args.count
    print(f"{args.backend} on {n} spheres ({args.dist} omega {args.omega:g}, phi {args.phi}, skin {args.skin}), "
          f"{py_pairs} pairs; medians of {args.rounds} interleaved rounds of {args.repeat} runs")
    print(f"  C++    build + find {1e3 * cli_median:10.3f} ms  ({1e6 * cli_median / n:.4f} us/particle)")
    print(f"  Python build + find {1e3 * py_median:10.3f} ms  ({1e6 * py_median / n:.4f} us/particle)")
    print(f"  Python / C++ = {py_median / cli_median:.4f} (issue 22 asks <= 1.05)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
