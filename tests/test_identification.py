"""Identification (opendyn.algorithm.identification): from noise-free torques, identify finds
the robot's exact base parameters, as many as the rank of Pinocchio's stacked regressor, and
combinations that reproduce every torque through Pinocchio's regressor; its standard deviations
match the spread of the estimates over repeated noise; identify_payload recovers a payload
exactly without noise and, in the shipped UR5 example (a scene's computed-torque excitation,
accelerations filtered from the velocities, 1% torque noise), within 1% in mass and 5 mm in
centre of mass, inside its reported standard deviations.
"""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest

import opendyn as od

pytest.importorskip("pinocchio")
from pin_adapter import PinOracle
from test_pinocchio import URDFS

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / "scripts" / "identify_payload.py"
UR5 = next(p for p in URDFS if p.endswith("ur5_robot.urdf"))


def samples(model, n, seed):
    rng = np.random.default_rng(seed)
    q = np.array([od.random_configuration(model, rng) for _ in range(n)])
    return q, *rng.normal(size=(2, n, model.nv))


def test_identify_finds_the_exact_base_parameters_of_noise_free_torques():
    model = od.load_urdf(UR5)
    P = PinOracle(UR5, model)
    q, qd, qdd = samples(model, 60, 1)
    tau = od.inverse_dynamics(model, q, qd, qdd)
    found = od.identify(model, q, qd, qdd, tau)
    pi = model.inertial_parameters()
    truth = found.base @ pi
    assert np.abs(found.parameters - truth).max() <= 1e-8 * np.abs(truth).max()
    # Pinocchio's regressor, stacked: the same rank, and the base parameters reproduce its
    # torques through the independent columns
    W = np.concatenate([P.torque_regressor(*state) for state in zip(q, qd, qdd)])
    assert found.rank == np.linalg.matrix_rank(W) == 36
    assert np.abs(W[:, found.independent] @ truth - W @ pi).max() <= 1e-9 * np.abs(W @ pi).max()
    assert found.base[np.arange(found.rank), found.independent].tolist() == [1.0] * found.rank
    assert len(found.grouping) == found.rank and found.names[0] == "m[shoulder_link]"
    assert found.residual_rms <= 1e-10 and np.isfinite(found.condition_number)


def test_identify_with_friction_finds_each_joints_coefficients():
    model = od.load_urdf("solo12", floating_base=True)
    q, qd, qdd = samples(model, 40, 2)
    nj = len(model.joint_names)
    rng = np.random.default_rng(3)
    fv, fc = rng.uniform(0.05, 0.5, size=(2, nj))
    tau = od.inverse_dynamics(model, q, qd, qdd)
    joints = np.asarray(model.v_index)
    tau[:, joints] += fv * qd[:, joints] + fc * np.sign(qd[:, joints])
    found = od.identify(model, q, qd, qdd, tau, friction=True)
    full = np.r_[model.inertial_parameters(), fv, fc]
    truth = found.base @ full
    assert np.abs(found.parameters - truth).max() <= 1e-8 * np.abs(truth).max()
    for k, joint in enumerate(model.joint_names):
        for name, value in ((f"fv[{joint}]", fv[k]), (f"fc[{joint}]", fc[k])):
            (row,) = [r for r, g in enumerate(found.grouping) if g == name]
            assert found.parameters[row] == pytest.approx(value, rel=1e-8)


def test_reported_standard_deviations_match_the_spread_over_repeated_noise():
    model = od.load_urdf(UR5)
    q, qd, qdd = samples(model, 40, 4)
    tau = od.inverse_dynamics(model, q, qd, qdd)
    rng = np.random.default_rng(5)
    estimates, reported = [], []
    for _ in range(300):
        found = od.identify(model, q, qd, qdd, tau + 0.05 * rng.normal(size=tau.shape))
        estimates.append(found.parameters)
        reported.append(found.std)
    ratio = np.std(estimates, axis=0) / np.mean(reported, axis=0)
    # 300 draws estimate a standard deviation to about 4%: 15% is five of those
    assert np.all(np.abs(ratio - 1.0) < 0.15), ratio


def test_identify_payload_recovers_a_payload_exactly_without_noise():
    model = od.load_urdf(UR5)
    I_c = np.array([[4e-3, 1e-4, -2e-4], [1e-4, 6e-3, 3e-4], [-2e-4, 3e-4, 9e-3]])
    loaded = model.with_payload("tool0", 2.5, com=(0.01, -0.02, 0.05), inertia=I_c)
    q, qd, qdd = samples(model, 30, 6)
    found = od.identify_payload(model, "tool0", q, qd, qdd, od.inverse_dynamics(loaded, q, qd, qdd))
    assert found.mass == pytest.approx(2.5, rel=1e-9)
    np.testing.assert_allclose(found.com, (0.01, -0.02, 0.05), rtol=0, atol=1e-10)
    np.testing.assert_allclose(found.inertia, I_c, rtol=0, atol=1e-10)
    assert found.mass_std < 1e-9


def test_the_ur5_payload_example_recovers_mass_and_centre_of_mass_within_its_errors():
    spec = importlib.util.spec_from_file_location("identify_payload", SCRIPT)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    found = example.main([])
    mass_error, com_error = found.mass - example.MASS, found.com - np.array(example.COM)
    assert abs(mass_error) <= 0.01 * example.MASS
    assert np.linalg.norm(com_error) <= 5e-3
    # the reported standard deviations cover the errors (three of them)
    assert abs(mass_error) <= 3 * found.mass_std
    assert np.all(np.abs(com_error) <= 3 * found.com_std), (com_error, found.com_std)


def test_bad_samples_are_clear_errors():
    model = od.load_urdf(UR5)
    q, qd, qdd = samples(model, 3, 7)
    tau = od.inverse_dynamics(model, q, qd, qdd)
    with pytest.raises(ValueError, match="do not overdetermine"):
        od.identify(model, q, qd, qdd, tau)
    with pytest.raises(ValueError, match=r"tau must have shape \(6,\)"):
        od.identify(model, q, qd, qdd, tau[:, :5])
    with pytest.raises(KeyError, match="not a frame"):
        od.identify_payload(model, "no_such_frame", q, qd, qdd, tau)
    with pytest.raises(ValueError, match="welded to the fixed world"):
        od.identify_payload(model, "base_link", q, qd, qdd, tau)
    # the same state over and over: a few combinations of the payload's parameters at most
    still = [np.repeat(x[:1], 20, axis=0) for x in (q, qd, qdd, tau)]
    with pytest.raises(ValueError, match="do not excite the payload's parameters"):
        od.identify_payload(model, "tool0", *still)
