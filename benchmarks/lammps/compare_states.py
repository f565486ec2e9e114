#!/usr/bin/env python3
"""Compare a polydem final state (text particle file with velocities, particles in id order) with a
LAMMPS dump written by in.relax (id radius x y z vx vy vz, sorted by id): same particles, same
order. Prints one line of key=value pairs:

    max_dx_over_rmin   largest minimum-image position difference / smallest radius
    max_dv_over_vmax   largest velocity difference / largest speed
    ke_polydem ke_lammps ke_rel_diff   translational kinetic energies from the two states (same formula)

    compare_states.py POLYDEM_FINAL.txt LAMMPS_FINAL.dump --density 2500
"""
import argparse
import math


def read_polydem(path):
    rows, header = [], None
    for line in open(path):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        if header is None:
            header = [float(t) for t in line.split()[1:4]]
        else:
            rows.append([float(t) for t in line.split()])
    return header, rows


def read_dump(path):
    lines = open(path).read().splitlines()
    start = next(k for k, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    cols = lines[start].split()[2:]
    at = {c: k for k, c in enumerate(cols)}
    rows = []
    for l in lines[start + 1:]:
        if l.strip():
            t = l.split()
            rows.append([float(t[at[c]]) for c in ("x", "y", "z", "radius", "vx", "vy", "vz")])
    return rows


def kinetic(rows, density):
    return sum(0.5 * density * 4.0 / 3.0 * math.pi * r[3] ** 3 * (r[4] ** 2 + r[5] ** 2 + r[6] ** 2) for r in rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("polydem")
    ap.add_argument("lammps")
    ap.add_argument("--density", type=float, required=True)
    a = ap.parse_args()
    box, p = read_polydem(a.polydem)
    q = read_dump(a.lammps)
    if len(p) != len(q):
        raise SystemExit(f"{len(p)} particles in {a.polydem}, {len(q)} in {a.lammps}")
    rmin = min(r[3] for r in p)
    vmax = max(math.sqrt(r[4] ** 2 + r[5] ** 2 + r[6] ** 2) for r in p)
    dx = dv = 0.0
    for s, t in zip(p, q):
        for k in range(3):
            d = s[k] - t[k]
            d -= box[k] * round(d / box[k])
            dx = max(dx, abs(d))
            dv = max(dv, abs(s[4 + k] - t[4 + k]))
    kp, kl = kinetic(p, a.density), kinetic(q, a.density)
    print(f"max_dx_over_rmin={dx / rmin:.3e} max_dv_over_vmax={dv / vmax:.3e} ke_polydem={kp:.10g} "
          f"ke_lammps={kl:.10g} ke_rel_diff={(kl - kp) / kp:.3e}")


if __name__ == "__main__":
    main()
