"""CONTRIBUTING.md, "Adding an integrator", done as it says: an explicit Runge-Kutta method is one
row of INTEGRATORS in opendyn/sim/integrators.py (its name, order, kind, whether it adapts, and
its Butcher tableau). In a copy of the package with only that file changed, the explicit
midpoint rule (Hairer, Norsett & Wanner, Solving ODE I, Table 1.1: A = [[0, 0], [1/2, 0]],
b = (0, 1), c = (0, 1/2)) is a scene's `run.integrator`, is offered by `opendyn simulate
--integrator`, and converges at its order 2 on the double pendulum."""

from __future__ import annotations

from test_adding_an_effect import changed_files, copy_of_the_package, run_in

_MIDPOINT_ROW = """    "midpoint": Integrator(
        "midpoint", 2, EXPLICIT_RK, False, "explicit midpoint rule",
        A=np.array([[0, 0], [0.5, 0]]), b=np.array([0.0, 1.0]), c=np.array([0.0, 0.5]),
    ),
"""

_RUN_THE_MIDPOINT_RULE = r"""
import numpy as np

import opendyn as od
from opendyn.cli.main import command_line
from opendyn.io.urdf import shipped_robots_dir

assert command_line().parse_args(["simulate", "--integrator", "midpoint"]).integrator == "midpoint"
settings = {
    "robot": {"urdf": str(shipped_robots_dir() / "double_pendulum.urdf")},
    "initial": {"q": [1.0, -0.5]},
    "effects": {"gravity": True},
    "run": {"duration": 0.5, "integrator": "midpoint", "output_dt": 0.02},
}
scene = od.scene_from_dict(settings)
assert scene.run.integrator == "midpoint"
reference = od.simulate(scene.replace_run(integrator="rk4", dt=1e-4)).q[-1]
errors = [
    np.abs(od.simulate(scene.replace_run(dt=dt)).q[-1] - reference).max()
    for dt in (4e-3, 2e-3, 1e-3)
]
orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
print("errors", errors, "orders", orders)
assert np.all(np.abs(orders - 2.0) < 0.2), orders
print("the midpoint rule runs")
"""


def test_an_integrator_is_one_row_of_the_table(tmp_path):
    copy = copy_of_the_package(tmp_path)
    integrators = copy / "sim" / "integrators.py"
    text = integrators.read_text()
    anchor = "INTEGRATORS = {\n"
    assert anchor in text
    integrators.write_text(text.replace(anchor, anchor + _MIDPOINT_ROW, 1))
    assert changed_files(copy) == ["sim/integrators.py"]
    proc = run_in(copy, _RUN_THE_MIDPOINT_RULE)
    assert proc.returncode == 0, proc.stderr
    assert "the midpoint rule runs" in proc.stdout
