"""The joint-torque regressor and the inertial parameters (opendyn.algorithm.regressor,
Model.inertial_parameters, Model.with_inertial_parameters): Y against Pinocchio's
computeJointTorqueRegressor on every example-robot-data URDF it loads, fixed and floating, and on
seeded random trees, to 1e-9 relative; Y @ pi against inverse_dynamics (itself checked against
Pinocchio's RNEA) on the same robots, with coupled mimic joints and with gravity overridden;
the friction columns against the friction torques they stand for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import opendyn as od

pytest.importorskip("pinocchio")
from randtree import write_random_tree
from test_pinocchio import MIMIC, URDFS, _load, _states, assert_close


def _check_regressor(model, P):
    pi = model.inertial_parameters()
    assert pi.shape == (10 * model.nb,)
    for q, (qd, qdd, _) in _states(model, 6):
        Y = od.torque_regressor(model, q, qd, qdd)
        assert_close(Y, P.torque_regressor(q, qd, qdd), "torque_regressor")
        assert_close(Y @ pi, od.inverse_dynamics(model, q, qd, qdd), "Y @ pi")


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("path", URDFS, ids=[Path(p).stem for p in URDFS])
def test_torque_regressor_matches_pinocchio_and_inverse_dynamics(path, floating_base):
    _check_regressor(*_load(path, floating_base=floating_base))


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("seed", range(4))
def test_torque_regressor_matches_pinocchio_on_random_trees(tmp_path, seed, floating_base):
    _check_regressor(*_load(str(write_random_tree(tmp_path, seed)), floating_base=floating_base))


COUPLED = [p for p in MIMIC if Path(p).stem in ("baxter", "panda", "pr2", "romeo")]


@pytest.mark.parametrize("path", COUPLED, ids=[Path(p).stem for p in COUPLED])
def test_regressor_of_coupled_mimic_joints_gives_their_inverse_dynamics(path):
    model = od.load_urdf(path, check_inertia=False, mimic=True)
    assert model.coupled
    pi = model.inertial_parameters()
    for q, (qd, qdd, _) in _states(model, 2):
        assert_close(
            od.torque_regressor(model, q, qd, qdd) @ pi,
            od.inverse_dynamics(model, q, qd, qdd),
            "Y @ pi (mimic)",
        )


def test_regressor_takes_the_gravity_inverse_dynamics_takes():
    model = od.load_urdf("solo12", floating_base=True)
    rng = np.random.default_rng(1)
    g_moon = np.array([0.3, -0.2, -1.62])
    q, qd, qdd = od.random_configuration(model, rng), *rng.normal(size=(2, model.nv))
    assert_close(
        od.torque_regressor(model, q, qd, qdd, gravity=g_moon) @ model.inertial_parameters(),
        od.inverse_dynamics(model, q, qd, qdd, gravity=g_moon),
        "Y(gravity) @ pi",
    )


def test_friction_columns_give_viscous_and_coulomb_torques():
    model = od.load_urdf("solo12", floating_base=True)
    rng = np.random.default_rng(4)
    nj = len(model.joint_names)
    fv, fc = rng.uniform(0.1, 1.0, size=(2, nj))
    q, qd, qdd = od.random_configuration(model, rng), *rng.normal(size=(2, model.nv))
    Y = od.torque_regressor(model, q, qd, qdd, friction=True)
    assert Y.shape == (model.nv, 10 * model.nb + 2 * nj)
    expected = od.inverse_dynamics(model, q, qd, qdd)
    joints = np.asarray(model.v_index)
    expected[joints] += fv * qd[joints] + fc * np.sign(qd[joints])
    assert_close(Y @ np.r_[model.inertial_parameters(), fv, fc], expected, "Y_f @ (pi, fv, fc)")
    # the base's six rows carry no friction
    assert not Y[:6, 10 * model.nb :].any()


def test_a_batch_stacks_the_states_rows():
    model = od.load_urdf("ur5")
    rng = np.random.default_rng(6)
    n = 200
    q, qd, qdd = rng.normal(size=(3, n, model.nv))
    Y = od.torque_regressor(model, q, qd, qdd, friction=True)
    assert Y.shape == (n * model.nv, 10 * model.nb + 2 * model.nv)
    for k in (0, 99, n - 1):
        rows = Y[k * model.nv : (k + 1) * model.nv]
        np.testing.assert_array_equal(
            rows, od.torque_regressor(model, q[k], qd[k], qdd[k], friction=True)
        )
    assert_close(
        Y[:, : 10 * model.nb] @ model.inertial_parameters(),
        od.inverse_dynamics(model, q, qd, qdd).ravel(),
        "stacked Y @ pi",
    )


def test_with_inertial_parameters_round_trips_and_changes_the_dynamics():
    model = od.load_urdf("ur5")
    same = model.with_inertial_parameters(model.inertial_parameters())
    for field in ("G", "mass", "h", "I_o"):
        np.testing.assert_array_equal(getattr(same, field), getattr(model, field))
    # a payload changes exactly its body's ten parameters, and the new model's dynamics are
    # Y @ its parameters
    loaded = model.with_payload("tool0", 2.5, com=(0.0, 0.0, 0.05))
    pi, pi_loaded = model.inertial_parameters(), loaded.inertial_parameters()
    body = model.frames[model.frame_index("tool0")].body
    changed = np.flatnonzero(pi != pi_loaded)
    assert set(changed) <= set(range(10 * body, 10 * body + 10)) and pi_loaded[10 * body] == (
        pi[10 * body] + 2.5
    )
    rebuilt = model.with_inertial_parameters(pi_loaded)
    rng = np.random.default_rng(8)
    q, qd, qdd = rng.normal(size=(3, model.nv))
    assert_close(
        od.inverse_dynamics(rebuilt, q, qd, qdd),
        od.inverse_dynamics(loaded, q, qd, qdd),
        "dynamics of with_inertial_parameters",
    )


def test_physically_invalid_parameters_are_refused_naming_the_body():
    model = od.load_urdf("ur5")
    pi = model.inertial_parameters()
    names = model.body_names
    with pytest.raises(ValueError, match=r"pi must have shape \(60,\)"):
        model.with_inertial_parameters(pi[:-1])
    with pytest.raises(ValueError, match="pi must be finite"):
        model.with_inertial_parameters(np.r_[np.nan, pi[1:]])
    with pytest.raises(TypeError, match="pi must be an array of numbers"):
        model.with_inertial_parameters(["1"] * 60)
    negative = pi.copy()
    negative[20] = -1.0
    for check_inertia in (True, False):
        with pytest.raises(ValueError, match=rf"body {names[2]!r} \(pi\[20:30\]\): negative mass"):
            model.with_inertial_parameters(negative, check_inertia=check_inertia)
    # body 3's inertia about its centre of mass with one principal moment larger than the sum
    # of the others (I_zz about the body origin raised far above)
    flat = pi.copy()
    flat[39] += 10.0
    with pytest.raises(ValueError, match=rf"body {names[3]!r} \(pi\[30:40\]\): .*triangle"):
        model.with_inertial_parameters(flat)
    kept = model.with_inertial_parameters(flat, check_inertia=False)
    assert kept.I_o[3, 2, 2] == model.I_o[3, 2, 2] + 10.0
    not_definite = pi.copy()
    not_definite[4 + 10] -= 1.0  # I_xx of body 1 below zero about its centre of mass
    with pytest.raises(ValueError, match=rf"body {names[1]!r} .*positive semi-definite"):
        model.with_inertial_parameters(not_definite)
    moment_without_mass = pi.copy()
    moment_without_mass[0:2] = 0.0, 0.1
    with pytest.raises(ValueError, match="no mass but a first moment"):
        model.with_inertial_parameters(moment_without_mass)


def test_bad_arguments_are_clear_errors_naming_them():
    model = od.load_urdf("ur5")
    z = np.zeros(model.nv)
    with pytest.raises(TypeError, match="model must be an opendyn Model"):
        od.torque_regressor(None, z, z, z)
    with pytest.raises(ValueError, match=r"qdd must have shape \(6,\)"):
        od.torque_regressor(model, z, z, z[:3])
    with pytest.raises(ValueError, match="qd must be finite"):
        od.torque_regressor(model, z, np.full(6, np.inf), z)
    with pytest.raises(ValueError, match="gravity must be a 3-vector"):
        od.torque_regressor(model, z, z, z, gravity=(0, 9.81))
