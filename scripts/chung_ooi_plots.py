#!/usr/bin/python3
"""Chung & Ooi (2011) oblique-impact curves: run the engine's impacts, write CSV, plot PNG.

    /usr/bin/python3 scripts/chung_ooi_plots.py [--curves build/tests/chung_ooi_curves]
                                                [--csv-dir build/chung_ooi] [--png-dir docs/images]

Runs `chung_ooi_curves psi` (test 5: normalised recovery angle Psi2 against the normalised incident
angle Psi1, with the Maw et al. no-slip and sliding limits) and `chung_ooi_curves angle` (test 4:
tangential restitution, spin and contact-patch rebound angle against the incident angle, with the
rigid-body theory), each for the Hertz-Mindlin and the Cundall-Strack tangential laws, and writes
chung_ooi_psi.csv, chung_ooi_angle.csv and four PNGs (docs/images/chung_ooi_*.png).
Needs Debian's matplotlib (/usr/bin/python3).
"""
import argparse
import csv
import io
import os
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LAWS = ("hertz-mindlin", "cundall-strack")
STYLE = {"hertz-mindlin": dict(marker="o", ms=3, lw=0, color="C0"),
         "cundall-strack": dict(marker="s", ms=3, lw=0, color="C1", mfc="none")}


def run(curves, mode, csv_dir):
    out = subprocess.run([curves, mode], check=True, capture_output=True, text=True).stdout
    path = os.path.join(csv_dir, f"chung_ooi_{mode}.csv")
    with open(path + ".tmp", "w") as f:
        f.write(out)
    os.replace(path + ".tmp", path)
    print(f"wrote {path}")
    return list(csv.DictReader(io.StringIO(out)))


def column(rows, law, key):
    return [float(r[key]) for r in rows if r["law"] == law]


def save(fig, png_dir, name):
    path = os.path.join(png_dir, name)
    fig.tight_layout()
    fig.savefig(path + ".tmp.png", dpi=120)
    os.replace(path + ".tmp.png", path)
    plt.close(fig)
    print(f"wrote {path}")


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--curves", default=os.path.join(root, "build", "tests", "chung_ooi_curves"))
    p.add_argument("--csv-dir", default=os.path.join(root, "build", "chung_ooi"))
    p.add_argument("--png-dir", default=os.path.join(root, "docs", "images"))
    a = p.parse_args()
    if not os.access(a.curves, os.X_OK):
        sys.exit(f"chung_ooi_plots: --curves {a.curves} is not an executable (build the chung_ooi_curves target)")
    os.makedirs(a.csv_dir, exist_ok=True)
    os.makedirs(a.png_dir, exist_ok=True)

    psi = run(a.curves, "psi", a.csv_dir)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    x = column(psi, LAWS[0], "psi1")
    ax.plot(x, column(psi, LAWS[0], "psi2_no_slip"), "k:", label="no-slip limit (Psi1 -> 0)")
    ax.plot(x, column(psi, LAWS[0], "psi2_sliding"), "k--", label="sliding throughout: Psi1 - 4 chi")
    for law in LAWS:
        ax.plot(column(psi, law, "psi1"), column(psi, law, "psi2"), label=law, **STYLE[law])
    ax.axhline(0.0, color="0.7", lw=0.5)
    ax.set_ylim(-6.5, 8)
    ax.set_xlabel("normalised incident angle Psi1 = 2(1-nu)/(2-nu) tan(theta_i) / mu")
    ax.set_ylabel("normalised recovery angle Psi2")
    ax.set_title("Test 5: Al2O3 sphere on a rigid plane, v_n = 5 m/s, mu = 0.092")
    ax.legend(fontsize=8)
    save(fig, a.png_dir, "chung_ooi_psi.png")

    ang = run(a.curves, "angle", a.csv_dir)
    panels = [("tangential_restitution", "et_sliding", "tangential restitution e_t = v_t' / v_t",
               "chung_ooi_tangential_restitution.png"),
              ("rebound_angle_deg", "rebound_sliding_deg", "contact-patch rebound angle (deg)",
               "chung_ooi_rebound_angle.png"),
              ("r_omega_over_v", None, "r omega' / |V|", "chung_ooi_spin.png")]
    for key, theory, label, name in panels:
        fig, ax = plt.subplots(figsize=(6, 4.5))
        th = column(ang, LAWS[0], "theta_deg")
        if theory:
            ax.plot(th, column(ang, LAWS[0], theory), "k--", label="rigid-body theory")
        for law in LAWS:
            ax.plot(column(ang, law, "theta_deg"), column(ang, law, key), label=law, **STYLE[law])
        ax.set_xlabel("incident angle theta_i (deg from the normal)")
        ax.set_ylabel(label)
        ax.set_title("Test 4: Al2O3 sphere on a rigid plane, |V| = 3.9 m/s, mu = 0.092, e = 0.98", fontsize=9)
        ax.legend(fontsize=8)
        save(fig, a.png_dir, name)


if __name__ == "__main__":
    main()
