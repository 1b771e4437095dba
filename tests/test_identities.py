"""Identities of rigid-body dynamics that hold for every robot, checked on seeded random trees.

The trees (tests/randtree.py) mix revolute, continuous, prismatic and fixed joints, with
arbitrary joint and inertial frames, non-unit axes, massless links and tool flanges. Each
identity is checked at a few random states per tree: exact identities to 1e-10 relative to the
size of the quantity, finite-difference ones to a tolerance derived from the step (FD_RTOL).
"""

from __future__ import annotations

import numpy as np
import pytest
from randtree import write_random_tree

import opendyn as od
from opendyn.algorithm.energy import kinetic_gradient_kernel
from opendyn.spatial.algebra import adjoint, inverse_transform

SEEDS = range(20)
STATES_PER_TREE = 3
RTOL = 1e-10
METHODS = ("aba", "crba", "newton_euler")

# Central differences f'(x) ~ (f(x + h) - f(x - h)) / 2h with h = 1e-6: the truncation error
# h^2/6 |f'''| ~ 1e-13 (scaled by |qd|^3 ~ 10 along a velocity) is negligible; the rounding
# error dominates: f is computed to a few (nv) ulps of its size, eps ~ 2.2e-16, so the
# quotient is off by ~ nv eps |f| / h ~ 1e-9 |f| at worst (measured: <= 6e-10). FD_RTOL
# leaves a margin of 10 over that bound, relative to the size of f named at each use.
FD_STEP = 1e-6
FD_RTOL = 1e-8


def assert_close(actual, expected, rtol=RTOL, scale=None):
    """|actual - expected| <= rtol * scale elementwise; scale defaults to max |expected|, the
    size of the quantity, and is given explicitly where the terms summed are larger."""
    expected = np.asarray(expected, dtype=float)
    scale = np.abs(expected).max() if scale is None else scale
    np.testing.assert_allclose(actual, expected, rtol=0.0, atol=rtol * scale)


def central_difference(f, x, dx):
    """d/dt f(x + t dx) at t = 0, by central differences with step FD_STEP."""
    return (f(x + FD_STEP * dx) - f(x - FD_STEP * dx)) / (2.0 * FD_STEP)


def coriolis_scale(model, q, qd):
    """max |M| |qd|^2: the size of the velocity-product terms that make up c(q, qd), the scale
    of its rounding errors (c itself can vanish, e.g. for one body on a fixed axis)."""
    return np.abs(od.mass_matrix(model, q)).max() * np.abs(qd).max() ** 2


@pytest.fixture(scope="module", params=SEEDS, ids=lambda seed: f"tree{seed}")
def tree(request, tmp_path_factory):
    """(seed, model) of a random tree of 8 to 15 links plus two tool flanges."""
    seed = request.param
    path = write_random_tree(tmp_path_factory.mktemp("trees"), seed, n_links=8 + seed % 8)
    return seed, od.load_urdf(path)


def random_states(tree):
    """STATES_PER_TREE seeded (q, qd, qdd, tau): q within the joint limits (a full turn for
    continuous joints), the rest normally distributed."""
    seed, model = tree
    rng = np.random.default_rng(1000 + seed)
    lower = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    upper = np.where(np.isfinite(model.upper), model.upper, np.pi)
    return [
        (
            rng.uniform(lower, upper),
            rng.normal(0.0, 2.0, model.nv),
            rng.normal(0.0, 3.0, model.nv),
            rng.normal(0.0, 10.0, model.nv),
        )
        for _ in range(STATES_PER_TREE)
    ]


def random_wrench(tree, salt):
    return np.random.default_rng([tree[0], salt]).normal(0.0, 5.0, 6)


def test_random_tree_covers_the_joint_types_and_frames(tree):
    """The generator's promise: several moving joints, tool flanges on fixed joints merged into
    the body above them, massless links."""
    _, model = tree
    transformed = "\n".join(model.report.transformed)
    assert any(name.endswith("_flange") for name in model.frame_names)
    assert "merged into the body above it" in transformed
    assert "taken as massless" in transformed
    assert model.nv == model.nb >= 4


def test_mass_matrix_is_symmetric_positive_definite(tree):
    _, model = tree
    for q, _, _, _ in random_states(tree):
        M = od.mass_matrix(model, q)
        assert_close(M, M.T)
        np.linalg.cholesky(M)
        assert np.linalg.eigvalsh(M).min() > 0.0


def test_mass_matrix_derivative_minus_twice_coriolis_matrix_is_skew(tree):
    _, model = tree
    for q, qd, _, _ in random_states(tree):
        Mdot = central_difference(lambda x: od.mass_matrix(model, x), q, qd)
        N = Mdot - 2.0 * od.coriolis_matrix(model, q, qd)
        assert_close(
            N + N.T, np.zeros_like(N), rtol=FD_RTOL, scale=np.abs(od.mass_matrix(model, q)).max()
        )


def test_coriolis_matrix_times_velocity_is_coriolis_forces(tree):
    _, model = tree
    for q, qd, _, _ in random_states(tree):
        C = od.coriolis_matrix(model, q, qd)
        assert_close(C @ qd, od.coriolis_forces(model, q, qd), scale=coriolis_scale(model, q, qd))


def test_christoffel_symbols_are_symmetric_and_give_coriolis_forces(tree):
    _, model = tree
    for q, qd, _, _ in random_states(tree):
        Gamma = od.christoffel_symbols(model, q)
        assert_close(Gamma, Gamma.transpose(0, 2, 1))
        assert_close(
            np.einsum("ijk,j,k->i", Gamma, qd, qd),
            od.coriolis_forces(model, q, qd),
            scale=coriolis_scale(model, q, qd),
        )


def test_gravity_forces_are_gradient_of_potential_energy(tree):
    _, model = tree
    for q, _, _, _ in random_states(tree):
        g = od.gravity_forces(model, q)
        dU = [
            central_difference(lambda x: od.potential_energy(model, x), q, e)
            for e in np.eye(model.nv)
        ]
        assert_close(
            dU, g, rtol=FD_RTOL, scale=max(np.abs(g).max(), abs(od.potential_energy(model, q)))
        )


def test_inverse_dynamics_is_mass_matrix_times_acceleration_plus_bias(tree):
    _, model = tree
    for q, qd, qdd, _ in random_states(tree):
        M = od.mass_matrix(model, q)
        c, g = od.coriolis_forces(model, q, qd), od.gravity_forces(model, q)
        assert_close(od.bias_forces(model, q, qd), c + g)
        assert_close(
            od.inverse_dynamics(model, q, qd, qdd),
            M @ qdd + c + g,
            scale=(np.abs(M) @ np.abs(qdd) + np.abs(c) + np.abs(g)).max(),
        )


@pytest.mark.parametrize("method", METHODS)
def test_forward_dynamics_inverts_inverse_dynamics(tree, method):
    _, model = tree
    flange = next(name for name in model.frame_names if name.endswith("_flange"))
    f_tip = {flange: random_wrench(tree, 1)}
    for q, qd, qdd, _ in random_states(tree):
        tau = od.inverse_dynamics(model, q, qd, qdd, f_tip=f_tip)
        assert_close(od.forward_dynamics(model, q, qd, tau, f_tip=f_tip, method=method), qdd)


def test_forward_dynamics_methods_agree(tree):
    _, model = tree
    for q, qd, _, tau in random_states(tree):
        qdd = {m: od.forward_dynamics(model, q, qd, tau, method=m) for m in METHODS}
        assert_close(qdd["crba"], qdd["aba"])
        assert_close(qdd["newton_euler"], qdd["aba"])


def test_space_jacobian_is_adjoint_of_body_jacobian(tree):
    """J_s = Ad_{T_sf} J_b for every frame: moving links, flanges, links welded to the root."""
    _, model = tree
    for q, _, _, _ in random_states(tree):
        for frame in model.frame_names:
            J_s = od.jacobian(model, q, frame, expressed_in="space")
            J_b = od.jacobian(model, q, frame, expressed_in="body")
            assert_close(
                J_s,
                adjoint(od.frame_pose(model, q, frame)) @ J_b,
                scale=max(np.abs(J_s).max(), 1.0),
            )


def test_space_jacobian_gives_twist_of_frame_pose(tree):
    """[V_s] = (dT_sf/dt) T_sf^-1 with dT/dt by central differences along qd. The rounding
    error of dT/dt is ~ eps (1 + |p|) / h, and T^-1 multiplies it by up to (1 + |p|)."""
    _, model = tree
    for q, qd, _, _ in random_states(tree):
        for frame in model.frame_names:
            T_sf = od.frame_pose(model, q, frame)
            V_s = central_difference(
                lambda x: od.frame_pose(model, x, frame), q, qd
            ) @ inverse_transform(T_sf)
            twist = np.array([V_s[2, 1], V_s[0, 2], V_s[1, 0], *V_s[:3, 3]])
            assert_close(
                twist,
                od.jacobian(model, q, frame) @ qd,
                rtol=FD_RTOL,
                scale=(1.0 + np.abs(T_sf[:3, 3]).max()) ** 2,
            )


def test_kinetic_energy_is_half_qd_mass_matrix_qd(tree):
    _, model = tree
    for q, qd, _, _ in random_states(tree):
        assert_close(od.kinetic_energy(model, q, qd), 0.5 * qd @ od.mass_matrix(model, q) @ qd)


def test_kinetic_energy_gradient_is_coriolis_matrix_transpose_times_velocity(tree):
    """dK/dq at fixed qd (1/2 qd^T (dM/dq) qd) equals C^T qd: Mdot = C + C^T, and
    c = C qd = Mdot qd - dK/dq (Lagrange's equations), so dK/dq = (C + C^T) qd - C qd."""
    _, model = tree
    for q, qd, _, _ in random_states(tree):
        dK_dq = np.empty(model.nv)
        assert kinetic_gradient_kernel(model._ibuf, model._fbuf, model._work, q, qd, dK_dq) == 0
        expected = od.coriolis_matrix(model, q, qd).T @ qd
        # relative to the size of the terms: |qd|^2 |M| (dK/dq may vanish, e.g. on a chain's
        # first joint, where nothing depends on q_1)
        scale = np.abs(qd).max() ** 2 * np.abs(od.mass_matrix(model, q)).max()
        assert np.abs(dK_dq - expected).max() <= 1e-12 * scale


def test_tip_wrench_adds_body_jacobian_transpose_times_wrench(tree):
    """tau(f_tip) = tau + sum_frames J_b(frame)^T F, each frame alone and all of them at once
    (frames on the root give J_b = 0)."""
    _, model = tree
    f_tip = {frame: random_wrench(tree, k) for k, frame in enumerate(model.frame_names)}
    for q, qd, qdd, _ in random_states(tree):
        tau = od.inverse_dynamics(model, q, qd, qdd)
        forces = {
            frame: od.jacobian(model, q, frame, expressed_in="body").T @ F
            for frame, F in f_tip.items()
        }
        scale = np.abs(tau).max() + sum(np.abs(f).max() for f in forces.values())
        for frame, F in f_tip.items():
            assert_close(
                od.inverse_dynamics(model, q, qd, qdd, f_tip={frame: F}),
                tau + forces[frame],
                scale=scale,
            )
        assert_close(
            od.inverse_dynamics(model, q, qd, qdd, f_tip=f_tip),
            tau + sum(forces.values()),
            scale=scale,
        )


@pytest.mark.parametrize("k", [0.0, -1.0, 0.5, 3.0])
def test_gravity_forces_scale_with_gravity(tree, k):
    _, model = tree
    g0 = np.array(model.gravity)
    for q, _, _, _ in random_states(tree):
        g = od.gravity_forces(model, q)
        assert_close(od.gravity_forces(model, q, gravity=k * g0), k * g, scale=np.abs(g).max())


def test_gravity_forces_are_linear_in_the_gravity_vector(tree):
    seed, model = tree
    a, b = np.random.default_rng(seed).normal(0.0, 10.0, (2, 3))
    for q, _, _, _ in random_states(tree):
        g_a, g_b = od.gravity_forces(model, q, gravity=a), od.gravity_forces(model, q, gravity=b)
        assert_close(
            od.gravity_forces(model, q, gravity=a + b),
            g_a + g_b,
            scale=np.abs(g_a).max() + np.abs(g_b).max(),
        )


def test_batch_evaluation_matches_row_by_row(tree):
    _, model = tree
    q, qd, qdd, tau = (np.array(x) for x in zip(*random_states(tree)))
    tau_id = od.inverse_dynamics(model, q, qd, qdd)
    M = od.mass_matrix(model, q)
    assert tau_id.shape == q.shape and M.shape == (len(q), model.nv, model.nv)
    for n in range(len(q)):
        assert_close(tau_id[n], od.inverse_dynamics(model, q[n], qd[n], qdd[n]))
        assert_close(M[n], od.mass_matrix(model, q[n]))
    for method in METHODS:
        qdd_fd = od.forward_dynamics(model, q, qd, tau, method=method)
        for n in range(len(q)):
            assert_close(qdd_fd[n], od.forward_dynamics(model, q[n], qd[n], tau[n], method=method))
