"""The public API as a user meets it: argument errors that name the argument, batches, task
space, the model's documented fields, and the compiled kernels' view of the model buffers."""

from __future__ import annotations

import numpy as np
import pytest

import opendyn as od
from opendyn.multibody import layout
from opendyn.spatial.algebra import adjoint

STATE_FUNCTIONS = {
    "inverse_dynamics": lambda m, x: od.inverse_dynamics(m, x, x, x),
    "mass_matrix": lambda m, x: od.mass_matrix(m, x),
    "gravity_forces": lambda m, x: od.gravity_forces(m, x),
    "coriolis_forces": lambda m, x: od.coriolis_forces(m, x, x),
    "bias_forces": lambda m, x: od.bias_forces(m, x, x),
    "coriolis_matrix": lambda m, x: od.coriolis_matrix(m, x, x),
    "christoffel_symbols": lambda m, x: od.christoffel_symbols(m, x),
    "forward_dynamics aba": lambda m, x: od.forward_dynamics(m, x, x, x),
    "forward_dynamics crba": lambda m, x: od.forward_dynamics(m, x, x, x, method="crba"),
    "forward_dynamics newton_euler": lambda m, x: od.forward_dynamics(
        m, x, x, x, method="newton_euler"
    ),
    "frame_pose": lambda m, x: od.frame_pose(m, x, "tool0"),
    "jacobian space": lambda m, x: od.jacobian(m, x, "tool0"),
    "jacobian body": lambda m, x: od.jacobian(m, x, "tool0", expressed_in="body"),
    "kinetic_energy": lambda m, x: od.kinetic_energy(m, x, x),
    "potential_energy": lambda m, x: od.potential_energy(m, x),
}


@pytest.fixture(scope="module")
def ur5():
    return od.load_urdf("ur5")


@pytest.fixture(scope="module")
def states(ur5):
    return np.random.default_rng(3).uniform(-2, 2, (5, ur5.nv))


@pytest.mark.parametrize("name", STATE_FUNCTIONS)
@pytest.mark.parametrize(
    "bad, error, message",
    [
        (np.zeros(5), ValueError, "shape"),
        (np.zeros((2, 3, 6)), ValueError, "shape"),
        ([[0.0] * 6, [0.0] * 5], ValueError, "array of numbers"),
        ("abc", TypeError, "array of numbers"),
        (np.r_[0, 0, np.nan, 0, 0, 0], ValueError, "finite"),
        (np.r_[0, np.inf, 0, 0, 0, 0], ValueError, "finite"),
    ],
)
def test_bad_state_raises_an_error_naming_the_argument(ur5, name, bad, error, message):
    with pytest.raises(error, match=message) as info:
        STATE_FUNCTIONS[name](ur5, bad)
    assert "q" in str(info.value)


def test_error_names_the_argument_that_is_not_finite(ur5):
    q, bad = np.zeros(6), np.r_[0, 0, 0, 0, 0, np.nan]
    for args, name in (((q, bad, q), "qd"), ((q, q, bad), "qdd"), ((bad, q, q), "q")):
        with pytest.raises(ValueError, match=f"{name} must be finite"):
            od.inverse_dynamics(ur5, *args)
    with pytest.raises(ValueError, match="tau must be finite"):
        od.forward_dynamics(ur5, q, q, bad)


def test_bad_options_are_named(ur5):
    q = np.zeros(6)
    with pytest.raises(KeyError, match="'no_such_link'.*valid frames"):
        od.jacobian(ur5, q, "no_such_link")
    with pytest.raises(KeyError, match="no_such_link"):
        od.inverse_dynamics(ur5, q, q, q, f_tip={"no_such_link": np.zeros(6)})
    with pytest.raises(ValueError, match="method must be one of aba, crba, newton_euler"):
        od.forward_dynamics(ur5, q, q, q, method="euler")
    with pytest.raises(ValueError, match="expressed_in"):
        od.jacobian(ur5, q, "tool0", expressed_in="world")
    with pytest.raises(ValueError, match="gravity must be a 3-vector"):
        od.gravity_forces(ur5, q, gravity=[0, -9.81])
    with pytest.raises(ValueError, match=r"f_tip\['tool0'\] must have shape"):
        od.inverse_dynamics(ur5, q, q, q, f_tip={"tool0": np.zeros(3)})
    with pytest.raises(ValueError, match=r"f_tip\['tool0'\] must be finite"):
        od.inverse_dynamics(ur5, q, q, q, f_tip={"tool0": np.full(6, np.nan)})
    with pytest.raises(ValueError, match="a batch must have one N"):
        od.inverse_dynamics(ur5, np.zeros((3, 6)), np.zeros((4, 6)), q)


def test_lists_and_integer_arrays_are_accepted(ur5):
    q = [0.1, -0.2, 0.3, 0.0, 0.5, -0.4]
    expected = od.inverse_dynamics(ur5, np.array(q), np.zeros(6), np.zeros(6))
    np.testing.assert_array_equal(od.inverse_dynamics(ur5, q, [0] * 6, np.zeros(6, int)), expected)


@pytest.mark.parametrize("name", STATE_FUNCTIONS)
def test_a_batch_equals_the_states_one_by_one(ur5, states, name):
    fn = STATE_FUNCTIONS[name]
    batch = np.asarray(fn(ur5, states))
    assert batch.shape[0] == len(states)
    for k, x in enumerate(states):
        np.testing.assert_allclose(batch[k], fn(ur5, x), rtol=1e-13, atol=1e-13)


def test_a_non_contiguous_state_gives_the_same_answer(ur5, states):
    q = states[0]
    q_strided = np.zeros(12)[::2]
    q_strided[:] = q
    np.testing.assert_array_equal(
        od.inverse_dynamics(ur5, q_strided, q_strided, q_strided), od.inverse_dynamics(ur5, q, q, q)
    )


def test_batch_f_tip_per_state(ur5, states):
    F = np.random.default_rng(4).normal(size=(len(states), 6))
    batch = od.inverse_dynamics(ur5, states, states, states, f_tip={"tool0": F})
    for k in range(len(states)):
        np.testing.assert_allclose(
            batch[k],
            od.inverse_dynamics(ur5, states[k], states[k], states[k], f_tip={"tool0": F[k]}),
            rtol=1e-13,
            atol=1e-12,
        )


def test_kernel_views_of_the_model_buffers_match_the_documented_fields(ur5):
    parent, jtype, nv_j, iq, iv, mult, offset, S, R_home, p_home = layout.tree(
        ur5._ibuf, ur5._fbuf
    )
    mass, h, I_o = layout.rigid_inertias(ur5._ibuf, ur5._fbuf)
    G = layout.spatial_inertias(ur5._ibuf, ur5._fbuf)
    for ours, field in (
        (parent, ur5.parent),
        (jtype, ur5.jtype),
        (nv_j, ur5.nv_j),
        (iq, ur5.iq),
        (iv, ur5.iv),
        (mult, ur5.mult),
        (offset, ur5.offset),
        (S, ur5.S),
        (S[:, 0], ur5.A),
        (R_home, ur5.R_home),
        (p_home, ur5.p_home),
        (mass, ur5.mass),
        (h, ur5.h),
        (I_o, ur5.I_o),
        (G, ur5.G),
    ):
        np.testing.assert_array_equal(ours, field)
    # the rigid-body form is the spatial inertia G = [[I_o, [h]], [[h]^T, m 1]]
    np.testing.assert_array_equal(ur5.G[:, 3, 3], ur5.mass)
    np.testing.assert_array_equal(ur5.G[:, :3, :3], ur5.I_o)


def test_the_model_is_frozen(ur5):
    with pytest.raises(ValueError):
        ur5.A[0, 0] = 2.0
    with pytest.raises(ValueError):
        ur5.lower[0] = 0.0
    with pytest.raises(AttributeError):
        ur5.name = "other"


def test_task_space_mass_matrix_is_the_seed_formula_for_a_square_jacobian(ur5, states):
    """Lambda = J^-T M J^-1 (seed, "Dynamics in the Task Space") for the 6-joint UR5."""
    for q in states:
        J = od.jacobian(ur5, q, "tool0", expressed_in="body")
        M = od.mass_matrix(ur5, q)
        J_inv = np.linalg.inv(J)
        np.testing.assert_allclose(
            od.task_space_mass_matrix(ur5, q, "tool0"), J_inv.T @ M @ J_inv, rtol=1e-8, atol=1e-8
        )


def test_task_space_equation_of_motion_holds(ur5, states):
    """F = Lambda dV_b + eta with dV_b = J_b qdd + Jdot_b qd, for the F that tau = J_b^T F
    produces: seed eq. F = Lambda(theta) dV + eta(theta, V)."""
    rng = np.random.default_rng(5)
    for q in states:
        qd, F = rng.normal(size=6), rng.normal(size=6)
        J = od.jacobian(ur5, q, "tool0", expressed_in="body")
        qdd = od.forward_dynamics(ur5, q, qd, J.T @ F)
        dV = od.frame_acceleration(ur5, q, qd, qdd, "tool0")
        Lambda = od.task_space_mass_matrix(ur5, q, "tool0")
        eta = od.task_space_bias(ur5, q, qd, "tool0")
        np.testing.assert_allclose(Lambda @ dV + eta, F, rtol=1e-7, atol=1e-7)


def test_frame_acceleration_is_the_derivative_of_the_body_twist(ur5, states):
    """dV_b = d/dt (J_b(q(t)) qd(t)) along q(t) = q + qd t + qdd t^2 / 2 (central difference)."""
    rng = np.random.default_rng(6)
    q, qd, qdd, h = states[0], rng.normal(size=6), rng.normal(size=6), 1e-6

    def V_b(t):
        return od.jacobian(ur5, q + qd * t + qdd * t * t / 2, "tool0", "body") @ (qd + qdd * t)

    np.testing.assert_allclose(
        od.frame_acceleration(ur5, q, qd, qdd, "tool0"),
        (V_b(h) - V_b(-h)) / (2 * h),
        rtol=1e-6,
        atol=1e-6,
    )


def test_task_space_of_a_frame_that_cannot_move_in_six_directions():
    """A 3-joint arm's tool cannot move in six directions: Lambda is refused with a clear
    error, or damped on request, never silent garbage."""
    planar = od.load_urdf("planar_3r")
    q = np.zeros(planar.nv)
    with pytest.raises(od.SingularTaskSpaceError, match="cannot move in every task direction"):
        od.task_space_mass_matrix(planar, q, "tool")
    damped = od.task_space_mass_matrix(planar, q, "tool", damping=1e-3)
    assert np.all(np.isfinite(damped))
    np.testing.assert_allclose(damped, damped.T, atol=1e-9)


def test_space_and_body_jacobians_are_related_by_the_adjoint(ur5, states):
    for q in states:
        np.testing.assert_allclose(
            od.jacobian(ur5, q, "tool0"),
            adjoint(od.frame_pose(ur5, q, "tool0")) @ od.jacobian(ur5, q, "tool0", "body"),
            atol=1e-12,
        )


@pytest.mark.parametrize("mimic", [False, True])
def test_coriolis_matrix_is_the_christoffel_contraction(mimic):
    """C[i, j] = sum_k Gamma[i, j, k] qd_k on a fixed base (Gamma symmetrises dC/dqd, so this
    holds only when C(qd) w = C(w) qd, as for joint coordinates), C qd = c, and Mdot - 2C skew,
    also with coupled mimic joints (the Panda's fingers)."""
    model = od.load_urdf("panda", mimic=mimic)
    assert (model.nv < model.nb) == mimic
    rng = np.random.default_rng(8)
    for _ in range(3):
        q, qd = rng.uniform(-1, 1, (2, model.nv))
        C = od.coriolis_matrix(model, q, qd)
        np.testing.assert_allclose(C, od.christoffel_symbols(model, q) @ qd, atol=1e-12)
        np.testing.assert_allclose(C @ qd, od.coriolis_forces(model, q, qd), atol=1e-12)
        h = 1e-6
        Mdot = (od.mass_matrix(model, q + h * qd) - od.mass_matrix(model, q - h * qd)) / (2 * h)
        N = Mdot - 2 * C
        np.testing.assert_allclose(N, -N.T, atol=1e-8)
