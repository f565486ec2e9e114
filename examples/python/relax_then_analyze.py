#!/usr/bin/python3
"""Relax-then-analyze study with the polydem Python module: how friction changes a soft-sphere packing.

A polydisperse packing is softly compressed once (the scene's [compression] section, frictionless) to
phi = 0.6; for each friction coefficient mu that packing is stirred (impact velocities) and relaxed with viscous damping while the kinetic energy is
recorded through the progress callback. The final state goes to polydem.analyze (the contact network of
`polydem analyze`, with a contact gap wide enough for the soft overlaps) and to polydem.structure (bond
orientational order over Delaunay neighbours, `polydem analyze --order`; needs CGAL), and the results are
plotted: kinetic energy against time, and the mean coordination number against mu.

  PYTHONPATH=build/python /usr/bin/python3 examples/python/relax_then_analyze.py [--small] [--out DIR]
"""
import argparse
import csv
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import polydem  # noqa: E402


def compressed_start(count, growth_rate, path):
    """A frictionless soft compression to phi = 0.6, written to `path`: the common start of every run."""
    sim = polydem.Simulation({
        "particles": {"count": count, "distribution": "uniform-volume", "rmin": 1e-3, "omega": 2.0,
                      "packing_fraction": 0.3, "density": 2500.0, "seed": 11},
        "contact": {"stiffness": 1e4, "restitution": 0.5},
        "compression": {"packing_fraction": 0.6, "growth_rate": growth_rate},
        "velocities": {"initial": "zero"},
        "run": {"steps": 0, "progress_interval": 0.0},
    })
    if sim.target_not_reached:
        raise SystemExit(f"soft compression: {sim.target_not_reached}")
    sim.write(path)


def scene(start, friction, steps):
    """Relax the start with friction mu, stirred by impact velocities, under viscous damping."""
    return {
        "particles": {"file": start, "density": 2500.0},
        "contact": {"stiffness": 1e4, "restitution": 0.5, "friction": friction},
        "velocities": {"initial": "impact", "overlap": 0.01},
        "run": {"steps": steps, "viscous_damping": 20.0, "progress_interval": 0.0},
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--small", action="store_true", help="a few hundred spheres, a short run (CI)")
    parser.add_argument("--out", default="relax_then_analyze", help="output directory")
    args = parser.parse_args()
    count, steps, growth = (200, 1000, 2e-2) if args.small else (3000, 20000, 2e-3)
    frictions = [0.0, 0.3] if args.small else [0.0, 0.05, 0.1, 0.2, 0.5, 1.0]
    os.makedirs(args.out, exist_ok=True)

    start = os.path.abspath(os.path.join(args.out, "compressed_start.txt"))
    compressed_start(count, growth, start)
    rows, histories = [], {}
    for mu in frictions:
        sim = polydem.Simulation(scene(start, mu, steps))
        history = []
        sim.run(progress=lambda step, target, sim=sim, h=history: h.append((sim.time, sim.energies()["kinetic"])),
                chunk=max(1, steps // 100))
        sim.check_stability()
        final = os.path.join(args.out, f"final_mu{mu:g}.txt")
        sim.write(final)
        contacts = sim.contacts()
        # The soft overlaps (a few 1e-3 of a radius) are inside this contact tolerance.
        net = polydem.analyze(final, contact_gap=max(0.02, 2 * contacts["max_overlap_ratio"]))
        # Crystallinity of the relaxed packing: the fraction of solid-like spheres and the global Q6.
        order = polydem.structure(final, order=True)["bond_order"] if polydem.with_cgal else None
        rows.append({"friction": mu, "packing_fraction": sim.packing_fraction, "z": net["z"],
                     "z_backbone": net["z_backbone"], "rattler_fraction": net["rattler_fraction"],
                     "max_overlap_ratio": contacts["max_overlap_ratio"], "kinetic": sim.energies()["kinetic"],
                     "crystalline_fraction": order["crystalline_fraction"] if order else "",
                     "global_q6": order["global_q6"] if order else ""})
        histories[mu] = history
        print(f"mu = {mu:<5g} phi = {sim.packing_fraction:.4f}  Z = {net['z']:.3f}  rattlers "
              f"{100 * net['rattler_fraction']:.1f}%  max overlap / r = {contacts['max_overlap_ratio']:.2e}"
              + (f"  Q6 = {order['global_q6']:.3f}" if order else ""))

    with open(os.path.join(args.out, "relax_then_analyze.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    for mu, history in histories.items():
        t, e = zip(*history)
        left.semilogy(t, [max(x, 1e-300) for x in e], label=f"mu = {mu:g}")
    left.set_xlabel("time (s)")
    left.set_ylabel("kinetic energy (J)")
    left.legend()
    right.plot([r["friction"] for r in rows], [r["z"] for r in rows], "o-", label="all spheres")
    right.plot([r["friction"] for r in rows], [r["z_backbone"] or 0.0 for r in rows], "s--", label="backbone")
    right.set_xlabel("friction coefficient mu")
    right.set_ylabel("mean coordination number Z")
    right.legend()
    fig.tight_layout()
    png = os.path.join(args.out, "relax_then_analyze.png")
    fig.savefig(png, dpi=120)
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
