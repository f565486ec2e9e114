#!/usr/bin/env python3
"""Weak-scaling model of `polydem relax` on MPI ranks (docs/parallel.md, section "Weak-scaling model").

Predicted cost per step and per rank for N particles on P ranks, from
  - the serial cost per particle per step c (us), measured (docs/benchmarks; an input here),
  - the ghost count g of a cubic region holding n = N / P particles, from the ghost rule of parallel/
    (j is a ghost of rank q when its distance to q's region is at most r_j + r_max + skin):
        g = rho * (6 a^2 h + 3 pi a h^2 + 4/3 pi h^3),  a = (n / rho)^(1/3),  h = <r_j> + r_max + skin
    (the particles within h of a cube: its Minkowski sum with a ball), rho the number density; this is rule (1)
    of parallel/ alone; the reach field keeps a measured fraction f of it (--reach-fraction),
  - the messages: ghost updates of w doubles per ghost to the m neighbour ranks every step, one
    allreduce (2 log2 P latencies), and at every neighbour-list build (every k steps) the migration and
    the new ghosts (the ghost records, 13-20 doubles each) plus the count exchange (MPI_Alltoall: P latencies),
  - the network: latency alpha (s) and bandwidth beta (bytes/s) per rank.
Assumptions (stated in docs/parallel.md): one rank per core, compute and communication not overlapped,
perfect load balance, pairs with ghosts cost half a pair each extra (both ranks compute them).

Usage: /usr/bin/python3 scripts/parallel_model.py [--alpha 2e-6] [--beta 1e10]
"""
import argparse
import math


def distribution(name, omega):
    """Mean radius, mean r^3 (number-weighted, r_min = 1) and r_max of the size distribution."""
    if name == "mono":
        return 1.0, 1.0, 1.0
    if name == "uniform-volume":  # f(r) ~ r^-3 on [1, omega]
        norm = 0.5 * (1.0 - omega ** -2)
        mean_r = (1.0 - 1.0 / omega) / norm
        mean_r3 = (omega - 1.0) / norm
        return mean_r, mean_r3, omega
    raise ValueError(name)


def ghosts(n, phi, name, omega, skin=0.2):
    mean_r, mean_r3, rmax = distribution(name, omega)
    rho = phi / (4.0 / 3.0 * math.pi * mean_r3)  # particles per r_min^3
    a = (n / rho) ** (1.0 / 3.0)
    h = mean_r + rmax + skin
    return rho * (6.0 * a * a * h + 3.0 * math.pi * a * h * h + 4.0 / 3.0 * math.pi * h ** 3), a, h


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--alpha", type=float, default=2e-6, help="latency per message (s)")
    ap.add_argument("--beta", type=float, default=1e10, help="bandwidth per rank (bytes/s)")
    ap.add_argument("--phi", type=float, default=0.6)
    ap.add_argument("--rebuild-every", type=float, default=20.0, help="steps between neighbour-list builds")
    ap.add_argument("--validate", action="store_true", help="print rule (1) counts for 8 ranks of 10^4 at phi 0.3")
    args = ap.parse_args()
    # Serial cost per particle per step (us), measured by the lead on one core (docs/benchmarks/):
    # uniform-volume omega 10 at phi 0.6 (restructure_check.md: 0.0227 to 0.0238), mono (dem_threads.csv: 0.073).
    # Reach-field fraction f (ghosts kept / rule (1) ghosts), measured on 8 ranks of 10^4 particles at phi 0.3
    # (docs/parallel.md): mono 0.994, omega 10 0.668, omega 100 0.142.
    cases = [("mono", 1.0, 0.073, 6, 0.994), ("uniform-volume", 10.0, 0.023, 6, 0.668),
             ("uniform-volume", 100.0, 0.023, 6, 0.142)]
    if args.validate:
        for name, omega, _, _, _ in cases:
            g, a, h = ghosts(1e4, 0.3, name, omega)
            print(f"{name} omega {omega:g}: rule (1) ghosts per rank {g:.0f} (a = {a:.1f}, h = {h:.1f} r_min)")
        return
    print("| N | P | n = N/P | distribution | g rule (1) | g = f x rule (1) | g/n | compute (ms) | ghost update (ms) | "
          "allreduce (ms) | builds (ms/step) | step (ms) | efficiency |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for N in (1e8, 1e9):
        for P in (128, 1024):
            n = N / P
            for name, omega, cost_us, width, fraction in cases:
                g1, a, h = ghosts(n, args.phi, name, omega)
                g = fraction * g1
                m = min(P - 1, (2 * math.ceil(h / a) + 1) ** 3 - 1)  # ranks within reach h of a cube of side a
                compute = cost_us * 1e-6 * (n + 0.5 * g)
                update = m * args.alpha + 8.0 * width * g / args.beta
                reduce = 2.0 * math.log2(P) * args.alpha
                build = (P * args.alpha + 8.0 * 20.0 * g / args.beta + 2.0 * m * args.alpha) / args.rebuild_every
                step = compute + update + reduce + build
                serial = cost_us * 1e-6 * n
                label = "mono" if name == "mono" else f"uv {omega:g}"
                print(f"| {N:.0e} | {P} | {n:.3g} | {label} | {g1:.3g} | {g:.3g} | {g / n:.3f} | {1e3 * compute:.3f} | "
                      f"{1e3 * update:.3f} | {1e3 * reduce:.4f} | {1e3 * build:.3f} | {1e3 * step:.3f} | "
                      f"{serial / step:.2f} |")


if __name__ == "__main__":
    main()
