"""panda_push: the Panda, run by a Python controller stepped through od.Simulator, pushes a box
across a table. The box moves by the commanded distance, nothing passes through anything, and
the contact forces are in the record."""

import numpy as np
import pytest
from shipped_controller import shipped_controller

import opendyn as od

G = 9.81


@pytest.fixture(scope="module")
def controller():
    return shipped_controller("panda_push")


@pytest.fixture(scope="module")
def pushed(controller):
    """The scene stepped by hand: at each millisecond the controller's torque from the
    Simulator's state, held over the step."""
    scene = od.load_scene("panda_push")
    sim = od.Simulator(scene.without("control"))
    dt = scene.run.dt
    for _ in range(round(scene.run.duration / dt)):
        sim.step(controller.push(sim.t, sim.q, sim.qd), dt)
    return scene, sim.trajectory()


def test_the_box_moves_by_the_commanded_distance(pushed, controller):
    scene, traj = pushed
    box = scene.model.q_names.index("box.x")
    x, y, z = (traj.q[:, box + k] for k in range(3))
    # it moved by PUSH = 10 cm, less the tool's lag behind its set point and the contacts'
    # compliance (tenths of a millimetre), straight ahead, on the table, without turning
    assert x[-1] - x[0] == pytest.approx(controller.PUSH, abs=1e-3)
    assert abs(y[-1]) < 1e-3 and abs(z[-1] - z[0]) < 1e-4
    quat = traj.q[-1, box + 3 : box + 7]
    assert 2.0 * np.arccos(min(abs(quat[3]), 1.0)) < 0.01  # rad
    # the box was still until the fingers reached it, and is at rest at the end (under 1 mm/s:
    # the tool still closes its last tenth of a millimetre on its set point)
    t_touch = traj.t[np.flatnonzero(x - x[0] > 1e-4)[0]]
    assert t_touch > 1.5 + 0.5 * controller.GAP / (controller.GAP + controller.PUSH)
    assert np.abs(np.diff(x[-20:]) / np.diff(traj.t[-20:])).max() < 1e-3


def test_nothing_passes_through_anything_and_the_forces_are_recorded(pushed):
    scene, traj = pushed
    contacts = traj.contacts
    assert contacts.depth.max() < 2e-3  # m, every pair at every sample
    names = [contacts.pair_names[p] for p in contacts.pair]
    finger_on_box = np.array([("finger" in a and b == "box") for a, b in names])
    assert finger_on_box.any()
    # the fingers push the box forward (+x), the table holds it up against its weight and
    # friction against the push: at a sample mid-push, the forces on the box add up to m a
    k = int(np.searchsorted(traj.t, 2.75))
    rows = contacts.at(k)
    on_box = np.zeros(3)
    for pair, force in zip(rows.pair, rows.force):
        a, b = rows.pair_names[pair]
        on_box += force if b == "box" else -force if a == "box" else 0.0
    pushing = [f for p, f in zip(rows.pair, rows.force) if "finger" in rows.pair_names[p][0]]
    assert pushing and sum(f[0] for f in pushing) > 0.0
    mass = 0.4
    box = scene.model.v_names.index("box.vx")
    # the box's acceleration from the record (world frame; it does not turn)
    R = od.frame_pose(scene.model, traj.q[k], "box")[:3, :3]
    v = np.array([R @ traj.qd[j, box : box + 3] for j in (k - 1, k + 1)])
    a = (v[1] - v[0]) / (traj.t[k + 1] - traj.t[k - 1])
    np.testing.assert_allclose(on_box + mass * np.array([0, 0, -G]), mass * a, atol=0.05)


def test_the_scene_run_as_shipped_is_the_same_run(pushed):
    """opendyn simulate panda_push runs the controller from the scene's [control]: the same
    torques at the same ticks, the same trajectory."""
    scene, traj = pushed
    shipped = od.simulate(scene)
    assert shipped.complete
    np.testing.assert_allclose(shipped.q, traj.q, atol=1e-12)
