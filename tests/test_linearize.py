"""od.linearize: A and B of a scene's dynamics against central differences of the scene's own
compiled dynamics (the step's evaluation, every effect it names), in q along integrate, in qd
and in the joint torques; the free joint's error dynamics against differences of difference();
the zero-order hold against scipy's; clear errors; and the LQR example that balances the double
pendulum upright."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
from shipped_controller import shipped_controller
from test_effects_registry import scene_named, scene_settings  # noqa: E402

import opendyn as od
from opendyn.sim import effects, step
from opendyn.sim.linearize import effect_forces


def scene_qdd(scene, t, q, qd, u):
    """qdd of the scene's own compiled step at (t, q, qd) with the torque u (nv,) held."""
    model = scene.model
    data = step.scene_data(model, effects.stage_table(scene), np.array(u, dtype=float))
    qdd = np.empty(model.nv)
    status = step.evaluate(data, t, q, qd, qdd, np.empty(model.nv), np.empty(2))
    assert status == 0
    return qdd


def differenced(scene, t, q, qd, h_q=1e-6, h_v=1e-7):
    """(dqdd/dq, dqdd/dqd, dqdd/du) of scene_qdd by central differences."""
    model = scene.model
    nv, E, u = model.nv, np.eye(model.nv), np.zeros(model.nv)

    def moved(e, h):
        return od.integrate(model, q, h * e, 1.0)

    dq = [
        (scene_qdd(scene, t, moved(e, h_q), qd, u) - scene_qdd(scene, t, moved(e, -h_q), qd, u))
        / (2 * h_q)
        for e in E
    ]
    dqd = [
        (scene_qdd(scene, t, q, qd + h_v * e, u) - scene_qdd(scene, t, q, qd - h_v * e, u))
        / (2 * h_v)
        for e in E
    ]
    du = [(scene_qdd(scene, t, q, qd, e) - scene_qdd(scene, t, q, qd, -e)) / 2 for e in E]
    return np.array(dq).T, np.array(dqd).T, np.array(du).T[:, model.v_index].reshape(nv, -1)


def assert_matches_differences(scene, t, q, qd, rtol=2e-6):
    model = scene.model
    nv = model.nv
    A, B = od.linearize(scene, t, q, qd)
    assert A.shape == (2 * nv, 2 * nv) and B.shape == (2 * nv, len(model.v_index))
    dq, dqd, du = differenced(scene, t, q, qd)
    for name, ours, ref in (
        ("dqdd/dq", A[nv:, :nv], dq),
        ("dqdd/dqd", A[nv:, nv:], dqd),
        ("B", B[nv:], du),
    ):
        scale = max(1.0, np.abs(ref).max(initial=0.0))
        assert np.abs(ours - ref).max(initial=0.0) <= rtol * scale, (scene.name, name)
    np.testing.assert_array_equal(A[:nv, nv:], np.eye(nv))
    assert not B[:nv].any()


def _touching_states(scene, count=3):
    """States of the scene's own run where a contact sphere presses into the ground."""
    tr = od.simulate(scene, progress=False)
    touching = np.flatnonzero((tr.penetration > 0).any(axis=1))
    assert touching.size, scene.name
    picks = touching[np.linspace(0, touching.size - 1, count).astype(int)]
    return [(tr.t[k], tr.q[k], tr.qd[k]) for k in picks]


@pytest.mark.parametrize(
    "name",
    [
        "double_pendulum_push",
        "panda_computed_torque",
        "planar_3r_limits",
        "ur5_falling",
        "solo12_falling",
        "t_handle_flip",
        "double_pendulum_swing",
    ],
)
def test_linearize_matches_differences_of_the_scenes_own_dynamics(name):
    scene = od.load_scene(name)
    rng = np.random.default_rng(1)
    model = scene.model
    for t in (0.0, 0.37):
        q = od.random_configuration(model, rng)
        qd = rng.normal(size=model.nv)
        assert_matches_differences(scene, t, q, qd)


@pytest.mark.parametrize("name", ["quadruped_drop", "box_slide", "ball_drop"])
def test_linearize_matches_differences_while_in_contact(name):
    """Contact springs, dampers and friction slopes, at states of the run where spheres press
    into the ground (sliding and sticking), on floating robots."""
    scene = od.load_scene(name)
    for t, q, qd in _touching_states(scene):
        assert_matches_differences(scene, t, q, qd, rtol=1e-5)


# the registry's scenes that linearize takes: not the Python controller's (refused: the next
# test), nor the contact between geometries' (refused: tests/test_world_contact.py)
LINEARIZED = sorted(set(scene_settings()) - {"python_control", "geometry_contact"})


@pytest.mark.parametrize("key", LINEARIZED)
def test_linearize_matches_differences_with_every_effect(key):
    """The registry's scenes, which together name every effect: gravity, damping, friction,
    armature, limits, a world-aligned wrench, contact, PD, a clipped constant torque and
    computed torque (the Python controller, which linearize refuses, is the next test's)."""
    scene = scene_named(key)
    rng = np.random.default_rng(3)
    for _ in range(4):
        q = rng.uniform(-3.5, 3.5, scene.model.nq)
        qd = rng.normal(size=scene.model.nv)
        assert_matches_differences(scene, 0.3, q, qd)


def test_a_python_controller_is_refused_and_the_scene_without_it_matches_its_dynamics():
    """A Python controller has no derivative: linearize refuses it, naming the function and
    the way out it gives (linearize the scene without the controller); that linearisation is
    the differences of the Python scene's own compiled step with its held torque as the input
    (the controller's zero-order hold does not move with the state)."""
    scene = scene_named("python_control")
    with pytest.raises(ValueError, match=r"Python function 'math:cos'.*scene\.without\('control'\)"):
        od.linearize(scene)
    without = scene.without("control")
    nv = scene.model.nv
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = rng.uniform(-3.5, 3.5, scene.model.nq)
        qd = rng.normal(size=nv)
        A, B = od.linearize(without, 0.3, q, qd)
        dq, dqd, du = differenced(scene, 0.3, q, qd)
        for ours, ref in ((A[nv:, :nv], dq), (A[nv:, nv:], dqd), (B[nv:], du)):
            assert np.abs(ours - ref).max() <= 2e-6 * max(1.0, np.abs(ref).max())
        np.testing.assert_array_equal(A[:nv, nv:], np.eye(nv))


def test_every_effects_tangent_is_its_compiled_force():
    """The tangents' forces add up to the step's own generalized force, effect by effect's
    scene (what their derivatives are taken of)."""
    rng = np.random.default_rng(4)
    for key in LINEARIZED:
        scene = scene_named(key)
        model = scene.model
        data = step.scene_data(model, effects.stage_table(scene))
        for _ in range(5):
            q = rng.uniform(-3.5, 3.5, model.nq)
            qd = rng.normal(size=model.nv)
            (tau_e, _, _), _ = effect_forces(scene, 0.3, q, qd)
            tau, K = np.empty(model.nv), np.zeros((model.nv, model.nv))
            step.generalized_forces(
                data, 0.3, q, qd, tau, np.empty(model.nv), np.empty(2), K, K.copy(), False
            )
            np.testing.assert_allclose(tau_e, tau, rtol=1e-12, atol=1e-12)


def test_computed_torque_on_a_floating_base():
    """The base's reaction to the joint torques (a_b keeps the base rows of ID at zero)."""
    scene = od.scene_from_dict(
        {
            "robot": {"name": "solo12", "floating_base": True},
            "effects": {"gravity": True},
            "control": {"type": "computed_torque", "kp": 50.0, "kd": 5.0, "amplitude": 0.2},
        }
    )
    rng = np.random.default_rng(5)
    q = od.random_configuration(scene.model, rng)
    assert_matches_differences(scene, 0.2, q, rng.normal(size=scene.model.nv))


def test_the_free_joints_error_moves_with_the_bases_twist():
    """dq of a free joint is e = log(T_0^-1 T): de/dt = dqd - ad_{v_0} e. Checked against
    differences of od.difference along both motions (t_handle: one free body)."""
    scene = od.load_scene("t_handle_flip")
    model = scene.model
    rng = np.random.default_rng(6)
    q0 = od.random_configuration(model, rng)
    v0 = rng.normal(size=6)
    A, _ = od.linearize(scene, 0.0, q0, v0)
    h, eps = 1e-5, 1e-4

    def e_rate(dq, dv):
        q = od.integrate(model, q0, dq, 1.0)

        def e(s):
            return od.difference(
                model,
                od.integrate(model, q0, v0 * s, 1.0),
                od.integrate(model, q, (v0 + dv) * s, 1.0),
            )

        return (e(h) - e(-h)) / (2 * h)

    E, zero = np.eye(6), np.zeros(6)
    d_dq = np.array([(e_rate(eps * x, zero) - e_rate(-eps * x, zero)) / (2 * eps) for x in E]).T
    d_dv = np.array([(e_rate(zero, eps * x) - e_rate(zero, -eps * x)) / (2 * eps) for x in E]).T
    np.testing.assert_allclose(A[:6, :6], d_dq, atol=1e-5)
    np.testing.assert_allclose(A[:6, 6:], d_dv, atol=1e-5)
    assert np.abs(A[:6, :6]).max() > 0.1  # the base moves: the block is not zero


def test_the_discrete_pair_is_scipys_zero_order_hold():
    scene = od.load_scene("panda_computed_torque")
    A, B = od.linearize(scene, 0.1)
    A_d, B_d = od.linearize(scene, 0.1, discrete=True)
    ref = scipy.signal.cont2discrete((A, B, np.eye(len(A)), 0), scene.run.dt, method="zoh")
    np.testing.assert_allclose(A_d, ref[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(B_d, ref[1], rtol=0, atol=1e-12)


def test_bad_scenes_and_arguments_are_refused_naming_them():
    with pytest.raises(ValueError, match="has constraints"):
        od.linearize("ur5_on_plane")
    with pytest.raises(TypeError, match="linearize: scene must be"):
        od.linearize(od.load_urdf("ur5"))
    scene = od.load_scene("solo12_falling")
    with pytest.raises(ValueError, match="linearize: tau: the free joints .a floating base"):
        od.linearize(scene, tau=np.ones(scene.model.nv))
    with pytest.raises(ValueError, match=r"linearize: q: expected shape \(19,\)"):
        od.linearize(scene, q=np.zeros(3))
    with pytest.raises(ValueError, match="linearize: qd: not finite"):
        od.linearize(scene, qd=np.full(scene.model.nv, np.nan))
    # the joints' torques alone are the floating robot's input
    A, B = od.linearize(scene, tau=np.zeros(12))
    assert B.shape == (36, 12)


def test_the_lqr_example_balances_the_double_pendulum_upright():
    """robots/double_pendulum_lqr: discrete LQR on linearize(..., discrete=True), from 0.1 rad
    off in both joints: the closed loop of the linearization is stable, the simulated error
    falls below 1e-6 rad from 3 s on, and the torques stay within the URDF's effort limits."""
    example = shipped_controller("double_pendulum_lqr")
    A, B = od.linearize(example.PLANT, q=example.UPRIGHT, qd=np.zeros(2), discrete=True)
    assert np.abs(np.linalg.eigvals(A)).max() > 1.0  # upright is unstable without control
    assert np.abs(np.linalg.eigvals(A - B @ example.K)).max() < 0.995
    tr = od.simulate("double_pendulum_lqr", progress=False)
    assert tr.complete
    error = np.abs(tr.q - example.UPRIGHT).max(axis=1)
    assert error[0] == pytest.approx(0.1)
    assert error[tr.t >= 3.0].max() < 1e-6
    assert np.all(np.abs(tr.tau) <= od.load_urdf("double_pendulum").effort_limit)
