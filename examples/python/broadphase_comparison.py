#!/usr/bin/python3
"""Broad-phase comparison across size ratios with the polydem Python module.

For each size ratio omega of a size distribution (uniform-volume by default), spheres are placed by random
sequential addition and every backend of the registry (and `auto`) builds and finds all pairs; the cost
per particle (build + find, median of --repeat runs, microseconds) is plotted against omega, one line per
backend, with matplotlib (Agg) to a PNG, and written to a CSV beside it. Every backend must report the same
pairs (exit 1 otherwise). Brute force is skipped above 20000 spheres (O(N^2)).

  PYTHONPATH=build/python /usr/bin/python3 examples/python/broadphase_comparison.py [--small] [--out DIR]
"""
import argparse
import csv
import os
import statistics
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import polydem  # noqa: E402


def cost_per_particle(backend, x, r, box, skin, repeat):
    """Median build + find_pairs seconds per particle, after one untimed warm-up; and the pairs."""
    bp = polydem.BroadPhase(backend)
    times = []
    for k in range(repeat + 1):
        t0 = time.perf_counter()
        bp.build(x, r, box, skin=skin)
        pairs = bp.find_pairs(sort=False)
        if k > 0:
            times.append(time.perf_counter() - t0)
    return statistics.median(times) / len(r), pairs, bp


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--small", action="store_true", help="2000 spheres, four size ratios (CI)")
    parser.add_argument("--dist", default="uniform-volume", help="distribution kind (as polydem --dist)")
    parser.add_argument("--count", type=int, default=100000)
    parser.add_argument("--phi", type=float, default=0.3)
    parser.add_argument("--skin", type=float, default=0.1, help="pair distance (gap), rmin = 1")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", default="broadphase_comparison", help="output directory")
    args = parser.parse_args()
    omegas = [1, 2, 5, 10] if args.small else [1, 1.5, 2, 3, 5, 7, 10, 15, 20, 30, 50]
    count = 2000 if args.small else args.count
    repeat = 1 if args.small else args.repeat
    backends = polydem.backend_names() + ["auto"]
    os.makedirs(args.out, exist_ok=True)

    rows = []
    for omega in omegas:
        dist = polydem.Distribution(args.dist, rmin=1.0, omega=omega)
        start = polydem.start_packing(dist, count, args.phi, seed=1)
        x, r, box = start["positions"], start["radii"], start["box"]
        model = polydem.cost_model(radii=r, box_volume=box.volume, skin=args.skin)
        reference = None
        for backend in backends:
            if backend == "brute" and count > 20000:
                continue
            seconds, (i, j), bp = cost_per_particle(backend, x, r, box, args.skin, repeat)
            pairs = np.sort(i.astype(np.int64) * count + j)
            if reference is None:
                reference = pairs
            elif not np.array_equal(pairs, reference):
                print(f"FAIL: {backend} at omega {omega} finds {len(pairs)} pairs, expected {len(reference)}")
                sys.exit(1)
            rows.append({"omega": omega, "backend": backend, "us_per_particle": 1e6 * seconds, "pairs": len(pairs),
                         "memory_bytes_per_particle": bp.memory_bytes / count,
                         "chosen": bp.chosen if backend == "auto" else "",
                         "model_T_per_N": model["chosen"]["predicted"]})
            print(f"omega {omega:<5g} {backend:<12} {1e6 * seconds:9.4f} us/particle  {len(pairs)} pairs"
                  + (f"  (auto chose {bp.chosen})" if backend == "auto" else ""))

    with open(os.path.join(args.out, "broadphase_comparison.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    fig, ax = plt.subplots(figsize=(7, 5))
    for backend in backends:
        points = [(row["omega"], row["us_per_particle"]) for row in rows if row["backend"] == backend]
        if points:
            ax.loglog(*zip(*points), "o-" if backend != "auto" else "k--", label=backend)
    ax.set_xlabel("size ratio omega = rmax / rmin")
    ax.set_ylabel("build + find pairs per particle (us)")
    ax.set_title(f"{args.dist}, N = {count}, phi = {args.phi}, skin = {args.skin} rmin")
    ax.legend(fontsize=8)
    fig.tight_layout()
    png = os.path.join(args.out, "broadphase_comparison.png")
    fig.savefig(png, dpi=120)
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
