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


def generated(cli, tmp_path, name, seed, walls=False):
    path = tmp_path / name
    args = ["generate", "--dist", "bi", "--omega", "2", "-n", "40", "--seed", seed, "-o", path]
    cli(*args, *(["--boundary", "walls"] if walls else []))
    return path


def test_lammps_data_is_the_cli_file(cli, tmp_path):
    text = generated(cli, tmp_path, "g.txt", 3)
    cli("convert", text, tmp_path / "cli.data")
    d = polydem.read_particles(text)
    polydem.write_particles(tmp_path / "py.data", d)  # by extension
    assert filecmp.cmp(tmp_path / "py.data", tmp_path / "cli.data", shallow=False)
    polydem.write_lammps_data(tmp_path / "explicit.txt", d)  # whatever the extension
    assert filecmp.cmp(tmp_path / "explicit.txt", tmp_path / "cli.data", shallow=False)
    back = polydem.read_lammps_data(tmp_path / "cli.data", boundaries="periodic,periodic,wall")
    np.testing.assert_array_equal(back["positions"], d["positions"])
    np.testing.assert_array_equal(back["radii"], d["radii"])
    assert back["box"].boundaries == ("periodic", "periodic", "wall")
    assert polydem.read_particles(tmp_path / "cli.data")["box"].boundaries == ("periodic",) * 3
    # Atom types come back as an array and are written again.
    types = np.where(d["radii"] > 1.5, 2.0, 1.0)
    polydem.write_lammps_data(tmp_path / "typed.data", dict(d, arrays={"type": types}))
    typed = polydem.read_lammps_data(tmp_path / "typed.data")
    assert typed["arrays"]["type"].dtype == np.float64
    np.testing.assert_array_equal(typed["arrays"]["type"], types)
    with pytest.raises(polydem.InputError, match="cli.txt"):
        (tmp_path / "cli.txt").write_text("LAMMPS data file\n\n40 atoms\nbroken\n")
        polydem.read_lammps_data(tmp_path / "cli.txt")


def test_lammps_dump_frames_are_the_cli_file(cli, tmp_path):
    a, b = generated(cli, tmp_path, "a.txt", 1), generated(cli, tmp_path, "b.txt", 2)
    cli("convert", a, b, tmp_path / "cli.dump")
    frames = [polydem.read_particles(a), polydem.read_particles(b)]
    polydem.write_lammps_dump(tmp_path / "py.dump", frames)
    assert filecmp.cmp(tmp_path / "py.dump", tmp_path / "cli.dump", shallow=False)
    back = polydem.read_lammps_dump(tmp_path / "cli.dump")
    assert len(back) == 2
    for mine, theirs in zip(back, frames):
        np.testing.assert_array_equal(mine["positions"], theirs["positions"])
        np.testing.assert_array_equal(mine["id"], theirs["id"])
    # A one-frame dump is a particle file; two frames are not.
    polydem.write_lammps_dump(tmp_path / "one.dump", frames[0])
    np.testing.assert_array_equal(polydem.read_particles(tmp_path / "one.dump")["radii"], frames[0]["radii"])
    with pytest.raises(polydem.InputError, match="2 frames"):
        polydem.read_particles(tmp_path / "cli.dump")
    # Per-particle arrays become dump columns and come back.
    force = np.arange(120, dtype=float).reshape(40, 3)
    polydem.write_lammps_dump(tmp_path / "f.dump", dict(frames[0], arrays={"force": force}))
    np.testing.assert_array_equal(polydem.read_lammps_dump(tmp_path / "f.dump")[0]["arrays"]["force"], force)
    with pytest.raises(polydem.ConfigError, match="frames"):
        polydem.write_lammps_dump(tmp_path / "none.dump", [])


@pytest.mark.skipif(not polydem.with_hdf5, reason="XDMF series refer to HDF5 snapshots")
def test_xdmf_series_is_the_cli_file(cli, tmp_path):
    snaps = []
    for k in range(2):
        d = polydem.read_particles(generated(cli, tmp_path, f"s{k}.txt", k + 1))
        d["time"] = 0.5 * k
        snaps.append(tmp_path / f"s{k}.h5")
        polydem.write_particles(snaps[-1], d)
    cli("convert", "--series", tmp_path / "cli.xmf", *snaps)
    assert polydem.write_xdmf_series(tmp_path / "py.xmf", snaps) == 2
    assert filecmp.cmp(tmp_path / "py.xmf", tmp_path / "cli.xmf", shallow=False)
    assert "xdmf-series" in polydem.formats() and "lammps-dump" in polydem.formats()
    assert str(polydem.series_path_for("out/snap_{step}.h5")) == "out/snap_series.xmf"
    with pytest.raises(polydem.ConfigError, match="not an HDF5 snapshot"):
        polydem.write_xdmf_series(tmp_path / "bad.xmf", [tmp_path / "s0.txt"])
    with pytest.raises(polydem.ConfigError, match="must end in .xmf"):
        polydem.write_xdmf_series(tmp_path / "bad.h5", snaps)
    with pytest.raises(polydem.ConfigError, match="sidecar"):
        polydem.write_xdmf_series(polydem.xdmf_path(snaps[0]), snaps)


def test_bad_arrays_are_refused(tmp_path):
    d = polydem.start_packing(polydem.Distribution("mono"), 10, 0.2, seed=1)
    d.pop("distribution")
    with pytest.raises(polydem.ConfigError, match="array 'force' is 3 x 9"):
        polydem.write_particles(tmp_path / "a.dump", dict(d, arrays={"force": np.zeros((9, 3))}))
    with pytest.raises(polydem.ConfigError, match="arrays\\['bad'\\]"):
        polydem.write_particles(tmp_path / "a.dump", dict(d, arrays={"bad": np.zeros((10, 2))}))
