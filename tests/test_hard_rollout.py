"""od.rollout of scenes with a hard model (model = "hard"): run i is simulate of its scene, bit
for bit, each run with its own warm start, so that what a run gives depends neither on the
thread that ran it nor on the runs before it (spheres on the ground, hard limits, a box on a
ramp)."""

from __future__ import annotations

import numpy as np
from test_hard_contact import hard_ball

import opendyn as od

RECORDED = ("t", "q", "qd", "tau", "kinetic", "potential", "work_applied", "work_passive")


def assert_runs_are_simulate(result, runs):
    """Runs `runs` (indices) of the rollout are simulate of their scenes, bit for bit: their
    samples, counts and the hard model's solve statistics."""
    for i in runs:
        expected = od.simulate(result.scene_for(i), raise_on_failure=False)
        got = result.trajectory(i)
        for name in RECORDED:
            np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)
        for key in ("steps", "evaluations", "unconverged_steps", "worst_residual"):
            assert got.stats[key] == expected.stats[key], (i, key)
        assert result.unconverged_steps[i] == expected.stats["unconverged_steps"]
        np.testing.assert_array_equal(result.q_final[i], expected.q[-1])


def ball_starts(n, seed=0):
    """n starts of the hard ball, thrown sideways at up to 1 m/s and spinning: every other one
    on the ground, 1e-5 m deep (the ball's radius is 0.1 m), so that its first step warm-starts
    from whatever impulse the room holds, the others 0.15 to 0.3 m up, landing, sliding and
    rolling within 0.4 s: (q0 (n, 7), qd0 (n, 6))."""
    rng = np.random.default_rng(seed)
    q0 = np.tile(hard_ball().q0, (n, 1))
    q0[:, 2] = rng.uniform(0.15, 0.3, n)
    q0[::2, 2] = 0.1 - 1e-5
    qd0 = np.zeros((n, 6))
    qd0[:, :3] = rng.uniform(-5.0, 5.0, (n, 3))  # omega_b, rad/s
    qd0[:, 3:5] = rng.uniform(-1.0, 1.0, (n, 2))  # v_b, m/s
    return q0, qd0


def short_ball():
    return hard_ball().replace_run(duration=0.4)


def test_each_hard_run_is_simulate_bit_for_bit():
    """Four balls from different starts on two threads: each run is simulate of its scene, bit
    for bit, and each lands (the solve has contact rows to warm-start)."""
    scene = short_ball()
    q0, qd0 = ball_starts(4)
    result = od.rollout(scene, q0=q0, qd0=qd0, threads=2)
    assert result.complete.all()
    assert np.all(result.q[:, -1, 2] < 0.1 + 1e-6)  # on the ground at the end
    assert_runs_are_simulate(result, range(4))


def test_threads_and_order_change_no_hard_run():
    """Forty balls on one thread, on two, and in reverse order give the same runs, bit for bit:
    on one thread a slice's runs share a working room one after another (a block of runs is
    cut in slices of several runs once the rate is known), on two they share it with other
    runs."""
    scene = short_ball()
    q0, qd0 = ball_starts(40, seed=1)
    one = od.rollout(scene, q0=q0, qd0=qd0, threads=1)
    two = od.rollout(scene, q0=q0, qd0=qd0, threads=2)
    backwards = od.rollout(scene, q0=q0[::-1], qd0=qd0[::-1], threads=2)
    assert one.complete.all()
    for name in ("q", "qd", "tau", "work_passive", "unconverged_steps", "worst_residual"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name), err_msg=name)
        np.testing.assert_array_equal(
            getattr(one, name), getattr(backwards, name)[::-1], err_msg=name
        )


def test_a_runs_warm_start_does_not_reach_the_next_run():
    """planar_3r_limits_hard from two starts in turn, forty runs on one thread, both with
    joint1 on its +3 rad limit and joint3 on its -2.5 rad one (within the margin, driven into
    them: their rows are in the first step's solve, warm-started from the room), joint2
    swinging one way or the other. Every A is the same run, bit for bit, whatever B ran before
    it in the same working room, and is simulate's; so is every B."""
    scene = od.load_scene("planar_3r_limits_hard").replace_run(duration=0.3)
    a = np.array([3.0 - 1e-4, 0.0, -2.5 + 1e-4]), np.array([0.0, 1.0, 0.0])
    b = np.array([3.0 - 1e-4, 2.0, -2.5 + 1e-4]), np.array([0.0, -2.0, 0.0])
    q0 = np.array([a[0], b[0]] * 20)
    qd0 = np.array([a[1], b[1]] * 20)
    result = od.rollout(scene, q0=q0, qd0=qd0, threads=1)
    assert result.complete.all()
    for start in (0, 1):
        for name in ("q", "qd", "work_passive"):
            runs = getattr(result, name)[start::2]
            np.testing.assert_array_equal(runs, np.broadcast_to(runs[0], runs.shape))
    assert_runs_are_simulate(result, (0, 1, 38, 39))


def test_boxes_on_a_ramp_roll_out_as_simulate_runs_them():
    """box_incline_hard (geometry contact, its manifold's ids warm-starting the solve) from
    three starts pushed along the ramp, each with its own friction coefficient (params: 0.6
    holds the box, 0.25 lets it slide), on two threads: each run is simulate of its scene, bit
    for bit."""
    scene = od.load_scene("box_incline_hard").replace_run(duration=0.1)
    qd0 = np.zeros((3, scene.model.nv))
    qd0[:, 3] = [0.0, 0.5, -0.5]  # along the ramp, in the box's frame (m/s)
    friction = {"effects.contact.friction": np.array([0.6, 0.25, 0.4])}
    result = od.rollout(scene, qd0=qd0, params=friction, threads=2)
    assert result.complete.all()
    assert_runs_are_simulate(result, range(3))
