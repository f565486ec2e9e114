#!/usr/bin/env python3
"""Convert a polydem text particle file (x y z r [vx vy vz], periodic box at the origin) into a LAMMPS
data file for atom_style sphere (units si): diameter and density per atom, velocities (zero spin).

    polydem_to_lammps.py STATE.txt OUT.data --density 2500 [--collections]

Numbers are written with repr() (shortest round-trip form), so LAMMPS reads exactly the positions,
radii (diameter / 2 is exact) and velocities polydem wrote with %.17g. With --collections it prints,
on stdout, the `neigh_modify collection/interval` arguments for `neighbor multi`: size collections
whose upper interaction cutoffs (diameters, as LAMMPS' granular atom2cut) double from the smallest
diameter up to the largest, the same levels as polydem's doubling HGrid.

With --restitution E it prints the pair_style granular damping arguments that reproduce polydem's
linear dashpot c = 2 zeta sqrt(m_eff k) exactly. LAMMPS 29Sep2021 (Debian 12) has no `damping
coeff_restitution`; its `damping tsuji` has the same form, alpha(cor) sqrt(m_eff k_n), with Tsuji's
polynomial alpha(cor): solving alpha(cor) = 2 zeta(E) for cor gives the same dashpot for every pair.
With --stiffness K and equal radii it also prints gran/hooke's gamma_n (damping per unit m_eff).
"""
import argparse
import math
import sys


def read_polydem(path):
    header = None
    rows = []
    boundaries = None
    with open(path) as f:
        for line in f:
            if line.startswith("# boundaries:"):
                boundaries = line.split(":", 1)[1].split()
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            tokens = line.split()
            if header is None:
                header = (int(tokens[0]), float(tokens[1]), float(tokens[2]), float(tokens[3]))
            else:
                rows.append([float(t) for t in tokens])
    if header is None:
        sys.exit(f"{path}: no header line `N Lx Ly Lz`")
    if len(rows) != header[0]:
        sys.exit(f"{path}: header says {header[0]} particles, found {len(rows)}")
    if boundaries and any(b != "periodic" for b in boundaries):
        sys.exit(f"{path}: only periodic boxes are converted (boundaries: {' '.join(boundaries)})")
    return header, rows


def collections(diameters):
    dmin, dmax = min(diameters), max(diameters)
    cuts = []
    c = 2.0 * dmin
    while c < dmax:
        cuts.append(c)
        c *= 2.0
    cuts.append(dmax * (1.0 + 1e-9))  # every diameter <= its collection's upper cutoff
    return cuts


def tsuji_alpha(cor):
    """LAMMPS' Tsuji damping prefactor alpha(cor) (pair granular, damping tsuji), same operation order."""
    def powint(x, n):  # LAMMPS MathSpecial::powint: binary powering
        y, w = 1.0, x
        while n:
            if n & 1:
                y *= w
            n >>= 1
            w *= w
        return y
    return (1.2728 - 4.2783 * cor + 11.087 * (cor * cor) - 22.348 * (cor * cor * cor) + 27.467 * powint(cor, 4)
            - 18.022 * powint(cor, 5) + 4.8218 * powint(cor, 6))


def tsuji_cor_for(e):
    """The `cor` argument that makes LAMMPS' Tsuji damping eta_n = alpha(cor) sqrt(m_eff k_n) equal to the
    linear spring-dashpot's exact eta_n = 2 zeta sqrt(m_eff k_n), zeta = -ln e / sqrt(pi^2 + ln^2 e), i.e.
    restitution exactly e for every pair (alpha is Tsuji's Hertz fit; only its value matters here).
    alpha decreases monotonically on [0, 1]: bisection."""
    target = -2.0 * math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)
    lo, hi = 0.0, 1.0
    if not tsuji_alpha(hi) < target < tsuji_alpha(lo):
        sys.exit(f"restitution {e}: 2 zeta = {target} is outside Tsuji's range; use e < 0.9999")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if tsuji_alpha(mid) > target:
            lo = mid
        else:
            hi = mid
    return hi, target


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("state")
    ap.add_argument("data")
    ap.add_argument("--density", type=float, required=True, help="kg/m^3, as particles.density in polydem")
    ap.add_argument("--collections", action="store_true", help="print collection/interval arguments")
    ap.add_argument("--restitution", type=float, help="print the damping arguments for this e (see --help)")
    ap.add_argument("--stiffness", type=float, help="k (N/m), for gran/hooke's gamma_n with --restitution")
    a = ap.parse_args()
    (n, lx, ly, lz), rows = read_polydem(a.state)
    with open(a.data, "w") as out:
        out.write(f"LAMMPS data file from polydem {a.state} (atom_style sphere, units si)\n\n")
        out.write(f"{n} atoms\n1 atom types\n\n")
        out.write(f"0 {lx!r} xlo xhi\n0 {ly!r} ylo yhi\n0 {lz!r} zlo zhi\n\n")
        out.write("Atoms # sphere\n\n")
        for k, row in enumerate(rows):
            x, y, z, r = row[:4]
            out.write(f"{k + 1} 1 {2.0 * r!r} {a.density!r} {x!r} {y!r} {z!r}\n")
        if rows and len(rows[0]) == 7:
            out.write("\nVelocities\n\n")
            for k, row in enumerate(rows):
                out.write(f"{k + 1} {row[4]!r} {row[5]!r} {row[6]!r} 0 0 0\n")
    if a.collections:
        cuts = collections([2.0 * row[3] for row in rows])
        print("collections=" + str(len(cuts)) + " " + " ".join(repr(c) for c in cuts))
    if a.restitution is not None:
        if a.restitution >= 1.0:
            print("damping=velocity dampcoeff=0.0 gamman=0.0")  # elastic: no dashpot at all
        else:
            cor, alpha = tsuji_cor_for(a.restitution)
            line = f"damping=tsuji dampcoeff={cor!r} alpha={alpha!r} alpha_lammps={tsuji_alpha(cor)!r}"
            radii = {row[3] for row in rows}
            if a.stiffness and len(radii) == 1:
                # gran/hooke: F_damp = m_eff gamma_n v_n, so gamma_n = 2 zeta sqrt(k / m_eff), m_eff = m / 2.
                r = radii.pop()
                meff = 0.5 * a.density * 4.0 / 3.0 * math.pi * r ** 3
                line += f" gamman={alpha * math.sqrt(a.stiffness / meff)!r}"
            print(line)


if __name__ == "__main__":
    main()
