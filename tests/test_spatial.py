"""Tests of opendyn.spatial against independent references.

References: scipy.spatial.transform.Rotation, scipy.linalg.expm/logm of the 4x4 se(3)
matrix, finite differences, closed-form inertias and physics identities, with the
conventions of Lynch & Park, "Modern Robotics" (2017), chapters 3 and 8.
"""

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.spatial.transform import Rotation

from opendyn.spatial.algebra import (
    ad,
    adjoint,
    angular,
    exp_se3,
    exp_so3,
    inverse_transform,
    kinetic_energy_body,
    lie_bracket,
    linear,
    log_se3,
    log_so3,
    principal_axes,
    rigid_body_acceleration,
    rigid_body_wrench,
    skew,
    spatial_inertia,
    transform_inertia,
    twist_to_matrix,
    unskew,
)

ANGLES = [0.0, 1e-12, 1e-8, 1e-4, 0.05, 0.1, 0.5, 1.0, 2.0, 3.0, np.pi - 1e-4, np.pi - 1e-8]


@pytest.fixture
def rng():
    return np.random.default_rng(20170525)


def random_unit(rng):
    u = rng.normal(size=3)
    return u / np.linalg.norm(u)


def random_transform(rng):
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.normal(size=3)
    return T


def point_cloud(rng, count=7):
    """Random point masses (kg) at positions (m) in {b}, a body with a known exact inertia."""
    return rng.uniform(0.5, 2.0, size=count), rng.normal(size=(count, 3))


def point_cloud_inertia(masses, points):
    """Mass, centre of mass and rotational inertia about it: I = sum m_i (|r_i|^2 1 - r_i r_i^T)."""
    mass = masses.sum()
    com = masses @ points / mass
    r = points - com
    I_com = sum(m * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for m, ri in zip(masses, r))
    return mass, com, I_com


def random_spatial_inertia(rng):
    mass, com, I_com = point_cloud_inertia(*point_cloud(rng))
    return spatial_inertia(mass, com, I_com)


def test_angular_and_linear_split_twists_on_last_axis(rng):
    V = rng.normal(size=(4, 2, 6))
    np.testing.assert_array_equal(np.concatenate([angular(V), linear(V)], axis=-1), V)
    assert angular(V).shape == (4, 2, 3) and linear(V).shape == (4, 2, 3)


def test_skew_matrix_product_is_cross_product(rng):
    for _ in range(10):
        a, b = rng.normal(size=3), rng.normal(size=3)
        np.testing.assert_allclose(skew(a) @ b, np.cross(a, b), atol=1e-14)
        np.testing.assert_array_equal(skew(a), -skew(a).T)
        np.testing.assert_array_equal(unskew(skew(a)), a)


@pytest.mark.parametrize("theta", ANGLES)
def test_exp_so3_matches_scipy_rotation_and_log_inverts_it(rng, theta):
    w = theta * random_unit(rng)
    R = exp_so3(w)
    np.testing.assert_allclose(R, Rotation.from_rotvec(w).as_matrix(), atol=1e-14)
    np.testing.assert_allclose(log_so3(R), w, atol=1e-12)


def test_log_so3_matches_scipy_rotvec_for_random_rotations(rng):
    for R in Rotation.random(50, random_state=rng).as_matrix():
        np.testing.assert_allclose(log_so3(R), Rotation.from_matrix(R).as_rotvec(), atol=1e-12)


@pytest.mark.parametrize(
    "axis", [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, -2.0, 3.0], [-1.0, 1.0, 1.0]]
)
def test_log_so3_at_half_turn_returns_the_axis_up_to_sign(axis):
    axis = np.asarray(axis) / np.linalg.norm(axis)
    R = Rotation.from_rotvec(np.pi * axis).as_matrix()
    w = log_so3(R)
    assert np.linalg.norm(w) == pytest.approx(np.pi, abs=1e-12)
    assert abs(w @ axis) == pytest.approx(np.pi, abs=1e-12)
    np.testing.assert_allclose(exp_so3(w), R, atol=1e-14)


def test_twist_matrix_gives_velocity_of_a_point(rng):
    # MR Section 3.3.2: the velocity of a point p (space frame) is w x p + v.
    V, p = rng.normal(size=6), rng.normal(size=3)
    velocity = twist_to_matrix(V) @ np.append(p, 1.0)
    np.testing.assert_allclose(velocity, np.append(np.cross(V[:3], p) + V[3:], 0.0), atol=1e-14)


@pytest.mark.parametrize("theta", ANGLES)
def test_exp_se3_matches_matrix_exponential(rng, theta):
    V = np.concatenate([theta * random_unit(rng), rng.normal(size=3)])
    np.testing.assert_allclose(exp_se3(V), scipy.linalg.expm(twist_to_matrix(V)), atol=1e-13)


def test_exp_se3_of_pure_translation_is_translation(rng):
    v = rng.normal(size=3)
    T = exp_se3(np.concatenate([np.zeros(3), v]))
    np.testing.assert_array_equal(T[:3, :3], np.eye(3))
    np.testing.assert_array_equal(T[:3, 3], v)
    np.testing.assert_array_equal(log_se3(T), np.concatenate([np.zeros(3), v]))


@pytest.mark.parametrize("theta", ANGLES)
def test_log_se3_inverts_exp_se3(rng, theta):
    V = np.concatenate([theta * random_unit(rng), rng.normal(size=3)])
    np.testing.assert_allclose(log_se3(exp_se3(V)), V, atol=1e-11)


def test_log_se3_matches_matrix_logarithm(rng):
    for _ in range(20):
        T = random_transform(rng)
        L = np.real(scipy.linalg.logm(T))
        np.testing.assert_allclose(
            log_se3(T), np.concatenate([unskew(L[:3, :3]), L[:3, 3]]), atol=1e-9
        )


@pytest.mark.parametrize("axis", [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [2.0, -1.0, 0.5]])
def test_log_se3_at_half_turn_reproduces_transform(rng, axis):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.pi * np.asarray(axis) / np.linalg.norm(axis)).as_matrix()
    T[:3, 3] = rng.normal(size=3)
    V = log_se3(T)
    assert np.linalg.norm(V[:3]) == pytest.approx(np.pi, abs=1e-12)
    np.testing.assert_allclose(scipy.linalg.expm(twist_to_matrix(V)), T, atol=1e-12)


def test_inverse_transform_matches_matrix_inverse(rng):
    for _ in range(10):
        T = random_transform(rng)
        np.testing.assert_allclose(inverse_transform(T), np.linalg.inv(T), atol=1e-13)


def test_adjoint_of_inverse_is_inverse_of_adjoint(rng):
    T = random_transform(rng)
    np.testing.assert_allclose(adjoint(T) @ adjoint(np.linalg.inv(T)), np.eye(6), atol=1e-13)


def test_adjoint_is_a_homomorphism(rng):
    T1, T2 = random_transform(rng), random_transform(rng)
    np.testing.assert_allclose(adjoint(T1 @ T2), adjoint(T1) @ adjoint(T2), atol=1e-13)


def test_adjoint_maps_twist_like_conjugation(rng):
    # MR Section 3.3.2: [Ad_T V] = T [V] T^-1.
    for _ in range(10):
        T, V = random_transform(rng), rng.normal(size=6)
        np.testing.assert_allclose(
            twist_to_matrix(adjoint(T) @ V), T @ twist_to_matrix(V) @ np.linalg.inv(T), atol=1e-13
        )


def test_lie_bracket_is_antisymmetric(rng):
    V1, V2 = rng.normal(size=6), rng.normal(size=6)
    np.testing.assert_allclose(lie_bracket(V1, V2), -lie_bracket(V2, V1), atol=1e-14)
    np.testing.assert_allclose(ad(V1) @ V2, -ad(V2) @ V1, atol=1e-14)
    np.testing.assert_allclose(lie_bracket(V1, V1), np.zeros(6), atol=1e-14)


def test_lie_bracket_matches_matrix_commutator(rng):
    # MR Section 8.2.2: [ad_V1 V2] = [V1][V2] - [V2][V1].
    for _ in range(10):
        V1, V2 = rng.normal(size=6), rng.normal(size=6)
        M1, M2 = twist_to_matrix(V1), twist_to_matrix(V2)
        np.testing.assert_allclose(
            twist_to_matrix(lie_bracket(V1, V2)), M1 @ M2 - M2 @ M1, atol=1e-13
        )


def test_ad_is_derivative_of_adjoint_along_flow(rng):
    # d/dt Ad_{exp([V] t)} at t = 0 equals ad_V (central finite difference, scipy expm).
    V, h = rng.normal(size=6), 1e-5
    derivative = (
        adjoint(scipy.linalg.expm(twist_to_matrix(h * V)))
        - adjoint(scipy.linalg.expm(twist_to_matrix(-h * V)))
    ) / (2 * h)
    np.testing.assert_allclose(derivative, ad(V), atol=1e-8)


def test_spatial_inertia_kinetic_energy_equals_sum_over_particles(rng):
    masses, points = point_cloud(rng)
    mass, com, I_com = point_cloud_inertia(masses, points)
    R_com = Rotation.random(random_state=rng).as_matrix()
    G = spatial_inertia(mass, com, R_com.T @ I_com @ R_com, R_com)
    for _ in range(10):
        V = rng.normal(size=6)
        w, v = V[:3], V[3:]
        particles = 0.5 * sum(m * np.sum((v + np.cross(w, r)) ** 2) for m, r in zip(masses, points))
        assert kinetic_energy_body(G, V) == pytest.approx(particles, rel=1e-12)


def test_spatial_inertia_kinetic_energy_identity(rng):
    # 1/2 V^T G V = 1/2 m |v + w x c|^2 + 1/2 w^T I_c w, I_c = R I R^T.
    mass, com, I_com = point_cloud_inertia(*point_cloud(rng))
    R_com = Rotation.random(random_state=rng).as_matrix()
    G = spatial_inertia(mass, com, I_com, R_com)
    np.testing.assert_allclose(G, G.T, atol=1e-14)
    assert np.all(np.linalg.eigvalsh(G) > 0.0)
    for _ in range(10):
        V = rng.normal(size=6)
        w, v = V[:3], V[3:]
        expected = (
            0.5 * mass * np.sum((v + np.cross(w, com)) ** 2) + 0.5 * w @ R_com @ I_com @ R_com.T @ w
        )
        assert kinetic_energy_body(G, V) == pytest.approx(expected, rel=1e-12)


def test_transform_inertia_preserves_kinetic_energy(rng):
    G_b, T_ba = random_spatial_inertia(rng), random_transform(rng)
    G_a = transform_inertia(G_b, T_ba)
    for _ in range(10):
        V_a = rng.normal(size=6)
        V_b = adjoint(T_ba) @ V_a
        assert kinetic_energy_body(G_a, V_a) == pytest.approx(
            kinetic_energy_body(G_b, V_b), rel=1e-12
        )


def test_transform_inertia_from_centre_of_mass_matches_spatial_inertia(rng):
    # MR Section 8.2.2: G_b = Ad_{T_cb}^T G_c Ad_{T_cb}, with {c} at the centre of mass.
    mass, com, I_com = point_cloud_inertia(*point_cloud(rng))
    R_com = Rotation.random(random_state=rng).as_matrix()
    T_bc = np.eye(4)
    T_bc[:3, :3], T_bc[:3, 3] = R_com, com
    G_c = spatial_inertia(mass, np.zeros(3), I_com)
    np.testing.assert_allclose(
        transform_inertia(G_c, np.linalg.inv(T_bc)),
        spatial_inertia(mass, com, I_com, R_com),
        atol=1e-12,
    )


def parallel_axis_spatial_inertia(mass, com, I_c):
    """G about a point at -com from the centre of mass, axes unchanged.

    Steiner's parallel-axis theorem (MR Section 8.2.1): I_b = I_c + m (|c|^2 1 - c c^T);
    the coupling block m [c] is the moment of the linear momentum m v about the origin.
    """
    I_b = I_c + mass * (com @ com * np.eye(3) - np.outer(com, com))
    coupling = mass * np.array([[0, -com[2], com[1]], [com[2], 0, -com[0]], [-com[1], com[0], 0]])
    return np.block([[I_b, coupling], [coupling.T, mass * np.eye(3)]])


def test_spatial_inertia_of_offset_box_follows_parallel_axis_theorem(rng):
    # Solid box with sides (lx, ly, lz), MR Figure 8.5: Ixx = m (ly^2 + lz^2) / 12, etc.
    mass, (lx, ly, lz), com = 3.0, (0.4, 0.2, 0.1), rng.normal(size=3)
    I_c = mass / 12.0 * np.diag([ly**2 + lz**2, lx**2 + lz**2, lx**2 + ly**2])
    np.testing.assert_allclose(
        spatial_inertia(mass, com, I_c), parallel_axis_spatial_inertia(mass, com, I_c), atol=1e-14
    )


def test_spatial_inertia_of_tilted_offset_cylinder_follows_parallel_axis_theorem(rng):
    # Solid cylinder of radius r, height h along its z axis, MR Figure 8.5:
    # Ixx = Iyy = m (3 r^2 + h^2) / 12, Izz = m r^2 / 2. About a unit axis u:
    # I_c = Izz u u^T + Ixx (1 - u u^T).
    mass, r, h, com = 2.0, 0.05, 0.3, rng.normal(size=3)
    R_com = Rotation.random(random_state=rng).as_matrix()
    Ixx, Izz = mass * (3 * r**2 + h**2) / 12.0, mass * r**2 / 2.0
    u = R_com[:, 2]
    I_c = Izz * np.outer(u, u) + Ixx * (np.eye(3) - np.outer(u, u))
    G = spatial_inertia(mass, com, np.diag([Ixx, Ixx, Izz]), R_com)
    np.testing.assert_allclose(G, parallel_axis_spatial_inertia(mass, com, I_c), atol=1e-14)


def test_principal_axes_diagonalise_a_rotated_inertia(rng):
    for _ in range(20):
        expected = np.sort(rng.uniform(1.0, 2.0, size=3))
        R0 = Rotation.random(random_state=rng).as_matrix()
        I = R0 @ np.diag(expected) @ R0.T
        moments, R_bp = principal_axes(I)
        np.testing.assert_allclose(moments, expected, atol=1e-12)
        assert np.linalg.det(R_bp) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(R_bp.T @ R_bp, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(R_bp.T @ I @ R_bp, np.diag(expected), atol=1e-12)
        np.testing.assert_allclose(np.abs(np.sum(R_bp * R0, axis=0)), np.ones(3), atol=1e-9)


def test_rigid_body_wrench_reduces_to_newton_euler_at_centre_of_mass(rng):
    # Euler's equations (MR Section 8.2.1): m_b = I dw + w x I w, componentwise
    # m_x = Ixx dwx + (Izz - Iyy) wy wz; Newton in a rotating frame: f_b = m (dv + w x v).
    mass, (Ixx, Iyy, Izz) = 2.5, (0.3, 0.5, 0.7)
    G = spatial_inertia(mass, np.zeros(3), np.diag([Ixx, Iyy, Izz]))
    (wx, wy, wz), (dwx, dwy, dwz) = rng.normal(size=3), rng.normal(size=3)
    dv = rng.normal(size=3)
    F = rigid_body_wrench(G, [wx, wy, wz, 0.0, 0.0, 0.0], [dwx, dwy, dwz, *dv])
    euler = [
        Ixx * dwx + (Izz - Iyy) * wy * wz,
        Iyy * dwy + (Ixx - Izz) * wz * wx,
        Izz * dwz + (Iyy - Ixx) * wx * wy,
    ]
    np.testing.assert_allclose(F, np.concatenate([euler, mass * dv]), atol=1e-14)
    V, dV = rng.normal(size=6), rng.normal(size=6)
    np.testing.assert_allclose(
        linear(rigid_body_wrench(G, V, dV)), mass * (dV[3:] + np.cross(V[:3], V[3:])), atol=1e-14
    )


def test_rigid_body_wrench_is_rate_of_change_of_spatial_momentum(rng):
    # Newton-Euler in an inertial frame {s}: F_s = d/dt P_s, with P_s = Ad_{T_bs}^T G_b V_b
    # and F_s = Ad_{T_bs}^T F_b. The motion T_sb(t) = T0 exp([V0 t + A t^2 / 2]) has
    # V_b(0) = V0 and dV_b(0) = A; d/dt is a central finite difference.
    G, T0 = random_spatial_inertia(rng), random_transform(rng)
    V0, A, h = rng.normal(size=6), rng.normal(size=6), 1e-4

    def momentum_s(t):
        X = V0 * t + 0.5 * A * t**2
        T_sb = T0 @ scipy.linalg.expm(twist_to_matrix(X))
        X_dot = V0 + A * t
        dexp = sum(np.linalg.matrix_power(-ad(X), k) / math.factorial(k + 1) for k in range(20))
        return adjoint(np.linalg.inv(T_sb)).T @ G @ (dexp @ X_dot)

    F_s = (momentum_s(h) - momentum_s(-h)) / (2 * h)
    F_b = rigid_body_wrench(G, V0, A)
    np.testing.assert_allclose(adjoint(np.linalg.inv(T0)).T @ F_b, F_s, rtol=1e-6, atol=1e-6)


def test_rigid_body_acceleration_inverts_rigid_body_wrench(rng):
    for _ in range(10):
        G, V, dV = random_spatial_inertia(rng), rng.normal(size=6), rng.normal(size=6)
        np.testing.assert_allclose(
            rigid_body_acceleration(G, V, rigid_body_wrench(G, V, dV)), dV, rtol=1e-9, atol=1e-9
        )


def test_free_body_conserves_kinetic_energy_and_power_equals_work_rate(rng):
    # d/dt 1/2 V^T G V = V^T G dV, which equals V^T F (zero for F = 0).
    for _ in range(10):
        G, V, F = random_spatial_inertia(rng), rng.normal(size=6), rng.normal(size=6)
        assert V @ G @ rigid_body_acceleration(G, V, np.zeros(6)) == pytest.approx(0.0, abs=1e-10)
        assert V @ G @ rigid_body_acceleration(G, V, F) == pytest.approx(V @ F, rel=1e-9)


def test_kinetic_energy_of_free_body_is_constant_along_integrated_motion(rng):
    # Integrate dV = rigid_body_acceleration(G, V, 0) with classical RK4; energy drift is O(dt^4).
    G, V = random_spatial_inertia(rng), rng.normal(size=6)
    energy, dt = kinetic_energy_body(G, V), 1e-3

    def f(x):
        return rigid_body_acceleration(G, x, np.zeros(6))

    for _ in range(200):
        k1 = f(V)
        k2 = f(V + 0.5 * dt * k1)
        k3 = f(V + 0.5 * dt * k2)
        k4 = f(V + dt * k3)
        V = V + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert kinetic_energy_body(G, V) == pytest.approx(energy, rel=1e-8)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: skew([1.0, 2.0]), "w"),
        (lambda: skew([1.0, np.nan, 2.0]), "w"),
        (lambda: unskew(np.ones((3, 3))), "W"),
        (lambda: exp_so3([np.inf, 0.0, 0.0]), "w"),
        (lambda: log_so3(2.0 * np.eye(3)), "R"),
        (lambda: log_so3(np.diag([1.0, 1.0, -1.0])), "R"),
        (lambda: log_so3(np.eye(4)), "R"),
        (lambda: twist_to_matrix(np.zeros(5)), "V"),
        (lambda: exp_se3([0.0, 0.0, 0.0, 1.0, np.nan, 0.0]), "V"),
        (lambda: log_se3(np.diag([1.0, 1.0, -1.0, 1.0])), "T"),
        (lambda: log_se3(np.ones((4, 4))), "T"),
        (lambda: inverse_transform(np.eye(3)), "T"),
        (lambda: adjoint(np.full((4, 4), np.nan)), "T"),
        (lambda: ad(np.zeros((6, 1))), "V"),
        (lambda: lie_bracket(np.zeros(6), np.zeros(3)), "V2"),
        (lambda: angular(np.zeros(5)), "V"),
        (lambda: spatial_inertia(-1.0, np.zeros(3), np.eye(3)), "mass"),
        (lambda: spatial_inertia(np.nan, np.zeros(3), np.eye(3)), "mass"),
        (lambda: spatial_inertia(1.0, np.zeros(2), np.eye(3)), "com"),
        (lambda: spatial_inertia(1.0, np.zeros(3), np.diag([1.0, 1.0, 3.0])), "I_com"),
        (lambda: spatial_inertia(1.0, np.zeros(3), np.diag([-1.0, 1.0, 1.0])), "I_com"),
        (lambda: spatial_inertia(1.0, np.zeros(3), np.triu(np.ones((3, 3)))), "I_com"),
        (lambda: spatial_inertia(1.0, np.zeros(3), np.eye(3), 2.0 * np.eye(3)), "R_com"),
        (lambda: transform_inertia(np.eye(6), np.eye(3)), "T_ba"),
        (lambda: transform_inertia(np.eye(5), np.eye(4)), "G_b"),
        (lambda: principal_axes(np.triu(np.ones((3, 3)))), "I"),
        (lambda: rigid_body_wrench(np.eye(6), np.zeros(6), np.zeros(7)), "dV_b"),
        (lambda: rigid_body_acceleration(np.eye(6), np.zeros(6), [np.nan] * 6), "F_b"),
        (
            lambda: rigid_body_acceleration(
                np.diag([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]), np.ones(6), np.ones(6)
            ),
            "G_b",
        ),
        (lambda: kinetic_energy_body(np.eye(6), np.zeros(3)), "V_b"),
    ],
)
def test_invalid_arguments_raise_value_error_naming_the_argument(call, name):
    with pytest.raises(ValueError, match=rf"^{name} "):
        call()


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: linear("not a twist"), "V"),
        (lambda: spatial_inertia("2.5", np.zeros(3), np.eye(3)), "mass"),
        (lambda: spatial_inertia(True, np.zeros(3), np.eye(3)), "mass"),
        (lambda: spatial_inertia(1.0, [True, False, True], np.eye(3)), "com"),
        (lambda: skew([1j, 0.0, 0.0]), "w"),
    ],
)
def test_arguments_that_are_not_numbers_raise_type_error_naming_them(call, name):
    """Text, booleans and complex numbers are refused, never converted ("2.5" was 2.5 kg and
    True 1 kg), as every array argument of the dynamics functions refuses them."""
    with pytest.raises(TypeError, match=rf"^{name} must be a number or an array of numbers"):
        call()


def test_inertia_at_triangle_inequality_limit_is_accepted():
    # A thin flat plate has Izz = Ixx + Iyy exactly (perpendicular-axis theorem).
    G = spatial_inertia(1.0, np.zeros(3), np.diag([1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(G[:3, :3], np.diag([1.0, 2.0, 3.0]))


def test_rpy_matrix_is_urdf_s_fixed_axis_roll_pitch_yaw():
    """Against scipy's extrinsic x-y-z Euler angles (the URDF specification's <origin rpy>)."""
    from opendyn.spatial import rpy_matrix

    rng = np.random.default_rng(7)
    for rpy in rng.uniform(-np.pi, np.pi, (50, 3)):
        R = rpy_matrix(rpy)
        assert np.allclose(R, Rotation.from_euler("xyz", rpy).as_matrix(), atol=1e-14)
    with pytest.raises(ValueError, match="rpy"):
        rpy_matrix([0.1, 0.2])
