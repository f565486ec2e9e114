"""The DEM Simulation: byte-identical to `polydem relax`, numpy views, progress, Ctrl-C."""
import filecmp
import os
import signal
import threading

import numpy as np
import pytest

import polydem

# A small polydisperse frictional scene with walls across gravity (like tests/determinism/relax_reference.toml).
SCENE = {
    "particles": {"count": 250, "distribution": "uniform-volume", "rmin": 1e-3, "omega": 4.0,
                  "packing_fraction": 0.35, "density": 2500.0, "seed": 7},
    "box": {"boundaries": ["periodic", "periodic", "wall"]},
    "contact": {"stiffness": 1e4, "restitution": 0.6, "friction": 0.4},
    "run": {"steps": 500, "gravity": [0.0, 0.0, -9.81], "check_interval": 100, "progress_interval": 0.0},
}


def cli_final(cli, tmp_path, scene, name):
    """Write `scene` as a TOML file with output.final = NAME, run `polydem relax` on it, return the file."""
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(polydem.scene_toml(scene) + f'[output]\nfinal = "{name}"\n')
    cli("relax", scene_file, "-q", cwd=tmp_path)
    return tmp_path / name


@pytest.mark.parametrize("suffix", ["txt", "h5"])
def test_reproduces_relax_byte_for_byte(cli, tmp_path, suffix):
    if suffix == "h5" and not polydem.with_hdf5:
        pytest.skip("built without HDF5")
    reference = cli_final(cli, tmp_path, SCENE, f"cli.{suffix}")
    sim = polydem.Simulation(SCENE)
    assert sim.run() == SCENE["run"]["steps"]
    sim.check_stability()
    mine = tmp_path / f"py.{suffix}"
    sim.write(mine)
    assert filecmp.cmp(mine, reference, shallow=False)
    if suffix == "txt":
        # Also read back: the same arrays as the snapshot dict.
        back = polydem.read_particles(mine)
        snap = sim.snapshot()
        np.testing.assert_array_equal(back["positions"], snap["positions"])
        np.testing.assert_array_equal(back["velocities"], snap["velocities"])


def test_reproduces_relax_with_soft_compression_and_chunks(cli, tmp_path):
    scene = {
        "particles": {"count": 200, "distribution": "mono", "rmin": 1e-3, "packing_fraction": 0.3, "seed": 3},
        "contact": {"stiffness": 1e4, "restitution": 0.5},
        "compression": {"packing_fraction": 0.45},
        "run": {"steps": 300, "progress_interval": 0.0, "broadphase": "hgrid-td"},
    }
    reference = cli_final(cli, tmp_path, scene, "cli.txt")
    sim = polydem.Simulation(scene)
    assert sim.target_not_reached is None
    # Any split into step() calls and chunks gives the same trajectory.
    sim.step(7, chunk=3)
    sim.step(293, chunk=50)
    sim.write(tmp_path / "py.txt")
    assert filecmp.cmp(tmp_path / "py.txt", reference, shallow=False)


def test_from_file_matches_dict(tmp_path):
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(polydem.scene_toml(SCENE))
    a = polydem.Simulation.from_file(scene_file, overrides=["run.steps=50"])
    b = polydem.Simulation(SCENE, overrides=["run.steps=50"])
    assert a.steps == b.steps == 50
    a.run()
    b.run()
    np.testing.assert_array_equal(a.positions, b.positions)


def test_views_dtypes_and_shapes():
    sim = polydem.Simulation(SCENE)
    n = SCENE["particles"]["count"]
    x = sim.positions
    for name, shape, dtype in [("positions", (n, 3), np.float64), ("velocities", (n, 3), np.float64),
                               ("forces", (n, 3), np.float64), ("angular_velocities", (n, 3), np.float64),
                               ("radii", (n,), np.float64), ("inverse_masses", (n,), np.float64),
                               ("ids", (n,), np.int32)]:
        a = getattr(sim, name)
        assert a.shape == shape and a.dtype == dtype, name
        assert not a.flags.writeable, name
        assert np.shares_memory(a, getattr(sim, name)), name  # a view of the engine's array, not a copy
        with pytest.raises(ValueError):
            a[0] = 0
    before = x.copy()
    sim.step(20)
    assert np.shares_memory(x, sim.positions)
    assert not np.array_equal(before, x)  # the old view sees the new state
    assert sorted(sim.ids.tolist()) == list(range(n))
    # The snapshot (id order, copies) holds the same particles.
    snap = sim.snapshot()
    assert not np.shares_memory(snap["positions"], x)
    order = np.argsort(sim.ids)
    np.testing.assert_array_equal(snap["radii"], sim.radii[order])
    # A frictionless scene has no rotation arrays.
    plain = polydem.Simulation({**SCENE, "contact": {"stiffness": 1e4}})
    assert plain.angular_velocities is None


def test_energies_contacts_and_progress():
    sim = polydem.Simulation(SCENE)
    calls = []
    sim.step(450, progress=lambda step, target: calls.append((step, target)), chunk=100)
    assert calls == [(100, 450), (200, 450), (300, 450), (400, 450), (450, 450)]
    e = sim.energies()
    assert set(e) == {"kinetic", "rotational", "elastic", "potential", "total"}
    assert e["total"] == pytest.approx(e["kinetic"] + e["rotational"] + e["elastic"] + e["potential"], rel=1e-12)
    c = sim.contacts()
    assert c["contacts"] >= 0 and 0 <= c["max_overlap_ratio"] < 0.25
    assert sim.step_count == 450 and sim.time == pytest.approx(450 * sim.dt, rel=1e-12)
    assert 0.3 < sim.packing_fraction < 0.4


def test_ctrl_c_interrupts_cleanly():
    sim = polydem.Simulation(SCENE)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            sim.step(10 ** 9, chunk=50)
    finally:
        timer.cancel()
    stopped = sim.step_count
    assert 0 < stopped < 10 ** 9 and stopped % 50 == 0  # stopped after a complete chunk
    sim.step(10)  # and the run goes on
    assert sim.step_count == stopped + 10


def test_progress_callback_errors_propagate():
    sim = polydem.Simulation(SCENE)

    def fail(step, target):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        sim.step(100, progress=fail, chunk=10)
    assert sim.step_count == 10


def test_write_refuses_the_scene_file(tmp_path):
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(polydem.scene_toml(SCENE))
    sim = polydem.Simulation.from_file(scene_file)
    with pytest.raises(polydem.ConfigError, match="is the input"):
        sim.write(scene_file)
