"""jam and analyze: the CLI's compression and contact network."""
import filecmp

import numpy as np
import pytest

import polydem
from conftest import field


def test_jam_then_analyze():
    blocks = []
    r = polydem.jam(polydem.Distribution("mono"), count=100, seed=2, target_pressure=1e5,
                    progress=lambda p: blocks.append(p["pressure"]))
    assert r["target_reached"] and r["pressure"] >= 1e5
    assert 0.62 < r["packing_fraction"] < 0.7
    assert blocks and blocks[-1] == r["pressure"]
    assert r["positions"].shape == (100, 3) and r["radii"].shape == (100,)
    net = r["network"]
    i, j = net["contacts"]
    assert i.dtype == np.int32 and len(i) > 250
    assert net["coordination"].shape == (100,) and net["rattler"].dtype == np.bool_
    a = polydem.analyze({"positions": r["positions"], "radii": r["radii"], "box": r["box"]},
                        pressure=r["pressure"])
    assert len(a["contacts"][0]) == len(i)
    assert a["valid"] and a["z"] == pytest.approx(net["z"])


def test_analyze_matches_cli(cli, tmp_path):
    path = tmp_path / "j.txt"
    cli("jam", "-n", "100", "--target-pressure", "1e5", "--seed", "2", "-o", path)
    out = cli("analyze", path).stdout
    a = polydem.analyze(str(path), taus=[1e-6, 1e-3])
    assert int(field(out, r"^contacts \(gap <= [0-9.e+-]+\) (\d+)")) == len(a["contacts"][0])
    assert f"{a['z']:.4f}" == field(out, r"^contacts .* z = ([0-9.]+)")
    assert int(field(out, r"^backbone +(\d+) spheres")) == a["backbone"]
    assert f"1e-06:{a['z_of_tau'][0]:.3f}" in out


def test_analyze_needs_a_pressure():
    d = polydem.start_packing(polydem.Distribution("mono"), 50, 0.3, seed=1)
    with pytest.raises(polydem.ConfigError, match="no reduced_pressure attribute"):
        polydem.analyze({"positions": d["positions"], "radii": d["radii"], "box": d["box"]})
    overlapping = polydem.start_packing(polydem.Distribution("mono"), 50, 0.3, seed=1, placement="overlapping")
    with pytest.raises(polydem.InputError, match="not a valid hard-sphere packing"):
        polydem.analyze({k: overlapping[k] for k in ("positions", "radii", "box")}, contact_gap=1e-6)
    assert not polydem.check_packing({k: overlapping[k] for k in ("positions", "radii", "box")})["valid"]


def test_jam_ctrl_c_stops_at_a_block_boundary(tmp_path):
    import os
    import signal
    import threading
    import time

    checkpoint = tmp_path / "ck.h5" if polydem.with_hdf5 else None
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            polydem.jam(polydem.Distribution("uv", rmin=1, omega=3), count=2000, seed=1, target_pressure=1e11,
                        checkpoint=checkpoint)
    finally:
        timer.cancel()
    assert time.monotonic() - start < 60
    if checkpoint:
        # The checkpoint was written at the boundary where the run stopped: it goes on from there.
        assert checkpoint.exists()
        r = polydem.resume_jam(checkpoint, stop_after_blocks=1)
        assert r["interrupted"] and r["positions"].shape == (2000, 3)


def test_jam_writes_the_cli_file(cli, tmp_path):
    cli("jam", "-n", "100", "--target-pressure", "1e5", "--seed", "2", "-o", tmp_path / "cli.txt")
    r = polydem.jam(polydem.Distribution("mono"), count=100, seed=2, target_pressure=1e5, output=tmp_path / "py.txt")
    assert r["output"] == str(tmp_path / "py.txt")
    assert filecmp.cmp(tmp_path / "py.txt", tmp_path / "cli.txt", shallow=False)
    eos = r["eos"]
    assert len(eos["phi"]) == r["blocks"] and eos["Z"][-1] == r["pressure"] and eos["phi"].dtype == np.float64
    assert np.all(np.diff(eos["phi"]) >= 0)


def test_jam_equivalent_mixture_matches_cli(cli, tmp_path):
    args = ["-n", "120", "--dist", "uv", "--omega", "3", "--equivalent", "bi", "--target-pressure", "1e4",
            "--seed", "3"]
    cli("jam", *args, "-o", tmp_path / "cli.txt")
    r = polydem.jam(polydem.Distribution("uv", rmin=1, omega=3), count=120, equivalent="bi", target_pressure=1e4,
                    seed=3, output=tmp_path / "py.txt")
    assert filecmp.cmp(tmp_path / "py.txt", tmp_path / "cli.txt", shallow=False)
    assert len(set(r["radii"].tolist())) == 2 and "bidisperse equivalent" in r["attributes"]["equivalent_mixture"]


def test_jam_reopen_and_run_collisions_match_cli(cli, tmp_path):
    jammed = tmp_path / "jammed.txt"
    cli("jam", "-n", "100", "--target-pressure", "1e6", "--seed", "4", "-o", jammed)
    args = ["--reopen", "1e4", "--schedule", "1e-2", "--target-pressure", "1e5", "--run-collisions", "50"]
    cli("jam", "-i", jammed, *args, "-o", tmp_path / "cli.txt")
    r = polydem.jam(packing=str(jammed), reopen=1e4, schedule="1e-2", target_pressure=1e5, run_collisions=50,
                    output=tmp_path / "py.txt")
    assert filecmp.cmp(tmp_path / "py.txt", tmp_path / "cli.txt", shallow=False)
    assert "reopened to p ~ 10000" in r["origin"]
    fixed = r["fixed_density"]
    assert fixed["collisions_per_particle"] == 50 and fixed["reduced_pressure"] == r["pressure"]
    assert fixed["compression_end_pressure"] >= 1e5
    with pytest.raises(polydem.ConfigError, match="not well above it"):
        polydem.jam(packing=str(jammed), reopen=1e6)
    with pytest.raises(polydem.ConfigError, match="reopen needs packing"):
        polydem.jam(polydem.Distribution("mono"), count=50, reopen=1e4)


def test_jam_checkpoint_and_resume_are_the_uninterrupted_run(cli, tmp_path):
    if not polydem.with_hdf5:
        pytest.skip("checkpoints are HDF5 files")
    run = dict(count=200, seed=5, schedule="1e-2:1e2,1e-3", target_pressure=1e6)
    dist = polydem.Distribution("bi", omega=1.4)
    whole = polydem.jam(dist, **run, output=tmp_path / "whole.txt")
    checkpoint = tmp_path / "ck.h5"
    stopped = polydem.jam(dist, **run, output=tmp_path / "part.txt", checkpoint=checkpoint, stop_after_blocks=15)
    assert stopped["interrupted"] and stopped["stop_reason"] == "interrupted" and stopped["blocks"] == 15
    assert not stopped["target_reached"] and checkpoint.exists()
    assert not filecmp.cmp(tmp_path / "part.txt", tmp_path / "whole.txt", shallow=False)  # the state at block 15
    # Stopped again later (the checkpoint is rewritten), then resumed to the end: the bytes of the whole run.
    again = polydem.resume_jam(checkpoint, stop_after_blocks=40)
    assert again["interrupted"] and again["blocks"] == 40
    done = polydem.resume_jam(checkpoint)
    assert done["target_reached"] and done["output"] == str(tmp_path / "part.txt")
    assert filecmp.cmp(tmp_path / "part.txt", tmp_path / "whole.txt", shallow=False)
    np.testing.assert_array_equal(done["positions"], whole["positions"])
    # The module's checkpoint is the CLI's: `polydem jam --resume` finishes it to the same bytes.
    polydem.jam(dist, **run, output=tmp_path / "c.txt", checkpoint=tmp_path / "c.h5", stop_after_blocks=20)
    result = cli("jam", "--resume", tmp_path / "c.h5", check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert filecmp.cmp(tmp_path / "c.txt", tmp_path / "whole.txt", shallow=False)


def test_jam_bad_inputs(tmp_path):
    mono = polydem.Distribution("mono")
    with pytest.raises(polydem.ConfigError, match="equivalent 'quad'"):
        polydem.jam(mono, count=50, equivalent="quad")
    with pytest.raises(polydem.ConfigError, match="block 0.5"):
        polydem.jam(mono, count=50, block=0.5)
    with pytest.raises(polydem.ConfigError, match="at least 2 spheres"):
        polydem.jam(mono, count=1)
    with pytest.raises(polydem.ConfigError, match="stop_after_blocks -1"):
        polydem.jam(mono, count=50, stop_after_blocks=-1)
    d = polydem.start_packing(mono, 50, 0.3, seed=1)
    with pytest.raises(polydem.ConfigError, match="cannot be combined with packing"):
        polydem.jam(packing={k: d[k] for k in ("positions", "radii", "box")}, equivalent="bi")
    with pytest.raises(polydem.ConfigError, match="the same file as the output"):
        polydem.jam(mono, count=50, output=tmp_path / "a.h5", checkpoint=tmp_path / "a.h5")
    with pytest.raises(polydem.InputError):
        polydem.resume_jam(tmp_path / "missing.h5")
