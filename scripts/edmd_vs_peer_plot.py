#!/usr/bin/python3
"""Plot scripts/edmd_vs_peer.sh results: collisions per CPU second of polydem and the peer against N (equal
spheres) and against size ratio (at one N), medians with the min-max range of the rounds as bars.

usage: /usr/bin/python3 scripts/edmd_vs_peer_plot.py OUT.png [--ratio-n N] [--phi PHI] [--size-cost FILE]
       summary.csv [summary.csv ...]

Each summary.csv is one written by scripts/edmd_vs_peer.sh. Case names give the size ratio: mono 1, bi1.2 1.2,
uvW W. The left panel takes the mono rows at PHI (default 0.5) for every N; the right panel the rows at N =
--ratio-n (default 10000) and PHI for every case. --size-cost adds to the right panel polydem's rates from a
summary.csv of scripts/edmd_size_cost.sh (its rows at N = --ratio-n; a separate run, including size ratios the
peer cannot run), as a separate series. Also prints the plotted points as a table.
"""
import argparse
import csv
import os
import sys


def size_ratio(case):
    kind = case.split("_n")[0]
    if kind == "mono":
        return 1.0
    if kind.startswith("bi"):
        return float(kind[2:])
    if kind.startswith("uv"):
        return float(kind[2:])
    raise ValueError(f"case {case}: unknown kind {kind}")


def read_rows(path, keys, writer):
    """The rows of a summary.csv that `writer` wrote, each with its file as "source"; exits on a missing file,
    a missing column or a value that is not a number where one is needed."""
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"error: {path}: {e.strerror}")
    for line, r in enumerate(rows, start=2):
        for key in keys:
            if r.get(key) is None:
                sys.exit(f"error: {path}: no column '{key}' (not a summary.csv of {writer})")
        try:
            int(r["n"])
            size_ratio(r["case"])
            for key in keys:
                if key not in ("n", "case"):
                    float(r[key])
        except ValueError as e:
            sys.exit(f"error: {path}, line {line}: {e}")
        r["source"] = path
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("png")
    ap.add_argument("summaries", nargs="+")
    ap.add_argument("--ratio-n", type=int, default=10000)
    ap.add_argument("--phi", type=float, default=0.5)
    ap.add_argument("--size-cost", help="summary.csv of scripts/edmd_size_cost.sh")
    args = ap.parse_args()
    own = []
    if args.size_cost:
        own = read_rows(args.size_cost, ("n", "case", "median", "min", "max"), "scripts/edmd_size_cost.sh")
        own = sorted((r for r in own if int(r["n"]) == args.ratio_n), key=lambda r: size_ratio(r["case"]))
    rows = []
    for path in args.summaries:
        rows += read_rows(path, ("case", "n", "phi", "polydem_median", "peer_median"), "scripts/edmd_vs_peer.sh")
    near = [r for r in rows if abs(float(r["phi"]) - args.phi) < 1e-6]
    by_n = sorted((r for r in near if r["case"].startswith("mono_")), key=lambda r: int(r["n"]))
    by_ratio = sorted((r for r in near if int(r["n"]) == args.ratio_n), key=lambda r: size_ratio(r["case"]))
    if not by_n and not by_ratio:
        sys.exit(f"error: no rows at phi {args.phi} in {', '.join(args.summaries)}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))

    def panel(ax, data, x, xlabel, title):
        for code, style in (("polydem", "o-"), ("peer", "s--")):
            med = [float(r[f"{code}_median"]) for r in data]
            lo = [m - float(r[f"{code}_min"]) for m, r in zip(med, data)]
            hi = [float(r[f"{code}_max"]) - m for m, r in zip(med, data)]
            label = "polydem" if code == "polydem" else "Smallenburg EDMD `Single` (peer)"
            ax.errorbar(x, med, yerr=[lo, hi], fmt=style, capsize=3, label=label)
        for xv, r in zip(x, data):
            ax.annotate(f"{float(r['ratio_polydem_over_peer']):.3g}x", (xv, float(r["polydem_median"])),
                        textcoords="offset points", xytext=(0, 7), ha="center", fontsize=8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("collisions per CPU second")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)

    if by_n:
        panel(axes[0], by_n, [int(r["n"]) for r in by_n], "N (equal spheres)",
              f"equal spheres, phi {args.phi:g}: labels polydem/peer")
    if by_ratio:
        panel(axes[1], by_ratio, [size_ratio(r["case"]) for r in by_ratio],
              "size ratio (1: equal; 1.2: binary 50:50; >= 2: uniform volume)",
              f"N = {args.ratio_n}, phi {args.phi:g}: labels polydem/peer")
    if own:
        med = [float(r["median"]) for r in own]
        axes[1].errorbar([size_ratio(r["case"]) for r in own], med,
                         yerr=[[m - float(r["min"]) for m, r in zip(med, own)],
                               [float(r["max"]) - m for m, r in zip(med, own)]],
                         fmt="^:", capsize=3, color="tab:green", label="polydem, separate run (edmd_size_cost.sh)")
        axes[1].set_ylim(bottom=min(axes[1].get_ylim()[0], 1e2))
        axes[1].legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    # Written beside the target and renamed over it, so an interrupted run leaves no half-written image.
    part = args.png + ".part.png"
    fig.savefig(part, dpi=110)
    os.replace(part, args.png)
    print("panel | case | N | polydem | peer | polydem/peer | Z polydem | Z peer | dZ | source")
    for name, data in (("N", by_n), ("ratio", by_ratio)):
        for r in data:
            print(" | ".join([name, r["case"], r["n"], r["polydem_median"], r["peer_median"],
                              r["ratio_polydem_over_peer"], r.get("Z_polydem", ""), r.get("Z_peer", ""),
                              r.get("Z_relative_difference", ""), r["source"]]))
    for r in own:
        print(" | ".join(["ratio (polydem only)", r["case"], r["n"], r["median"], "", "", "", "", "", args.size_cost]))
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
