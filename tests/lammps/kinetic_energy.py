#!/usr/bin/env python3
"""Kinetic energy of a polydem particle file (x y z r vx vy vz ...) of spheres of one density.

    kinetic_energy.py FILE DENSITY [REFERENCE DIGITS]

Prints the kinetic energy sum 0.5 m |v|^2 (and the rotational energy if the file has angular velocities) (m = density 4/3 pi r^3, J) with 17 significant digits. With
REFERENCE and DIGITS, also the number of agreeing significant digits, -log10(|E - E_ref| / |E_ref|), and
exits 1 if fewer than DIGITS agree. fsum keeps the sum itself exact to rounding.
"""
import math
import sys


def main():
    path, density = sys.argv[1], float(sys.argv[2])
    terms, spin, header_seen = [], [], False
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            if not header_seen:
                header_seen = True  # N Lx Ly Lz
                continue
            w = [float(t) for t in line.split()]
            if len(w) < 7:
                sys.exit(f"{path}: expected x y z r vx vy vz columns, got {len(w)}")
            r, v = w[3], w[4:7]
            m = density * 4.0 / 3.0 * math.pi * r ** 3
            terms.append(0.5 * m * (v[0] ** 2 + v[1] ** 2 + v[2] ** 2))
            if len(w) >= 10:  # angular velocity: rotational energy 0.5 (0.4 m r^2) |omega|^2
                spin.append(0.2 * m * r * r * (w[7] ** 2 + w[8] ** 2 + w[9] ** 2))
    ke = math.fsum(terms)
    print(f"kinetic energy (J): {ke:.17g} ({len(terms)} particles)")
    if spin:
        print(f"rotational energy (J): {math.fsum(spin):.17g}")
    if len(sys.argv) > 3:
        ref, need = float(sys.argv[3]), float(sys.argv[4])
        rel = abs(ke - ref) / abs(ref)
        digits = math.inf if rel == 0.0 else -math.log10(rel)
        print(f"reference (J):      {ref:.17g}; relative difference {rel:.3e}: {digits:.1f} significant digits agree")
        if not digits >= need:
            print(f"FAIL: fewer than {need:g} significant digits agree")
            sys.exit(1)
        print(f"PASS: at least {need:g} significant digits agree")


if __name__ == "__main__":
    main()
