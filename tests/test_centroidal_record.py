"""A floating scene records its centre of mass and centroidal momentum (Trajectory.com,
Trajectory.centroidal_momentum), and they obey the momentum balance: in free fall the angular
momentum about the centre of mass stays what it was and the linear momentum gains M g t, the
centre of mass following a parabola; with ground contact the momentum's change equals the
impulse of the recorded contact forces (their moments about the centre of mass) and gravity, to
the integrator's error, which shrinks with the step.
"""

from __future__ import annotations

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.simulate import summary
from plotcheck import assert_lines_shown, read_png, saved_figures

pytest.importorskip("pinocchio")  # solo12 and the UR5 come from example-robot-data with it


def test_free_fall_keeps_the_angular_momentum_and_gains_m_g_t():
    scene = od.load_scene("solo12_falling")
    traj = od.simulate(scene)
    K = len(traj.t)
    assert traj.com.shape == (K, 3) and traj.centroidal_momentum.shape == (K, 6)
    # the record is what the public functions give at each sample (one kernel computes both)
    np.testing.assert_array_equal(traj.com, od.center_of_mass(scene.model, traj.q))
    momentum = od.centroidal_momentum(scene.model, traj.q, traj.qd)
    np.testing.assert_array_equal(traj.centroidal_momentum, momentum)
    M, g = float(np.sum(scene.model.mass)), np.asarray(scene.gravity)
    t = traj.t - traj.t[0]
    k_G, l_G = traj.centroidal_momentum[:, :3], traj.centroidal_momentum[:, 3:]
    assert np.abs(k_G - k_G[0]).max() <= 1e-8
    assert np.abs(l_G - l_G[0] - np.outer(t, M * g)).max() <= 1e-6 * M * np.linalg.norm(g)
    parabola = traj.com[0] + np.outer(t, l_G[0] / M) + 0.5 * np.outer(t**2, g)
    # to RK4's error at 1 ms: 1e-8 of the 4.9 m fall
    fall = np.abs(traj.com - traj.com[0]).max()
    assert fall > 4.0 and np.abs(traj.com - parabola).max() <= 1e-7 * fall
    # the legs moved: the test is not of a robot at rest
    assert np.abs(traj.qd[:, 6:]).max() > 1.0


def _balance_error(scene, dt):
    """max over time of |h_G(t) - h_G(0) - integral of the external wrench about c|, per
    component, and the gross impulse (the integral of the absolute values of each foot's
    wrench and of gravity, which largely cancel in the sum), from a run recording every step
    (the trapezoid rule on the samples)."""
    traj = od.simulate(scene.replace_run(integrator="rk4", dt=dt, output_dt=dt, duration=0.4))
    M, g = float(np.sum(scene.model.mass)), np.asarray(scene.gravity)
    f, x, c = traj.contact_force, traj.contact_point, traj.com
    feet = np.concatenate([np.cross(x - c[:, None], f), f], axis=2)  # (K, P, 6) about c
    weight = np.r_[0.0, 0.0, 0.0, M * g]
    dt_k = np.diff(traj.t)[:, None]
    steps = 0.5 * (feet[1:] + feet[:-1]).sum(axis=1) * dt_k + weight * dt_k
    impulse = np.concatenate([np.zeros((1, 6)), np.cumsum(steps, axis=0)])
    gross = (0.5 * np.abs(feet[1:] + feet[:-1]).sum(axis=1) * dt_k + np.abs(weight) * dt_k).sum(0)
    h = traj.centroidal_momentum
    assert np.abs(f).max() > 100.0  # the feet hit the ground
    return np.abs(h - h[0] - impulse).max(axis=0), gross


def test_with_contact_the_momentum_changes_by_the_contact_and_gravity_impulse():
    """quadruped_drop's feet land at t = 0.25 s; explicit RK4 below the contact's stability
    limit (dt x rate < 2.8 for friction near zero slip, rate 1.7e5 1/s: dt < 1.7e-5 s). At
    dt = 4e-6 s (dt x rate = 0.67) RK4 follows the stiff friction to about 1e-3 of the feet's
    impulses; the vertical momentum, which the normal forces and gravity change by 6 kg m/s,
    to 2e-4 of its impulse, and its error shrinks with the step."""
    scene = od.load_scene("quadruped_drop")
    coarse, _ = _balance_error(scene, 1.6e-5)
    fine, gross = _balance_error(scene, 4e-6)
    assert np.all(fine <= 2e-3 * gross), (fine, gross)
    assert fine[5] <= 2e-4 * gross[5] and fine[5] <= coarse[5] / 4, (fine, coarse)


def test_the_record_is_saved_loaded_and_written_with_its_columns(tmp_path):
    traj = od.simulate(od.load_scene("solo12_falling").replace_run(duration=0.05))
    loaded = od.Trajectory.load(traj.save(tmp_path / "run.npz"))
    np.testing.assert_array_equal(loaded.com, traj.com)
    np.testing.assert_array_equal(loaded.centroidal_momentum, traj.centroidal_momentum)
    header = traj.to_csv(tmp_path / "run.csv").read_text().splitlines()[0].split(",")
    columns = ["com_x", "com_y", "com_z", "kG_x", "kG_y", "kG_z", "lG_x", "lG_y", "lG_z"]
    first = header.index("com_x")
    assert header[first : first + 9] == columns
    table = np.loadtxt(tmp_path / "run.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, first : first + 3], traj.com)
    with saved_figures() as saved:
        png = traj.plot(tmp_path / "run.png")
    ((figure, dpi),) = saved
    momentum = figure.axes[-1]
    assert len(figure.axes) == 4  # q, qd, energy and h_G: nothing touches the falling robot
    drawn = np.column_stack([line.get_ydata() for line in momentum.lines])
    np.testing.assert_array_equal(drawn, traj.centroidal_momentum)
    # what Newton says the panel shows: nothing outside acts but gravity, from rest, so
    # k_G = 0 and l_G = (0, 0, -m g t) (to the free-fall test's tolerances above)
    m = float(np.sum(od.load_scene("solo12_falling").model.mass))
    np.testing.assert_allclose(drawn[:, :5], 0.0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(drawn[:, 5], -m * 9.81 * traj.t, rtol=0, atol=1e-6 * m * 9.81)
    image = read_png(png, figure, dpi)
    assert_lines_shown(image, momentum.lines)
    fixed = od.simulate(od.load_scene("ur5_falling").replace_run(duration=0.05))
    assert fixed.com.shape == (0, 3) and fixed.centroidal_momentum.shape == (0, 6)
    assert "com_x" not in fixed.to_csv(tmp_path / "fixed.csv").read_text().splitlines()[0]


def test_the_summary_reports_momentum_only_where_nothing_outside_pushes():
    falling = od.load_scene("solo12_falling").replace_run(duration=0.1)
    line = [s for s in summary(falling, od.simulate(falling)).splitlines() if "momentum" in s]
    assert len(line) == 1 and "max |k_G - k_G(0)|" in line[0] and "M g t" in line[0]
    drop = od.load_scene("quadruped_drop").replace_run(duration=0.01)
    assert "momentum" not in summary(drop, od.simulate(drop))
