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


needs_hdf5 = pytest.mark.skipif(not polydem.with_hdf5, reason="checkpoints are HDF5 files")


@needs_hdf5
def test_checkpoint_resume_is_byte_identical(cli, tmp_path):
    whole = polydem.Simulation(SCENE)
    whole.run()
    whole.write(tmp_path / "whole.txt")
    first = polydem.Simulation(SCENE)
    first.step(180)
    checkpoint = tmp_path / "ck.h5"
    first.save_checkpoint(checkpoint)
    again = polydem.Simulation.resume(checkpoint)
    assert again.step_count == 180 and again.steps == SCENE["run"]["steps"] and again.time == first.time
    np.testing.assert_array_equal(again.positions, first.positions)
    again.run()
    again.write(tmp_path / "resumed.txt")
    assert filecmp.cmp(tmp_path / "resumed.txt", tmp_path / "whole.txt", shallow=False)
    # `polydem relax --resume` continues the module's checkpoint to the same bytes.
    cli("relax", "--resume", checkpoint, "-q", "--set", 'output.final="cli.txt"', cwd=tmp_path)
    assert filecmp.cmp(tmp_path / "cli.txt", tmp_path / "whole.txt", shallow=False)


@needs_hdf5
def test_resume_a_cli_checkpoint(cli, tmp_path):
    scene = {
        "particles": {"count": 200, "distribution": "mono", "rmin": 1e-3, "packing_fraction": 0.3, "seed": 3},
        "contact": {"stiffness": 1e4, "restitution": 0.5},
        "compression": {"packing_fraction": 0.45},
        "run": {"steps": 300, "progress_interval": 0.0},
    }
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(polydem.scene_toml(scene) + '[output]\nfinal = "cli.txt"\ncheckpoint = "ck.h5"\n')
    cli("relax", scene_file, "-q", cwd=tmp_path)
    whole = polydem.Simulation(scene)
    whole.run()
    # The CLI's checkpoint at the end of its run (step 300), resumed for 100 more steps.
    resumed = polydem.Simulation.resume(tmp_path / "ck.h5", overrides=["run.steps=400"])
    assert resumed.step_count == 300 and resumed.steps == 400
    np.testing.assert_array_equal(resumed.positions, whole.positions)
    np.testing.assert_array_equal(resumed.velocities, whole.velocities)
    whole.step(100)
    resumed.run()
    whole.write(tmp_path / "whole.txt")
    resumed.write(tmp_path / "resumed.txt")
    assert filecmp.cmp(tmp_path / "resumed.txt", tmp_path / "whole.txt", shallow=False)


@needs_hdf5
def test_resume_a_cli_checkpoint_of_the_soft_compression(cli, tmp_path):
    """SIGINT during the CLI's soft compression leaves a checkpoint of phase "compression"; the module
    finishes the compression and the run to the bytes of an uninterrupted run."""
    import subprocess
    import time

    scene = {
        "particles": {"count": 300, "distribution": "mono", "rmin": 1e-3, "packing_fraction": 0.3, "seed": 4},
        "contact": {"stiffness": 1e4, "restitution": 0.5},
        "compression": {"packing_fraction": 0.5, "growth_rate": 2e-4},
        "run": {"steps": 100, "progress_interval": 0.0},
    }
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(polydem.scene_toml(scene) + '[output]\ncheckpoint = "ck.h5"\ncheckpoint_interval = 2000\n')
    proc = subprocess.Popen([os.path.abspath(os.environ["POLYDEM_CLI"]), "relax", str(scene_file), "-q"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + 60
    while not (tmp_path / "ck.h5").exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    log = proc.communicate(timeout=120)[0]
    if "soft compression interrupted" not in log:
        pytest.skip("the soft compression ended before the signal arrived (machine too fast)")
    resumed = polydem.Simulation.resume(tmp_path / "ck.h5")
    assert resumed.step_count == 0 and resumed.target_not_reached is None
    resumed.run()
    resumed.write(tmp_path / "resumed.txt")
    whole = polydem.Simulation(scene)
    whole.run()
    whole.write(tmp_path / "whole.txt")
    assert filecmp.cmp(tmp_path / "resumed.txt", tmp_path / "whole.txt", shallow=False)


@needs_hdf5
def test_resume_refuses_what_would_change_the_run(tmp_path):
    sim = polydem.Simulation(SCENE)
    sim.step(10)
    checkpoint = tmp_path / "ck.h5"
    sim.save_checkpoint(checkpoint)
    with pytest.raises(polydem.ConfigError, match="would change the trajectory"):
        polydem.Simulation.resume(checkpoint, overrides=["contact.friction=0.1"])
    resumed = polydem.Simulation.resume(checkpoint, overrides=["run.steps=20"])
    resumed.run()
    resumed.save_checkpoint(checkpoint)  # a resumed run checkpoints into its file again, as the CLI's
    assert polydem.Simulation.resume(checkpoint).step_count == 20
    with pytest.raises(polydem.ConfigError, match="ck.h5"):
        resumed.write(checkpoint)  # but no particle file goes over it
    with pytest.raises(polydem.InputError):
        polydem.Simulation.resume(tmp_path / "missing.h5")
    (tmp_path / "bad.h5").write_text("not a checkpoint")
    with pytest.raises(polydem.InputError):
        polydem.Simulation.resume(tmp_path / "bad.h5")
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(polydem.scene_toml(SCENE))
    from_file = polydem.Simulation.from_file(scene_file)
    with pytest.raises(polydem.ConfigError, match="is the input"):
        from_file.save_checkpoint(scene_file)


def test_relax_sweep_matches_cli(cli, tmp_path):
    import json

    scene = {**SCENE, "run": {**SCENE["run"], "steps": 200}}
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(polydem.scene_toml(scene))
    cli("relax", scene_file, "-q", "--sweep", "dt-factor=10,40,20", "--summary-json", tmp_path / "s.json", cwd=tmp_path)
    s = json.loads((tmp_path / "s.json").read_text())["sweep"]
    r = polydem.relax_sweep(scene, "dt-factor", [10, 40, 20])
    assert r["key"] == s["key"] == "dt-factor" and r["error_reference"] == s["error_reference"]
    assert r["values"].tolist() == s["values"] == [10.0, 20.0, 40.0]
    assert r["steps"].dtype == np.int64 and r["steps"].tolist() == s["steps"]
    assert r["position_error"].tolist() == s["position_error"] and r["position_error"][-1] == 0.0
    assert r["energy_error"] == s["energy_error"]
    assert r["wall_seconds"].shape == (3,) and np.all(r["wall_seconds"] > 0)
    with pytest.raises(polydem.ConfigError, match="only dt-factor and skin can be swept"):
        polydem.relax_sweep(scene, "friction", [0.1])
    with pytest.raises(polydem.ConfigError, match="below the smallest allowed value"):
        polydem.relax_sweep(scene, "dt-factor", [2])
