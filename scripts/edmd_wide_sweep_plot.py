#!/usr/bin/python3
"""Plot of scripts/edmd_wide_sweep.sh: fixed-density (phi 0.5) collision rates against size ratio.

Usage: /usr/bin/python3 scripts/edmd_wide_sweep_plot.py SWEEP.csv OUT.png

Top panel: collisions per second (median over the rounds of each case, bars = the rounds' range) against the
realised size ratio r_max / r_min, one line per family (US, UV, LN), monodisperse as a horizontal line. Bottom
panel: cost per collision relative to monodisperse (mono rate / case rate, medians) with the issue's 4x target
and 10x "collapse" lines. Prints the table of medians it plots (with exits, events and pair predictions per
collision and neighbours per sphere, medians too; they are deterministic up to the run's start).
"""
import csv
import statistics
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(argv):
    if len(argv) != 3:
        sys.exit("usage: edmd_wide_sweep_plot.py SWEEP.csv OUT.png")
    with open(argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{argv[1]}: no rows")
    cases = {}
    for r in rows:
        cases.setdefault(r["case"], []).append(r)
    table = []
    for name, rs in cases.items():
        rates = [float(r["coll_per_s"]) for r in rs]

        def med(key, rs=rs):
            return statistics.median(float(r[key]) for r in rs)

        table.append(
            dict(
                case=name,
                family=rs[0]["family"],
                param=rs[0]["param"],
                n=int(rs[0]["n"]),
                ratio=med("size_ratio"),
                rate=statistics.median(rates),
                lo=min(rates),
                hi=max(rates),
                runs=len(rates),
                exits=med("exits_per_coll"),
                events=med("events_per_coll"),
                pairs=med("pairs_per_coll"),
                nb=med("neighbours"),
            )
        )
    mono = [t for t in table if t["family"] == "mono"]
    if not mono:
        sys.exit(f"{argv[1]}: no monodisperse case (the reference)")
    mono_rate = mono[0]["rate"]

    print("case,family,param,n,size_ratio,runs,coll_per_s_median,min,max,x_mono_cost,exits,events,pairs,neighbours")
    for t in table:
        print(
            f"{t['case']},{t['family']},{t['param']},{t['n']},{t['ratio']:.1f},{t['runs']},{t['rate']:.4g},"
            f"{t['lo']:.4g},{t['hi']:.4g},{mono_rate / t['rate']:.2f},{t['exits']:.3f},{t['events']:.3f},"
            f"{t['pairs']:.1f},{t['nb']:.2f}"
        )

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 9), sharex=True)
    styles = {"US": ("o-", "uniform radius (US), omega"), "UV": ("s-", "uniform volume (UV), omega"),
              "LN": ("^-", "log-normal (LN), sigma")}
    for family, (style, label) in styles.items():
        ts = sorted((t for t in table if t["family"] == family), key=lambda t: t["ratio"])
        if not ts:
            continue
        # A parameter that also runs at a larger N (LN sigma 1.0 at N = 50,000: less squeezed by the box) is drawn
        # as an open marker beside the line, the line joins the smallest N of each parameter.
        smallest = {}
        for t in ts:
            smallest[t["param"]] = min(smallest.get(t["param"], t["n"]), t["n"])
        extra = [t for t in ts if t["n"] != smallest[t["param"]]]
        ts = [t for t in ts if t["n"] == smallest[t["param"]]]
        x = [t["ratio"] for t in ts]
        y = [t["rate"] for t in ts]
        err = [[t["rate"] - t["lo"] for t in ts], [t["hi"] - t["rate"] for t in ts]]
        line = top.errorbar(x, y, yerr=err, fmt=style, capsize=3, label=f"{label} {', '.join(t['param'] for t in ts)}")
        for t in ts:
            if t["n"] != mono[0]["n"]:
                top.annotate(f"N = {t['n']}", (t["ratio"], t["rate"]), textcoords="offset points", xytext=(-45, 6),
                             fontsize=8)
        bottom.plot(x, [mono_rate / t["rate"] for t in ts], style, color=line[0].get_color())
        for t in extra:
            colour = line[0].get_color()
            top.errorbar([t["ratio"]], [t["rate"]], yerr=[[t["rate"] - t["lo"]], [t["hi"] - t["rate"]]], fmt=style[0],
                         mfc="none", color=colour, capsize=3)
            top.annotate(f"N = {t['n']}", (t["ratio"], t["rate"]), textcoords="offset points", xytext=(-45, 6),
                         fontsize=8)
            bottom.plot([t["ratio"]], [mono_rate / t["rate"]], style[0], mfc="none", color=colour)
    top.axhline(mono_rate, color="black", lw=1, ls="--", label=f"monodisperse ({mono_rate:.3g}/s)")
    top.set_xscale("log")
    top.set_yscale("log")
    top.set_ylabel("collisions per second (median of rounds)")
    top.set_title(f"fixed density phi 0.5, N = {mono[0]['n']} unless marked, one core, class skins")
    top.legend(fontsize=8)
    top.grid(True, which="both", alpha=0.3)
    bottom.axhline(1, color="black", lw=1, ls="--")
    bottom.axhline(4, color="tab:green", lw=1, ls=":", label="4x (issue 24 target)")
    bottom.axhline(10, color="tab:red", lw=1, ls=":", label="10x (collapse)")
    bottom.set_yscale("log")
    bottom.set_xlabel("size ratio r_max / r_min (realised in the sample)")
    bottom.set_ylabel("cost per collision / monodisperse")
    bottom.legend(fontsize=8)
    bottom.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(argv[2], dpi=110)
    print(f"wrote {argv[2]}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv)
