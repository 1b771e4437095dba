"""Constrained dynamics: A(q) qd = 0, tau = M qdd + h + A^T lam
(opendyn.multibody.constraint_objects and opendyn.algorithm.constraints).

Against independent truths:
- Pinocchio: constraint rows against its frame Jacobians (LOCAL_WORLD_ALIGNED linear rows at the
  point; LOCAL for a weld), drifts against its classical (points) and spatial (weld) frame
  accelerations at a = 0, and qdd and lam against its constrained dynamics (constraintDynamics
  with CONTACT_3D / CONTACT_6D and zero regularisation; its KKT forwardDynamics for a plane).
  Pinocchio writes M a = tau - h + J^T lambda_pin, the force ON the robot: lam = -lambda_pin.
  Tolerance 1e-9 relative to the largest entry of the reference (or 1 when that is smaller).
- the seed's equations: A qdd + Adot qd = 0, P A^T = 0, P^2 = P, P tau = P (M qdd + h),
  constrained inverse then forward dynamics, J^T F_tip = A^T lam;
- finite differences along a trajectory: d/dt phi = A qd and d/dt (A qd) = A qdd + Adot qd,
  by the five-point central difference (error O(h^4));
- rank-deficient constraints against numpy's pseudo-inverse;
- the four-bar's loop-closure equations in Freudenstein's closed form;
- floating base (solo12 on four feet, a floating random tree with a loop, a weld to its base, a
  plane and a coupling): A v and A qdd + Adot v against derivatives of frame_pose along
  `integrate`, qdd and lam against numpy's KKT solve and Pinocchio's constraintDynamics with a
  JointModelFreeFlyer root, and a base welded to the world against the fixed-base robot.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import opendyn as od
from opendyn._runtime.status import Status, decode
from opendyn.algorithm import constraints as dc

RTOL = 1e-9
FD_STEP = 1e-3  # five-point stencil: truncation ~ h^4 |f^(5)| / 30, rounding ~ 1e-16 / h


def assert_close(ours, ref, what, rtol=RTOL):
    ours, ref = np.asarray(ours, dtype=float), np.asarray(ref, dtype=float)
    assert ours.shape == ref.shape, f"{what}: shape {ours.shape} != {ref.shape}"
    scale = max(1.0, float(np.abs(ref).max())) if ref.size else 1.0
    err = float(np.abs(ours - ref).max()) / scale if ref.size else 0.0
    assert err <= rtol, f"{what}: relative error {err:.3e} > {rtol:g}"


@pytest.fixture(scope="module")
def ur5():
    return od.load_urdf("ur5")


@pytest.fixture(scope="module")
def four_bar():
    return od.load_urdf("four_bar")


def _state(model, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2.0, 2.0, model.nv), rng.normal(size=model.nv), rng.normal(size=model.nv)


# ------------------------------------------------------------------------------------------
# the four-bar: Freudenstein's closed form (Norton, Design of Machinery, Section 4.5)

GROUND, CRANK, COUPLER, ROCKER = 0.8, 0.2, 0.7, 0.5  # d, a, b, c (m), as robots/four_bar.urdf


def four_bar_angles(theta2, a=CRANK, b=COUPLER, c=ROCKER, d=GROUND):
    """Open-branch theta3 (coupler) and theta4 (rocker, from the ground pivot O4) of a four-bar
    with the crank at theta2, from the vector loop a e^{i theta2} + b e^{i theta3} -
    c e^{i theta4} - d = 0 (Norton, eqs. 4.10 and 4.13):
      K1 = d/a, K2 = d/c, K3 = (a^2 - b^2 + c^2 + d^2) / (2 a c)
      A = cos t2 - K1 - K2 cos t2 + K3, B = -2 sin t2, C = K1 - (K2 + 1) cos t2 + K3
      theta4 = 2 atan2(-B - sqrt(B^2 - 4 A C), 2 A)
      K4 = d/b, K5 = (c^2 - d^2 - a^2 - b^2) / (2 a b)
      D = cos t2 - K1 + K4 cos t2 + K5, E = -2 sin t2, F = K1 + (K4 - 1) cos t2 + K5
      theta3 = 2 atan2(-E - sqrt(E^2 - 4 D F), 2 D)"""
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    K4, K5 = d / b, (c * c - d * d - a * a - b * b) / (2 * a * b)
    ct, st = np.cos(theta2), np.sin(theta2)
    A, B, C = ct - K1 - K2 * ct + K3, -2 * st, K1 - (K2 + 1) * ct + K3
    D, E, F = ct - K1 + K4 * ct + K5, -2 * st, K1 + (K4 - 1) * ct + K5
    theta4 = 2 * np.arctan2(-B - np.sqrt(B * B - 4 * A * C), 2 * A)
    theta3 = 2 * np.arctan2(-E - np.sqrt(E * E - 4 * D * F), 2 * D)
    return _wrap(theta3), _wrap(theta4)


def _wrap(angle):
    """The angle in [-pi, pi)."""
    return (angle + np.pi) % (2 * np.pi) - np.pi


def four_bar_q(theta2):
    """Joint angles (crank_joint, coupler_joint, rocker_joint) that close the loop: the rocker
    link points from the coupler's end to O4, at theta4 + pi."""
    theta3, theta4 = four_bar_angles(theta2)
    return _wrap(np.array([theta2, theta3 - theta2, theta4 + np.pi - theta3]))


CLOSURE = od.PointToPoint("rocker_tip", "ground_pivot")


def test_four_bar_is_a_grashof_crank_rocker(four_bar):
    lengths = [np.linalg.norm(four_bar.p_home[i]) for i in (1, 2)]  # crank, coupler
    T_tip = four_bar.frames[four_bar.frame_index("rocker_tip")].T_body_frame
    T_pivot = four_bar.frames[four_bar.frame_index("ground_pivot")].T_body_frame
    a, b, c, d = lengths[0], lengths[1], np.linalg.norm(T_tip[:3, 3]), T_pivot[0, 3]
    assert np.allclose([a, b, c, d], [CRANK, COUPLER, ROCKER, GROUND], atol=0, rtol=1e-15)
    s, ell = min(a, b, c, d), max(a, b, c, d)
    assert s == a and s + ell < (a + b + c + d) - s - ell  # Grashof, shortest link the crank
    assert four_bar.frames[four_bar.frame_index("ground_pivot")].body == -1


def test_four_bar_closed_form_closes_the_loop_at_every_crank_angle(four_bar):
    for theta2 in np.linspace(0.0, 2 * np.pi, 25):
        phi = od.constraint_error(four_bar, four_bar_q(theta2), CLOSURE)
        assert np.abs(phi).max() < 1e-14, f"crank {theta2}: rocker_tip misses O4 by {phi} m"


def test_four_bar_closed_configuration_at_crank_zero_is_the_documented_one(four_bar):
    q = four_bar_q(0.0)
    theta3, theta4 = np.arccos(5 / 7), np.arctan2(np.sqrt(0.24), -0.1)
    assert_close(four_bar_angles(0.0), (theta3, theta4), "theta3, theta4 at crank 0")
    assert np.allclose(q, [0.0, 0.7751934, -2.1446318], atol=1e-7, rtol=0)  # URDF comment


# ------------------------------------------------------------------------------------------
# rank deficiency: the planar closure (a zero row) and a duplicated constraint


def _pinv_solution(model, q, qd, tau, A, Adot_qd):
    """lam = pinv(A M^-1 A^T) (A M^-1 (tau - h) + Adot qd), qdd = M^-1 (tau - h - A^T lam)."""
    M = od.mass_matrix(model, q)
    h = od.bias_forces(model, q, qd)
    Minv_At = np.linalg.solve(M, A.T)
    G = A @ Minv_At
    lam = np.linalg.pinv(G, rcond=dc.RANK_RTOL, hermitian=True) @ (Minv_At.T @ (tau - h) + Adot_qd)
    return np.linalg.solve(M, tau - h - A.T @ lam), lam


def test_planar_closure_has_a_zero_row_and_rank_two(four_bar):
    q = four_bar_q(0.7)
    A = od.constraint_jacobian(four_bar, q, CLOSURE)
    assert A.shape == (3, 3) and np.all(A[2] == 0.0)  # out of the plane: identically zero
    M = od.mass_matrix(four_bar, q)
    qdd, lam, rank = np.empty(3), np.empty(3), np.zeros(1, dtype=np.int64)
    assert dc.constrained_solve_rank_kernel(M, np.ones(3), A, np.zeros(3), qdd, lam, rank) == 0
    assert rank[0] == 2


@pytest.mark.parametrize("theta2", [0.0, 0.7, 2.0, 4.0])
def test_four_bar_dynamics_are_finite_and_minimum_norm(four_bar, theta2):
    q = four_bar_q(theta2)
    rng = np.random.default_rng(int(theta2 * 10))
    A = od.constraint_jacobian(four_bar, q, CLOSURE)
    # a consistent velocity: along the one-dimensional null space of A
    qd = np.linalg.svd(A)[2][-1] * rng.uniform(1.0, 5.0)
    tau = rng.normal(size=3)
    g = np.array([0.0, -9.81, 0.0])  # in the plane of motion
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        qdd, lam = od.constrained_forward_dynamics(four_bar, q, qd, tau, CLOSURE, gravity=g)
    Adot_qd = od.constraint_drift(four_bar, q, qd, CLOSURE)
    assert np.all(np.isfinite(qdd)) and np.all(np.isfinite(lam))
    assert_close(A @ qdd + Adot_qd, np.zeros(3), "A qdd + Adot qd")
    assert lam[2] == 0.0  # the minimum-norm solution puts no force on the zero row
    M = od.mass_matrix(four_bar, q)
    h = od.bias_forces(four_bar, q, qd, gravity=g)
    G = A @ np.linalg.solve(M, A.T)
    lam_pinv = np.linalg.pinv(G, rcond=dc.RANK_RTOL, hermitian=True) @ (
        A @ np.linalg.solve(M, tau - h) + Adot_qd
    )
    assert_close(lam, lam_pinv, "lam = pinv(G) b")
    assert_close(qdd, np.linalg.solve(M, tau - h - A.T @ lam_pinv), "qdd")


def test_duplicated_constraint_shares_the_force_equally(ur5):
    q, qd, tau = _state(ur5, 11)
    c = od.PointToWorld("tool0", (0.0, 0.05, 0.1))
    qdd_1, lam_1 = od.constrained_forward_dynamics(ur5, q, qd, tau, c)
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        qdd_2, lam_2 = od.constrained_forward_dynamics(ur5, q, qd, tau, [c, c])
    A = od.constraint_jacobian(ur5, q, [c, c])
    Adot_qd = od.constraint_drift(ur5, q, qd, [c, c])
    assert np.all(np.isfinite(qdd_2)) and np.all(np.isfinite(lam_2))
    assert_close(A @ qdd_2 + Adot_qd, np.zeros(6), "A qdd + Adot qd")
    assert_close(qdd_2, qdd_1, "qdd with the duplicate")
    assert_close(lam_2, np.r_[lam_1, lam_1] / 2, "lam split between the two copies")
    qdd_ref, lam_ref = _pinv_solution(ur5, q, qd, tau, A, Adot_qd)
    assert_close(lam_2, lam_ref, "lam = numpy pinv solution")
    assert_close(qdd_2, qdd_ref, "qdd = numpy pinv solution")


def test_redundant_general_A_gives_the_pinv_solution(ur5):
    """A general A with a row that is a combination of two others, and a zero row."""
    q, qd, tau = _state(ur5, 12)
    rng = np.random.default_rng(12)
    A = rng.normal(size=(4, 6))
    A[2] = 0.3 * A[0] - 2.0 * A[1]
    A = np.vstack([A, np.zeros(6)])
    Adot_qd = rng.normal(size=5)
    Adot_qd[2] = 0.3 * Adot_qd[0] - 2.0 * Adot_qd[1]  # consistent
    Adot_qd[4] = 0.0
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        qdd, lam = od.constrained_forward_dynamics(ur5, q, qd, tau, A=A, Adot_qd=Adot_qd)
    qdd_ref, lam_ref = _pinv_solution(ur5, q, qd, tau, A, Adot_qd)
    assert_close(lam, lam_ref, "lam")
    assert_close(qdd, qdd_ref, "qdd")
    assert_close(A @ qdd + Adot_qd, np.zeros(5), "A qdd + Adot qd")
    P = od.constraint_projection(ur5, q, A)
    assert_close(P @ A.T, np.zeros((6, 5)), "P A^T")
    assert_close(P @ P, P, "P^2")


def test_solve_kernel_reports_the_singular_pivot_of_M():
    M = np.diag([2.0, 0.0, 1.0])
    qdd, lam = np.empty(3), np.empty(1)
    status = dc.constrained_solve_kernel(M, np.ones(3), np.ones((1, 3)), np.zeros(1), qdd, lam)
    assert decode(status) == (Status.SINGULAR, 1)


def test_solve_kernel_without_constraints_is_plain_forward_dynamics(ur5):
    q, qd, tau = _state(ur5, 13)
    M = od.mass_matrix(ur5, q)
    rhs = tau - od.bias_forces(ur5, q, qd)
    qdd, lam = np.empty(6), np.empty(0)
    assert dc.constrained_solve_kernel(M, rhs, np.zeros((0, 6)), np.zeros(0), qdd, lam) == Status.OK
    assert_close(qdd, od.forward_dynamics(ur5, q, qd, tau), "qdd")


# ------------------------------------------------------------------------------------------
# identities of the seed's equations

UR5_SETS = {
    "point": [od.PointToWorld("tool0", (0.02, -0.03, 0.1))],
    "plane+loop": [
        od.PointOnPlane("wrist_2_link", (0.2, -1.0, 0.5), (0.05, 0.0, 0.1)),
        od.PointToPoint("tool0", "upper_arm_link", (0.0, 0.1, 0.0), (0.2, 0.0, 0.05)),
    ],
    "weld": [od.FixedPose("base_link", "tool0")],
    "weld, world as frame b": [od.FixedPose("tool0", "world")],
    "coupling+plane": [
        od.JointCoupling([[1.0, -1.0, 0.0, 0.0, 0.0, 0.0]]),
        od.PointOnPlane("tool0", (0.0, 0.0, 1.0)),
    ],
}


@pytest.mark.parametrize("name", UR5_SETS)
def test_forward_dynamics_satisfies_the_constraint_accelerations(ur5, name):
    cs = UR5_SETS[name]
    for seed in range(3):
        q, qd, tau = _state(ur5, seed)
        qdd, lam = od.constrained_forward_dynamics(ur5, q, qd, tau, cs)
        A = od.constraint_jacobian(ur5, q, cs)
        Adot_qd = od.constraint_drift(ur5, q, qd, cs)
        assert_close(A @ qdd + Adot_qd, np.zeros(len(lam)), "A qdd + Adot qd")
        # the equation of motion itself: tau = M qdd + h + A^T lam
        tau_back = od.inverse_dynamics(ur5, q, qd, qdd) + A.T @ lam
        assert_close(tau_back, tau, "M qdd + h + A^T lam")
        # the general-A form gives the same answer
        qdd_A, lam_A = od.constrained_forward_dynamics(ur5, q, qd, tau, A=A, Adot_qd=Adot_qd)
        assert_close(qdd_A, qdd, "qdd from A")
        assert_close(lam_A, lam, "lam from A")


@pytest.mark.parametrize("name", UR5_SETS)
def test_projection_removes_constraint_forces_and_gives_constrained_inverse_dynamics(ur5, name):
    cs = UR5_SETS[name]
    q, qd, tau = _state(ur5, 5)
    A = od.constraint_jacobian(ur5, q, cs)
    P = od.constraint_projection(ur5, q, A)
    M = od.mass_matrix(ur5, q)
    k = A.shape[0]
    assert_close(P @ A.T, np.zeros((6, k)), "P A^T")
    assert_close(P @ P, P, "P^2 = P")
    assert_close(A @ np.linalg.solve(M, P), np.zeros((k, 6)), "A M^-1 P")
    assert_close(P @ M, (P @ M).T, "P M symmetric")
    # the seed's constrained inverse dynamics: P tau = P (M qdd + h) along the motion
    qdd, lam = od.constrained_forward_dynamics(ur5, q, qd, tau, cs)
    assert_close(P @ tau, P @ od.inverse_dynamics(ur5, q, qd, qdd), "P tau = P (M qdd + h)")


@pytest.mark.parametrize("name", UR5_SETS)
def test_constrained_inverse_then_forward_dynamics_gives_back_qdd_and_lam(ur5, name):
    cs = UR5_SETS[name]
    q, qd, tau = _state(ur5, 6)
    A = od.constraint_jacobian(ur5, q, cs)
    qdd, _ = od.constrained_forward_dynamics(ur5, q, qd, tau, cs)  # a consistent qdd
    lam = np.random.default_rng(6).normal(size=A.shape[0]) * 10
    g = np.array([0.5, 1.0, -9.0])
    tau_lam = od.constrained_inverse_dynamics(ur5, q, qd, qdd, A, lam, gravity=g)
    qdd_back, lam_back = od.constrained_forward_dynamics(ur5, q, qd, tau_lam, cs, gravity=g)
    assert_close(qdd_back, qdd, "qdd")
    assert_close(lam_back, lam, "lam")
    # without lam: the projected torque P (M qdd + h); the constraints carry
    # lam_P = -(A M^-1 A^T)^-1 A M^-1 (M qdd + h), and A M^-1 tau = 0
    tau_P = od.constrained_inverse_dynamics(ur5, q, qd, qdd, A, gravity=g)
    M = od.mass_matrix(ur5, q)
    tau_free = od.inverse_dynamics(ur5, q, qd, qdd, gravity=g)
    P = od.constraint_projection(ur5, q, A)
    assert_close(tau_P, P @ tau_free, "tau = P (M qdd + h)")
    assert_close(A @ np.linalg.solve(M, tau_P), np.zeros(A.shape[0]), "A M^-1 tau")
    qdd_back, lam_back = od.constrained_forward_dynamics(ur5, q, qd, tau_P, cs, gravity=g)
    G = A @ np.linalg.solve(M, A.T)
    assert_close(qdd_back, qdd, "qdd from P (M qdd + h)")
    assert_close(lam_back, -np.linalg.solve(G, A @ np.linalg.solve(M, tau_free)), "lam_P")


def test_gravity_and_tip_wrenches_enter_as_in_forward_dynamics(ur5):
    cs = UR5_SETS["plane+loop"]
    q, qd, tau = _state(ur5, 7)
    F = np.array([0.3, -0.2, 0.1, 5.0, -3.0, 2.0])
    g = np.array([1.0, 0.0, -3.0])
    qdd, lam = od.constrained_forward_dynamics(
        ur5, q, qd, tau, cs, gravity=g, f_tip={"wrist_1_link": F}
    )
    J_b = od.jacobian(ur5, q, "wrist_1_link", expressed_in="body")
    tau_eff = tau - J_b.T @ F
    A = od.constraint_jacobian(ur5, q, cs)
    Adot_qd = od.constraint_drift(ur5, q, qd, cs)
    h = od.bias_forces(ur5, q, qd, gravity=g)
    qdd_ref, lam_ref = _pinv_solution_with_h(ur5, q, tau_eff - h, A, Adot_qd)
    assert_close(qdd, qdd_ref, "qdd")
    assert_close(lam, lam_ref, "lam")


def _pinv_solution_with_h(model, q, rhs, A, Adot_qd):
    M = od.mass_matrix(model, q)
    G = A @ np.linalg.solve(M, A.T)
    lam = np.linalg.solve(G, A @ np.linalg.solve(M, rhs) + Adot_qd)
    return np.linalg.solve(M, rhs - A.T @ lam), lam


def test_tip_wrench_reproduces_the_constraint_torques(ur5):
    q, qd, tau = _state(ur5, 8)
    J_b = od.jacobian(ur5, q, "tool0", expressed_in="body")
    R_sb = od.frame_pose(ur5, q, "tool0")[:3, :3]
    for c in (od.PointToWorld("tool0"), od.FixedPose("world", "tool0")):
        qdd, lam = od.constrained_forward_dynamics(ur5, q, qd, tau, c)
        A = od.constraint_jacobian(ur5, q, c)
        F_tip = od.constraint_wrench(ur5, q, "tool0", A, lam)
        assert_close(J_b.T @ F_tip, A.T @ lam, f"J_b^T F_tip = A^T lam ({type(c).__name__})")
        if isinstance(c, od.FixedPose):  # rows = the body twist of tool0: F_tip = lam
            assert_close(F_tip, lam, "weld: F_tip = lam")
        else:  # a force at the origin, world axes: no moment, force R^T lam
            assert_close(F_tip, np.r_[0.0, 0.0, 0.0, R_sb.T @ lam], "point: F_tip = (0, R^T lam)")


def test_tip_wrench_refuses_non_square_and_singular_jacobians(ur5):
    panda = od.load_urdf("panda")
    q = np.zeros(panda.nv)
    A = od.constraint_jacobian(panda, q, od.PointToWorld("panda_hand"))
    with pytest.raises(ValueError, match="not square.*nv=9"):
        od.constraint_wrench(panda, q, "panda_hand", A, np.ones(3))
    q = np.zeros(6)  # the UR5 stretched out: a singular configuration
    A = od.constraint_jacobian(ur5, q, od.PointToWorld("tool0"))
    with pytest.raises(ValueError, match="not invertible at this q"):
        od.constraint_wrench(ur5, q, "tool0", A, np.ones(3))


# ------------------------------------------------------------------------------------------
# finite differences along a trajectory, every kind

FD_CASES = {
    "point_to_world": ("ur5", od.PointToWorld("tool0", (0.05, 0.1, -0.02))),
    "point_on_plane": ("ur5", od.PointOnPlane("wrist_2_link", (1.0, 2.0, 3.0), (0.1, 0, 0.05))),
    "point_to_point": ("ur5", od.PointToPoint("tool0", "upper_arm_link", (0.02, 0, 0.1))),
    "point_to_world_point": ("ur5", od.PointToPoint("base_link", "tool0", (0.3, 0.2, 0.1))),
    "fixed_pose_to_world": ("ur5", od.FixedPose("world", "tool0")),
    "fixed_pose_between_links": ("ur5", od.FixedPose("upper_arm_link", "tool0")),
    "fixed_pose_world_as_b": ("ur5", od.FixedPose("wrist_1_link", "base_link")),
    "joint_coupling": ("ur5", od.JointCoupling([[1, -1, 0, 0, 0, 0], [0, 0, 0.5, 0, 0, -2]])),
    "mimic_fingers_point": (
        "panda_mimic",
        od.PointToPoint("panda_leftfinger", "panda_rightfinger", (0, 0.01, 0.05)),
    ),
    "mimic_finger_weld": ("panda_mimic", od.FixedPose("panda_link2", "panda_leftfinger")),
    "four_bar_closure": ("four_bar", CLOSURE),
}


def _five_point(f, h):
    return (8 * (f(h) - f(-h)) - (f(2 * h) - f(-2 * h))) / (12 * h)


@pytest.fixture(scope="module")
def fd_models(ur5, four_bar):
    return {"ur5": ur5, "panda_mimic": od.load_urdf("panda", mimic=True), "four_bar": four_bar}


@pytest.mark.parametrize("case", FD_CASES)
def test_phi_and_A_qd_have_the_derivatives_A_qd_and_A_qdd_plus_drift(fd_models, case):
    model_name, c = FD_CASES[case]
    model = fd_models[model_name]
    for seed in range(2):
        q0, qd0, qdd0 = _state(model, 100 + seed)

        def q_at(t):
            return q0 + t * qd0 + 0.5 * t * t * qdd0

        def qd_at(t):
            return qd0 + t * qdd0

        # bound at q0: phi(0) = 0 (needed for the weld's log only)
        dphi = _five_point(lambda t: od.constraint_error(model, q_at(t), c, q_bound=q0), FD_STEP)
        A = od.constraint_jacobian(model, q0, c)
        assert_close(dphi, A @ qd0, f"{case}: d/dt phi = A qd")
        dAqd = _five_point(lambda t: od.constraint_jacobian(model, q_at(t), c) @ qd_at(t), FD_STEP)
        drift = od.constraint_drift(model, q0, qd0, c)
        assert_close(dAqd, A @ qdd0 + drift, f"{case}: d/dt (A qd) = A qdd + Adot qd")


# ------------------------------------------------------------------------------------------
# the compiled interface


def test_table_resolves_defaults_at_q0_and_lays_out_rows(ur5):
    q0 = np.random.default_rng(9).uniform(-2, 2, 6)
    cs = [
        od.PointToWorld("tool0", (0.1, 0, 0)),
        od.PointOnPlane("wrist_3_link", (0, 0, 2.0)),
        od.PointToPoint("tool0", "base_link"),
        od.FixedPose("shoulder_link", "tool0"),
        od.JointCoupling([[1, 0, 0, 0, 0, -1]]),
    ]
    rows, params = dc.constraint_table(ur5, cs, q0)
    assert rows.dtype == np.int64 and params.dtype == np.float64
    tool = ur5.frames[ur5.frame_index("tool0")].body
    shoulder = ur5.frames[ur5.frame_index("shoulder_link")].body
    wrist3 = ur5.frames[ur5.frame_index("wrist_3_link")].body
    kinds = [dc.POINT_TO_WORLD, dc.POINT_ON_PLANE, dc.POINT_TO_POINT, dc.FIXED_POSE]
    assert rows[:, dc.KIND].tolist() == kinds + [dc.JOINT_COUPLING]
    assert rows[:, dc.OFFSET].tolist() == [0, 6, 13, 19, 55] and params.shape == (55 + 6 + 6,)
    assert rows[:, dc.ROW_COUNT].tolist() == [3, 1, 3, 6, 1]
    assert rows[:, dc.BODY_A].tolist() == [tool, wrist3, tool, shoulder, -1]
    assert rows[:, dc.BODY_B].tolist() == [-1, -1, -1, tool, -1]
    T = od.frame_pose(ur5, q0, "tool0")
    assert_close(params[3:6], T[:3, :3] @ [0.1, 0, 0] + T[:3, 3], "target bound at q0")
    assert_close(params[9:12], [0, 0, 1.0], "normal normalised")
    assert_close(params[12], od.frame_pose(ur5, q0, "wrist_3_link")[2, 3], "offset bound at q0")
    T_ab = np.linalg.solve(od.frame_pose(ur5, q0, "shoulder_link"), T)
    assert_close(params[19 + 24 : 19 + 33].reshape(3, 3), T_ab[:3, :3], "T_ab rotation")
    assert_close(params[19 + 33 : 19 + 36], T_ab[:3, 3], "T_ab translation")
    assert_close(params[61:67], q0, "q_ref bound at q0")
    # the kernel fills A, Adot qd, phi as the public functions do, phi = 0 at q0
    qd = np.ones(6)
    k = int(rows[:, dc.ROW_COUNT].sum())
    A, Adot_qd, phi = np.empty((k, 6)), np.empty(k), np.empty(k)
    status = dc.constraint_terms_kernel(ur5._ibuf, ur5._fbuf, rows, params, q0, qd, A, Adot_qd, phi)
    assert status == 0
    assert_close(A, od.constraint_jacobian(ur5, q0, cs), "A")
    assert_close(Adot_qd, od.constraint_drift(ur5, q0, qd, cs), "Adot qd")
    assert_close(phi[[0, 1, 2, 3, 7, 8, 9, 10, 11, 12, 13]], np.zeros(11), "phi = 0 where bound")


def test_terms_kernel_reports_non_finite_state(ur5):
    rows, params = dc.constraint_table(ur5, od.PointToWorld("tool0"), np.zeros(6))
    A, Adot_qd, phi = np.empty((3, 6)), np.empty(3), np.empty(3)
    bad = np.r_[0, 0, np.nan, 0, 0, 0]
    good = np.zeros(6)
    args = (ur5._ibuf, ur5._fbuf, rows, params)
    assert dc.constraint_terms_kernel(*args, bad, good, A, Adot_qd, phi) == Status.Q_NOT_FINITE
    assert dc.constraint_terms_kernel(*args, good, bad, A, Adot_qd, phi) == Status.QD_NOT_FINITE


# ------------------------------------------------------------------------------------------
# bad input


def test_unknown_frame_is_named_with_its_constraint(ur5):
    with pytest.raises(KeyError, match=r"constraints\[1\] PointToPoint.*'no_such_link'"):
        od.constraint_jacobian(
            ur5, np.zeros(6), [od.PointToWorld("tool0"), od.PointToPoint("tool0", "no_such_link")]
        )


def test_constraint_between_two_world_frames_is_refused(ur5):
    for c in (od.PointToPoint("base_link", "world"), od.FixedPose("world", "base")):
        with pytest.raises(ValueError, match="two world frames"):
            od.constraint_jacobian(ur5, np.zeros(6), c)
    with pytest.raises(ValueError, match="belongs to the fixed world"):
        od.constraint_jacobian(ur5, np.zeros(6), od.PointToWorld("base_link"))


@pytest.mark.parametrize(
    "build, message",
    [
        (lambda: od.PointToWorld("tool0", (1.0, 2.0)), "PointToWorld: point must have shape"),
        (lambda: od.PointToWorld("tool0", target=(0, np.nan, 0)), "target must be finite"),
        (lambda: od.PointToWorld(""), "PointToWorld: frame must be a frame name"),
        (lambda: od.PointOnPlane("tool0", (0, 0, 0)), "normal must be a non-zero vector"),
        (lambda: od.PointToPoint("tool0", 3), "frame_b must be a frame name"),
        (lambda: od.FixedPose("a", "b", np.eye(3)), r"T_ab must be a \(4, 4\)"),
        (lambda: od.FixedPose("a", "b", 2 * np.eye(4)), "T_ab must be a rigid transform"),
        (lambda: od.JointCoupling(np.zeros((0, 6))), "JointCoupling: A must be a"),
        (lambda: od.JointCoupling([[1, np.inf]]), "A must be finite"),
        (lambda: od.JointCoupling([[1, -1]], q_ref=[[0, 0]]), r"q_ref must be a vector"),
        (lambda: od.JointCoupling([[1, -1]], q_ref=(0, np.nan)), "q_ref must be finite"),
    ],
)
def test_bad_constraint_fields_are_named(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def test_coupling_of_the_wrong_width_is_named(ur5):
    with pytest.raises(ValueError, match=r"constraints\[0\] JointCoupling.*nv=6 columns"):
        od.constraint_jacobian(ur5, np.zeros(6), od.JointCoupling([[1, -1, 0]]))
    # q_ref is a configuration (nq,): its shape is checked when the constraint is bound
    coupling = od.JointCoupling(np.ones((1, 6)), q_ref=np.zeros(5))
    message = r"constraints\[0\] JointCoupling.*q_ref must have shape \(6,\)"
    with pytest.raises(ValueError, match=message):
        od.constraint_error(ur5, np.zeros(6), coupling)


def test_unbound_defaults_need_q_bound_for_the_error(ur5):
    q = np.zeros(6)
    with pytest.raises(ValueError, match="target is None.*pass q_bound"):
        od.constraint_error(ur5, q, od.PointToWorld("tool0"))
    assert od.constraint_error(ur5, q, od.PointToWorld("tool0"), q_bound=q).tolist() == [0, 0, 0]
    assert od.constraint_error(ur5, q, od.PointToWorld("tool0", target=(0, 0, 0))).shape == (3,)
    with pytest.raises(ValueError, match="q0 is None|T_ab is None.*pass q0"):
        dc.constraint_table(ur5, od.FixedPose("world", "tool0"), None)


def test_exactly_one_of_constraints_and_A(ur5):
    q = np.zeros(6)
    c = od.PointToWorld("tool0")
    A = od.constraint_jacobian(ur5, q, c)
    with pytest.raises(ValueError, match="exactly one of `constraints`.*got both"):
        od.constrained_forward_dynamics(ur5, q, q, q, c, A=A, Adot_qd=np.zeros(3))
    with pytest.raises(ValueError, match="exactly one of `constraints`.*got neither"):
        od.constrained_forward_dynamics(ur5, q, q, q)
    with pytest.raises(ValueError, match="A needs its drift Adot_qd"):
        od.constrained_forward_dynamics(ur5, q, q, q, A=A)
    with pytest.raises(ValueError, match="Adot_qd goes with A"):
        od.constrained_forward_dynamics(ur5, q, q, q, c, Adot_qd=np.zeros(3))
    with pytest.raises(ValueError, match="constraints must be a constraint"):
        od.constrained_forward_dynamics(ur5, q, q, q, "tool0")
    with pytest.raises(ValueError, match=r"constraints\[1\] must be one of"):
        od.constraint_jacobian(ur5, q, [c, "tool0"])


def test_wrong_shapes_and_non_finite_numbers_are_named(ur5):
    q = np.zeros(6)
    c = od.PointToWorld("tool0")
    A = od.constraint_jacobian(ur5, q, c)
    cases = [
        (lambda: od.constraint_jacobian(ur5, np.zeros(5), c), "q must have shape"),
        (lambda: od.constraint_jacobian(ur5, np.zeros((2, 6)), c), "q must be a single state"),
        (lambda: od.constraint_drift(ur5, q, np.r_[0, 0, np.nan, 0, 0, 0], c), "qd must be finite"),
        (
            lambda: od.constrained_forward_dynamics(ur5, q, q, q, A=A[:, :5], Adot_qd=np.zeros(3)),
            r"A must have shape \(k, nv=6\)",
        ),
        (
            lambda: od.constrained_forward_dynamics(ur5, q, q, q, A=A, Adot_qd=np.zeros(2)),
            r"Adot_qd must have shape \(3,\)",
        ),
        (
            lambda: od.constrained_forward_dynamics(ur5, q, q, np.r_[q[:5], np.inf], c),
            "tau must be finite",
        ),
        (lambda: od.constraint_projection(ur5, q, A * np.nan), "A must be finite"),
        (
            lambda: od.constrained_inverse_dynamics(ur5, q, q, q, A, lam=np.zeros(4)),
            r"lam must have shape \(3,\)",
        ),
        (lambda: od.constrained_inverse_dynamics(ur5, q, q, q[:4], A), "qdd must have shape"),
        (lambda: od.constraint_wrench(ur5, q, "tool0", A, np.zeros(6)), "lam must have shape"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError, match=message):
            call()
    with pytest.raises(KeyError, match="no_such_link"):
        od.constraint_wrench(ur5, np.full(6, 0.3), "no_such_link", A, np.zeros(3))


# ------------------------------------------------------------------------------------------
# against Pinocchio


@pytest.fixture(scope="module")
def pin():
    return pytest.importorskip("pinocchio")


def _oracle(model, mimic=False):
    from pin_adapter import PinOracle

    return PinOracle(model.source, model, mimic=mimic)


def _pin_point_frame(P, frame, point):
    """Pinocchio's frame id of a frame at `point` (frame coordinates) of `frame`, added once."""
    pin = P.pin
    name = f"{frame}@{tuple(float(x) for x in point)}"
    if P.model.existFrame(name):
        return P.model.getFrameId(name)
    parent = P.frame_id(frame)
    placement = P.model.frames[parent].placement * pin.SE3(np.eye(3), np.asarray(point, float))
    joint = P.model.frames[parent].parentJoint
    fid = P.model.addFrame(pin.Frame(name, joint, parent, placement, pin.FrameType.OP_FRAME))
    P.data = P.model.createData()
    return fid


def _pin_point(P, frame, point, q, qd):
    """Pinocchio's (J (3, nv) LOCAL_WORLD_ALIGNED linear rows, classical acceleration at a = 0,
    world position) of a point of a frame."""
    pin = P.pin
    fid = _pin_point_frame(P, frame, point)
    qp, vp = P.q(q), P.v(qd)
    J = pin.computeFrameJacobian(P.model, P.data, qp, fid, pin.LOCAL_WORLD_ALIGNED)
    pin.forwardKinematics(P.model, P.data, qp, vp, np.zeros(P.model.nv))
    pin.updateFramePlacements(P.model, P.data)
    a = pin.getFrameClassicalAcceleration(P.model, P.data, fid, pin.LOCAL_WORLD_ALIGNED)
    return J[:3][:, P.perm_v], a.linear.copy(), P.data.oMf[fid].translation.copy()


def _pin_frame_local(P, frame, q, qd):
    """Pinocchio's LOCAL frame Jacobian (angular first) and spatial acceleration at a = 0."""
    pin = P.pin
    fid = P.frame_id(frame)
    qp, vp = P.q(q), P.v(qd)
    J = pin.computeFrameJacobian(P.model, P.data, qp, fid, pin.LOCAL)
    pin.forwardKinematics(P.model, P.data, qp, vp, np.zeros(P.model.nv))
    pin.updateFramePlacements(P.model, P.data)
    a = pin.getFrameAcceleration(P.model, P.data, fid, pin.LOCAL)
    return np.r_[J[3:], J[:3]][:, P.perm_v], np.r_[a.angular, a.linear]


def _pin_constraint_dynamics(P, q, qd, tau, constraint_models, gravity=None):
    """Pinocchio's constraintDynamics (no regularisation: mu = 0): qdd and lambda_pin."""
    pin = P.pin
    models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for cm in constraint_models:
        models.append(cm)
        datas.append(cm.createData())
    pin.initConstraintDynamics(P.model, P.data, models, datas)
    P.set_gravity(gravity)
    settings = pin.ProximalSettings(1e-14, 0.0, 1)
    a = pin.constraintDynamics(P.model, P.data, P.q(q), P.v(qd), P.v(tau), models, datas, settings)
    P.set_gravity(None)
    return P.back(a), P.data.lambda_c.copy()


def _pin_contact_3d(P, frame_a, point_a, frame_b=None, point_b=(0, 0, 0)):
    """CONTACT_3D between a point of frame_a and a point of frame_b (None: the world origin),
    velocity difference in world axes (LOCAL_WORLD_ALIGNED)."""
    pin = P.pin

    def placement(frame, point):
        fr = P.model.frames[P.frame_id(frame)]
        return fr.parentJoint, fr.placement * pin.SE3(np.eye(3), np.asarray(point, float))

    j1, M1 = placement(frame_a, point_a)
    j2, M2 = (0, pin.SE3.Identity()) if frame_b is None else placement(frame_b, point_b)
    return pin.RigidConstraintModel(
        pin.ContactType.CONTACT_3D, P.model, j1, M1, j2, M2, pin.LOCAL_WORLD_ALIGNED
    )


def _pin_contact_6d(P, frame_a, frame_b, q):
    """CONTACT_6D: frame_b (joint 1) welded to frame_a (joint 2; None = world) at their relative
    pose at q, relative twist in frame b (LOCAL)."""
    pin = P.pin
    pin.framesForwardKinematics(P.model, P.data, P.q(q))
    fb = P.model.frames[P.frame_id(frame_b)]
    oMb = P.data.oMf[P.frame_id(frame_b)]
    if frame_a is None:
        j2, M2 = 0, oMb
    else:
        fa = P.model.frames[P.frame_id(frame_a)]
        j2 = fa.parentJoint
        M2 = fa.placement * (P.data.oMf[P.frame_id(frame_a)].inverse() * oMb)
    return pin.RigidConstraintModel(
        pin.ContactType.CONTACT_6D, P.model, fb.parentJoint, fb.placement, j2, M2, pin.LOCAL
    )


ARMS = {"ur5": "tool0", "panda": "panda_hand"}


@pytest.mark.parametrize("robot", ARMS)
def test_point_rows_and_drifts_match_pinocchio(pin, robot):
    model = od.load_urdf(robot)
    P = _oracle(model)
    tip = ARMS[robot]
    mid = model.body_names[2]
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    r_tip, r_mid = np.array([0.02, 0.03, 0.1]), np.array([-0.05, 0.1, 0.02])
    for seed in range(3):
        q, qd, _ = _state(model, 20 + seed)
        J_tip, a_tip, p_tip = _pin_point(P, tip, r_tip, q, qd)
        J_mid, a_mid, p_mid = _pin_point(P, mid, r_mid, q, qd)
        cases = [
            (
                od.PointToWorld(tip, r_tip, target=(0.1, 0.2, 0.3)),
                J_tip,
                a_tip,
                p_tip - [0.1, 0.2, 0.3],
            ),
            (od.PointOnPlane(tip, n, r_tip, offset=0.25), n @ J_tip, n @ a_tip, n @ p_tip - 0.25),
            (od.PointToPoint(tip, mid, r_tip, r_mid), J_tip - J_mid, a_tip - a_mid, p_tip - p_mid),
        ]
        for c, J, a, phi in cases:
            what = f"{robot} {type(c).__name__}"
            assert_close(od.constraint_jacobian(model, q, c), np.atleast_2d(J), f"{what} A")
            assert_close(od.constraint_drift(model, q, qd, c), np.atleast_1d(a), f"{what} drift")
            assert_close(od.constraint_error(model, q, c), np.atleast_1d(phi), f"{what} phi")


@pytest.mark.parametrize("robot", ARMS)
def test_weld_rows_and_drift_match_pinocchio_local_jacobian_and_acceleration(pin, robot):
    model = od.load_urdf(robot)
    P = _oracle(model)
    tip = ARMS[robot]
    for seed in range(3):
        q, qd, _ = _state(model, 30 + seed)
        J_b, dV_b = _pin_frame_local(P, tip, q, qd)
        c = od.FixedPose(model.frames[0].name, tip)
        assert_close(od.constraint_jacobian(model, q, c), J_b, f"{robot} weld A = J_b")
        assert_close(od.constraint_drift(model, q, qd, c), dV_b, f"{robot} weld drift = dV_b")


@pytest.mark.parametrize("robot", ARMS)
def test_point_and_weld_dynamics_match_pinocchio_constraint_dynamics(pin, robot):
    model = od.load_urdf(robot)
    P = _oracle(model)
    tip = ARMS[robot]
    base = model.frames[0].name
    link1 = model.body_names[0]
    r = np.array([0.05, -0.1, 0.2])
    g_moon = np.array([0.3, -0.2, -1.62])
    for seed in range(3):
        q, qd, tau = _state(model, 40 + seed)
        cases = [
            (od.PointToWorld(tip, r), [_pin_contact_3d(P, tip, r)], None, False),
            (od.PointToWorld(tip, r), [_pin_contact_3d(P, tip, r)], g_moon, False),
            (od.FixedPose(base, tip), [_pin_contact_6d(P, None, tip, q)], None, True),
        ]
        if robot == "panda":  # joints 2-7 move the hand relative to link 1: rank 6
            cases.append(
                (od.FixedPose(link1, tip), [_pin_contact_6d(P, link1, tip, q)], None, True)
            )
        for c, cms, gravity, six in cases:
            what = f"{robot} {type(c).__name__} gravity={gravity}"
            qdd_ref, lam_pin = _pin_constraint_dynamics(P, q, qd, tau, cms, gravity)
            lam_ref = -(np.r_[lam_pin[3:], lam_pin[:3]] if six else lam_pin)
            qdd, lam = od.constrained_forward_dynamics(model, q, qd, tau, c, gravity=gravity)
            assert_close(qdd, qdd_ref, f"{what} qdd")
            assert_close(lam, lam_ref, f"{what} lam")


@pytest.mark.parametrize("robot", ARMS)
def test_plane_dynamics_match_pinocchio_kkt_forward_dynamics(pin, robot):
    model = od.load_urdf(robot)
    P = _oracle(model)
    tip = ARMS[robot]
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    r = np.array([0.02, 0.03, 0.1])
    for seed in range(3):
        q, qd, tau = _state(model, 50 + seed)
        J, a, _ = _pin_point(P, tip, r, q, qd)
        J_pin, gamma = (n @ J)[None], np.array([n @ a])
        J_pin_order = np.zeros((1, P.model.nv))
        J_pin_order[:, P.perm_v] = J_pin
        P.set_gravity(None)
        qdd_ref = P.back(
            pin.forwardDynamics(P.model, P.data, P.q(q), P.v(qd), P.v(tau), J_pin_order, gamma, 0.0)
        )
        lam_ref = -P.data.lambda_c.copy()
        c = od.PointOnPlane(tip, n, r)
        qdd, lam = od.constrained_forward_dynamics(model, q, qd, tau, c)
        assert_close(qdd, qdd_ref, f"{robot} plane qdd")
        assert_close(lam, lam_ref, f"{robot} plane lam")
        # a general A: Pinocchio's own row and drift
        qdd_A, lam_A = od.constrained_forward_dynamics(model, q, qd, tau, A=J_pin, Adot_qd=gamma)
        assert_close(qdd_A, qdd_ref, f"{robot} general A qdd")
        assert_close(lam_A, lam_ref, f"{robot} general A lam")


def _depth(model, body):
    d = 0
    while body >= 0:
        body, d = model.parent[body], d + 1
    return d


def _root_branch(model, body):
    while model.parent[body] >= 0:
        body = model.parent[body]
    return body


@pytest.mark.parametrize("seed", range(8))
def test_loop_closure_on_random_trees_matches_pinocchio(pin, tmp_path, seed):
    """A PointToPoint between the deepest frames of two different branches from the root."""
    from pin_adapter import PinOracle
    from randtree import write_random_tree

    path = write_random_tree(tmp_path, seed)
    model = od.load_urdf(str(path))
    P = PinOracle(path, model)
    frames = sorted((f for f in model.frames if f.body >= 0), key=lambda f: -_depth(model, f.body))
    fa = frames[0]
    fb = next(f for f in frames if _root_branch(model, f.body) != _root_branch(model, fa.body))
    rng = np.random.default_rng(seed)
    r_a, r_b = rng.uniform(-0.2, 0.2, (2, 3))
    c = od.PointToPoint(fa.name, fb.name, r_a, r_b)
    cm = _pin_contact_3d(P, fa.name, r_a, fb.name, r_b)
    for k in range(3):
        q, qd, tau = _state(model, 60 + 10 * seed + k)
        J_a, acc_a, _ = _pin_point(P, fa.name, r_a, q, qd)
        J_b, acc_b, _ = _pin_point(P, fb.name, r_b, q, qd)
        assert_close(od.constraint_jacobian(model, q, c), J_a - J_b, "loop A")
        assert_close(od.constraint_drift(model, q, qd, c), acc_a - acc_b, "loop drift")
        qdd_ref, lam_pin = _pin_constraint_dynamics(P, q, qd, tau, [cm])
        qdd, lam = od.constrained_forward_dynamics(model, q, qd, tau, c)
        assert_close(qdd, qdd_ref, "loop qdd")
        assert_close(lam, -lam_pin, "loop lam")


def test_mimic_finger_rows_match_pinocchio(pin):
    """Coupled mimic joints (the Panda's fingers, nv = 8 < nb = 9): a point on each finger."""
    model = od.load_urdf("panda", mimic=True)
    P = _oracle(model, mimic=True)
    r = (0.0, 0.01, 0.05)
    c = od.PointToPoint("panda_leftfinger", "panda_rightfinger", r, r)
    for seed in range(3):
        q, qd, _ = _state(model, 70 + seed)
        J_l, a_l, _ = _pin_point(P, "panda_leftfinger", r, q, qd)
        J_r, a_r, _ = _pin_point(P, "panda_rightfinger", r, q, qd)
        assert_close(od.constraint_jacobian(model, q, c), J_l - J_r, "mimic A")
        assert_close(od.constraint_drift(model, q, qd, c), a_l - a_r, "mimic drift")


# ------------------------------------------------------------------------------------------
# floating base: q (nq,) with a quaternion, v (nv,) with the base's body twist (omega_b, v_b)
# in its first 6 columns; qdd the rate of v

FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")


@pytest.fixture(scope="module")
def solo():
    return od.load_urdf("solo12", floating_base=True)


def _welded_solo_urdf(directory):
    """solo12 with its root link on a URDF floating joint from a `world` link: a free base and
    a frame of the fixed world to weld it to."""
    import xml.etree.ElementTree as ET

    tree = ET.parse(od.load_urdf("solo12").source)
    robot = tree.getroot()
    ET.SubElement(robot, "link", name="world")
    joint = ET.SubElement(robot, "joint", name="world_to_base", type="floating")
    ET.SubElement(joint, "parent", link="world")
    ET.SubElement(joint, "child", link="base_link")
    path = directory / "solo12_on_world.urdf"
    tree.write(path)
    return path


@pytest.fixture(scope="module")
def welded_solo(tmp_path_factory):
    path = _welded_solo_urdf(tmp_path_factory.mktemp("solo"))
    return path, od.load_urdf(str(path))


def _branch(model, body):
    """The child of the floating root (body 0) that `body` hangs from."""
    while model.parent[body] > 0:
        body = model.parent[body]
    return body


@pytest.fixture(scope="module")
def floating_tree(tmp_path_factory):
    """A floating random tree (16 velocity coordinates) with a loop between the deepest frames
    of two branches, a weld of the deepest frame (7 joints below the base) to the base's own
    frame, a plane and a coupling of the base twist and joints: 12 independent rows."""
    from randtree import write_random_tree

    path = write_random_tree(tmp_path_factory.mktemp("floating_tree"), 3)
    model = od.load_urdf(str(path), floating_base=True)
    frames = sorted((f for f in model.frames if f.body > 0), key=lambda f: -_depth(model, f.body))
    fa = frames[0]
    fb = next(f for f in frames if _branch(model, f.body) != _branch(model, fa.body))
    rng = np.random.default_rng(3)
    r_a, r_b = rng.uniform(-0.2, 0.2, (2, 3))
    coupling = rng.normal(size=(2, model.nv))
    constraints = [
        od.PointToPoint(fa.name, fb.name, r_a, r_b),
        od.FixedPose(model.body_names[0], fa.name),
        od.PointOnPlane(fa.name, (0.2, -0.4, 0.9), r_b),
        od.JointCoupling(coupling),
    ]
    return path, model, constraints


def _floating_state(model, seed):
    """A random configuration (unit quaternion) and random v, qdd, tau."""
    rng = np.random.default_rng(seed)
    q = od.random_configuration(model, rng)
    return (q, *rng.normal(size=(3, model.nv)))


def _floating_cases(solo, floating_tree):
    """name -> (model, constraints): solo12 standing on its four feet (points chosen off the
    foot frames' origins), and the floating tree's loop, weld on its base, plane and coupling."""
    feet = [od.PointToWorld(f, (0.01 * k, -0.02, 0.015)) for k, f in enumerate(FEET)]
    _, tree, constraints = floating_tree
    return {"solo12_feet": (solo, feet), "tree_loop_weld_plane_coupling": (tree, constraints)}


def _vee(X):
    """(w, v) of a (4, 4) twist matrix [[[w], v], [0, 0]]."""
    return np.r_[X[2, 1], X[0, 2], X[1, 0], X[:3, 3]]


def _kinematic_quantity(model, q, c):
    """What each constraint holds, from frame_pose alone (no constraint code): a point's world
    position (m), n . p, p_a - p_b, or the relative pose T_ab (4, 4) of a weld."""

    def point(frame, r):
        return (od.frame_pose(model, q, frame) @ np.r_[r, 1.0])[:3]

    if isinstance(c, od.PointToWorld):
        return point(c.frame, c.point)
    if isinstance(c, od.PointOnPlane):
        return np.atleast_1d(np.dot(c.normal, point(c.frame, c.point)))
    if isinstance(c, od.PointToPoint):
        return point(c.frame_a, c.point_a) - point(c.frame_b, c.point_b)
    return np.linalg.solve(od.frame_pose(model, q, c.frame_a), od.frame_pose(model, q, c.frame_b))


def _second_difference(f, h):
    """f''(0) by the five-point central stencil (error O(h^4))."""
    return (-(f(2 * h) + f(-2 * h)) + 16 * (f(h) + f(-h)) - 30 * f(0.0)) / (12 * h * h)


@pytest.mark.parametrize("case", ["solo12_feet", "tree_loop_weld_plane_coupling"])
def test_floating_A_v_is_the_velocity_along_integrate(solo, floating_tree, case):
    """A v equals the rate of what each constraint holds along q (+) v t (frame_pose, central
    difference): a point's world velocity, a weld's relative body twist T_ab^-1 dT_ab/dt in
    frame b's axes; a coupling's rows are its matrix C, on v-space."""
    model, constraints = _floating_cases(solo, floating_tree)[case]
    for seed in range(2):
        q, v, _, _ = _floating_state(model, 200 + seed)
        row = 0
        for c in constraints:
            A = od.constraint_jacobian(model, q, c)
            stacked = od.constraint_jacobian(model, q, constraints)[row : row + len(A)]
            assert_close(A, stacked, f"{case}: {type(c).__name__} rows in the stack")
            row += len(A)
            if isinstance(c, od.JointCoupling):
                assert_close(A, c.matrix, f"{case}: coupling A = C")
                continue

            def along(t, c=c):
                return _kinematic_quantity(model, od.integrate(model, q, v, t), c)

            rate = _five_point(along, FD_STEP)
            if isinstance(c, od.FixedPose):
                rate = _vee(np.linalg.solve(along(0.0), rate))
            assert_close(A @ v, rate, f"{case}: {type(c).__name__} A v")


@pytest.mark.parametrize("case", ["solo12_feet", "tree_loop_weld_plane_coupling"])
def test_floating_A_qdd_plus_drift_is_the_second_derivative_along_a_trajectory(
    solo, floating_tree, case
):
    """A qdd + Adot v = d^2/dt^2 of what each constraint holds along the trajectory
    q(t) = q (+) (v t + qdd t^2 / 2), which has velocity v and acceleration qdd at t = 0 (the
    exponential map's right Jacobian I - ad_{xi}/2 + ... adds ad_v v / 2 = 0). A weld's
    phi(t) = log(T_ab(0)^-1 T_ab(t)) (scipy's matrix logarithm) is zero at t = 0, where its
    second derivative is the rate of the relative twist; a coupling bound at q has
    phi(t) = C (v t + qdd t^2 / 2)."""
    from scipy.linalg import logm

    model, constraints = _floating_cases(solo, floating_tree)[case]
    for seed in range(2):
        q, v, qdd, _ = _floating_state(model, 210 + seed)

        def q_at(t):
            return od.integrate(model, q, v * t + 0.5 * qdd * t * t, 1.0)

        for c in constraints:
            what = f"{case}: {type(c).__name__}"
            A = od.constraint_jacobian(model, q, c)
            acceleration = A @ qdd + od.constraint_drift(model, q, v, c)
            if isinstance(c, od.JointCoupling):
                phi = lambda t, c=c: od.constraint_error(model, q_at(t), c, q_bound=q)  # noqa: E731
            elif isinstance(c, od.FixedPose):
                T_ab0 = _kinematic_quantity(model, q, c)
                phi = lambda t, c=c, T0=T_ab0: _vee(  # noqa: E731
                    np.real(logm(np.linalg.solve(T0, _kinematic_quantity(model, q_at(t), c))))
                )
            else:
                phi = lambda t, c=c: _kinematic_quantity(model, q_at(t), c)  # noqa: E731
            # rounding of the second difference ~ 64 eps |phi| / (12 h^2) ~ 1e-9 |phi|
            second = _second_difference(phi, FD_STEP)
            assert_close(acceleration, second, f"{what} A qdd + Adot v", rtol=1e-8)
            if isinstance(c, od.JointCoupling):
                assert_close(acceleration, c.matrix @ qdd, f"{what}: C qdd, no drift")


def _kkt(model, q, v, tau, A, drift):
    """qdd, lam from numpy's solve of [[M, A^T], [A, 0]] [qdd; lam] = [tau - h; -Adot v] with
    M = od.mass_matrix and h = od.bias_forces (independent of the constrained kernels)."""
    k = A.shape[0]
    K = np.block([[od.mass_matrix(model, q), A.T], [A, np.zeros((k, k))]])
    x = np.linalg.solve(K, np.r_[tau - od.bias_forces(model, q, v), -drift])
    return x[: model.nv], x[model.nv :]


@pytest.mark.parametrize("case", ["solo12_feet", "tree_loop_weld_plane_coupling"])
def test_floating_constrained_dynamics_is_the_kkt_solution_and_P_projects(
    solo, floating_tree, case
):
    """qdd and lam against numpy's KKT solve; A qdd + Adot v = 0; the projection identities of
    the module docstring: P A^T = 0, P^2 = P, A M^-1 P = 0, P M symmetric,
    P tau = P (M qdd + h); constrained inverse dynamics gives tau back."""
    model, constraints = _floating_cases(solo, floating_tree)[case]
    for seed in range(3):
        q, v, _, tau = _floating_state(model, 220 + seed)
        A = od.constraint_jacobian(model, q, constraints)
        drift = od.constraint_drift(model, q, v, constraints)
        qdd, lam = od.constrained_forward_dynamics(model, q, v, tau, constraints)
        qdd_ref, lam_ref = _kkt(model, q, v, tau, A, drift)
        assert_close(qdd, qdd_ref, f"{case}: qdd")
        assert_close(lam, lam_ref, f"{case}: lam")
        assert_close(A @ qdd + drift, np.zeros(len(A)), f"{case}: A qdd + Adot v = 0")
        qdd_A, lam_A = od.constrained_forward_dynamics(model, q, v, tau, A=A, Adot_qd=drift)
        assert_close(qdd_A, qdd_ref, f"{case}: qdd from a general A")
        assert_close(lam_A, lam_ref, f"{case}: lam from a general A")

        M, h = od.mass_matrix(model, q), od.bias_forces(model, q, v)
        P = od.constraint_projection(model, q, A)
        assert_close(P @ A.T, np.zeros(A.T.shape), f"{case}: P A^T = 0")
        assert_close(P @ P, P, f"{case}: P^2 = P")
        assert_close(A @ np.linalg.solve(M, P), np.zeros(A.shape), f"{case}: A M^-1 P = 0")
        assert_close(P @ M, (P @ M).T, f"{case}: P M symmetric")
        assert_close(P @ tau, P @ (M @ qdd + h), f"{case}: P tau = P (M qdd + h)")
        tau_back = od.constrained_inverse_dynamics(model, q, v, qdd, A, lam=lam)
        assert_close(tau_back, tau, f"{case}: constrained ID(FD) = tau")


def test_floating_feet_and_loops_match_pinocchio_constraint_dynamics(pin, solo, floating_tree):
    """Against Pinocchio's constraintDynamics with a JointModelFreeFlyer root (zero
    regularisation): solo12 on four point feet (CONTACT_3D to the world, under g and under
    the Moon's tilted gravity), and the floating tree's loop (CONTACT_3D between two frames)
    and the weld of its deepest frame to the base (CONTACT_6D); rows and drifts against its
    frame Jacobians and accelerations."""
    from pin_adapter import PinOracle

    g_moon = np.array([0.3, -0.2, -1.62])
    P_solo = PinOracle(solo.source, solo)
    feet = _floating_cases(solo, floating_tree)["solo12_feet"][1]
    path, tree, (loop, weld, _, _) = floating_tree
    P_tree = PinOracle(path, tree)
    for seed in range(3):
        q, v, _, tau = _floating_state(solo, 230 + seed)
        for c in feet:
            J, a, p = _pin_point(P_solo, c.frame, c.point, q, v)
            assert_close(od.constraint_jacobian(solo, q, c), J, f"solo {c.frame} A")
            assert_close(od.constraint_drift(solo, q, v, c), a, f"solo {c.frame} drift")
        contacts = [_pin_contact_3d(P_solo, c.frame, c.point) for c in feet]
        for gravity in (None, g_moon):
            qdd_ref, lam_pin = _pin_constraint_dynamics(P_solo, q, v, tau, contacts, gravity)
            qdd, lam = od.constrained_forward_dynamics(solo, q, v, tau, feet, gravity=gravity)
            assert_close(qdd, qdd_ref, f"solo feet qdd gravity={gravity}")
            assert_close(lam, -lam_pin, f"solo feet lam gravity={gravity}")

        q, v, _, tau = _floating_state(tree, 240 + seed)
        J_a, acc_a, _ = _pin_point(P_tree, loop.frame_a, loop.point_a, q, v)
        J_b, acc_b, _ = _pin_point(P_tree, loop.frame_b, loop.point_b, q, v)
        assert_close(od.constraint_jacobian(tree, q, loop), J_a - J_b, "tree loop A")
        assert_close(od.constraint_drift(tree, q, v, loop), acc_a - acc_b, "tree loop drift")
        cases = [
            (loop, [_pin_contact_3d(P_tree, loop.frame_a, loop.point_a, loop.frame_b,
                                    loop.point_b)], False),
            (weld, [_pin_contact_6d(P_tree, weld.frame_a, weld.frame_b, q)], True),
        ]
        for c, cms, six in cases:
            qdd_ref, lam_pin = _pin_constraint_dynamics(P_tree, q, v, tau, cms)
            lam_ref = -(np.r_[lam_pin[3:], lam_pin[:3]] if six else lam_pin)
            qdd, lam = od.constrained_forward_dynamics(tree, q, v, tau, c)
            assert_close(qdd, qdd_ref, f"tree {type(c).__name__} qdd")
            assert_close(lam, lam_ref, f"tree {type(c).__name__} lam")


def test_a_floating_base_welded_to_the_world_is_the_fixed_base_robot(pin, welded_solo):
    """solo12 on a URDF floating joint, its base welded to the world frame by a FixedPose at a
    random pose, at rest (v_b = 0): the base does not accelerate and the legs move as the
    fixed-base solo12's forward dynamics with gravity in the base's axes, R^T g; qdd and the
    weld's wrench also against Pinocchio's CONTACT_6D."""
    from pin_adapter import PinOracle

    path, model = welded_solo
    fixed = od.load_urdf("solo12")
    assert model.floating_base and model.joint_names == fixed.joint_names
    weld = od.FixedPose("world", "base_link")
    P = PinOracle(path, model)
    for seed in range(3):
        q, v, _, tau = _floating_state(model, 250 + seed)
        v[:6] = 0.0
        qdd, lam = od.constrained_forward_dynamics(model, q, v, tau, weld)
        R_sb = od.frame_pose(model, q, "base_link")[:3, :3]
        qdd_legs = od.forward_dynamics(fixed, q[7:], v[6:], tau[6:], gravity=R_sb.T @ model.gravity)
        assert_close(qdd[:6], np.zeros(6), "welded base: no base acceleration")
        assert_close(qdd[6:], qdd_legs, "welded base: the fixed-base legs")
        qdd_ref, lam_pin = _pin_constraint_dynamics(P, q, v, tau, [_pin_contact_6d(P, None,
                                                                               "base_link", q)])
        assert_close(qdd, qdd_ref, "welded base qdd against Pinocchio")
        assert_close(lam, -np.r_[lam_pin[3:], lam_pin[:3]], "welded base wrench against Pinocchio")


def test_floating_coupling_error_lives_on_v_space(floating_tree):
    """JointCoupling's phi = C (q (-) q_ref): at q = q_ref (+) u (integrate, unit time) it is
    C u, for a base turned by up to ~1.7 rad and moved along a screw (q - q_ref would not even
    have nv entries)."""
    _, model, _ = floating_tree
    rng = np.random.default_rng(260)
    C = rng.normal(size=(3, model.nv))
    for seed in range(3):
        q_ref, u, _, _ = _floating_state(model, 260 + seed)
        q = od.integrate(model, q_ref, u, 1.0)
        c = od.JointCoupling(C, q_ref=q_ref)
        assert_close(od.constraint_error(model, q, c), C @ u, "coupling phi = C u")
        assert_close(od.constraint_error(model, q, od.JointCoupling(C), q_bound=q_ref), C @ u,
                     "coupling phi with q_ref bound at q_bound")


def test_floating_compiled_interface_takes_nq_sized_q(solo):
    """The kernels the simulation step calls, with q (nq,) and v (nv,): constraint_terms_kernel
    fills what the public functions return; constrained_solve_at and constrained_forward_kernel
    solve M qdd + A^T lam = tau - h with A qdd + Adot v + 2 alpha A v + beta^2 phi = 0 (numpy
    KKT from od.mass_matrix, od.bias_forces); a quaternion off unit norm is reported."""
    feet = [od.PointToWorld(f) for f in FEET]
    q, v, _, tau = _floating_state(solo, 270)
    q_bound = od.integrate(solo, q, v, 0.01)  # phi != 0 at q
    rows, params = dc.constraint_table(solo, feet, q_bound)
    k = int(rows[:, dc.ROW_COUNT].sum())
    A, drift, phi = np.empty((k, solo.nv)), np.empty(k), np.empty(k)
    args = (solo._ibuf, solo._fbuf, rows, params)
    assert dc.constraint_terms_kernel(*args, q, v, A, drift, phi) == Status.OK
    assert_close(A, od.constraint_jacobian(solo, q, feet), "kernel A")
    assert_close(drift, od.constraint_drift(solo, q, v, feet), "kernel drift")
    assert_close(phi, od.constraint_error(solo, q, feet, q_bound=q_bound), "kernel phi")
    assert np.abs(phi).max() > 1e-3
    M, h = od.mass_matrix(solo, q), od.bias_forces(solo, q, v)
    for gains in (dc.NO_STABILISATION, np.array([5.0, 20.0])):
        gamma = drift + 2 * gains[0] * A @ v + gains[1] ** 2 * phi
        qdd_ref, lam_ref = _kkt(solo, q, v, tau, A, gamma)
        qdd, work = np.empty(solo.nv), dc.constraint_work(solo.nb, solo.nv, k)
        con = dc.ConstraintTable(rows, params, gains)
        status = dc.constrained_solve_at(
            solo._ibuf, solo._fbuf, con, q, v, M.copy(), tau - h, qdd, work
        )
        assert status == Status.OK
        assert_close(qdd, qdd_ref, f"constrained_solve_at qdd, gains {gains}")
        assert_close(work.lam, lam_ref, f"constrained_solve_at lam, gains {gains}")
        qdd, lam = np.empty(solo.nv), np.empty(k)
        status = dc.constrained_forward_kernel(
            solo._ibuf, solo._fbuf, con, q, v, tau, solo._loads, np.zeros(0), qdd, lam
        )
        assert status == Status.OK
        assert_close(qdd, qdd_ref, f"constrained_forward_kernel qdd, gains {gains}")
        assert_close(lam, lam_ref, f"constrained_forward_kernel lam, gains {gains}")
    bad = q.copy()
    bad[3:7] *= 1.1
    status = dc.constraint_terms_kernel(*args, bad, v, A, drift, phi)
    assert status == Status.Q_NOT_UNIT_QUATERNION


def test_floating_bad_input_names_the_argument(solo):
    """No constraint function refuses a floating base; shapes are nq for configurations and
    nv for velocities, and a quaternion off unit norm is named by its slice."""
    q, v, _, tau = _floating_state(solo, 280)
    foot = od.PointToWorld("FL_FOOT")
    A = od.constraint_jacobian(solo, q, foot)
    off = q.copy()
    off[3:7] *= 1.1
    cases = [
        (lambda: od.constraint_jacobian(solo, q[1:], foot), r"q must have shape \(19,\)"),
        (lambda: od.constraint_drift(solo, q, q, foot), r"qd must have shape \(18,\)"),
        (lambda: od.constraint_error(solo, off, foot, q_bound=q), r"quaternion q\[3:7\]"),
        (lambda: od.constraint_error(solo, q, foot, q_bound=off), r"quaternion q_bound\[3:7\]"),
        (
            lambda: od.constraint_error(solo, q, od.JointCoupling(np.eye(18)[:1], q_ref=q[1:])),
            r"JointCoupling.*q_ref must have shape \(19,\)",
        ),
        (
            lambda: od.constraint_error(solo, q, od.JointCoupling(np.eye(18)[:1], q_ref=off)),
            r"JointCoupling.*quaternion q_ref\[3:7\]",
        ),
        (
            lambda: od.constraint_jacobian(solo, q, od.JointCoupling(np.eye(19)[:1])),
            r"JointCoupling.*nv=18 columns",
        ),
        (lambda: od.constrained_forward_dynamics(solo, q, v, tau[1:], foot), "tau must have"),
        (lambda: od.constraint_projection(solo, off, A), r"quaternion q\[3:7\]"),
        (lambda: od.constrained_inverse_dynamics(solo, q, v, tau, A[:, 1:]), r"A must have"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError, match=message):
            call()
