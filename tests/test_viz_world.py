"""Playback of a scene's world: its objects (blue) and static entries (grey) drawn from their
collision geometry and moved as the trajectory moves them, a world plane as a slab under it, and
the contact forces between collision geometries as arrows on the moving body of each pair."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_viz import (
    clips_by_path,
    metres_per_newton,
    objects_by_path,
    page_commands,
    transforms_by_path,
)

import opendyn as od
from opendyn.cli.main import main
from opendyn.sim.contacts import ContactTable
from opendyn.viz.visuals import OBJECT_RGBA, WORLD_RGBA


def hex_colour(rgba):
    """three.js's colour number of an (r, g, b, a) in [0, 1]."""
    r, g, b = (round(255 * c) for c in rgba[:3])
    return r << 16 | g << 8 | b


def test_the_slots_follow_each_pairs_points_and_turn_forces_onto_the_moving_body():
    """Pair 0 (a, ground) has two points at sample 0 and one at sample 2; pair 1 (a, b) one at
    sample 0. Three slots: pair 0's first and second points, pair 1's; the ground's force on a
    is -force (the row's force is a's on the ground); an empty sample keeps the slot's nearest
    point and has no force."""
    f = np.array([[0, 0, -1.0], [0, 0, -2.0], [1.0, 0, 0], [0, 0, -3.0]])
    table = ContactTable(
        sample=np.array([0, 0, 0, 2]), pair=np.array([0, 0, 1, 0]),
        point=np.arange(12.0).reshape(4, 3), normal=np.zeros((4, 3)), force=f,
        depth=np.ones(4), pair_names=(("a", "ground"), ("a", "b")),
    )
    points, forces = table.slots(3, static={"ground"})
    assert points.shape == forces.shape == (3, 3, 3)
    np.testing.assert_array_equal(forces[0], [[0, 0, 1], [0, 0, 2], [1, 0, 0]])
    np.testing.assert_array_equal(forces[1], np.zeros((3, 3)))
    np.testing.assert_array_equal(forces[2], [[0, 0, 3], [0, 0, 0], [0, 0, 0]])
    np.testing.assert_array_equal(points[:, 0], [[0, 1, 2], [9, 10, 11], [9, 10, 11]])
    np.testing.assert_array_equal(points[:, 1], [[3, 4, 5]] * 3)
    np.testing.assert_array_equal(points[:, 2], [[6, 7, 8]] * 3)


@pytest.fixture(scope="module")
def stack_page(tmp_path_factory):
    pytest.importorskip("meshcat")
    folder = tmp_path_factory.mktemp("page")
    page, run = folder / "stack.html", folder / "stack.npz"
    argv = ["simulate", "box_stack", "--duration", "0.1", "-o", str(run), "--html", str(page)]
    assert main(argv) == 0
    return page.read_text(), od.Trajectory.load(run), od.load_scene("box_stack")


def test_the_objects_are_drawn_as_their_shapes_where_the_trajectory_has_them(stack_page):
    html, traj, scene = stack_page
    commands = page_commands(html)
    objects, clips = objects_by_path(commands), clips_by_path(commands)
    for name in ("bottom", "middle", "top"):
        node = f"/meshcat/world/{name}"
        drawn = objects[f"{node}/visual_0"]
        box = drawn["geometries"][0]
        assert (box["width"], box["height"], box["depth"]) == (0.2, 0.2, 0.1)
        colour = drawn["materials"][0]["color"]
        assert colour == hex_colour(OBJECT_RGBA)
        times, position = clips[node][".position"]  # at the page's 30 frames a second
        i = scene.model.q_names.index(f"{name}.x")
        assert times[0] == traj.t[0] and times[-1] == pytest.approx(traj.t[-1])
        q = np.column_stack([np.interp(times, traj.t, traj.q[:, k]) for k in range(i, i + 7)])
        np.testing.assert_allclose(position, q[:, :3], atol=1e-6)
        _, quat = clips[node][".quaternion"]
        unit = q[:, 3:] / np.linalg.norm(q[:, 3:], axis=1, keepdims=True)
        assert np.all(np.abs(np.abs(np.sum(quat * unit, axis=1)) - 1.0) < 1e-6)


def test_the_forces_on_each_box_are_arrows_that_carry_the_weight_above_it(stack_page):
    """At the last sample the arrows under the bottom box (the ground's, turned onto the box)
    point up and add up to 3 m g; the page's stated scale gives each arrow's length."""
    html, traj, scene = stack_page
    commands = page_commands(html)
    clips = clips_by_path(commands)
    scale = metres_per_newton(html)
    ground = [p for p, (a, b) in enumerate(traj.contacts.pair_names) if b == "ground"]
    rows = traj.contacts.at(len(traj.t) - 1)
    assert {rows.pair_names[p] for p in rows.pair} >= {("bottom", "ground")}
    up = 0.0
    for slot in range(len(traj.contacts.slots(len(traj.t), {"ground"})[0][0])):
        shaft = clips[f"/ContactForces/point_{slot}/shaft"]
        head = clips[f"/ContactForces/point_{slot}/head"]
        start = shaft[".position"][1][-1]
        along = Rotation.from_quat(shaft[".quaternion"][1][-1]).apply([0.0, 0.0, 1.0])
        length = shaft[".scale"][1][-1, 2] + head[".scale"][1][-1, 2] * (
            objects_by_path(commands)[f"/ContactForces/point_{slot}/head/cone"]["geometries"][0][
                "height"
            ]
        )
        if abs(start[2]) < 1e-3 and length > 0:  # at the ground: the bottom box's corners
            assert along[2] > 0.99
            up += length / scale * along[2]
    assert ground and up == pytest.approx(3 * 9.81, rel=1e-4)


def test_the_world_entries_are_drawn_still_in_grey_and_a_plane_as_a_slab_below_it(tmp_path):
    pytest.importorskip("meshcat")
    from opendyn.viz import playback

    tilt = [0.3, 0.0, 0.0]
    scene = od.scene_from_dict({
        "objects": [{"name": "ball", "shape": "sphere", "size": [0.1], "mass": 1.0,
                     "position": [0.0, 0.0, 1.0]}],
        "world": [{"name": "slope", "shape": "plane", "position": [0.0, 0.0, 0.2], "rpy": tilt},
                  {"name": "post", "shape": "cylinder", "size": [0.05, 1.0],
                   "position": [1.0, 0.0, 0.5]}],
        "run": {"duration": 0.1},
    })
    traj = od.simulate(scene)
    page = playback.write_html(scene.model, traj.t, traj.q, tmp_path / "w.html")
    commands = page_commands(page.read_text())
    objects, transforms = objects_by_path(commands), transforms_by_path(commands)
    clips = clips_by_path(commands)
    for name in ("slope", "post"):
        assert f"/meshcat/world/{name}" not in clips  # static
        colour = objects[f"/meshcat/world/{name}/visual_0"]["materials"][0]["color"]
        assert colour == hex_colour(WORLD_RGBA)
    T_slope = transforms["/meshcat/world/slope"]
    np.testing.assert_allclose(T_slope[:3, 3], [0.0, 0.0, 0.2], atol=1e-12)
    np.testing.assert_allclose(
        T_slope[:3, :3], Rotation.from_euler("xyz", tilt).as_matrix(), atol=1e-12
    )
    slab = objects["/meshcat/world/slope/visual_0"]["geometries"][0]
    thickness = slab["depth"]
    # the slab's top face is the plane: its centre half its thickness below, along its normal
    np.testing.assert_allclose(
        transforms["/meshcat/world/slope/visual_0"][:3, 3], [0, 0, -thickness / 2], atol=1e-12
    )
    assert "/meshcat/world/ball/visual_0" in objects
