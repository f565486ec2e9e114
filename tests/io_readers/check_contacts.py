#!/usr/bin/python3
"""Contact files of `polydem relax` (output.contacts) and the arrays rattler, size_class (issue 21).

    check_contacts.py POLYDEM WORKDIR

1. Two spheres overlapping across a periodic boundary, from a particle file: the step-0 contact row
   against the forces and overlap computed by hand (linear spring-dashpot from the restitution), ids and
   centre consistent with the snapshot, the line drawn to the periodic image; rattler and size_class.
2. A generated frictional run without dashpots (restitution 1, no tangential damping): at every snapshot
   the contact forces summed per particle equal the snapshot's force array, the contacts per particle equal
   contact_count, rattler equals a recursive d + 1 = 4 removal over the file's contacts, size_class equals
   floor(log2(r / r_min)).
3. The same run with text snapshots: CSV contact files with the same values as the HDF5 ones, and the
   arrays as text columns.
4. Without output.contacts no contact file is written; a LAMMPS dump snapshot carries rattler and
   size_class columns and gets a CSV contact file.
5. minimise --contacts: fn = k R_eff overlap by hand, the contact count of the report, forces that balance.
Needs h5py and numpy (Debian python3-h5py, python3-numpy); exit 77 (skipped) without them.
"""
import glob
import math
import os
import re
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"SKIP: {e}")
    sys.exit(77)

from reader_checks import check, failures, run, start  # noqa: E402 (after the optional imports)

start(sys.argv)


def contacts_h5(file):
    with h5py.File(file, "r") as f:
        c = {k: f["/contacts/" + k][()] for k in f["/contacts"]}
        c["points"] = f["/xdmf/points"][()]
        c["lines"] = f["/xdmf/lines"][()]
        c["time"] = float(f.attrs["time"])
    return c


def snapshot_h5(file):
    with h5py.File(file, "r") as f:
        s = {k: f["/particles/" + k][()] for k in f["/particles"]}
        s["lengths"] = f["/box/lengths"][()]
        s["time"] = float(f.attrs["time"])
    return s


def close(a, b, rel=1e-12):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and np.all(np.abs(a - b) <= rel * max(np.max(np.abs(b), initial=0.0), 1e-300))


# ---------------------------------------------------------------------------------------------------------
# 1. Two spheres across the x boundary of a periodic box, by hand.
L, density, k, e = 0.01, 2500.0, 1000.0, 0.5
spheres = {  # id: centre, radius, velocity, angular velocity
    5: (np.array([0.4e-3, 5.0e-3, 5.2e-3]), 1.0e-3, np.array([-0.02, 0.01, 0.0]), np.zeros(3)),
    2: (np.array([L - 1.1e-3, 4.7e-3, 5.0e-3]), 0.6e-3, np.array([0.03, 0.0, -0.01]), np.zeros(3)),
}
with open("two.txt", "w") as f:
    f.write("# columns: id x y z r vx vy vz\n# boundaries: periodic periodic periodic\n")
    f.write(f"2 {L!r} {L!r} {L!r}\n")
    for i, (x, r, v, w) in spheres.items():
        f.write(f"{i} {x[0]!r} {x[1]!r} {x[2]!r} {r!r} {v[0]!r} {v[1]!r} {v[2]!r}\n")
with open("two.toml", "w") as f:
    f.write(f"""[particles]
file = "two.txt"
density = {density}
[contact]
stiffness = {k}
restitution = {e}
[velocities]
initial = "file"
[run]
steps = 2
progress_interval = 0.0
[output]
snapshot = "two_{{step}}.h5"
snapshot_interval = 1
contacts = true
arrays = ["force", "contact_count", "rattler", "size_class"]
""")
run("relax", "two.toml", "-q")
c = contacts_h5("two_000000000_contacts.h5")
s = snapshot_h5("two_000000000.h5")
check(list(c["id_i"]) == [2] and list(c["id_j"]) == [5], f"two spheres: one contact (2, 5), got {list(c['id_i'])}")
xi, ri, vi, _ = spheres[2]
xj, rj, vj, _ = spheres[5]
d = xi - xj
d -= L * np.round(d / L)  # minimum image: from j to i
dist = np.linalg.norm(d)
n = d / dist
overlap = ri + rj - dist
mi, mj = density * 4 / 3 * math.pi * ri**3, density * 4 / 3 * math.pi * rj**3
meff = mi * mj / (mi + mj)
zeta = -math.log(e) / math.sqrt(math.pi**2 + math.log(e) ** 2)
rate = -np.dot(vi - vj, n)
fn = k * overlap + 2 * zeta * math.sqrt(meff * k) * rate
check(close(c["overlap"], [overlap]), f"two spheres: overlap {c['overlap'][0]:.15g} m (by hand {overlap:.15g})")
check(close(c["fn"], [fn]), f"two spheres: fn {c['fn'][0]:.15g} N (by hand k d + c d' = {fn:.15g})")
check(close(c["normal_force"], [fn * n]), "two spheres: normal_force = fn n on i, n from j to i")
check(close(c["branch"], [-d], 1e-15), f"two spheres: branch {c['branch'][0]} = the minimum image from i to j")
check("tangential_force" not in c, "two spheres: frictionless law, no tangential_force dataset")
slot = {int(i): a for a, i in enumerate(s["id"])}
check(np.array_equal(c["centre"][0], s["position"][slot[2]]), "two spheres: centre = the snapshot's position of id_i")
check(np.array_equal(c["points"][0], c["centre"][0]) and close(c["points"][1], c["centre"][0] + c["branch"][0], 1e-15),
      "two spheres: the line runs from the centre of i to centre + branch")
check(c["points"][1][0] > L, f"two spheres: across the boundary the line ends at the image of j (x = {c['points'][1][0]:.3g} > L)")
check(list(c["lines"][0]) == [0, 1], "two spheres: connectivity 0 1")
check(list(s["rattler"][[slot[2], slot[5]]]) == [1.0, 1.0], "two spheres: both are rattlers (1 contact < 4)")
check(list(s["size_class"][[slot[2], slot[5]]]) == [0.0, 1.0], "two spheres: size_class 0 (r = 0.6 mm), 1 (r = 1 mm)")
with h5py.File("two_000000000.h5", "r") as f:
    rule = f["/parameters"].attrs["size_class"]
    rule = rule.decode() if isinstance(rule, bytes) else rule
check(rule.startswith("component index among 2 distinct radii"), f"two spheres: size_class rule stored: {rule}")
# A later snapshot's contact row matches its own snapshot's state, by hand again.
c2, s2 = contacts_h5("two_000000002_contacts.h5"), snapshot_h5("two_000000002.h5")
slot2 = {int(i): a for a, i in enumerate(s2["id"])}
xi2, xj2 = s2["position"][slot2[2]], s2["position"][slot2[5]]
d2 = xi2 - xj2
d2 -= L * np.round(d2 / L)
n2 = d2 / np.linalg.norm(d2)
fn2 = k * (ri + rj - np.linalg.norm(d2)) + 2 * zeta * math.sqrt(meff * k) * -np.dot(
    s2["velocity"][slot2[2]] - s2["velocity"][slot2[5]], n2)
check(close(c2["fn"], [fn2], 1e-10), f"two spheres, step 2: fn {c2['fn'][0]:.12g} N from the step-2 snapshot state")
check(c2["time"] == s2["time"] and c2["time"] > 0, "two spheres, step 2: the contact file's time is its snapshot's")

# ---------------------------------------------------------------------------------------------------------
# 2. Generated, frictional, no dashpots: contact forces add up to the force array.
scene = """[particles]
count = 300
distribution = "uniform-volume"
rmin = 0.5e-3
omega = 4.0
packing_fraction = 0.5
density = 2500.0
[contact]
law = "linear"
stiffness = 1000.0
restitution = 1.0
friction = 0.3
[run]
steps = 200
progress_interval = 0.0
[output]
snapshot_interval = 100
"""
with open("gen.toml", "w") as f:
    f.write(scene)
run("relax", "gen.toml", "-q", "--set", 'output.snapshot="g_{step}.h5"', "--set", "output.contacts=true", "--set",
    'output.arrays=["force", "contact_count", "rattler", "size_class"]')
# The same checks on a dense start, a FIRE packing (many contacts, rattlers and non-rattlers).
run("minimise", "-n", "300", "--dist", "uv", "--omega", "3", "--phi0", "0.72", "--seed", "4", "--progress", "0",
    "-o", "dense.h5")
with open("dense.toml", "w") as f:
    f.write(scene.replace('count = 300\ndistribution = "uniform-volume"\nrmin = 0.5e-3\nomega = 4.0\n'
                          'packing_fraction = 0.5\n', 'file = "dense.h5"\n')
            .replace("[contact]", '[velocities]\ninitial = "zero"\n[contact]'))
run("relax", "dense.toml", "-q", "--set", 'output.snapshot="p_{step}.h5"', "--set", "output.contacts=true", "--set",
    'output.arrays=["force", "contact_count", "rattler", "size_class"]')
for prefix, step in [("g", 0), ("g", 100), ("g", 200), ("p", 0), ("p", 100), ("p", 200)]:
    s = snapshot_h5(f"{prefix}_{step:09d}.h5")
    c = contacts_h5(f"{prefix}_{step:09d}_contacts.h5")
    step = f"{prefix} {step}"
    slot = {int(i): a for a, i in enumerate(s["id"])}
    a = np.array([slot[int(i)] for i in c["id_i"]], dtype=int)
    b = np.array([slot[int(j)] for j in c["id_j"]], dtype=int)
    total = c["normal_force"] + c["tangential_force"]
    summed = np.zeros_like(s["force"])
    np.add.at(summed, a, total)
    np.add.at(summed, b, -total)
    scale = max(np.max(np.abs(s["force"])), 1e-300)
    check((step == "g 0" or len(c["fn"]) > 10) and np.max(np.abs(summed - s["force"]), initial=0.0) <= 1e-9 * scale,
          f"step {step}: {len(c['fn'])} contacts; their forces sum to the force array "
          f"(max difference {np.max(np.abs(summed - s['force']), initial=0.0) / scale:.2e} of max |F|)")
    counts = np.bincount(np.concatenate([a, b]), minlength=len(s["id"]))
    check(np.array_equal(counts, s["contact_count"]), f"step {step}: contacts per particle = contact_count")
    check(np.all(c["id_i"] < c["id_j"]) and np.all(np.diff(c["id_i"].astype(np.int64) * 2**32 + c["id_j"]) > 0),
          f"step {step}: rows sorted by (id_i, id_j), id_i < id_j")
    r = s["radius"]
    gap = np.linalg.norm(c["branch"], axis=1) - (r[a] + r[b])
    check(np.all(gap < 0) and close(-gap, c["overlap"], 1e-9), f"step {step}: overlap = r_i + r_j - |branch| > 0")
    check(np.all(np.abs(np.sum(c["tangential_force"] * c["branch"], axis=1))
                 <= 1e-9 * np.linalg.norm(c["tangential_force"], axis=1) * np.linalg.norm(c["branch"], axis=1) + 1e-300),
          f"step {step}: tangential forces in the tangent plane")
    # Rattlers: remove particles with < 4 contacts until none is left (periodic box: no walls).
    alive = np.ones(len(r), bool)
    while True:
        keep = alive[a] & alive[b]
        z = np.bincount(np.concatenate([a[keep], b[keep]]), minlength=len(r))
        drop = alive & (z < 4)
        if not drop.any():
            break
        alive &= ~drop
    check(np.array_equal(s["rattler"], (~alive).astype(float)),
          f"step {step}: rattler = recursive d + 1 removal ({int((~alive).sum())} of {len(r)})")
    if prefix == "p":
        check(0 < int((~alive).sum()) < len(r) // 2, f"step {step}: a jammed start has some rattlers, not all")
    rmin = r.min()
    expected = np.floor(np.log2(r / rmin))
    check(np.array_equal(s["size_class"], expected),
          f"step {step}: size_class = floor(log2(r / r_min)), classes {sorted(set(s['size_class'].astype(int)))}")

# ---------------------------------------------------------------------------------------------------------
# 3. Text snapshots: CSV contact files with the same values.
run("relax", "gen.toml", "-q", "--set", 'output.snapshot="t_{step}.txt"', "--set", "output.contacts=true", "--set",
    'output.arrays=["rattler", "size_class", "force"]')


def text_snapshot(file):
    """The columns of a polydem text file by name (the `# columns:` line), rows in file order."""
    with open(file) as f:
        lines = f.read().splitlines()
    names = next(line for line in lines if line.startswith("# columns:")).split()[2:]
    rows = [line.split() for line in lines if line and not line.startswith("#")][1:]  # [0] is N Lx Ly Lz
    return {name: np.array([float(r[k]) for r in rows]) for k, name in enumerate(names)}


for step in (0, 100, 200):
    t, g = text_snapshot(f"t_{step:09d}.txt"), snapshot_h5(f"g_{step:09d}.h5")
    ids = t["id"] if "id" in t else np.arange(len(t["x"]))
    same = np.array_equal(ids, g["id"]) and np.array_equal(t["rattler"], g["rattler"])
    same = same and np.array_equal(t["size_class"], g["size_class"]) and np.array_equal(t["force_y"], g["force"][:, 1])
    check(same, f"t step {step}: the text snapshot's rattler, size_class, force_x.. columns = the HDF5 arrays")
for step in (0, 100, 200):
    csv = np.genfromtxt(f"t_{step:09d}_contacts.csv", delimiter=",", names=True, comments="#")
    c = contacts_h5(f"g_{step:09d}_contacts.h5")
    same = len(csv) == len(c["fn"]) and np.array_equal(csv["id_i"], c["id_i"]) and np.array_equal(csv["id_j"], c["id_j"])
    for name, col in (("fn", "fn"), ("overlap", "overlap")):
        same = same and np.array_equal(csv[col], c[name])
    for k_, axis in enumerate("xyz"):
        same = same and np.array_equal(csv["branch_" + axis], c["branch"][:, k_])
        same = same and np.array_equal(csv["tangential_force_" + axis], c["tangential_force"][:, k_])
        same = same and np.array_equal(csv["normal_force_" + axis], c["normal_force"][:, k_])
        same = same and np.array_equal(csv["centre_" + axis], c["centre"][:, k_])
    check(same, f"t step {step}: the CSV holds the HDF5 file's {len(csv)} rows bit for bit")
with open("t_000000100_contacts.csv") as f:
    head = f.read(400)
check(head.startswith("id_i,id_j,") and "\n# polydem contacts:" in head and "# time:" in head and "# box:" in head,
      "t: CSV column names, then the comment header")
check(not glob.glob("t_*_contacts.xmf") and not glob.glob("t_contacts_series.xmf"), "t: no XDMF for CSV contacts")

# ---------------------------------------------------------------------------------------------------------
# 4. No key, no file; LAMMPS dumps.
run("relax", "gen.toml", "-q", "--steps", "100", "--set", 'output.snapshot="n_{step}.h5"')
check(os.path.exists("n_000000100.h5") and not glob.glob("n_*contacts*"),
      f"n: without output.contacts no contact file ({glob.glob('n_*contacts*')})")
run("relax", "gen.toml", "-q", "--steps", "100", "--set", 'output.snapshot="d_{step}.dump"', "--set",
    "output.contacts=true", "--set", 'output.arrays=["rattler", "size_class"]')
with open("d_000000100.dump") as f:
    atoms = next(line for line in f if line.startswith("ITEM: ATOMS"))
check("rattler" in atoms.split() and "size_class" in atoms.split(), f"d: dump columns {atoms.strip()}")
check(os.path.exists("d_000000100_contacts.csv"), "d: a CSV contact file beside the dump")

# ---------------------------------------------------------------------------------------------------------
# 5. minimise --contacts: the contact network of a FIRE packing in mechanical equilibrium.
out = run("minimise", "-n", "200", "--phi0", "0.75", "--seed", "2", "--progress", "0", "-o", "m.h5", "--contacts")
reported = int(re.search(r"^final .*contacts (\d+)", out, re.M).group(1))
c, s = contacts_h5("m_contacts.h5"), snapshot_h5("m.h5")
slot = {int(i): a for a, i in enumerate(s["id"])}
a = np.array([slot[int(i)] for i in c["id_i"]], dtype=int)
b = np.array([slot[int(j)] for j in c["id_j"]], dtype=int)
r = s["radius"]
reff = r[a] * r[b] / (r[a] + r[b])
check(len(c["fn"]) == reported, f"m: {len(c['fn'])} contacts, the report's {reported}")
check(close(c["fn"], 1.0 * reff * c["overlap"]), "m: fn = k R_eff overlap (linear, radius-scaled, k = 1) by hand")
summed = np.zeros((len(r), 3))
np.add.at(summed, a, c["normal_force"])
np.add.at(summed, b, -c["normal_force"])
check(np.max(np.abs(summed)) <= 1e-6 * np.mean(c["fn"]),
      f"m: the contact forces balance on every sphere (max |sum F| {np.max(np.abs(summed)) / np.mean(c['fn']):.1e} of <fn>)")
check(os.path.exists("m_contacts.xmf") and "tangential_force" not in c, "m: sidecar, no tangential force")

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("contact files and the rattler / size_class arrays agree with the hand computations and the snapshots")
