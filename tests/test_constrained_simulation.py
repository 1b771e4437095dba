"""Constrained scenes: the step solves the seed's constrained dynamics (checked against
Pinocchio in test_constraints.py), Baumgarte stabilisation holds the closure, the violation is
recorded, and bad constraint tables in scene files are named.

Independent references: od.constrained_forward_dynamics (Pinocchio-checked) at single states;
the Freudenstein closed form of the four-bar (test_constraints.four_bar_angles); a locked elbow
turning the double pendulum into one rigid pendulum, whose qdd is (tau_1 - h_1) / M_11.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.main import main
from opendyn.sim import effects
from opendyn.sim.driver import Stepper

# the four-bar's closure with Baumgarte alpha = beta = 20 1/s, RK4 at 1 ms over 10 s: measured
# max 4.2e-10 m, 1.4e-10 m at the end
CLOSURE_BOUND = 1e-8  # m


def _qdd(scene, t, q, qd):
    nv = scene.model.nv
    k, power, tau = np.empty((2, nv)), np.empty(2), np.empty(nv)
    assert Stepper(scene, effects.stage_table(scene)).first_stage(t, q, qd, k, power, tau) == 0
    return k[1]


def _on_manifold_states(scene, n):
    """n states of the scene's own (stabilised) run: on the constraints to round-off."""
    traj = od.simulate(scene.replace_run(duration=1.0))
    pick = np.linspace(0, len(traj.t) - 1, n).astype(int)
    return traj.q[pick], traj.qd[pick]


@pytest.fixture(scope="module")
def four_bar():
    return od.load_scene("four_bar")


def test_step_is_the_constrained_forward_dynamics(four_bar):
    """Without stabilisation the step's qdd is od.constrained_forward_dynamics with the scene's
    torques: motor, damping and gravity."""
    scene = dataclasses.replace(four_bar, baumgarte=None)
    model = scene.model
    for q, qd in zip(*_on_manifold_states(four_bar, 5)):
        tau = scene.control.tau - scene.damping * qd
        qdd_ref, _ = od.constrained_forward_dynamics(
            model, q, qd, tau, scene.constraints, gravity=scene.gravity
        )
        np.testing.assert_allclose(_qdd(scene, 0.0, q, qd), qdd_ref, rtol=1e-12, atol=1e-12)


def test_baumgarte_step_pulls_the_error_back_at_the_stated_rates(four_bar):
    """Off the constraint (q perturbed, qd arbitrary) the step's qdd satisfies
    A qdd + Adot qd + 2 alpha A qd + beta^2 phi = 0 with the scene's gains."""
    model = four_bar.model
    alpha, beta = four_bar.baumgarte
    rng = np.random.default_rng(4)
    closure = four_bar.constraints
    for _ in range(5):
        q = four_bar.q0 + rng.normal(scale=0.05, size=3)
        qd = rng.normal(size=3)
        qdd = _qdd(four_bar, 0.0, q, qd)
        A = od.constraint_jacobian(model, q, closure)
        drift = od.constraint_drift(model, q, qd, closure)
        phi = od.constraint_error(model, q, closure, q_bound=four_bar.q0)
        assert np.abs(phi).max() > 1e-3  # really off the constraint
        residual = A @ qdd + drift + 2 * alpha * A @ qd + beta**2 * phi
        np.testing.assert_allclose(residual, 0.0, atol=1e-10)


def test_four_bar_stays_closed_for_10_s_with_baumgarte(four_bar):
    traj = od.simulate(four_bar)
    assert traj.complete and traj.t[-1] == pytest.approx(10.0)
    assert traj.violation_position.max() < CLOSURE_BOUND
    assert traj.violation_velocity.max() < 100 * CLOSURE_BOUND  # m/s, measured 1.4e-8
    assert traj.q[-1, 0] > 6 * 2 * np.pi  # the crank really turns round (measured 11 turns)
    # the recorded violation is max |phi| of the public function at each sample
    pick = np.arange(0, len(traj.t), 97)
    phi = [
        np.abs(od.constraint_error(four_bar.model, traj.q[i], four_bar.constraints)).max()
        for i in pick
    ]
    np.testing.assert_allclose(traj.violation_position[pick], phi, rtol=1e-6, atol=1e-15)


def test_four_bar_follows_the_freudenstein_closed_form(four_bar):
    from test_constraints import four_bar_q

    traj = od.simulate(four_bar.replace_run(duration=3.0))
    for i in range(0, len(traj.t), 29):
        closed = four_bar_q(traj.q[i, 0])
        wrapped = np.angle(np.exp(1j * (traj.q[i] - closed)))
        np.testing.assert_allclose(wrapped, 0.0, atol=1e-7)


def test_without_stabilisation_the_closure_drifts(four_bar):
    """Integrating A qdd + Adot qd = 0 leaves phi free to drift: with RK4 at 5 ms the error
    grows over the run (measured 4.1e-8 m in the first second, 2.7e-4 m in the last) and ends
    far above the stabilised run's; Baumgarte at the same step holds it (measured max 2.8e-7 m,
    8.7e-8 m at the end). At 1 ms the free drift is 6.7e-11 m -> 4.0e-7 m."""
    coarse = four_bar.replace_run(dt=0.005)
    free = od.simulate(dataclasses.replace(coarse, baumgarte=None))
    held = od.simulate(coarse)
    first_second = free.violation_position[free.t <= 1.0].max()
    last_second = free.violation_position[free.t >= 9.0].max()
    assert last_second > 10 * first_second
    assert free.violation_position[-1] > 100 * held.violation_position[-1]
    assert held.violation_position.max() < 1e-6


def test_ideal_constraint_does_no_work_on_the_pinned_arm():
    """The planar 3R with its tool pinned (3 rows, rank 2) is conservative: no damping, no
    control, the pin is workless, so E stays constant (measured drift 5e-8 J of 25 J)."""
    traj = od.simulate(od.load_scene("planar_3r_pinned"))
    assert traj.complete
    assert np.all(np.isfinite(traj.q))
    assert np.abs(traj.energy - traj.energy[0]).max() < 1e-6
    assert traj.violation_position.max() < 1e-8


def test_tool_slides_on_its_table():
    pytest.importorskip("pinocchio")  # the UR5 comes from example-robot-data
    scene = od.load_scene("ur5_on_plane")
    traj = od.simulate(scene)
    z0 = od.frame_pose(scene.model, scene.q0, "tool0")[2, 3]
    z = [od.frame_pose(scene.model, q, "tool0")[2, 3] for q in traj.q[::25]]
    np.testing.assert_allclose(z, z0, atol=1e-8)
    xy = np.array([od.frame_pose(scene.model, q, "tool0")[:2, 3] for q in traj.q[::25]])
    assert np.ptp(xy, axis=0).max() > 0.05  # and it really slides


def test_locked_elbow_makes_the_double_pendulum_one_rigid_pendulum():
    """joint_coupling with coefficients {elbow = 1}: qd_elbow = 0. Row 1 of the equations of
    motion then carries no constraint force: qdd_1 = (tau_1 - h_1) / M_11 with qd_2 = 0."""
    scene = od.scene_from_dict(
        {
            "robot": {"urdf": "double_pendulum.urdf"},
            "initial": {"q": [1.0, 0.4], "qd": [0.5, 0.0]},
            "run": {"duration": 2.0},
            "effects": {"gravity": True},
            "constraints": [{"type": "joint_coupling", "coefficients": {"elbow": 1.0}}],
        },
        base_dir=od.io.urdf.shipped_robots_dir(),
    )
    model = scene.model
    rng = np.random.default_rng(2)
    for _ in range(5):
        q, qd = rng.uniform(-2, 2, 2), np.array([rng.normal(), 0.0])
        M = od.mass_matrix(model, q)
        h = od.bias_forces(model, q, qd)
        qdd = _qdd(scene, 0.0, q, qd)
        assert qdd[1] == pytest.approx(0.0, abs=1e-12)
        assert qdd[0] == pytest.approx(-h[0] / M[0, 0], rel=1e-12)
    traj = od.simulate(scene)
    np.testing.assert_allclose(traj.q[:, 1], 0.4, atol=1e-12)


def test_implicit_euler_keeps_the_constraints_to_first_order():
    """The implicit step solves the same constrained system with its effective mass matrix; its
    local error, and so the stabilised closure error, is first order in dt (measured 1.6e-3 m
    at 1 ms and 1.6e-4 m at 0.1 ms over 2 s, as semi-implicit and explicit Euler)."""
    scene = od.load_scene("four_bar").replace_run(integrator="implicit_euler", duration=2.0)
    errors = []
    for dt in (1e-3, 1e-4):
        traj = od.simulate(scene.replace_run(dt=dt))
        assert traj.complete
        errors.append(traj.violation_position.max())
    assert errors[0] < 5e-3
    assert errors[0] / errors[1] == pytest.approx(10.0, rel=0.2)


def test_violation_is_saved_loaded_and_written_to_csv(four_bar, tmp_path):
    traj = od.simulate(four_bar.replace_run(duration=0.5))
    path = traj.save(tmp_path / "run.npz")
    back = od.Trajectory.load(path)
    np.testing.assert_array_equal(back.violation_position, traj.violation_position)
    np.testing.assert_array_equal(back.violation_velocity, traj.violation_velocity)
    header = traj.to_csv(tmp_path / "run.csv").read_text().splitlines()[0].split(",")
    assert header[-2:] == ["violation_position", "violation_velocity"]
    free = od.simulate(od.load_scene("double_pendulum_swing").replace_run(duration=0.1))
    assert free.violation_position.shape == (0,)


def test_cli_summarises_the_constraint_violation(capsys):
    assert main(["simulate", "four_bar", "--duration", "0.5", "--no-save"]) == 0
    out = capsys.readouterr().out
    assert "constraints PointToPoint" in out
    assert "Baumgarte alpha = 20, beta = 20 1/s): max |phi| = " in out


def _scene(constraints, baumgarte=None, q=(0.3, 0.8, 0.9)):
    data = {
        "robot": {"urdf": "planar_3r.urdf"},
        "initial": {"q": list(q)},
        "constraints": constraints,
    }
    if baumgarte is not None:
        data["baumgarte"] = baumgarte
    return od.scene_from_dict(data, source="bad.toml", base_dir=od.io.urdf.shipped_robots_dir())


@pytest.mark.parametrize(
    "constraints, baumgarte, message",
    [
        ([{"type": "point_to_wrold", "frame": "tool"}], None, "did you mean 'point_to_world'"),
        ([{"type": "point_to_world", "frame": "tol"}], None, "constraints[0].frame: 'tol'"),
        ([{"type": "point_to_world"}], None, "constraints[0].frame: missing"),
        ([{"type": "point_to_world", "frame": "tool", "targt": [0, 0, 0]}], None, "'target'"),
        ([{"type": "point_on_plane", "frame": "tool"}], None, "constraints[0].normal: missing"),
        (
            [{"type": "point_to_world", "frame": "tool", "target": [9.0, 0, 0]}],
            None,
            "constraints[0]: the initial state breaks this PointToWorld constraint",
        ),
        (
            [{"type": "joint_coupling", "matrix": [[1.0, 0.0]]}],
            None,
            "constraints[0].matrix[0]: expected a list of 3 numbers",
        ),
        ([{"type": "joint_coupling"}], None, "give exactly one of coefficients"),
        (
            [{"type": "point_to_world", "frame": "tool"}],
            {"alpha": -1.0},
            "baumgarte.alpha: expected a number >= 0",
        ),
        (
            [{"type": "point_to_point", "frame_a": "base_link", "frame_b": "base_link"}],
            None,
            "base_link",
        ),
    ],
)
def test_bad_constraint_tables_are_named(constraints, baumgarte, message):
    with pytest.raises(od.SceneError) as info:
        _scene(constraints, baumgarte)
    assert "bad.toml" in str(info.value)
    assert message in str(info.value)


def test_baumgarte_without_constraints_is_refused():
    with pytest.raises(od.SceneError, match="baumgarte: stabilises constraints"):
        od.scene_from_dict(
            {"robot": {"urdf": "planar_3r.urdf"}, "baumgarte": {"alpha": 1.0}},
            base_dir=od.io.urdf.shipped_robots_dir(),
        )


def test_initial_velocity_must_satisfy_the_constraints():
    with pytest.raises(od.SceneError, match="its velocity error is"):
        od.scene_from_dict(
            {
                "robot": {"urdf": "planar_3r.urdf"},
                "initial": {"q": [0.3, 0.8, 0.9], "qd": [1.0, 0.0, 0.0]},
                "constraints": [{"type": "point_to_world", "frame": "tool"}],
            },
            base_dir=od.io.urdf.shipped_robots_dir(),
        )


def test_semi_implicit_euler_refuses_constraints(four_bar):
    with pytest.raises(od.SceneError, match="semi_implicit_euler .* does not support constraints"):
        od.simulate(four_bar.replace_run(integrator="semi_implicit_euler"))
