"""docs/developing.md, "Adding an effect", done as the page says: its spring module, read from
the page as written, declares every part the registry asks for; registered with the page's one
line (in a fresh process and kernel cache, so that nothing of it stays behind), it is read from
the page's scene settings, switched off by Scene.without, and the step's acceleration is
M^-1 (-k (q - rest) - h) at random states, while a run's energy balance closes."""

from __future__ import annotations

import importlib.util
import os
import pathlib
import re
import subprocess
import sys

from test_effects_registry import assert_declares_every_part

PAGE = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "developing.md").read_text()
MODULE_NAME = "opendyn.sim.effects.spring"  # where the page puts it


def page_block(language, containing):
    """The page's ```language block that contains `containing`."""
    (block,) = [
        b for b in re.findall(rf"^```{language}\n(.*?)^```", PAGE, re.M | re.S) if containing in b
    ]
    return block


def load_spring(path):
    spec = importlib.util.spec_from_file_location(MODULE_NAME, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[MODULE_NAME] = module
    spec.loader.exec_module(module)
    return module


def test_the_page_s_spring_declares_every_part(tmp_path, monkeypatch):
    path = tmp_path / "spring.py"
    path.write_text(page_block("python", 'NAME = "spring"'))
    monkeypatch.setitem(sys.modules, MODULE_NAME, None)  # taken out again afterwards
    assert_declares_every_part(load_spring(path))


_RUN_THE_SPRING = r"""
import importlib.util
import sys

import numpy as np

import opendyn as od
from opendyn.io.scene.files import tomllib
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim import effects
from opendyn.sim.effects import registry
from opendyn.sim.simulate import first_stage

# the page's module, as opendyn/sim/effects/spring.py
spec = importlib.util.spec_from_file_location("opendyn.sim.effects.spring", sys.argv[1])
spring = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = spring
spec.loader.exec_module(spring)
# the page's registry line: the spring after the limits, so the slots after it move
at = registry.EFFECTS.index(effects.limits) + 1
registry.EFFECTS = registry.EFFECTS[:at] + (spring,) + registry.EFFECTS[at:]

scene = od.scene_from_dict(
    {
        "robot": {"urdf": str(shipped_robots_dir() / "double_pendulum.urdf")},
        "initial": {"q": [0.4, -0.3], "qd": [0.5, 0.2]},
        "run": {"duration": 1.0, "dt": 1e-3},
        "effects": {"gravity": True, **tomllib.loads(sys.argv[2])["effects"]},
    }
)
assert scene.effects == ("gravity", "spring"), scene.effects
record = scene.other_effects["spring"]
assert np.all(record.stiffness == 20.0) and np.all(record.rest == [0.0, 0.5])
assert scene.without("spring").effects == ("gravity",)
table = effects.stage_table(scene)
assert table.names == ("gravity", "spring") and table.params(spring) is not None
try:
    od.scene_from_dict({"robot": scene.settings["robot"], "effects": {"spring": {"k": 1}}})
except od.SceneError as error:
    assert "effects.spring.k: unknown key" in str(error), error
else:
    raise AssertionError("an unknown key of [effects.spring] was accepted")

model = scene.model
rng = np.random.default_rng(5)
for _ in range(5):
    q, qd, t = rng.uniform(-3, 3, 2), rng.normal(size=2), rng.uniform(0, 1)
    k, power, tau = np.empty((2, 2)), np.empty(2), np.empty(2)
    assert first_stage(scene, table, t, q, qd, k, power, tau) == 0
    spring_tau = -record.stiffness * (q - record.rest)
    h = od.bias_forces(model, q, qd, gravity=scene.gravity)
    expected = np.linalg.solve(od.mass_matrix(model, q), spring_tau - h)
    np.testing.assert_allclose(k[1], expected, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(power, [0.0, qd @ spring_tau], rtol=1e-12, atol=1e-12)

traj = od.simulate(scene)
scale = np.abs(traj.energy).max()
assert traj.complete and np.abs(traj.work_passive).max() > 1e-2 * scale
assert np.abs(traj.energy_error).max() < 1e-8 * scale, np.abs(traj.energy_error).max()
print("the spring runs")
"""


def test_the_page_s_spring_runs_in_a_scene_as_its_closed_form(tmp_path):
    path = tmp_path / "spring.py"
    path.write_text(page_block("python", 'NAME = "spring"'))
    settings = page_block("toml", "[effects.spring]")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "kernels"))
    proc = subprocess.run(
        [sys.executable, "-c", _RUN_THE_SPRING, str(path), settings],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    assert "the spring runs" in proc.stdout
