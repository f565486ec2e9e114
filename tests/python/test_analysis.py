"""certify, leak_test, structure: the jamming tests and structure analyses of `polydem analyze`, compared key
for key with the numbers of its --summary-json (and its CSV files with the arrays)."""
import json

import numpy as np
import pytest

import polydem

N = 100


@pytest.fixture(scope="module")
def packing(cli, tmp_path_factory):
    """A jammed packing written by the CLI (with velocities, for the speed rattlers)."""
    path = tmp_path_factory.mktemp("packing") / "j.txt"
    cli("jam", "-n", N, "--target-pressure", "1e6", "--seed", "2", "--velocities", "-o", path)
    return path


def summary(cli, tmp_path, *args):
    out = tmp_path / "summary.json"
    cli("analyze", *args, "--summary-json", out, cwd=tmp_path)
    return json.loads(out.read_text())


def same_keys(mine, theirs, keys):
    for key in keys:
        assert mine[key] == theirs[key], key


def backbone_sphere(path):
    a = polydem.analyze(str(path))
    return int(np.flatnonzero(~a["rattler"])[0])


def test_certify_matches_cli(cli, tmp_path, packing):
    motion_csv = tmp_path / "motion.csv"
    args = [packing, "--certify", "--motion-csv", motion_csv]
    if not polydem.with_glpk:
        args.append("--no-ideal")
    s = summary(cli, tmp_path, *args)["certify"]
    r = polydem.certify(str(packing), ideal=polydem.with_glpk)
    assert r["removed_sphere"] is None
    if polydem.with_glpk:
        ideal = r["ideal_contacts"]
        same_keys(ideal, s["ideal_contacts"], ["outcome", "verdict", "lps_solved"])
        if ideal["lps_solved"] > 0:
            same_keys(ideal, s["ideal_contacts"], ["opening_objective", "floppy_objective"])
    else:
        assert r["ideal_contacts"] is None
    loads = r["loads"]
    same_keys(loads, s["loads"], ["protocol", "outcome", "verdict", "largest_displacement", "displaced_spheres",
                                  "constraints", "gap_tolerance", "solver", "local_rattlers"])
    assert loads["outcome"] in ("jammed", "unjammed", "undecided")
    assert loads["jammed"] == (loads["outcome"] == "jammed")
    assert loads["motion"].shape == (N, 3) and loads["motion"].dtype == np.float64
    assert loads["rattler"].shape == (N,) and loads["rattler"].dtype == np.bool_
    # The --motion-csv columns: i, radius, contacts, rattler, dx, dy, dz, moved_over_diameter.
    table = np.loadtxt(motion_csv, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, 3].astype(bool), loads["rattler"])
    np.testing.assert_allclose(table[:, 4:7], loads["motion"], rtol=1e-9, atol=1e-300)
    np.testing.assert_allclose(table[:, 7], loads["moved_over_diameter"], rtol=1e-5, atol=1e-300)


def test_certify_without_a_backbone_sphere_matches_cli(cli, tmp_path, packing):
    k = backbone_sphere(packing)
    s = summary(cli, tmp_path, packing, "--certify", "--remove", k, "--no-ideal", "--load-test", "single")["certify"]
    r = polydem.certify(str(packing), remove=k, ideal=False, load_test="single")
    assert r["removed_sphere"] == k == s["removed_sphere"]
    assert r["loads"]["rattler"][k]
    same_keys(r["loads"], s["loads"], ["protocol", "outcome", "verdict", "largest_displacement",
                                       "displaced_spheres", "constraints"])


def test_certify_bad_inputs(packing):
    with pytest.raises(polydem.ConfigError, match="load_test 'bogus'"):
        polydem.certify(str(packing), load_test="bogus")
    with pytest.raises(polydem.ConfigError, match="strict needs load_test='single'"):
        polydem.certify(str(packing), strict=True, ideal=False)
    with pytest.raises(polydem.ConfigError, match=r"remove 100: the packing has 100 spheres \(indices 0..99\)"):
        polydem.certify(str(packing), remove=N, ideal=False)
    with pytest.raises(polydem.ConfigError, match="loads: 0 is outside"):
        polydem.certify(str(packing), loads=0, ideal=False)
    with pytest.raises(polydem.ConfigError, match="beta: -1"):
        polydem.certify(str(packing), beta=-1.0, ideal=False)
    with pytest.raises(polydem.ConfigError, match="lp_solver 'glpk'"):
        polydem.certify(str(packing), lp_solver="glpk", ideal=False)
    d = polydem.read_particles(packing)
    d["attributes"] = {}
    with pytest.raises(polydem.ConfigError, match="no reduced_pressure attribute"):
        polydem.certify(d, ideal=False)
    with pytest.raises(polydem.InputError):
        polydem.certify("/nonexistent/packing.txt", ideal=False)


def test_leak_test_matches_cli(cli, tmp_path, packing):
    s = summary(cli, tmp_path, packing, "--leak-test", 200, "--leak-blocks", 8)["leak_test"]
    lines = []
    r = polydem.leak_test(str(packing), collisions=200, blocks=8, progress=lines.append)
    assert len(lines) == 8
    same_keys(r, s, ["outcome", "verdict", "leaks", "pressure_change", "drift_ratio", "collisions"])
    assert r["removed_sphere"] is None
    for key in ("collisions_per_particle", "reduced_pressure", "mean_displacement", "max_displacement"):
        assert r["blocks"][key].dtype == np.float64 and r["blocks"][key].shape == (8,)
        assert r["blocks"][key].tolist() == s["blocks"][key], key
    assert r["blocks"]["max_sphere"].dtype == np.int32


def test_leak_test_without_a_sphere_matches_cli(cli, tmp_path, packing):
    k = backbone_sphere(packing)
    s = summary(cli, tmp_path, packing, "--leak-test", 100, "--leak-blocks", 4, "--remove", k)["leak_test"]
    r = polydem.leak_test(str(packing), collisions=100, blocks=4, remove=k)
    assert r["removed_sphere"] == k == s["removed_sphere"]
    same_keys(r, s, ["outcome", "verdict", "pressure_change", "drift_ratio", "collisions"])
    assert r["blocks"]["reduced_pressure"].tolist() == s["blocks"]["reduced_pressure"]


def test_leak_test_bad_inputs(packing):
    with pytest.raises(polydem.ConfigError, match="blocks: 3 is outside"):
        polydem.leak_test(str(packing), collisions=10, blocks=3)
    with pytest.raises(polydem.ConfigError, match="drift: 1"):
        polydem.leak_test(str(packing), collisions=10, drift=1.0)
    with pytest.raises(polydem.ConfigError, match="collisions: 0"):
        polydem.leak_test(str(packing), collisions=0.0)
    with pytest.raises(polydem.ConfigError, match="remove 500"):
        polydem.leak_test(str(packing), collisions=10, remove=500)

    def stop(line):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        polydem.leak_test(str(packing), collisions=20, blocks=4, progress=stop)


@pytest.mark.skipif(not polydem.with_cgal, reason="the Delaunay neighbours need CGAL")
def test_structure_matches_cli(cli, tmp_path, packing):
    channels_csv, sk_csv = tmp_path / "channels.csv", tmp_path / "sk.csv"
    s = summary(cli, tmp_path, packing, "--structure-only", "--order", "--channels-csv", channels_csv, "--sk-csv",
                sk_csv, "--sk-kmax", 12, "--velocity-rattlers=1e-4")
    r = polydem.structure(str(packing), order=True, channels=True, structure_factor=True, k_max=12,
                          velocity_threshold=1e-4)
    same_keys(r["delaunay"], s["delaunay"], ["image_shell", "triangulations", "unverified_cells", "hidden_spheres",
                                             "mean_neighbours"])
    assert r["delaunay"]["neighbours"].dtype == np.int32 and r["delaunay"]["neighbours"].sum() > 6 * N
    same_keys(r["bond_order"], s["bond_order"], ["crystalline_fraction", "solid_like", "mean_q6", "global_q6"])
    bo = r["bond_order"]
    assert bo["q6"].shape == (N,) and bo["solid"].dtype == np.bool_ and bo["solid"].sum() == bo["solid_like"]
    same_keys(r["channels"], s["channels"], ["acute_triangles", "triangles", "with_gap_circle", "mean", "sd"])
    table = np.loadtxt(channels_csv, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 1], r["channels"]["x_mid"], atol=1e-4)
    np.testing.assert_allclose(table[:, 2], r["channels"]["f"], rtol=1e-7, atol=1e-300)
    np.testing.assert_array_equal(table[:, 3], r["channels"]["count"])
    assert r["channels"]["count"].dtype == np.int64 and r["channels"]["count"].sum() > 0
    same_keys(r["structure_factor"], s["structure_factor"], ["wave_vectors", "k_min", "s_at_k_min", "peak_s",
                                                             "peak_k"])
    sk = np.loadtxt(sk_csv, delimiter=",", skiprows=1)
    np.testing.assert_allclose(sk[:, 0], r["structure_factor"]["K"], atol=1e-6)
    np.testing.assert_allclose(sk[:, 1], r["structure_factor"]["S"], rtol=1e-7)
    np.testing.assert_array_equal(sk[:, 3], r["structure_factor"]["vectors"])
    same_keys(r["velocity_rattlers"], s["velocity_rattlers"], ["threshold", "count", "number_fraction",
                                                               "volume_fraction", "volume_share"])
    assert r["velocity_rattlers"]["rattler"].sum() == r["velocity_rattlers"]["count"]


def test_structure_bad_inputs(packing):
    d = polydem.read_particles(packing)
    walled = dict(d, box=polydem.Box(d["box"].lengths, "walls"))
    with pytest.raises(polydem.InputError, match="periodic on every axis"):
        polydem.structure(walled, order=False, structure_factor=True)
    with pytest.raises(polydem.ConfigError, match="has no velocities"):
        polydem.structure(dict(d, velocities=None), order=False, velocity_threshold=1e-4)
    empty = {"positions": np.zeros((0, 3)), "radii": np.zeros(0), "box": d["box"]}
    with pytest.raises(polydem.InputError, match="no spheres"):
        polydem.structure(empty, order=False, channels=True)
    with pytest.raises(polydem.ConfigError, match="k_max"):
        polydem.structure(d, order=False, structure_factor=True, k_max=0.0)
