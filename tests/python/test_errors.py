"""Bad inputs raise the module's exceptions, with the CLI's messages naming the key, option or file."""
import numpy as np
import pytest

import polydem

BASE = {
    "particles": {"count": 50, "packing_fraction": 0.2},
    "contact": {"stiffness": 1e4},
    "run": {"steps": 10, "progress_interval": 0.0},
}


def with_key(section, key, value):
    scene = {s: dict(v) for s, v in BASE.items()}
    scene.setdefault(section, {})[key] = value
    return scene


def cli_message(cli, tmp_path, scene):
    path = tmp_path / "scene.toml"
    path.write_text(polydem.scene_toml(scene))
    result = cli("relax", path, "-q", check=False, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    line = [ln for ln in result.stderr.splitlines() if ln.startswith("polydem: ")][-1]
    return line.split(": ", 2)[2]  # after "polydem: configuration error: "


def test_exception_hierarchy():
    assert issubclass(polydem.ConfigError, ValueError)
    assert issubclass(polydem.InputError, ValueError) and issubclass(polydem.InputError, OSError)
    assert issubclass(polydem.SimulationError, RuntimeError)


@pytest.mark.parametrize("section,key,value,named", [
    ("run", "dt_factor", 2, "run.dt_factor"),
    ("run", "stepz", 5, "stepz"),
    ("contact", "restitution", 1.5, "contact.restitution"),
    ("particles", "distribution", "gaussian", "gaussian"),
    ("run", "broadphase", "octree", "octree"),
    ("box", "boundaries", "sideways", "sideways"),
])
def test_scene_errors_match_the_cli(cli, tmp_path, section, key, value, named):
    scene = with_key(section, key, value)
    with pytest.raises(polydem.ConfigError) as error:
        polydem.Simulation(scene)
    assert named in str(error.value)
    assert str(error.value) == cli_message(cli, tmp_path, scene)


def test_scene_value_types():
    with pytest.raises(polydem.ConfigError, match="run.steps: a object cannot be a scene value"):
        polydem.Simulation(with_key("run", "steps", object()))
    with pytest.raises(polydem.ConfigError, match="run.steps: scene sections hold values, not tables"):
        polydem.Simulation(with_key("run", "steps", {"a": 1}))


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(OSError, match="missing.txt: cannot open for reading"):
        polydem.read_particles(tmp_path / "missing.txt")
    bad = tmp_path / "bad.txt"
    bad.write_text("3 1 1 1\n0.5 0.5 0.5 0.1\n")
    with pytest.raises(polydem.InputError, match=r"bad.txt:2: truncated: expected 3 particles"):
        polydem.read_particles(bad)
    with pytest.raises(ValueError):
        polydem.read_particles(bad)
    with pytest.raises(OSError, match="cannot open scene file"):
        polydem.Simulation.from_file(tmp_path / "nope.toml")
    scene = with_key("particles", "file", str(tmp_path / "absent.txt"))
    del scene["particles"]["count"], scene["particles"]["packing_fraction"]
    with pytest.raises(polydem.InputError, match="absent.txt: cannot open for reading"):
        polydem.Simulation(scene)


def test_simulation_error_on_blow_up():
    scene = with_key("run", "dt", 1e-2)
    scene["run"]["allow_unstable_dt"] = True
    scene["particles"]["packing_fraction"] = 0.3
    scene["velocities"] = {"initial": "impact", "overlap": 0.05}
    sim = polydem.Simulation(scene)
    with pytest.raises(polydem.SimulationError, match="step"):
        sim.step(2000)


def test_api_argument_errors():
    with pytest.raises(polydem.ConfigError, match="unknown broad phase|octree"):
        polydem.BroadPhase("octree")
    with pytest.raises(polydem.ConfigError, match="omega"):
        polydem.Distribution("uv", rmin=1, omega=0.5)
    with pytest.raises(polydem.ConfigError, match="sampling 'sorted'"):
        polydem.Distribution("uv", rmin=1, omega=2).sample(10, sampling="sorted")
    bp = polydem.BroadPhase("linked-cell")
    with pytest.raises(polydem.ConfigError, match="positions: expected an array of shape"):
        bp.build(np.zeros((10, 4)), np.ones(10), (20, 20, 20))
    with pytest.raises(polydem.ConfigError, match="radii: 9 radii for 10 centres"):
        bp.build(np.zeros((10, 3)), np.ones(9), (20, 20, 20))
    with pytest.raises(polydem.ConfigError, match="find_pairs: call build"):
        bp.find_pairs()
    x = np.array([[1.0, 1.0, 1.0], [30.0, 1.0, 1.0]])
    with pytest.raises(polydem.ConfigError, match="outside the box"):
        bp.build(x, np.ones(2), (20, 20, 20))
    with pytest.raises(polydem.ConfigError, match="boundary 'sideways'"):
        polydem.Box((1, 1, 1), "sideways")
    with pytest.raises(polydem.ConfigError, match="particle data: 'radii' is required"):
        polydem.write_particles("x.txt", {"positions": np.zeros((1, 3)), "box": (1, 1, 1)})
