#!/usr/bin/python3
"""Every file polydem writes opens in meshio (issue 21): point count, radius range, time steps.

    check_meshio.py POLYDEM WORKDIR

Makes the files with the real binary (generate -o .h5, a relax run with an HDF5 snapshot series,
jam -o .h5, convert outputs from text, LAMMPS data and dump, convert --series) and reads each .xmf
with meshio.read() (sidecars) or meshio.xdmf.TimeSeriesReader (series). The expected values come from
the HDF5 datasets read with h5py and from the generating parameters. Exit 77 (skipped) without meshio.
"""
import sys

try:
    import h5py
    import meshio
    import numpy as np
except ImportError as e:  # a check tool, not a build dependency
    print(f"SKIP: {e}")
    sys.exit(77)

from reader_checks import check, failures, run, start  # noqa: E402 (after the optional imports)

start(sys.argv)


def h5_radius(h5):
    with h5py.File(h5, "r") as f:
        return f["/particles/radius"][()], float(f.attrs["time"])


def check_sidecar(xmf, n, rmin=None, rmax=None, arrays=("radius", "id")):
    m = meshio.read(xmf)
    r, _ = h5_radius(xmf[:-4] + ".h5")
    check(m.points.shape == (n, 3), f"{xmf}: {m.points.shape[0]} points (expected {n})")
    check(len(m.cells) == 1 and m.cells[0].type == "vertex" and len(m.cells[0].data) == n,
          f"{xmf}: one vertex cell per particle")
    for a in arrays:
        check(a in m.point_data, f"{xmf}: point array {a}")
    check(np.array_equal(m.point_data["radius"], r), f"{xmf}: radii as stored")
    if rmin is not None:
        check(r.min() >= rmin * (1 - 1e-12) and r.max() <= rmax * (1 + 1e-12),
              f"{xmf}: radius range [{r.min():.6g}, {r.max():.6g}] inside [{rmin}, {rmax}]")
    return m


def check_series(xmf, files):
    with meshio.xdmf.TimeSeriesReader(xmf) as reader:
        points, cells = reader.read_points_cells()
        check(reader.num_steps == len(files), f"{xmf}: {reader.num_steps} time steps (expected {len(files)})")
        for k, h5 in enumerate(files):
            t, point_data, _ = reader.read_data(k)
            r, time = h5_radius(h5)
            with h5py.File(h5, "r") as f:
                x = f["/particles/position"][()]
            check(t == time, f"{xmf}: step {k} at t = {t} (the snapshot's time {time})")
            check(np.array_equal(point_data["radius"], r), f"{xmf}: step {k} radii, range [{r.min():.6g}, {r.max():.6g}]")
            check(np.array_equal(point_data["position"], x), f"{xmf}: step {k} positions of its own snapshot")
        check(points.shape[0] == len(r), f"{xmf}: {points.shape[0]} points")


# generate -o .h5
n, rmin, omega = 300, 1.0, 5.0
run("generate", "--dist", "uniform-volume", "--omega", str(omega), "--rmin", str(rmin), "-n", str(n), "--phi", "0.3",
    "-o", "g.h5")
check_sidecar("g.xmf", n, rmin, rmin * omega)

# relax: HDF5 snapshot series
with open("scene.toml", "w") as f:
    f.write("""[particles]
count = 200
distribution = "uniform-volume"
rmin = 0.5e-3
omega = 4.0
packing_fraction = 0.5
density = 2500.0
[contact]
law = "linear"
stiffness = 1000.0
restitution = 0.9
friction = 0.3
[run]
steps = 300
[output]
snapshot = "snap_{step}.h5"
snapshot_interval = 100
final = "final.h5"
""")
run("relax", "scene.toml", "-q")
snaps = [f"snap_{s:09d}.h5" for s in (0, 100, 200, 300)]
for s in snaps:
    check_sidecar(s[:-3] + ".xmf", 200, 0.5e-3, 2e-3, ("radius", "id", "velocity", "angular_velocity"))
check_sidecar("final.xmf", 200, 0.5e-3, 2e-3)
check_series("snap_series.xmf", snaps)

# a resumed run's series holds the first run's snapshots too, as the uninterrupted run's series does
run("relax", "scene.toml", "-q", "--steps", "150", "--set", 'output.snapshot="res_{step}.h5"', "--set",
    'output.checkpoint="ck.h5"', "--set", "output.final=\"\"", "--set", "output.contacts=true")
run("relax", "--resume", "ck.h5", "-q", "--steps", "300")
check_series("res_series.xmf", [f"res_{s:09d}.h5" for s in (0, 100, 200, 300)])

# relax output.arrays: the optional arrays reach the snapshot, its sidecar and the series, and agree
# with the run's own report (contacts, kinetic + rotational energy)
out = run("relax", "scene.toml", "--set", 'output.snapshot="arr_{step}.h5"', "--set", "output.final=\"\"", "--set",
          'output.arrays=["force","torque","contact_count","max_overlap","kinetic_energy"]')
m = check_sidecar("arr_000000300.xmf", 200, 0.5e-3, 2e-3,
                  ("radius", "force", "torque", "contact_count", "max_overlap", "kinetic_energy"))
contacts = int(next(line for line in out.splitlines() if line.startswith("contacts")).split()[1])
check(m.point_data["contact_count"].sum() == 2 * contacts,
      f"arr_000000300.xmf: contact counts sum to 2 x {contacts} (the report's contacts)")
energy = next(line for line in out.splitlines() if line.startswith("energy (J)")).replace(",", "").split()
kinetic, rotational = float(energy[3]), float(energy[5])
total = m.point_data["kinetic_energy"].sum()
check(abs(total - (kinetic + rotational)) <= 1e-5 * (kinetic + rotational),
      f"arr_000000300.xmf: kinetic energies sum to {total:.6g} J (report: {kinetic + rotational:.6g} J, 6 digits)")
check(m.point_data["max_overlap"].max() > 0 and m.point_data["force"].shape == (200, 3), "arr: overlaps and forces")
with meshio.xdmf.TimeSeriesReader("arr_series.xmf") as reader:
    reader.read_points_cells()
    check("contact_count" in reader.read_data(reader.num_steps - 1)[1], "arr_series.xmf: arrays in the series")

# relax output.contacts: every contact file opens as line cells (one per contact, two points each) with
# the per-contact data as cell arrays; the contact series has one time step per snapshot, each with its
# own contacts (their number changes from frame to frame).
def check_contact_sidecar(h5):
    with h5py.File(h5, "r") as f:
        fn, points, time = f["/contacts/fn"][()], f["/xdmf/points"][()], float(f.attrs["time"])
    m = meshio.read(h5[:-3] + ".xmf")
    check(len(m.cells) == 1 and m.cells[0].type == "line" and len(m.cells[0].data) == len(fn),
          f"{h5[:-3]}.xmf: {len(m.cells[0].data)} line cells = {len(fn)} contacts")
    check(m.points.shape == (2 * len(fn), 3) and np.array_equal(m.points, points), f"{h5[:-3]}.xmf: two points per line")
    check(np.array_equal(m.cell_data["fn"][0], fn), f"{h5[:-3]}.xmf: cell array fn as stored")
    for a in ("normal_force", "tangential_force", "overlap", "branch", "id_i", "id_j"):
        check(a in m.cell_data and len(m.cell_data[a][0]) == len(fn), f"{h5[:-3]}.xmf: cell array {a}")
    return len(fn), time, points


def check_contact_series(xmf, files):
    with meshio.xdmf.TimeSeriesReader(xmf) as reader:
        reader.read_points_cells()
        check(reader.num_steps == len(files), f"{xmf}: {reader.num_steps} time steps (expected {len(files)})")
        for k, h5 in enumerate(files):
            count, time, points = check_contact_sidecar(h5)
            t, point_data, cell_data = reader.read_data(k)
            check(t == time and len(cell_data["fn"][0]) == count and np.array_equal(point_data["position"], points),
                  f"{xmf}: step {k} at t = {t}: its own {count} contacts and line ends")


run("relax", "scene.toml", "-q", "--set", 'output.snapshot="con_{step}.h5"', "--set", "output.final=\"\"", "--set",
    "output.contacts=true")
contact_files = [f"con_{s:09d}_contacts.h5" for s in (0, 100, 200, 300)]
check_contact_series("con_contacts_series.xmf", contact_files)
counts = [check_contact_sidecar(h5)[0] for h5 in contact_files]
check(max(counts) > 0 and len(set(counts)) > 1, f"con: contacts per frame {counts} (some, changing)")
check_contact_series("res_contacts_series.xmf", [f"res_{s:09d}_contacts.h5" for s in (0, 100, 200, 300)])

# jam -o .h5: with velocities
run("jam", "-n", "150", "--dist", "uv", "--omega", "3", "--seed", "2", "--target-pressure", "1e3", "-o", "j.h5")
check_sidecar("j.xmf", 150, arrays=("radius", "id", "velocity"))

# convert: text -> HDF5, LAMMPS data and dump -> HDF5, --series
run("convert", "g.h5", "g.txt")
run("convert", "g.txt", "from_text.h5")
check_sidecar("from_text.xmf", n, rmin, rmin * omega)
run("convert", "final.h5", "final.data")
run("convert", "final.data", "from_data.h5")
check_sidecar("from_data.xmf", 200, 0.5e-3, 2e-3, ("radius", "id", "velocity", "angular_velocity"))
run("convert", *snaps, "all.dump")
run("convert", "all.dump", "from_dump.h5", "--frame", "2")
m = check_sidecar("from_dump.xmf", 200, 0.5e-3, 2e-3, ("radius", "id", "velocity", "angular_velocity"))
r2, _ = h5_radius(snaps[2])
check(np.array_equal(m.point_data["radius"], r2), "from_dump.xmf: frame 2 of the dump is snapshot 200")
run("convert", "--series", "picked.xmf", snaps[0], snaps[3], "from_dump.h5")
check_series("picked.xmf", [snaps[0], snaps[3], "from_dump.h5"])

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("every polydem file opened in meshio with the expected points, radii and time steps")
