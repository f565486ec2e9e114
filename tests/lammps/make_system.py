#!/usr/bin/env python3
"""Write the polydisperse test system of tests/lammps/ in two formats that hold the same doubles.

    python3 tests/lammps/make_system.py tests/lammps

writes gran_hooke_poly.data (LAMMPS read_data, atom_style sphere, with Velocities) and
gran_hooke_poly.txt (polydem particle file: x y z r vx vy vz). 300 spheres, radii uniform in
[1, 4] mm (size ratio 4), random sequential addition without overlaps at packing fraction 0.35 in a
periodic cube with its origin at 0, velocity components uniform in [-2, 2] m/s, no spin. Every number
is written with repr() (17 significant digits at most, the shortest text that reads back to the same
double), so both programs start from bit-identical positions, radii and velocities. Plain Python
(random.Random with a fixed seed): the output is the same on every machine.
"""
import math
import random
import sys

N = 300
RMIN = 1.0e-3  # m
RATIO = 4.0
PHI = 0.35
DENSITY = 2500.0  # kg/m^3, set in the .in file and the scene (LAMMPS reads it per atom from the data file)
SEED = 20261201


def main(folder):
    rng = random.Random(SEED)
    radii = sorted((RMIN * (1.0 + (RATIO - 1.0) * rng.random()) for _ in range(N)), reverse=True)
    volume = sum(4.0 / 3.0 * math.pi * r ** 3 for r in radii)
    box = (volume / PHI) ** (1.0 / 3.0)
    box = float(f"{box:.6g}")  # a short box length, the same text in both files
    centres = []
    for r in radii:
        for _ in range(1_000_000):
            c = [rng.random() * box for _ in range(3)]
            ok = True
            for (q, s) in centres:
                d2 = 0.0
                for k in range(3):
                    d = c[k] - q[k]
                    d -= box * round(d / box)
                    d2 += d * d
                if d2 < (r + s) ** 2:
                    ok = False
                    break
            if ok:
                centres.append((c, r))
                break
        else:
            sys.exit("random sequential addition failed: lower PHI")
    velocities = [[rng.uniform(-2.0, 2.0) for _ in range(3)] for _ in range(N)]

    with open(f"{folder}/gran_hooke_poly.data", "w") as out:
        out.write("LAMMPS data file: polydem tests/lammps/make_system.py (300 spheres, radii 1-4 mm, phi 0.35)\n\n")
        out.write(f"{N} atoms\n1 atom types\n\n")
        for axis in "xyz":
            out.write(f"0.0 {box!r} {axis}lo {axis}hi\n")
        out.write("\nAtoms # sphere\n\n")
        for i, (c, r) in enumerate(centres):
            out.write(f"{i + 1} 1 {2.0 * r!r} {DENSITY!r} {c[0]!r} {c[1]!r} {c[2]!r} 0 0 0\n")
        out.write("\nVelocities\n\n")
        for i, v in enumerate(velocities):
            out.write(f"{i + 1} {v[0]!r} {v[1]!r} {v[2]!r} 0.0 0.0 0.0\n")

    with open(f"{folder}/gran_hooke_poly.txt", "w") as out:
        out.write("# polydem tests/lammps/make_system.py: the system of gran_hooke_poly.data (ids 1..N there,\n")
        out.write("# 0..N-1 here, same order)\n")
        out.write("# columns: x y z r vx vy vz\n")
        out.write("# boundaries: periodic periodic periodic\n")
        out.write(f"{N} {box!r} {box!r} {box!r}\n")
        for (c, r), v in zip(centres, velocities):
            out.write(f"{c[0]!r} {c[1]!r} {c[2]!r} {r!r} {v[0]!r} {v[1]!r} {v[2]!r}\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
