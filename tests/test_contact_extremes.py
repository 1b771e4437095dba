"""A run's contact at its worst, over every step and not only the samples: the deepest point,
the largest force and what touched (traj.contact_extremes, the summary's contact line), and the
warning when a pair sinks deeper than half its thinner geometry.

The references: the ball's closed-form bounce (energy from the fall into the spring, as
tests/test_contact.py), and the same run sampled at every step, whose samples are its steps.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.simulate import summary
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim.scene import thaw

G = 9.81
BALL_M, BALL_K, BALL_H, BALL_R = 1.0, 1e5, 0.5, 0.1  # kg, N/m, m, m (scenes/ball_drop.toml)


def ball(stiffness=BALL_K, **run):
    """The shipped ball_drop scene, its stiffness and run keys changed."""
    data = thaw(od.load_scene("ball_drop").settings)
    data["effects"]["contact"]["stiffness"] = stiffness
    data["run"].update(run)
    return od.scene_from_dict(data, base_dir=shipped_robots_dir())


def box_drop(height=0.05, mass=1.0, **run):
    """The shipped box_on_table scene, the box `height` m above the table and of `mass` kg."""
    data = thaw(od.load_scene("box_on_table").settings)
    data["objects"][0].update(position=[0.0, 0.0, 0.45 + height], mass=mass)
    data["run"].update(run)
    return od.scene_from_dict(data)


def bounce():
    """The ball's first bounce in closed form: (deepest penetration m, its time s). The fall
    from h takes sqrt(2 h / g); in contact m delta'' = m g - k delta, delta(0) = 0, so delta =
    delta_e + A sin(w t + phi) with w = sqrt(k / m), delta_e = m g / k, A = delta_max - delta_e
    and sin(phi) = -delta_e / A; m g (h + delta_max) = k delta_max^2 / 2 gives delta_max."""
    mg = BALL_M * G
    deepest = (mg + np.sqrt(mg**2 + 2 * BALL_K * mg * BALL_H)) / BALL_K
    w, rest = np.sqrt(BALL_K / BALL_M), mg / BALL_K
    phi = np.arcsin(-rest / (deepest - rest))
    return deepest, np.sqrt(2 * BALL_H / G) + (np.pi / 2 - phi) / w


def test_a_bounce_between_two_samples_is_seen():
    """Sampled every 0.1 s, the ball's 10 ms bounce falls between the samples at 0.3 and 0.4 s:
    the samples say it never touched (the summary said "no pair touched" before), the extremes
    over every step give the closed-form depth, force and time. At RK4, 0.1 ms, a step's state
    misses the peak by at most 1/2 (w dt)^2 = 5e-4 of it."""
    traj = od.simulate(ball(duration=0.5, output_dt=0.1))
    assert not traj.penetration.any()
    extremes = traj.contact_extremes
    deepest, t_deepest = bounce()
    assert extremes.every_step and extremes.touched
    assert extremes.pairs == ("ball",) and extremes.deepest_pair == 0
    assert extremes.deepest == pytest.approx(deepest, rel=5e-4)
    assert extremes.depth[0] == extremes.deepest
    assert extremes.deepest_t == pytest.approx(t_deepest, abs=1e-4)
    # undamped and frictionless: f = k delta, largest where deepest
    assert extremes.largest_force == pytest.approx(BALL_K * extremes.deepest, rel=1e-12)
    assert extremes.largest_t == extremes.deepest_t and extremes.most_points == 1
    line = summary(ball(), traj).splitlines()[-1]
    assert line.startswith("contact     1 point on the ground")
    assert "10 mm (ball at t = 0.324" in line
    assert line.endswith("over every step") and "WARNING" not in summary(ball(), traj)


def test_an_adaptive_run_keeps_the_extremes_of_its_accepted_steps():
    """DOPRI5 folds the state at the end of each accepted step: the bounce between two samples
    is seen there too, its depth within 1% of the closed form (the steps near the bottom are
    about 0.3 ms: 1/2 (w dt)^2 = 0.5%)."""
    traj = od.simulate(ball(duration=0.5, output_dt=0.1, integrator="dopri5", rtol=1e-8))
    assert not traj.penetration.any()
    deepest, t_deepest = bounce()
    assert traj.contact_extremes.every_step
    assert traj.contact_extremes.deepest == pytest.approx(deepest, rel=1e-2)
    assert traj.contact_extremes.deepest_t == pytest.approx(t_deepest, abs=1e-3)


def test_the_extremes_of_every_step_are_those_of_a_run_sampled_at_every_step():
    """A box dropped 5 cm onto the table (implicit Euler, 1 ms): the run sampled every 0.1 s
    keeps the same extremes as the same run sampled at every step, taken from its contact
    table: the deepest point, the largest force, each with its pair and time, the most points
    at once."""
    coarse = od.simulate(box_drop(duration=0.4, output_dt=0.1)).contact_extremes
    table = od.simulate(box_drop(duration=0.4, output_dt=0.001))
    rows, t = table.contacts, table.t
    force = np.linalg.norm(rows.force, axis=1)
    assert coarse.pairs == ("box-table", "box-ground")
    assert coarse.deepest_pair == coarse.largest_pair == 0 and coarse.depth[1] == 0.0
    assert coarse.deepest == pytest.approx(rows.depth.max(), rel=1e-9)
    assert coarse.deepest_t == pytest.approx(t[rows.sample[np.argmax(rows.depth)]], abs=1e-12)
    assert coarse.largest_force == pytest.approx(force.max(), rel=1e-9)
    assert coarse.largest_t == pytest.approx(t[rows.sample[np.argmax(force)]], abs=1e-12)
    assert coarse.most_points == np.bincount(rows.sample).max() == 4
    # the impact presses deeper than the resting depth m g / (4 k) = 24.5 um
    assert coarse.deepest > 2 * G / (4 * 1e5)


def test_a_pair_sunk_deeper_than_half_its_thinner_geometry_is_a_warning():
    """A 1e4 kg box on the 1e5 N/m table rests at m g / (4 k) = 0.25 m, through its own 0.1 m:
    the run completes, and says the bodies sink through each other (a RuntimeWarning, and a
    WARNING line of the summary). A ball on ground soft enough that m g / k is twice its radius,
    likewise. The shipped scenes, as they are, warn of nothing."""
    heavy = box_drop(height=0.0, mass=1e4, duration=0.3, output_dt=0.1)
    with pytest.warns(RuntimeWarning, match=r"'box-table' went 0\.\d+ m deep, more than half"):
        traj = od.simulate(heavy)
    assert traj.complete and traj.contact_extremes.too_deep().tolist() == [0]
    text = summary(heavy, traj)
    assert "complete, with the warning below" in text
    assert "WARNING     contact 'box-table' went" in text and "effects.contact.stiffness" in text
    soft = ball(stiffness=BALL_M * G / (2 * BALL_R), duration=1.0, output_dt=0.1)
    with pytest.warns(RuntimeWarning, match=r"contact 'ball' went .* than half its thinner"):
        od.simulate(soft)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        od.simulate(box_drop(height=0.0, duration=0.3, output_dt=0.1))
        od.simulate(ball(duration=0.5, output_dt=0.1))


def test_the_extremes_are_saved_with_the_trajectory(tmp_path):
    traj = od.simulate(ball(duration=0.5, output_dt=0.1))
    back = od.Trajectory.load(traj.save(tmp_path / "run.npz")).contact_extremes
    mine = traj.contact_extremes
    assert back.pairs == mine.pairs and back.every_step
    for name in ("deepest", "deepest_pair", "deepest_t", "largest_force", "largest_pair",
                 "largest_t", "most_points"):
        assert getattr(back, name) == getattr(mine, name)
    np.testing.assert_array_equal(back.depth, mine.depth)
    np.testing.assert_array_equal(back.limit, mine.limit)


def test_a_simulator_keeps_the_extremes_of_its_steps_and_forgets_them_at_reset():
    """od.Simulator, stepped past the bounce, holds it; after reset, a step that ends before
    the ball lands holds nothing."""
    sim = od.Simulator(ball(output_dt=0.1))
    sim.step(duration=0.5)
    deepest, _ = bounce()
    assert sim.trajectory().contact_extremes.deepest == pytest.approx(deepest, rel=5e-4)
    sim.reset()
    sim.step(duration=0.2)
    assert not sim.trajectory().contact_extremes.touched

