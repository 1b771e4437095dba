"""What a first import and a second kind of run cost: `import opendyn` imports no layer (each
public name is imported when first used, and is then the object of its module), and the
compiled step a plain run of a scene made serves a Python controller and a rollout of it."""

from __future__ import annotations

import ast
import os
import pathlib
import subprocess
import sys

import numba
import numpy as np
import pytest
from numba.core import types

import opendyn as od
from opendyn.sim import effects, integrators, step
from opendyn.sim.rollout import BATCH_LOOP_SECONDS

INIT = pathlib.Path(od.__file__)


def test_import_opendyn_imports_neither_numpy_nor_numba_nor_a_layer():
    code = (
        "import sys, opendyn\n"
        "heavy = [m for m in ('numpy', 'numba', 'scipy', 'yourdfpy', 'opendyn.algorithm', "
        "'opendyn.sim', 'opendyn.io') if m in sys.modules]\n"
        "print(heavy, opendyn.__version__)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split("]")[0] == "[", out.stdout


def test_every_public_name_is_the_object_its_module_defines():
    for name in od.__all__:
        value = getattr(od, name)
        module = sys.modules[value.__module__]
        assert getattr(module, name) is value, name
    assert set(od.__all__) <= set(dir(od))


def test_the_lazy_table_lists_exactly_the_public_names():
    tree = ast.parse(INIT.read_text(encoding="utf-8"))
    block = next(n for n in tree.body if isinstance(n, ast.If))
    listed = {alias.name for line in block.body for alias in line.names}
    assert listed == set(od.__all__)


def test_an_unknown_name_is_an_attribute_error_and_a_subpackage_is_imported():
    with pytest.raises(AttributeError, match="has no attribute 'mass_matrx'"):
        od.mass_matrx  # noqa: B018
    assert od.sim is sys.modules["opendyn.sim"]
    from opendyn import load_urdf  # noqa: F401  (from-imports go through the same table)


def test_a_public_name_wins_over_the_subpackage_of_the_same_name():
    """opendyn.sweep is the function, though importing the layer opendyn/sweep/ binds it."""
    from opendyn.sweep import engine

    assert od.sweep is engine.sweep
    assert od.sweep.__module__ == "opendyn.sweep.engine"


def pendulum_scene():
    return od.load_scene("double_pendulum_swing").replace_run(duration=0.05)


def test_a_python_controller_runs_the_step_a_plain_run_compiled():
    """The compiled step is chosen by the numba type of its SceneData: a Simulator that holds a
    Python caller's torque has the same type as a plain run's, so it reuses that compilation."""
    scene = pendulum_scene()
    table = effects.stage_table(scene)
    plain = step.scene_data(scene.model, table)
    sim = od.Simulator(scene, controller=lambda t, q, qd: np.ones(2), control_dt=0.01)
    assert numba.typeof(sim._data) == numba.typeof(plain)
    # and the held torque is applied: a constant 1 N m on each joint is work put in
    sim.step(duration=0.05)
    traj = sim.trajectory()
    assert np.allclose(traj.tau[1:], 1.0)
    assert np.all(np.diff(traj.work_applied) != 0.0)


def test_a_rollout_calls_the_fixed_step_loop_that_simulate_compiled():
    scene = pendulum_scene()
    od.simulate(scene)
    simulate_compiled = set(integrators.run_fixed.signatures)
    od.rollout(scene, q0=np.zeros((2, 2)))
    step0 = [signature[3] for signature in integrators.run_fixed.signatures]
    assert step0 and all(not isinstance(t, types.Literal) for t in step0), step0
    assert set(integrators.run_fixed.signatures) == simulate_compiled


_ROLLOUT_AFTER_A_PLAIN_RUN = r"""
import numpy as np, opendyn as od
from opendyn._runtime.compile_notice import compile_seconds
from opendyn.sim import rollout_loops
result = od.rollout(od.load_scene("double_pendulum_swing").replace_run(duration=0.05),
                    q0=np.zeros((2, 2)))
loops = rollout_loops.rollout_fixed.stats.cache_misses
print(result.stats["compile_s"] == compile_seconds() > 0, dict(loops) != {})
"""


def test_a_rollout_after_a_plain_run_compiles_its_batch_loop_alone_and_says_so(tmp_path):
    """In a cache where a plain run of the scene compiled its step and record, a rollout's one
    compile notice estimates its batch loop alone, and its stats report all it compiled."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    plain = "import opendyn as od; od.simulate(od.load_scene('double_pendulum_swing'))"
    subprocess.run([sys.executable, "-c", plain], env=env, capture_output=True, check=True)
    out = subprocess.run(
        [sys.executable, "-c", _ROLLOUT_AFTER_A_PLAIN_RUN],
        env=env, capture_output=True, text=True, check=True,
    )
    assert out.stdout.split() == ["True", "True"], out.stderr
    notices = [line for line in out.stderr.splitlines() if line.startswith("opendyn: compiling")]
    assert len(notices) == 1 and "the rollout loop for rk4 with gravity" in notices[0], notices
    assert f"about {BATCH_LOOP_SECONDS} s on 2 cores" in notices[0], notices


_RUN_FROM_THE_CACHE = r"""
import sys, numpy as np, opendyn as od
from opendyn._runtime.compile_notice import compile_seconds
traj = od.simulate(od.load_scene("double_pendulum_swing").replace_run(duration=0.05))
loaded = "numba.np.random.legacy" not in sys.modules and compile_seconds() == 0.0
print(loaded, repr(traj.q[-1].tolist()))
"""


def test_a_process_that_only_loads_kernels_imports_none_of_numbas_compiler_registries():
    """numba refreshes its whole target context (every lowering registry: its random number
    generators, array math with scipy's BLAS, ...) before each cache load; opendyn's kernels
    load without it (kernel_cache.loads_without_refresh), and run as compiled."""
    expected = od.simulate(pendulum_scene()).q[-1]  # compiled here, or loaded
    out = subprocess.run(
        [sys.executable, "-c", _RUN_FROM_THE_CACHE], capture_output=True, text=True, check=True
    )
    loaded, q_end = out.stdout.strip().splitlines()[-1].split(" ", 1)
    assert loaded == "True", out.stderr
    np.testing.assert_array_equal(np.array(ast.literal_eval(q_end)), expected)


def test_the_collision_queries_compile_notice_says_how_long_they_take(capsys):
    """Compiling distances or collisions takes 27-36 s on 2 cores: their notice says so
    (not "a few seconds")."""
    from opendyn._runtime import compile_notice
    from opendyn.algorithm.collision import queries

    for kernel in (queries.distances_kernel, queries.collisions_kernel):
        compile_notice._watch._announce(kernel)
        compile_notice._watch.bar.close()
        compile_notice._watch.bar = None
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert f"compiling opendyn.algorithm.collision.queries.{kernel.py_func.__name__} " in line
        assert "(20-35 s on 2 cores;" in line and "a few seconds" not in line
