"""jam and analyze: the CLI's compression and contact network."""
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


def test_jam_ctrl_c_stops_at_a_block_boundary():
    import os
    import signal
    import threading
    import time

    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            polydem.jam(polydem.Distribution("uv", rmin=1, omega=3), count=2000, seed=1, target_pressure=1e11)
    finally:
        timer.cancel()
    assert time.monotonic() - start < 60
