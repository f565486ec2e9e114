"""Particle files in every format polydem has: read what the CLI writes, and the CLI reads what we write."""
import filecmp

import numpy as np
import pytest

import polydem
from conftest import field

FORMATS = ["txt"] + (["h5"] if polydem.with_hdf5 else [])


@pytest.mark.parametrize("suffix", FORMATS)
def test_read_cli_files(cli, tmp_path, suffix):
    path = tmp_path / f"g.{suffix}"
    cli("generate", "--dist", "bi", "--omega", "2", "-n", "100", "--seed", "3", "--boundary", "walls", "-o", path)
    d = polydem.read_particles(path)
    assert d["positions"].shape == (100, 3) and d["positions"].dtype == np.float64
    assert d["radii"].shape == (100,) and d["id"].dtype == np.int32
    assert d["box"].boundaries == ("wall", "wall", "wall")
    assert d["attributes"]["distribution"].startswith("bi")
    assert sorted(set(d["radii"].tolist())) == [1.0, 2.0]


@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_and_cli_reads_ours(cli, tmp_path, suffix):
    rng = np.random.default_rng(1)
    n = 60
    box = polydem.Box((10.0, 12.0, 14.0), "periodic,periodic,wall")
    x = rng.uniform(1.0, 9.0, size=(n, 3))
    data = {"positions": x, "radii": np.full(n, 0.4), "velocities": rng.normal(size=(n, 3)),
            "id": np.arange(n, dtype=np.int32)[::-1].copy(), "box": box, "time": 0.25,
            "attributes": {"note": "from python"}}
    path = tmp_path / f"mine.{suffix}"
    polydem.write_particles(path, data)
    if suffix == "h5":
        assert polydem.xdmf_path(path).exists()
    back = polydem.read_particles(path)
    np.testing.assert_array_equal(back["positions"], x)
    np.testing.assert_array_equal(back["velocities"], data["velocities"])
    np.testing.assert_array_equal(back["id"], data["id"])
    assert back["angular_velocities"] is None
    assert back["time"] == 0.25 and back["attributes"]["note"] == "from python"
    assert back["box"] == box
    # The CLI reads it: the same pairs as the module.
    out = cli("pairs", path, "--broadphase", "linked-cell", "--skin", 0.3, "--repeat", 1).stdout
    bp = polydem.BroadPhase("linked-cell")
    bp.build(back["positions"], back["radii"], back["box"], skin=0.3)
    assert int(field(out, r"^candidate pairs: (\d+)$")) == len(bp.find_pairs()[0])


def test_explicit_format_functions(tmp_path):
    d = polydem.start_packing(polydem.Distribution("mono"), 20, 0.2, seed=1)
    d.pop("distribution")
    polydem.write_text(tmp_path / "a.dat", d)
    assert polydem.read_text(tmp_path / "a.dat")["radii"].tolist() == [1.0] * 20
    polydem.write_particles(tmp_path / "b.txt", d)
    assert filecmp.cmp(tmp_path / "a.dat", tmp_path / "b.txt", shallow=False)
    if polydem.with_hdf5:
        polydem.write_snapshot(tmp_path / "c.h5", d)
        np.testing.assert_array_equal(polydem.read_snapshot(tmp_path / "c.h5")["positions"], d["positions"])
    assert polydem.formats()[0] == "text"
