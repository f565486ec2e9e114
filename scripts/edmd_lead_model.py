#!/usr/bin/env python3
"""Exits of a random flight re-centred ahead of itself: the model behind the EDMD neighbourhood lead.

A point flies in straight lines of exponentially distributed length (mean free path lam) and scatters
isotropically at the end of each. It lives in a sphere of radius R (its neighbourhood's room); when it reaches
the surface, the sphere is re-centred at p + a R d (d: current direction, a: the lead) and the flight goes on.
Prints exits per unit path length and scatterings per exit B for each lam / R and lead a, and the best a.
docs/edmd.md, "Neighbourhood lead". Run with Debian's Python (numpy): /usr/bin/python3 scripts/edmd_lead_model.py
"""
import numpy as np

rng = np.random.default_rng(1)


def direction():
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def flight(lam, a, length=4000.0, room=1.0):
    p = np.zeros(3)
    d = direction()
    c = p + a * room * d
    exits = scatterings = 0
    travelled = 0.0
    while travelled < length:
        free = rng.exponential(lam)
        q = p - c
        b = q @ d
        t = -b + np.sqrt(max(b * b - (q @ q - room * room), 0.0))  # distance to the surface along d
        if t < free:  # exit first: re-centre, the flight goes on (memoryless)
            p = p + t * d
            travelled += t
            exits += 1
            c = p + a * room * d
        else:
            p = p + free * d
            travelled += free
            d = direction()
            scatterings += 1
    return exits / travelled, scatterings / max(exits, 1)


if __name__ == "__main__":
    leads = [0.0, 0.2, 0.4, 0.6, 0.8, 0.9]
    print("lam/R  " + "  ".join(f"a={a}: exits/length (B)" for a in leads) + "  best a")
    for lam in [0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0]:
        rows = [(a,) + flight(lam, a) for a in leads]
        best = min(rows, key=lambda r: r[1])[0]
        print(f"{lam:5}  " + "  ".join(f"{e:.3f} ({b:.1f})" for _, e, b in rows) + f"  {best}")
