"""docs/developing.md, "Adding an effect", done as the page says: its spring module, read from
the page as written, declares every part the registry asks for; put in a copy of the package as
opendyn/sim/effects/spring.py and registered with the page's one line of registry.py (no other
file of the copy changes; a fresh process and kernel cache run it), it is read from the page's
scene settings, switched off by Scene.without, and the step's acceleration is
M^-1 (-k (q - rest) - h) at random states, while a run's energy balance closes."""

from __future__ import annotations

import filecmp
import importlib.util
import os
import pathlib
import re
import shutil
import subprocess
import sys

from test_effects_registry import assert_declares_every_part

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGE = (ROOT / "docs" / "developing.md").read_text()
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
import sys

import numpy as np

import opendyn as od
from opendyn.io.scene.files import tomllib
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim import effects
from opendyn.sim.driver import Stepper
from opendyn.sim.effects import registry, spring

# the registry line: the spring after the limits, so the slots after it move
assert registry.EFFECTS.index(spring) == registry.EFFECTS.index(effects.registry.limits) + 1

scene = od.scene_from_dict(
    {
        "robot": {"urdf": str(shipped_robots_dir() / "double_pendulum.urdf")},
        "initial": {"q": [0.4, -0.3], "qd": [0.5, 0.2]},
        "run": {"duration": 1.0, "dt": 1e-3},
        "effects": {"gravity": True, **tomllib.loads(sys.argv[1])["effects"]},
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
    assert Stepper(scene, table).first_stage(t, q, qd, k, power, tau) == 0
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


def copy_of_the_package(into):
    """opendyn/ and robots/ copied into the folder `into` (without caches); returns its
    opendyn/."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "opendyn", into / "opendyn", ignore=ignore)
    shutil.copytree(ROOT / "robots", into / "robots", ignore=ignore)
    return into / "opendyn"


def changed_files(copy):
    """The files of the copy's package that differ from the source tree's, or are new."""
    changed = []
    for path in sorted(copy.rglob("*.py")):
        source = ROOT / "opendyn" / path.relative_to(copy)
        if not source.exists() or not filecmp.cmp(path, source, shallow=False):
            changed.append(str(path.relative_to(copy)))
    return changed


def run_in(copy, script, *args):
    """`script` run with the copy's package in a fresh process and kernel cache."""
    env = dict(os.environ, PYTHONPATH=str(copy.parent), NUMBA_CACHE_DIR=str(copy.parent / "k"))
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        cwd=copy.parent, env=env, capture_output=True, text=True, timeout=900,
    )


def test_the_page_s_spring_runs_in_a_scene_as_its_closed_form(tmp_path):
    copy = copy_of_the_package(tmp_path)
    (copy / "sim" / "effects" / "spring.py").write_text(page_block("python", 'NAME = "spring"'))
    registry = copy / "sim" / "effects" / "registry.py"
    text = registry.read_text()
    # the page's line: `from . import spring` and the spring after the limits in EFFECTS
    text = text.replace("from . import (\n", "from . import (\n    spring,\n", 1)
    text = text.replace("    limits,\n    wrench,\n", "    limits,\n    spring,\n    wrench,\n", 1)
    registry.write_text(text)
    assert changed_files(copy) == ["sim/effects/registry.py", "sim/effects/spring.py"]
    proc = run_in(copy, _RUN_THE_SPRING, page_block("toml", "[effects.spring]"))
    assert proc.returncode == 0, proc.stderr
    assert "the spring runs" in proc.stdout
