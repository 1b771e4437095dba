"""opendyn.verify: every contract function against Pinocchio on one robot, as a table.

The checks must pass on robots where opendyn is right (the shipped double pendulum, the UR5, a
seeded random tree, coupled mimic joints), and must fail where a function is deliberately made
wrong, so that a PASS means something.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import sys

import numpy as np
import pytest
from randtree import write_random_tree

import opendyn as od

# the module, whatever opendyn/__init__ re-exports under the name "verify"
V = importlib.import_module("opendyn.verify.contract")

needs_pinocchio = pytest.mark.skipif(
    importlib.util.find_spec("pinocchio") is None, reason="Pinocchio (pin) is not installed"
)
needs_erd = pytest.mark.skipif(
    "ur5" not in od.available_robots(), reason="example-robot-data is not installed"
)

FUNCTIONS = [
    "inverse_dynamics",
    "inverse_dynamics[f_tip]",
    "inverse_dynamics[gravity]",
    "mass_matrix",
    "gravity_forces",
    "coriolis_forces",
    "bias_forces",
    "coriolis_matrix",
    "christoffel_symbols",
    "forward_dynamics[aba]",
    "forward_dynamics[crba]",
    "forward_dynamics[newton_euler]",
    "inverse_dynamics_derivatives",
    "forward_dynamics_derivatives",
    "frame_pose",
    "jacobian[space]",
    "jacobian[body]",
    "kinetic_energy",
    "potential_energy",
    "task_space_mass_matrix",
    "center_of_mass",
    "center_of_mass_jacobian",
    "centroidal_momentum_matrix",
    "centroidal_momentum",
    "centroidal_momentum_rate_bias",
    "torque_regressor",
]

# a 2-link arm whose second moving link has no <inertial>: M(q) is singular (its last row and
# column are zero), so forward dynamics has no answer and must be refused
MASSLESS_TIP_URDF = """<?xml version="1.0"?>
<robot name="massless_tip">
  <link name="base"/>
  <link name="upper">
    <inertial>
      <origin xyz="0 0 -0.5"/>
      <mass value="2.0"/>
      <inertia ixx="0.1" iyy="0.2" izz="0.15" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <link name="tip"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/>
    <child link="upper"/>
    <axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/>
  </joint>
  <joint name="wrist" type="continuous">
    <parent link="upper"/>
    <child link="tip"/>
    <origin xyz="0 0 -1"/>
    <axis xyz="1 0 0"/>
  </joint>
</robot>
"""


def by_function(checks):
    return {c.function: c for c in checks}


@needs_pinocchio
def test_double_pendulum_agrees_with_pinocchio_on_every_function():
    model = od.load_urdf("double_pendulum")
    checks = V.verify(model, states=4, seed=3)
    assert [c.function for c in checks] == FUNCTIONS
    for c in checks:
        assert c.passed and c.max_rel_error <= 1e-9, (c.function, c.max_rel_error, c.note)
    rows = by_function(checks)
    assert all(rows[f].states == 4 for f in FUNCTIONS if f != "task_space_mass_matrix")
    # two joints cannot move a frame in six directions: Lambda is undefined, not compared
    assert rows["task_space_mass_matrix"].states == 0
    assert "nv = 2 < 6" in rows["task_space_mass_matrix"].note


@needs_pinocchio
@needs_erd
def test_ur5_agrees_with_pinocchio_on_every_function_including_task_space():
    checks = V.verify("ur5")
    assert [c.function for c in checks] == FUNCTIONS
    for c in checks:
        assert c.passed and c.states == 5, (c.function, c.max_rel_error, c.states, c.note)


@needs_pinocchio
@pytest.mark.parametrize("seed", [0, 5])
def test_random_tree_agrees_with_pinocchio(tmp_path, seed):
    """Branches from the root, continuous (cos/sin in Pinocchio), prismatic and fixed joints."""
    checks = V.verify(str(write_random_tree(tmp_path, seed)), states=3, seed=seed)
    failed = [(c.function, c.max_rel_error, c.note) for c in checks if not c.passed]
    assert not failed
    assert {c.function for c in checks} == set(FUNCTIONS)


@needs_pinocchio
@needs_erd
def test_coupled_mimic_joints_agree_with_pinocchio():
    """The Panda's second finger mimics the first: 8 coordinates for 9 moving joints. Where
    Pinocchio lacks an algorithm for mimic joints the oracle composes it from RNEA and CRBA."""
    model = od.load_urdf("panda", mimic=True)
    assert (model.nv, model.nb) == (8, 9)
    checks = V.verify(model, states=3)
    failed = [(c.function, c.max_rel_error, c.note) for c in checks if not c.passed]
    assert not failed
    # Pinocchio's dccrba and joint-torque regressor refuse mimic joints: nothing to compare
    unanswered = {"centroidal_momentum_rate_bias", "torque_regressor"}
    assert all(c.states == 3 for c in checks if c.function not in unanswered)
    for c in checks:
        if c.function in unanswered:
            assert c.states == 0 and "no reference" in c.note


@needs_pinocchio
def test_singular_mass_matrix_must_be_refused_by_forward_dynamics(tmp_path):
    path = tmp_path / "massless_tip.urdf"
    path.write_text(MASSLESS_TIP_URDF)
    rows = by_function(V.verify(str(path), states=2))
    for method in ("aba", "crba", "newton_euler"):
        row = rows[f"forward_dynamics[{method}]"]
        assert row.passed and row.states == 2
        assert "M is singular: refused as expected" in row.note


@needs_pinocchio
def test_a_forward_dynamics_that_answers_a_singular_mass_matrix_fails(tmp_path, monkeypatch):
    path = tmp_path / "massless_tip.urdf"
    path.write_text(MASSLESS_TIP_URDF)
    monkeypatch.setattr(V, "forward_dynamics", lambda model, q, *a, **kw: np.zeros(model.nv))
    row = by_function(V.verify(str(path), states=1))["forward_dynamics[aba]"]
    assert not row.passed
    assert "M is singular, but opendyn returned an answer" in row.note


@needs_pinocchio
def test_a_wrong_mass_matrix_fails_its_row_and_only_its_row(monkeypatch):
    right = V.mass_matrix
    monkeypatch.setattr(V, "mass_matrix", lambda model, q: right(model, q) + 1e-6)
    model = od.load_urdf("double_pendulum")
    checks = V.verify(model, states=2)
    rows = by_function(checks)
    wrong = rows["mass_matrix"]
    assert not wrong.passed
    # every entry is off by exactly 1e-6 (up to rounding); the pendulum's M has entries above 1
    assert wrong.max_abs_error == pytest.approx(1e-6, rel=1e-6)
    assert wrong.max_rel_error < wrong.max_abs_error
    assert "worst at state" in wrong.note
    assert [c.function for c in checks if not c.passed] == ["mass_matrix"]
    table = V.format_table(checks, model)
    row_line = next(line for line in table.splitlines() if line.startswith("mass_matrix "))
    assert row_line.split()[-1] == "FAIL"
    assert "FAILED: 1 of 26 functions: mass_matrix" in table


@needs_pinocchio
def test_a_wrong_centroidal_momentum_matrix_fails_its_row_and_only_its_row(monkeypatch):
    """Linear rows first, as Pinocchio's ccrba has them, is the mistake to catch."""
    right = V.centroidal_momentum_matrix
    monkeypatch.setattr(
        V, "centroidal_momentum_matrix", lambda model, q: np.roll(right(model, q), 3, axis=0)
    )
    checks = V.verify("double_pendulum", states=2)
    assert [c.function for c in checks if not c.passed] == ["centroidal_momentum_matrix"]


@needs_pinocchio
def test_an_error_raised_by_opendyn_is_a_failed_row_naming_it(monkeypatch):
    def broken(model, q, frame, expressed_in="space"):
        raise RuntimeError("kernel exploded")

    monkeypatch.setattr(V, "jacobian", broken)
    rows = by_function(V.verify("double_pendulum", states=1))
    for where in ("space", "body"):
        row = rows[f"jacobian[{where}]"]
        assert not row.passed and row.max_rel_error == np.inf
        assert "opendyn raised RuntimeError: kernel exploded" in row.note
    assert rows["frame_pose"].passed


@needs_pinocchio
def test_table_names_robot_nv_rtol_and_every_function():
    model = od.load_urdf("planar_3r")
    checks = V.verify(model, states=2, rtol=1e-10)
    table = V.format_table(checks, model)
    header = table.splitlines()[0]
    assert "'planar_3r'" in header and "nv = 3" in header and "rtol = 1e-10" in header
    lines = table.splitlines()
    for function in FUNCTIONS:
        (line,) = [line for line in lines if line.split()[:1] == [function]]
        assert line.split()[-1] == ("n/a" if function == "task_space_mass_matrix" else "PASS")
    assert "all 25 compared functions agree with Pinocchio" in table


def test_random_states_lie_within_the_joint_limits(tmp_path):
    """A joint with limits stays within them; a continuous joint within +-pi."""
    path = tmp_path / "massless_tip.urdf"
    path.write_text(MASSLESS_TIP_URDF)
    model = od.load_urdf(str(path))
    assert list(model.continuous) == [False, True]
    lo, hi = np.array([-2.0, -np.pi]), np.array([2.0, np.pi])
    for seed in (1, 2):
        states = list(V.random_states(model, 200, seed=seed))
        assert len(states) == 200
        for q, qd, qdd, tau, F in states:
            assert np.all(lo <= q) and np.all(q <= hi)
            assert qd.shape == qdd.shape == tau.shape == (model.nv,) and F.shape == (6,)
        Q = np.array([s[0] for s in states])
        # they fill the range: some q beyond 90% of each bound
        assert np.all(Q.max(axis=0) > 0.9 * hi) and np.all(Q.min(axis=0) < 0.9 * lo)
        again = list(V.random_states(model, 200, seed=seed))
        assert all(np.array_equal(a[0], b[0]) for a, b in zip(states, again))


def test_missing_pinocchio_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "pinocchio", None)  # makes `import pinocchio` fail
    with pytest.raises(ImportError, match="opendyn verify needs Pinocchio: pip install pin") as e:
        V.verify("double_pendulum")
    assert isinstance(e.value, V.PinocchioMissingError)
    assert str(e.value) == "opendyn verify needs Pinocchio: pip install pin"


@needs_pinocchio
def test_a_model_without_a_urdf_file_is_refused_naming_it():
    model = od.load_urdf("double_pendulum")
    orphan = dataclasses.replace(model, source="")
    with pytest.raises(ValueError, match="'double_pendulum' has no URDF file"):
        V.verify(orphan)
