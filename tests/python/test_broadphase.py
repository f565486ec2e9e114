"""Broad phases from Python: the same pairs as brute force and as `polydem pairs` for every backend."""
import numpy as np
import pytest

import polydem
from conftest import field

BACKENDS = polydem.backend_names() + ["auto"]


def checksum(i, j):
    """The pair checksum of apps/polydem/pair_report.cpp (sorted pairs), modulo 2^64."""
    s = 0
    for a, b in zip(i.tolist(), j.tolist()):
        s = (s * 1000003 + a * 7919 + b) % (1 << 64)
    return s


def numpy_pairs(x, r, lengths, periodic, skin):
    """Brute-force pairs with numpy (minimum image on periodic axes), sorted."""
    d = x[:, None, :] - x[None, :, :]
    for k in range(3):
        if periodic[k]:
            half = 0.5 * lengths[k]
            dk = d[:, :, k]
            dk[dk > half] -= lengths[k]
            dk[dk < -half] += lengths[k]
    dist2 = (d ** 2).sum(axis=2)
    limit = r[:, None] + r[None, :] + skin
    i, j = np.nonzero(np.triu(dist2 <= limit * limit, k=1))
    return i.astype(np.int32), j.astype(np.int32)


@pytest.fixture(scope="module", params=[("periodic", "rsa"), ("walls", "rsa"), ("periodic,periodic,wall", "random")])
def packing_file(request, tmp_path_factory, cli):
    boundary, placement = request.param
    path = tmp_path_factory.mktemp("pairs") / "spheres.txt"
    cli("generate", "--dist", "uv", "--omega", "5", "-n", "700", "--phi", "0.3", "--seed", "4", "--boundary",
        boundary, "--placement", placement, "-o", path)
    return path


@pytest.mark.parametrize("backend", BACKENDS)
def test_pairs_match_brute_force_and_cli(packing_file, backend, cli):
    skin = 0.15
    data = polydem.read_particles(packing_file)
    bp = polydem.BroadPhase(backend)
    bp.build(data["positions"], data["radii"], data["box"], skin=skin)
    i, j = bp.find_pairs()
    assert i.dtype == np.int32 and j.dtype == np.int32 and i.shape == j.shape
    assert np.all(i < j)

    brute = polydem.BroadPhase("brute")
    brute.build(data["positions"], data["radii"], data["box"], skin=skin)
    bi, bj = brute.find_pairs()
    np.testing.assert_array_equal(i, bi)
    np.testing.assert_array_equal(j, bj)

    box = data["box"]
    ni, nj = numpy_pairs(data["positions"], data["radii"], box.lengths,
                         [b == "periodic" for b in box.boundaries], skin)
    np.testing.assert_array_equal(i, ni)
    np.testing.assert_array_equal(j, nj)

    out = cli("pairs", packing_file, "--broadphase", backend, "--skin", skin, "--repeat", 1).stdout
    assert int(field(out, r"^candidate pairs: (\d+)$")) == len(i)
    x, r = data["positions"], data["radii"]
    d = x[i] - x[j]
    for k in range(3):
        if box.boundaries[k] == "periodic":
            d[:, k] -= box.lengths[k] * np.round(d[:, k] / box.lengths[k])
    overlapping = int(np.count_nonzero((d ** 2).sum(axis=1) < (r[i] + r[j]) ** 2))
    assert int(field(out, r"^overlapping pairs: (\d+)$")) == overlapping
    assert len(i) > 50  # the scene has pairs to find


def test_unsorted_pairs_are_the_same_set(packing_file):
    data = polydem.read_particles(packing_file)
    bp = polydem.BroadPhase("linked-cell")
    bp.build(data["positions"], data["radii"], data["box"], skin=0.1)
    i, j = bp.find_pairs(sort=False)
    si, sj = bp.find_pairs()
    assert sorted(zip(i.tolist(), j.tolist())) == list(zip(si.tolist(), sj.tolist()))


def test_layouts_zero_copy_and_copies_agree():
    d = polydem.Distribution("uv", rmin=1, omega=3)
    p = polydem.start_packing(d, 400, 0.3, seed=2)
    x, r = p["positions"], p["radii"]
    assert x.shape == (400, 3) and x.dtype == np.float64 and x.flags.c_contiguous
    reference = None
    for layout, zero_copy in [(x, True), (np.asfortranarray(x.T), True), (np.ascontiguousarray(x.T), False),
                              (x.copy(), True), (x.tolist(), False),
                              (x.astype(np.longdouble), False)]:
        bp = polydem.BroadPhase("hgrid-td")
        bp.build(layout, r, p["box"], skin=0.2)
        assert bp.zero_copy == zero_copy
        pairs = bp.find_pairs()
        if reference is None:
            reference = pairs
        np.testing.assert_array_equal(pairs[0], reference[0])
        np.testing.assert_array_equal(pairs[1], reference[1])


def test_update_sees_positions_moved_in_place():
    d = polydem.Distribution("mono", rmin=1)
    p = polydem.start_packing(d, 300, 0.2, seed=5)
    x = p["positions"].copy()
    bp = polydem.BroadPhase("linked-cell")
    bp.build(x, p["radii"], p["box"], skin=0.5)
    # Move sphere 1 next to sphere 0 in the caller's array: update() reads the same memory.
    x[1] = x[0] + np.array([2.1, 0.0, 0.0])
    x[1] %= p["box"].lengths
    bp.update([1])
    i, j = bp.find_pairs()
    assert (0, 1) in set(zip(i.tolist(), j.tolist()))
    assert 1 in bp.find_neighbours(0).tolist()
    assert 1 not in bp.find_neighbours(0, reach=0.0).tolist()


def test_neighbours_match_pairs():
    d = polydem.Distribution("uv", rmin=1, omega=4)
    p = polydem.start_packing(d, 500, 0.35, seed=1)
    bp = polydem.BroadPhase("hgrid-bu")
    bp.build(p["positions"], p["radii"], p["box"], skin=0.3)
    i, j = bp.find_pairs()
    for k in (0, 7, 123):
        expected = sorted(set(j[i == k].tolist()) | set(i[j == k].tolist()))
        got = bp.find_neighbours(k)
        assert got.dtype == np.int32
        assert got.tolist() == expected


def test_counters_memory_and_auto():
    d = polydem.Distribution("uv", rmin=1, omega=10)
    p = polydem.start_packing(d, 2000, 0.3, seed=3)
    bp = polydem.BroadPhase("hgrid-td", counting=True)
    bp.build(p["positions"], p["radii"], p["box"], skin=0.1)
    bp.find_pairs()
    c = bp.counters
    assert c["pair_tests"] > 0 and c["cell_accesses"] > 0
    bp.reset_counters()
    assert bp.counters["pair_tests"] == 0
    assert bp.memory_bytes > 0
    assert bp.cell_sizes is not None and len(bp.cell_sizes) >= 1

    auto = polydem.BroadPhase("auto")
    assert auto.chosen is None
    auto.build(p["positions"], p["radii"], p["box"], skin=0.1)
    assert auto.chosen in polydem.backend_names()
    assert auto.reason

    model = polydem.cost_model(radii=p["radii"], box_volume=p["box"].volume, skin=0.1)
    assert model["chosen"]["predicted"] > 0
    assert model["table"]["levels"][0] == 1 and len(model["table"]["levels"]) == 30
    assert all(v is None or v > 0 for v in model["table"]["top_down"])
    best = min(v for v in model["table"]["top_down"] + model["table"]["bottom_up"] if v is not None)
    assert model["chosen"]["predicted"] <= best * 1.011  # the fewest levels within 1% of the minimum
    sizes = model["chosen"]["cell_sizes"]
    if not model["chosen"]["linked_cell"]:
        predicted = polydem.cost_per_particle(sizes, model["chosen"]["mode"], radii=p["radii"],
                                              box_volume=p["box"].volume, skin=0.1, K=model["K"])
        assert predicted == pytest.approx(model["chosen"]["predicted"], rel=1e-9)
    analytic = polydem.cost_model(distribution=d, packing_fraction=0.3, skin=0.1, max_levels=8)
    assert len(analytic["table"]["levels"]) == 8


def test_hand_set_levels(packing_file, cli):
    data = polydem.read_particles(packing_file)
    bp = polydem.BroadPhase("hgrid-td", levels=2)
    bp.build(data["positions"], data["radii"], data["box"], skin=0.1)
    out = cli("pairs", packing_file, "--broadphase", "hgrid-td", "--levels", 2, "--skin", 0.1, "--repeat", 1).stdout
    assert int(field(out, r"^candidate pairs: (\d+)$")) == len(bp.find_pairs()[0])
    assert len(bp.cell_sizes) <= 2
    with pytest.raises(polydem.ConfigError, match="levels and cell_sizes apply to hgrid-td and hgrid-bu"):
        polydem.BroadPhase("linked-cell", levels=2)
