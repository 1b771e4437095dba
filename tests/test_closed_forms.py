"""Closed-form dynamics of the robots shipped in robots/: the double pendulum and the planar 3R arm.

Both are planar chains of revolute joints about one axis, so their dynamics have textbook closed
forms, written out here from the formulas and compared with opendyn to rounding (1e-12 relative
to the size of each quantity):

  double_pendulum  Lynch & Park, Modern Robotics (2017), Section 8.1.1, eqs. 8.8-8.9 (two-link
                   planar arm), generalised from point masses at the link ends to a centre of
                   mass at r_i with inertia I_i about it, angles from the downward vertical.
  planar_3r        Spong, Hutchinson & Vidyasagar, Robot Modeling and Control (2006),
                   Sections 7.4-7.5: M = sum_i m_i Jv_i^T Jv_i + I_i Jw_i^T Jw_i written out
                   entry by entry, c_i = sum_jk Gamma_ijk qd_j qd_k with the Christoffel symbols
                   Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i).

Each robot's numbers (masses, lengths, inertias) are those stated in its URDF's comment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import opendyn as od

G0 = 9.81
RTOL = 1e-12
SEEDS = range(5)


def assert_exact(actual, expected, scale=None):
    """|actual - expected| <= 1e-12 * scale elementwise; scale defaults to max |expected|, the
    size of the quantity (an entry that is zero in closed form is compared at that scale)."""
    expected = np.asarray(expected, dtype=float)
    scale = np.abs(expected).max() if scale is None else scale
    np.testing.assert_allclose(actual, expected, rtol=0.0, atol=RTOL * scale)


def unit(phi):
    """e(phi) = (cos phi, sin phi): the in-plane direction of a link at absolute angle phi."""
    return np.array([np.cos(phi), np.sin(phi)])


def unit_perp(phi):
    """de/dphi = (-sin phi, cos phi)."""
    return np.array([-np.sin(phi), np.cos(phi)])


@dataclass(frozen=True)
class PlanarArm:
    """A planar chain of n revolute joints about one axis, in plane coordinates.

    Link k (0-based) has length L[k], mass m[k], centre of mass at distance r[k] from its joint
    and rotational inertia I[k] about it (about the joint axis); its absolute angle is
    phi_k = q_0 + ... + q_k. The plane is the world plane through `origin` (the first joint)
    spanned by the world directions plane[:, 0] (phi = 0) and plane[:, 1] (phi = pi/2); the joint
    axis is their cross product. At q = 0 every link frame has the world's orientation.
    `gravity` is the world gravity vector the tests use; `frames` are (frame, link, distance
    along the link) for the link frames and the tool frame.
    """

    name: str
    m: tuple
    L: tuple
    r: tuple
    I: tuple
    origin: tuple
    plane: tuple
    gravity: tuple
    frames: tuple

    @property
    def n(self):
        return len(self.m)

    @property
    def axis(self):
        E = np.array(self.plane)
        return np.cross(E[:, 0], E[:, 1])

    def point(self, q, k, dist):
        """Plane position of the point `dist` along link k, and its (2, n) Jacobian
        (planar forward kinematics: p = sum_{j<k} L_j e(phi_j) + dist e(phi_k))."""
        phi = np.cumsum(q)
        arms = list(self.L[:k]) + [dist]
        p = sum(a * unit(phi[j]) for j, a in enumerate(arms))
        J = np.zeros((2, self.n))
        for i in range(k + 1):
            J[:, i] = sum(arms[j] * unit_perp(phi[j]) for j in range(i, k + 1))
        return p, J

    def pose(self, q, k, dist):
        """T_s(frame) of the frame `dist` along link k: rotated by phi_k about the axis."""
        T = np.eye(4)
        T[:3, :3] = Rotation.from_rotvec(self.axis * np.sum(q[: k + 1])).as_matrix()
        T[:3, 3] = np.array(self.origin) + np.array(self.plane) @ self.point(q, k, dist)[0]
        return T

    def kinetic_energy(self, q, qd):
        """K = sum_k 1/2 m_k |v_ck|^2 + 1/2 I_k (qd_0 + ... + qd_k)^2 from the centre-of-mass
        velocities v_ck = J_ck qd (Spong Section 7.4)."""
        K = 0.0
        for k in range(self.n):
            v = self.point(q, k, self.r[k])[1] @ qd
            K += 0.5 * self.m[k] * v @ v + 0.5 * self.I[k] * np.sum(qd[: k + 1]) ** 2
        return K

    def potential_energy(self, q, gravity):
        """U = -sum_k m_k g . c_k, c_k the world centre of mass of link k."""
        return -sum(
            self.m[k] * np.dot(gravity, self.pose(q, k, self.r[k])[:3, 3]) for k in range(self.n)
        )

    def mass_matrix(self, q):
        """M(q) = M0 + sum_t a_t cos(s_t . q) P_t, the arm's mass matrix written out."""
        M0, terms = self.mass_terms()
        return M0 + sum(a * np.cos(s @ q) * P for a, s, P in terms)

    def christoffel(self, q):
        """Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i), with the exact derivative
        dM/dq_k = -sum_t a_t sin(s_t . q) s_t[k] P_t (Spong Section 7.4)."""
        _, terms = self.mass_terms()
        dM = sum(-a * np.sin(s @ q) * np.multiply.outer(P, s) for a, s, P in terms)
        return 0.5 * (dM + dM.transpose(0, 2, 1) - dM.transpose(2, 0, 1))

    def coriolis(self, q, qd):
        """c_i = sum_jk Gamma_ijk qd_j qd_k."""
        return np.einsum("ijk,j,k->i", self.christoffel(q), qd, qd)

    def tip_wrench_torques(self, q, F):
        """tau = J^T F for the wrench F = (m, f) that the tool frame applies to the environment,
        in its own coordinates: the in-plane force through the planar Jacobian of the tool
        point, the moment about the joint axis on every joint."""
        name, k, dist = self.frames[-1]
        R = self.pose(q, k, dist)[:3, :3]
        f_plane = np.array(self.plane).T @ (R @ F[3:])
        return self.point(q, k, dist)[1].T @ f_plane + self.axis @ (R @ F[:3])


@dataclass(frozen=True)
class DoublePendulum(PlanarArm):
    """robots/double_pendulum.urdf: plane coordinates (down, -x) from the pivot at z = 2 m."""

    def mass_terms(self):
        """Modern Robotics eq. 8.8 with r_i, I_i:
        M11 = I1 + I2 + m1 r1^2 + m2 (L1^2 + r2^2 + 2 L1 r2 cos q2),
        M12 = I2 + m2 (r2^2 + L1 r2 cos q2), M22 = I2 + m2 r2^2."""
        (m1, m2), (L1, _), (r1, r2), (I1, I2) = self.m, self.L, self.r, self.I
        M0 = np.array(
            [
                [I1 + I2 + m1 * r1**2 + m2 * (L1**2 + r2**2), I2 + m2 * r2**2],
                [I2 + m2 * r2**2, I2 + m2 * r2**2],
            ]
        )
        return M0, [(m2 * L1 * r2, np.array([0.0, 1.0]), np.array([[2.0, 1.0], [1.0, 0.0]]))]

    def coriolis(self, q, qd):
        """Modern Robotics eq. 8.9: c1 = -m2 L1 r2 sin q2 (2 qd1 qd2 + qd2^2),
        c2 = m2 L1 r2 sin q2 qd1^2."""
        a = self.m[1] * self.L[0] * self.r[1]
        return np.array(
            [-a * np.sin(q[1]) * (2 * qd[0] * qd[1] + qd[1] ** 2), a * np.sin(q[1]) * qd[0] ** 2]
        )

    def gravity_forces(self, q):
        """Modern Robotics eq. 8.9 with angles from the downward vertical (gravity along phi = 0):
        g1 = g ((m1 r1 + m2 L1) sin q1 + m2 r2 sin(q1 + q2)), g2 = g m2 r2 sin(q1 + q2)."""
        (m1, m2), (L1, _), (r1, r2) = self.m, self.L, self.r
        return G0 * np.array(
            [
                (m1 * r1 + m2 * L1) * np.sin(q[0]) + m2 * r2 * np.sin(q[0] + q[1]),
                m2 * r2 * np.sin(q[0] + q[1]),
            ]
        )


@dataclass(frozen=True)
class Planar3R(PlanarArm):
    """robots/planar_3r.urdf: plane coordinates (x, y) at height z = 0.5 m; the tests use the
    in-plane gravity (0, -g, 0), the textbook vertical arm."""

    def mass_terms(self):
        """Spong Section 7.4, M = sum_i m_i Jv_i^T Jv_i + I_i Jw_i^T Jw_i written out:
        M11 = I1 + I2 + I3 + m1 r1^2 + m2 (L1^2 + r2^2 + 2 L1 r2 c2)
              + m3 (L1^2 + L2^2 + r3^2 + 2 L1 L2 c2 + 2 L1 r3 c23 + 2 L2 r3 c3)
        M12 = I2 + I3 + m2 (r2^2 + L1 r2 c2) + m3 (L2^2 + r3^2 + L1 L2 c2 + L1 r3 c23 + 2 L2 r3 c3)
        M13 = I3 + m3 (r3^2 + L1 r3 c23 + L2 r3 c3)
        M22 = I2 + I3 + m2 r2^2 + m3 (L2^2 + r3^2 + 2 L2 r3 c3)
        M23 = I3 + m3 (r3^2 + L2 r3 c3),   M33 = I3 + m3 r3^2
        grouped by cosine: c2 = cos q2, c3 = cos q3, c23 = cos(q2 + q3)."""
        (m1, m2, m3), (L1, L2, _), (r1, r2, r3), (I1, I2, I3) = self.m, self.L, self.r, self.I
        M33 = I3 + m3 * r3**2
        M22 = I2 + m2 * r2**2 + m3 * L2**2 + M33
        M11 = I1 + m1 * r1**2 + m2 * L1**2 + m3 * L1**2 + M22
        M0 = np.array([[M11, M22, M33], [M22, M22, M33], [M33, M33, M33]])
        terms = [
            (
                m2 * L1 * r2 + m3 * L1 * L2,
                np.array([0.0, 1.0, 0.0]),
                np.array([[2.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
            ),
            (
                m3 * L1 * r3,
                np.array([0.0, 1.0, 1.0]),
                np.array([[2.0, 1.0, 1.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]),
            ),
            (
                m3 * L2 * r3,
                np.array([0.0, 0.0, 1.0]),
                np.array([[2.0, 2.0, 1.0], [2.0, 2.0, 1.0], [1.0, 1.0, 0.0]]),
            ),
        ]
        return M0, terms

    def gravity_forces(self, q):
        """Spong Section 7.5 (gravity -y in the plane of motion):
        g1 = g ((m1 r1 + (m2 + m3) L1) c1 + (m2 r2 + m3 L2) c12 + m3 r3 c123),
        g2 = g ((m2 r2 + m3 L2) c12 + m3 r3 c123),   g3 = g m3 r3 c123."""
        (m1, m2, m3), (L1, L2, _), (r1, r2, r3) = self.m, self.L, self.r
        c1, c12, c123 = np.cos(np.cumsum(q))
        g3 = m3 * r3 * c123
        g2 = (m2 * r2 + m3 * L2) * c12 + g3
        return G0 * np.array([(m1 * r1 + (m2 + m3) * L1) * c1 + g2, g2, g3])


DOUBLE_PENDULUM = DoublePendulum(
    name="double_pendulum",
    m=(1.0, 2.0),
    L=(1.0, 0.5),
    r=(1.0, 0.5),
    I=(0.0075, 0.015),
    origin=(0.0, 0.0, 2.0),
    plane=((0.0, -1.0), (0.0, 0.0), (-1.0, 0.0)),
    gravity=(0.0, 0.0, -G0),
    frames=(("link1", 0, 0.0), ("link2", 1, 0.0), ("tip", 1, 0.5)),
)
PLANAR_3R = Planar3R(
    name="planar_3r",
    m=(3.0, 2.0, 1.0),
    L=(1.0, 0.6, 0.3),
    r=(0.5, 0.3, 0.15),
    I=(0.25, 0.06, 0.0075),
    origin=(0.0, 0.0, 0.5),
    plane=((1.0, 0.0), (0.0, 1.0), (0.0, 0.0)),
    gravity=(0.0, -G0, 0.0),
    frames=(("link1", 0, 0.0), ("link2", 1, 0.0), ("link3", 2, 0.0), ("tool", 2, 0.3)),
)

# (joint limits lower, upper), damping, friction as written in each URDF
URDF_JOINT_DATA = {
    "double_pendulum": ((-3.14, -3.14), (3.14, 3.14), (0.1, 0.05), (0.05, 0.02)),
    "planar_3r": ((-3.0, -2.5, -2.5), (3.0, 2.5, 2.5), (0.5, 0.3, 0.1), (0.2, 0.1, 0.05)),
}


@pytest.fixture(scope="module", params=[DOUBLE_PENDULUM, PLANAR_3R], ids=lambda arm: arm.name)
def arm(request):
    """(closed form, loaded model) for each shipped planar robot."""
    return request.param, od.load_urdf(request.param.name)


def random_state(seed, n):
    """q, qd, qdd of a seeded random state: angles over a full turn."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-np.pi, np.pi, n), rng.normal(0.0, 2.0, n), rng.normal(0.0, 3.0, n)


def test_model_has_the_urdf_joints_limits_and_dynamics(arm):
    form, model = arm
    lower, upper, damping, friction = URDF_JOINT_DATA[form.name]
    assert model.nv == form.n
    assert set(name for name, _, _ in form.frames) <= set(model.frame_names)
    np.testing.assert_array_equal(model.lower, lower)
    np.testing.assert_array_equal(model.upper, upper)
    np.testing.assert_array_equal(model.damping, damping)
    np.testing.assert_array_equal(model.friction, friction)


@pytest.mark.parametrize("seed", SEEDS)
def test_mass_matrix_matches_closed_form(arm, seed):
    form, model = arm
    q, _, _ = random_state(seed, form.n)
    assert_exact(od.mass_matrix(model, q), form.mass_matrix(q))


@pytest.mark.parametrize("seed", SEEDS)
def test_coriolis_forces_match_closed_form(arm, seed):
    form, model = arm
    q, qd, _ = random_state(seed, form.n)
    assert_exact(od.coriolis_forces(model, q, qd), form.coriolis(q, qd))


@pytest.mark.parametrize("seed", SEEDS)
def test_christoffel_symbols_match_closed_form(arm, seed):
    form, model = arm
    q, _, _ = random_state(seed, form.n)
    assert_exact(od.christoffel_symbols(model, q), form.christoffel(q))


@pytest.mark.parametrize("seed", SEEDS)
def test_gravity_forces_match_closed_form(arm, seed):
    form, model = arm
    q, _, _ = random_state(seed, form.n)
    assert_exact(od.gravity_forces(model, q, gravity=form.gravity), form.gravity_forces(q))


@pytest.mark.parametrize("seed", SEEDS)
def test_inverse_dynamics_matches_closed_form(arm, seed):
    form, model = arm
    q, qd, qdd = random_state(seed, form.n)
    tau = form.mass_matrix(q) @ qdd + form.coriolis(q, qd) + form.gravity_forces(q)
    assert_exact(od.inverse_dynamics(model, q, qd, qdd, gravity=form.gravity), tau)


@pytest.mark.parametrize("seed", SEEDS)
def test_energies_match_closed_form(arm, seed):
    form, model = arm
    q, qd, _ = random_state(seed, form.n)
    assert_exact(od.kinetic_energy(model, q, qd), form.kinetic_energy(q, qd))
    assert_exact(
        od.potential_energy(model, q, gravity=form.gravity),
        form.potential_energy(q, np.array(form.gravity)),
    )


@pytest.mark.parametrize("seed", SEEDS)
def test_frame_poses_match_planar_forward_kinematics(arm, seed):
    form, model = arm
    q, _, _ = random_state(seed, form.n)
    for name, k, dist in form.frames:
        assert_exact(od.frame_pose(model, q, name), form.pose(q, k, dist))


@pytest.mark.parametrize("seed", SEEDS)
def test_tip_wrench_gives_planar_jacobian_transpose(arm, seed):
    form, model = arm
    q, _, _ = random_state(seed, form.n)
    F = np.random.default_rng(100 + seed).normal(0.0, 10.0, 6)
    tip = form.frames[-1][0]
    zero = np.zeros(form.n)
    tau = od.inverse_dynamics(model, q, zero, zero, f_tip={tip: F}, gravity=np.zeros(3))
    assert_exact(tau, form.tip_wrench_torques(q, F))


@pytest.mark.parametrize("seed", SEEDS)
def test_planar_3r_default_gravity_does_no_work(seed):
    """Gravity (0, 0, -9.81) is along the joint axes: no torque, and U = g 0.5 m sum m_i."""
    model = od.load_urdf(PLANAR_3R.name)
    q, _, _ = random_state(seed, PLANAR_3R.n)
    in_plane = np.abs(PLANAR_3R.gravity_forces(q)).max()
    assert_exact(od.gravity_forces(model, q), np.zeros(3), scale=in_plane)
    assert_exact(od.potential_energy(model, q), G0 * 0.5 * sum(PLANAR_3R.m))
