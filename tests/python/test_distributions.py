"""Size distributions, start packings and predict: the CLI's own recipes."""
import numpy as np
import pytest

import polydem
from conftest import field


def test_start_packing_is_what_generate_writes(cli, tmp_path):
    path = tmp_path / "g.txt"
    cli("generate", "--dist", "uv", "--omega", "4", "-n", "300", "--phi", "0.3", "--seed", "2", "-o", path)
    cli_data = polydem.read_particles(path)
    p = polydem.start_packing(polydem.Distribution("uv", rmin=1, omega=4), 300, 0.3, seed=2)
    np.testing.assert_array_equal(p["positions"], cli_data["positions"])
    np.testing.assert_array_equal(p["radii"], cli_data["radii"])
    assert p["box"] == cli_data["box"]
    assert p["distribution"] == cli_data["attributes"]["distribution"]


def test_sampling_and_moments():
    d = polydem.Distribution("uniform-radius", rmin=1.0, omega=3.0)
    r = d.sample(10000, "systematic", seed=5)
    assert r.dtype == np.float64 and r.shape == (10000,)
    assert np.all(np.diff(r) >= 0)  # systematic samples are ascending
    assert r.min() >= 1.0 and r.max() <= 3.0
    m = d.moments()
    # Uniform on [1, 3]: <r> = 2, <r^2> = 13/3, <r^3> = 10.
    assert m["raw"][1] == pytest.approx(2.0, rel=1e-12)
    assert m["raw"][2] == pytest.approx(13.0 / 3.0, rel=1e-12)
    assert m["raw"][3] == pytest.approx(10.0, rel=1e-12)
    s = polydem.sample_moments(r)
    assert s["raw"][3] == pytest.approx(10.0, rel=1e-4)
    random = d.sample(1000, "random", seed=5)
    assert not np.all(np.diff(random) >= 0)
    assert polydem.Distribution("mono", rmin=2.0).moments()["kurtosis"] is None  # undefined, not nan


def test_equivalent_mixtures_match_moments():
    d = polydem.Distribution("uv", rmin=1.0, omega=10.0)
    m = d.moments()
    for nodes in (2, 3):
        mix = d.equivalent_mixture(nodes)
        a = np.array(mix["radius"])
        n = np.array(mix["number_fraction"])
        assert len(a) == nodes and n.sum() == pytest.approx(1.0)
        for k in range(2 * nodes):
            assert (n * a ** k).sum() == pytest.approx(m["raw"][k], rel=1e-8)
    radii = polydem.mixture_radii(d.equivalent_mixture(2), 1000)
    assert radii.shape == (1000,) and len(set(radii.tolist())) == 2


def test_predict_matches_cli(cli):
    d = polydem.Distribution("uv", rmin=1.0, omega=5.0)
    p = polydem.predict(d, phi=[0.3, 0.5])
    out = cli("predict", "--dist", "uv", "--omega", "5", "--phi", "0.3,0.5").stdout
    bmcsl = float(field(out, r"^\s+0\.3000\s+([0-9.]+)"))
    assert p["compressibility"]["BMCSL"][0] == pytest.approx(bmcsl, abs=5e-6)
    first = p["jamming"][0]
    assert f"{first['value']:.4f}  {first['equation']}" in out
    assert p["bounds"][0] <= p["bounds"][1] <= p["bounds"][2]
    with pytest.raises(polydem.ConfigError, match="phi: packing fraction 1.2"):
        polydem.predict(d, phi=[1.2])
