"""Floating-base models: the configuration space (integrate, difference, neutral, normalize,
random configurations), the q / v conventions, quaternion checks and identities that hold
for every free-flying tree. The agreement with Pinocchio is in test_pinocchio.py."""

from __future__ import annotations

import numpy as np
import pytest
from randtree import write_random_tree
from scipy.spatial.transform import Rotation

import opendyn as od

pin = pytest.importorskip("pinocchio")
from pin_adapter import PinOracle  # noqa: E402


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    path = write_random_tree(tmp_path_factory.mktemp("tree"), 3)
    return od.load_urdf(str(path), floating_base=True)


@pytest.fixture(scope="module")
def ur5():
    return od.load_urdf("ur5", floating_base=True)


def assert_same_configuration(model, a, b, atol=1e-12):
    """a and b are the same configuration: q and -q are the same rotation, so compare through
    difference (zero) rather than entry by entry."""
    np.testing.assert_allclose(od.difference(model, a, b), np.zeros(model.nv), atol=atol)


def _state(model, seed):
    rng = np.random.default_rng(seed)
    return od.random_configuration(model, rng), rng.normal(size=model.nv)


def test_floating_ur5_layout_and_names(ur5):
    fixed = od.load_urdf("ur5")
    assert ur5.floating_base and not fixed.floating_base
    assert (ur5.nq, ur5.nv) == (fixed.nv + 7, fixed.nv + 6)
    assert ur5.joint_names == fixed.joint_names
    assert ur5.q_names[:7] == ("base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw")
    assert ur5.v_names[:6] == ("base_wx", "base_wy", "base_wz", "base_vx", "base_vy", "base_vz")
    assert ur5.q_names[7:] == ur5.v_names[6:] == fixed.joint_names
    np.testing.assert_array_equal(ur5.q_index, np.arange(7, 13))
    np.testing.assert_array_equal(ur5.v_index, np.arange(6, 12))
    assert ur5.body_joints[0] == "root_joint" and ur5.parent[0] == -1
    np.testing.assert_array_equal(od.neutral(ur5), np.r_[0, 0, 0, 0, 0, 0, 1, np.zeros(6)])
    assert "floating base" in ur5.summary()


def test_the_base_q_is_the_root_frame_pose_and_v_its_body_twist(ur5):
    """q[:3] is the root link frame's origin in the world, q[3:7] its (x, y, z, w) quaternion;
    v[:6] its twist in its own frame: J_b(root) = [I_6, 0]."""
    q, v = _state(ur5, 0)
    root = ur5.frames[0].name
    T = od.frame_pose(ur5, q, root)
    np.testing.assert_allclose(T[:3, 3], q[:3], atol=1e-15)
    np.testing.assert_allclose(T[:3, :3], Rotation.from_quat(q[3:7]).as_matrix(), atol=1e-15)
    J_b = od.jacobian(ur5, q, root, expressed_in="body")
    np.testing.assert_allclose(J_b, np.eye(6, ur5.nv), atol=1e-15)
    # the base wrench of inverse dynamics with nothing moving is the weight, in the base frame
    tau = od.gravity_forces(ur5, q)
    m = float(ur5.mass.sum())
    f_world = -m * ur5.gravity
    np.testing.assert_allclose(tau[3:6], T[:3, :3].T @ f_world, rtol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_integrate_and_difference_are_inverse(tree, seed):
    q0, v = _state(tree, seed)
    q1, _ = _state(tree, seed + 100)
    assert_same_configuration(tree, od.integrate(tree, q0, od.difference(tree, q0, q1), 1.0), q1)
    dt = 0.3 / max(1.0, np.linalg.norm(v[:3]))  # a rotation below pi: the log recovers it
    np.testing.assert_allclose(
        od.difference(tree, q0, od.integrate(tree, q0, v, dt)) / dt, v, rtol=1e-10, atol=1e-12
    )
    np.testing.assert_allclose(od.difference(tree, q0, q0), np.zeros(tree.nv), atol=1e-15)


@pytest.mark.parametrize("seed", range(3))
def test_integrate_and_difference_match_pinocchio(ur5, seed):
    P = PinOracle(ur5.source, ur5)
    q0, v = _state(ur5, seed)
    q1, _ = _state(ur5, seed + 10)
    for dt in (1e-3, 0.7, 2.0):
        assert_same_configuration(
            ur5, od.integrate(ur5, q0, v, dt), pin.integrate(P.model, P.q(q0), P.v(v * dt))
        )
    np.testing.assert_allclose(
        od.difference(ur5, q0, q1),
        P.back(pin.difference(P.model, P.q(q0), P.q(q1))),
        atol=1e-12,
    )


def test_a_small_rotation_integrates_by_its_series(ur5):
    """Angles below the series threshold (1e-2 rad) and far below it stay exact."""
    q0, _ = _state(ur5, 5)
    P = PinOracle(ur5.source, ur5)
    for scale in (1e-3, 1e-9, 0.0):
        v = np.r_[scale * np.array([0.3, -0.2, 0.5]), 0.1, 0.2, -0.3, np.zeros(6)]
        np.testing.assert_allclose(
            od.integrate(ur5, q0, v, 1.0), pin.integrate(P.model, P.q(q0), P.v(v)), atol=1e-15
        )  # a small rotation keeps the quaternion's sign
        np.testing.assert_allclose(
            od.difference(ur5, q0, od.integrate(ur5, q0, v, 1.0)), v, atol=1e-14
        )


def test_batches_of_configurations(tree):
    rng = np.random.default_rng(1)
    Q = np.array([od.random_configuration(tree, rng) for _ in range(5)])
    V = rng.normal(size=(5, tree.nv))
    Q1 = od.integrate(tree, Q, V, 0.1)
    for n in range(5):
        np.testing.assert_array_equal(Q1[n], od.integrate(tree, Q[n], V[n], 0.1))
    np.testing.assert_allclose(od.difference(tree, Q, Q1), V * 0.1, rtol=1e-9, atol=1e-12)
    M = od.mass_matrix(tree, Q)
    np.testing.assert_array_equal(M[2], od.mass_matrix(tree, Q[2]))
    qdd = od.forward_dynamics(tree, Q, V, np.zeros((5, tree.nv)))
    np.testing.assert_array_equal(qdd[4], od.forward_dynamics(tree, Q[4], V[4], np.zeros(tree.nv)))


def test_random_configurations_respect_limits_and_are_seeded(tree):
    a = od.random_configuration(tree, 7)
    np.testing.assert_array_equal(a, od.random_configuration(tree, 7))
    assert np.linalg.norm(a[3:7]) == pytest.approx(1.0, abs=1e-15)
    joints = a[tree.q_index]
    assert np.all((joints >= np.where(np.isfinite(tree.lower), tree.lower, -np.pi)))
    assert np.all((joints <= np.where(np.isfinite(tree.upper), tree.upper, np.pi)))


def test_quaternions_are_checked_and_normalised(ur5):
    q, v = _state(ur5, 2)
    off = q.copy()
    off[3:7] *= 1.0 + 1e-5  # within the tolerance: used normalised
    np.testing.assert_allclose(od.mass_matrix(ur5, off), od.mass_matrix(ur5, q), rtol=1e-13)
    np.testing.assert_allclose(od.normalize(ur5, off), q, atol=1e-15)
    far = q.copy()
    far[3:7] *= 1.5
    for call in (
        lambda: od.inverse_dynamics(ur5, far, v, v),
        lambda: od.mass_matrix(ur5, far),
        lambda: od.forward_dynamics(ur5, far, v, v),
        lambda: od.jacobian(ur5, far, "tool0"),
        lambda: od.integrate(ur5, far, v, 0.1),
    ):
        with pytest.raises(ValueError, match=r"quaternion q\[3:7\].*unit norm"):
            call()
    # the configuration functions keep the same rule: a norm of 5 is refused, not used
    five = q.copy()
    five[3:7] *= 5.0
    with pytest.raises(ValueError, match=r"difference: the quaternion q1\[3:7\].*unit norm"):
        od.difference(ur5, q, five)
    with pytest.raises(ValueError, match=r"integrate: the quaternion q\[1\]\[3:7\].*unit norm"):
        od.integrate(ur5, np.stack([q, five]), np.zeros((2, 12)), 0.1)
    np.testing.assert_allclose(od.normalize(ur5, five), q, rtol=1e-15)
    np.testing.assert_allclose(
        od.mass_matrix(ur5, od.normalize(ur5, far)), od.mass_matrix(ur5, q), rtol=1e-13
    )
    zero = q.copy()
    zero[3:7] = 0.0
    for call in (lambda: od.normalize(ur5, zero), lambda: od.integrate(ur5, zero, v, 0.1)):
        with pytest.raises(ValueError, match=r"q\[3:7\].*zero"):
            call()
    with pytest.raises(ValueError, match=r"q must have shape \(13,\)"):
        od.mass_matrix(ur5, np.zeros(12))
    with pytest.raises(ValueError, match=r"qd must have shape \(12,\)"):
        od.inverse_dynamics(ur5, q, np.zeros(13), v)


@pytest.mark.parametrize("seed", range(3))
def test_identities_on_floating_trees(tree, seed):
    """M symmetric positive definite, FD(ID) = identity, the three FD methods agree."""
    q, v = _state(tree, seed)
    a = np.random.default_rng(seed).normal(size=tree.nv)
    M = od.mass_matrix(tree, q)
    np.testing.assert_allclose(M, M.T, atol=1e-14)
    assert np.linalg.eigvalsh(M)[0] > 0
    tau = od.inverse_dynamics(tree, q, v, a)
    for method in ("aba", "crba", "newton_euler"):
        np.testing.assert_allclose(
            od.forward_dynamics(tree, q, v, tau, method=method), a, rtol=1e-9, atol=1e-9
        )
    np.testing.assert_allclose(tau, M @ a + od.bias_forces(tree, q, v), rtol=1e-12, atol=1e-12)
    assert od.kinetic_energy(tree, q, v) == pytest.approx(0.5 * v @ M @ v, rel=1e-12)


def _mass_matrix_rate(model, q, v, h=1e-6):
    """Mdot along the motion q(t) = q (+) v t, by a central difference of M."""
    Mp = od.mass_matrix(model, od.integrate(model, q, v, h))
    Mm = od.mass_matrix(model, od.integrate(model, q, v, -h))
    return (Mp - Mm) / (2 * h)


@pytest.mark.parametrize("seed", range(3))
def test_coriolis_matrix_identities_on_floating_trees(tree, seed):
    """C v = c (RNEA) and Mdot - 2C skew, Mdot taken along integrate (the base velocity is a
    body twist, so q + v t would be no motion at all)."""
    q, v = _state(tree, seed)
    C = od.coriolis_matrix(tree, q, v)
    np.testing.assert_allclose(C @ v, od.coriolis_forces(tree, q, v), rtol=1e-12, atol=1e-12)
    N = _mass_matrix_rate(tree, q, v) - 2.0 * C
    scale = np.abs(C).max()
    np.testing.assert_allclose(N + N.T, np.zeros_like(N), atol=1e-7 * scale)
    assert np.abs(N).max() > 1e-3 * scale  # skew, not zero: the test can see a wrong C


@pytest.mark.parametrize("seed", range(3))
def test_christoffel_symbols_are_the_quadratic_form_of_the_coriolis_forces(tree, seed):
    """Gamma[i, j, k] symmetric in j, k with v^T Gamma_i v = c_i for any v, and
    Gamma[:, j, k] = (dC_:j/dv_k + dC_:k/dv_j) / 2 (C is linear in v)."""
    q, _ = _state(tree, seed)
    rng = np.random.default_rng(10 + seed)
    Gamma = od.christoffel_symbols(tree, q)
    np.testing.assert_array_equal(Gamma, Gamma.transpose(0, 2, 1))
    for v in rng.normal(size=(3, tree.nv)):
        np.testing.assert_allclose(
            np.einsum("ijk,j,k->i", Gamma, v, v),
            od.coriolis_forces(tree, q, v),
            rtol=1e-12,
            atol=1e-12,
        )
    E = np.eye(tree.nv)
    dC = np.stack([od.coriolis_matrix(tree, q, E[k]) for k in range(tree.nv)], axis=-1)
    np.testing.assert_allclose(Gamma, 0.5 * (dC + dC.transpose(0, 2, 1)), atol=1e-12)


def test_on_a_floating_base_the_coriolis_matrix_is_no_contraction_of_gamma(tmp_path):
    """One free rigid body: M = G is constant, c = -ad_V^T G V, so C must be skew (Mdot = 0);
    the contraction sum_k Gamma[:, :, k] V_k of the (unique) symmetric Gamma is not, by
    W^T C_Gamma(V) W = -(ad_V W)^T G W / 2 = (I_2 - I_3) / 2 for V = (e_1, 0),
    W = (e_2 + e_3, 0) and G = diag(I_1, I_2, I_3, m, m, m)."""
    urdf = tmp_path / "brick.urdf"
    urdf.write_text(
        """<robot name="brick"><link name="body"><inertial><mass value="2"/>
    <inertia ixx="0.1" iyy="0.2" izz="0.3" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""
    )
    body = od.load_urdf(str(urdf), floating_base=True)
    assert (body.nq, body.nv) == (7, 6)
    q, V = _state(body, 4)
    G = np.diag([0.1, 0.2, 0.3, 2.0, 2.0, 2.0])
    w, u = V[:3], V[3:]
    P = G @ V  # momentum (m, f) in {b}; c = -ad_V^T P = (w x m + u x f, w x f)
    c = np.r_[np.cross(w, P[:3]) + np.cross(u, P[3:]), np.cross(w, P[3:])]
    C = od.coriolis_matrix(body, q, V)
    np.testing.assert_allclose(C @ V, c, atol=1e-12)
    np.testing.assert_allclose(C, -C.T, atol=1e-12)
    Gamma = od.christoffel_symbols(body, q)
    e1, W = np.r_[1.0, 0, 0, 0, 0, 0], np.r_[0, 1.0, 1.0, 0, 0, 0]
    assert W @ (Gamma @ e1) @ W == pytest.approx((0.2 - 0.3) / 2, rel=1e-12)
    assert W @ od.coriolis_matrix(body, q, e1) @ W == pytest.approx(0.0, abs=1e-12)


def test_coriolis_batches_equal_single_calls(tree):
    rng = np.random.default_rng(5)
    Q = np.array([od.random_configuration(tree, rng) for _ in range(4)])
    V = rng.normal(size=(4, tree.nv))
    C, Gamma = od.coriolis_matrix(tree, Q, V), od.christoffel_symbols(tree, Q)
    for n in range(4):
        np.testing.assert_array_equal(C[n], od.coriolis_matrix(tree, Q[n], V[n]))
        np.testing.assert_array_equal(Gamma[n], od.christoffel_symbols(tree, Q[n]))
    bad = Q[1].copy()
    bad[3:7] *= 2.0
    with pytest.raises(ValueError, match=r"christoffel_symbols.*q\[3:7\]"):
        od.christoffel_symbols(tree, bad)


def _centre_of_mass(model, q):
    """sum_i m_i c_i / m from each body's pose (its frame is the body's link) and first moment."""
    c = np.zeros(3)
    for i, name in enumerate(model.body_names):
        T = od.frame_pose(model, q, name)
        c += T[:3, :3] @ model.h[i] + model.mass[i] * T[:3, 3]
    return c / model.mass.sum()


@pytest.mark.parametrize("seed", range(3))
def test_under_gravity_alone_the_centre_of_mass_falls_at_g(tree, seed):
    """tau = 0: no joint torque and no force on the base, so the only external force is the
    weight and the centre of mass accelerates at g, whatever the limbs do. c(t) is sampled along
    q(t) = q (+) (v t + a t^2 / 2), exact to second order, by a central difference."""
    q, v = _state(tree, seed)
    a = od.forward_dynamics(tree, q, v, np.zeros(tree.nv))
    h = 1e-4
    c = [_centre_of_mass(tree, od.integrate(tree, q, v * t + 0.5 * a * t * t, 1.0)) for t in (-h, 0, h)]
    c_ddot = (c[0] - 2 * c[1] + c[2]) / h**2
    np.testing.assert_allclose(c_ddot, tree.gravity, atol=2e-5 * np.linalg.norm(tree.gravity))


def test_jacobian_is_the_derivative_of_the_frame_pose_along_integrate(tree):
    """J_s v equals the space twist of frame_pose along q (+) v t (central difference)."""
    q, v = _state(tree, 9)
    frame = tree.frames[-1].name
    h = 1e-6
    T0 = od.frame_pose(tree, q, frame)
    Tp = od.frame_pose(tree, od.integrate(tree, q, v, h), frame)
    Tm = od.frame_pose(tree, od.integrate(tree, q, v, -h), frame)
    Tdot = (Tp - Tm) / (2 * h)
    twist = Tdot @ np.linalg.inv(T0)  # [V_s] = Tdot T^-1
    V_s = np.r_[twist[2, 1], twist[0, 2], twist[1, 0], twist[:3, 3]]
    np.testing.assert_allclose(od.jacobian(tree, q, frame) @ v, V_s, rtol=1e-7, atol=1e-7)


def test_a_urdf_floating_joint_is_a_free_joint(tmp_path):
    urdf = tmp_path / "flyer.urdf"
    urdf.write_text(
        """<robot name="flyer">
  <link name="world"/>
  <link name="body"><inertial><mass value="2"/>
    <inertia ixx="0.1" iyy="0.2" izz="0.3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="free" type="floating"><parent link="world"/><child link="body"/></joint>
  <joint name="hinge" type="revolute"><parent link="body"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""
    )
    for floating_base in (False, True):
        model = od.load_urdf(str(urdf), floating_base=floating_base)
        assert model.floating_base and (model.nq, model.nv) == (8, 7)
        assert model.joint_names == ("hinge",) and model.body_joints == ("free", "hinge")
        q, v = _state(model, 0)
        P = PinOracle(str(urdf), model)
        np.testing.assert_allclose(od.mass_matrix(model, q), P.mass_matrix(q), rtol=1e-12)
        np.testing.assert_allclose(
            od.inverse_dynamics(model, q, v, v), P.rnea(q, v, v), rtol=1e-12, atol=1e-12
        )
