"""Bodies that should rest, resting: contact manifolds that hold still under the small motions
of a body at rest ([effects.contact] geometry = "collision"), against statics: a box on a box
turned about the vertical by any angle, boxes dropped onto each other with their yaws apart, a
cylinder lying on the ground on both its ends, and a floor given as one flat quad, which must
hold a box as the ground plane does."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import opendyn as od

G = 9.81
K = 1e5  # N/m, the contact's stiffness in every scene here
BOX = [0.2, 0.2, 0.1]


def scene(objects, world=(), duration=1.0, integrator="implicit_euler", **contact):
    """A scene of objects (and world entries) under gravity, with the contact between collision
    geometries (the ground plane z = 0 included) of stiffness K."""
    data = {
        "name": "resting",
        "objects": list(objects),
        "world": list(world),
        "run": {"duration": duration, "integrator": integrator, "dt": 0.001, "output_dt": 0.01},
        "effects": {
            "gravity": True,
            "contact": {
                "geometry": "collision",
                "stiffness": K,
                "damping": 300.0,
                "friction": 0.5,
                **contact,
            },
        },
    }
    return od.scene_from_dict(data)


def box(name, z, yaw=0.0, x=0.0):
    """A 1 kg box of BOX's size at height z (its centre), turned by yaw about the vertical."""
    return {
        "name": name,
        "shape": "box",
        "size": BOX,
        "mass": 1.0,
        "position": [x, 0.0, z],
        "rpy": [0.0, 0.0, yaw],
    }


def speeds(traj, after):
    """The largest |v| of any coordinate from time `after` on (m/s or rad/s)."""
    return np.abs(traj.qd[traj.t >= after - 1e-12]).max()


def normal_force_on(traj, name, k=-1):
    """The total contact force on object `name` at sample k (N, world), from the contact table
    (a row's force is what its a applies to its b)."""
    rows = traj.contacts.at(len(traj.t) - 1 if k == -1 else k)
    total = np.zeros(3)
    for pair, force in zip(rows.pair, rows.force, strict=True):
        a, b = rows.pair_names[pair]
        total += force if b == name else (-force if a == name else 0.0)
    return total


@pytest.mark.parametrize("yaw_degrees", range(0, 91, 5))
def test_a_box_on_a_box_turned_about_the_vertical_rests(yaw_degrees):
    """Two 1 kg boxes, the bottom on the ground, the top turned by 0-90 degrees about z, each
    at its resting depth (4 corners, each k d = its load / 4), implicit Euler at 1 ms: after 1 s
    nothing moves faster than 1e-6 m/s (the old reduction kept an asymmetric four of the
    octagon's eight corners, which a 1e-5 rad tilt switched: at 0.2 rad the top box still slid
    at 0.25 m/s), the top has not moved by more than 1e-6 m, and the contact under it carries
    its weight, m g, to 1e-6 relative."""
    d_bottom, d_top = 2 * G / (4 * K), G / (4 * K)
    yaw = np.radians(yaw_degrees)
    traj = od.simulate(
        scene([box("bottom", 0.05 - d_bottom), box("top", 0.15 - d_bottom - d_top, yaw)])
    )
    assert traj.complete
    assert speeds(traj, 0.5) < 1e-6
    top = slice(7, 10)
    assert np.abs(traj.q[:, top] - traj.q[0, top]).max() < 1e-6
    np.testing.assert_allclose(normal_force_on(traj, "top"), [0, 0, G], atol=1e-6 * G)


def test_three_boxes_dropped_with_their_yaws_apart_come_to_rest():
    """Three 1 kg boxes dropped 2 cm each onto the ground and onto each other, turned 0, 0.3 and
    0.7 rad about z: at rest within 1 s (nothing faster than 1e-4 m/s after 1 s), stacked (the
    top centre within 1 mm of the bottom's axis), the contacts on each box carrying its weight.
    The top two boxes spin a little as they land; a linearly implicit step that took friction's
    tangent (whose slope along the slip vanishes) let that spin flip sign every step for ever:
    the friction's secant holds it (opendyn.algorithm.contact_tangent)."""
    traj = od.simulate(
        scene(
            [box("bottom", 0.07), box("middle", 0.19, 0.3), box("top", 0.31, 0.7)],
            duration=1.5,
        )
    )
    assert traj.complete
    assert speeds(traj, 1.0) < 1e-4
    assert np.linalg.norm(traj.q[-1, 14:16] - traj.q[-1, 0:2]) < 1e-3
    for name in ("top", "middle", "bottom"):  # the contacts on each carry its weight
        np.testing.assert_allclose(normal_force_on(traj, name), [0, 0, G], atol=1e-4 * G)


def lying_cylinder(z):
    """A 3 kg cylinder r = 0.1, length 0.4, lying along y with its axis at height z."""
    return {
        "name": "roller",
        "shape": "cylinder",
        "size": [0.1, 0.4],
        "mass": 3.0,
        "position": [0.0, 0.0, z],
        "rpy": [np.pi / 2, 0.0, 0.0],
    }


def test_a_cylinder_lying_on_the_ground_rests_on_both_ends():
    """A 3 kg cylinder lying on the ground at its resting depth (two contacts, its ends' lowest
    points, each m g / 2 = 14.7 N: the old manifold gave one end, flipping to the other every
    step, 39.7 N up and 19.8 N sideways): at the end of 1 s two contacts, 0.2 m either side of
    the centre, carrying m g between them to 1e-6 relative with no sideways force, nothing
    moving. Under DOPRI5 (tolerances 1e-6), 0.05 s takes under 10,000 steps (it took millions:
    the run did not advance)."""
    depth = 3.0 * G / (2 * K)
    traj = od.simulate(scene([lying_cylinder(0.1 - depth)]))
    assert traj.complete and speeds(traj, 0.5) < 1e-6
    rows = traj.contacts.at(len(traj.t) - 1)
    assert len(rows) == 2
    np.testing.assert_allclose(sorted(rows.point[:, 1]), [-0.2, 0.2], atol=1e-6)
    np.testing.assert_allclose(normal_force_on(traj, "roller"), [0, 0, 3.0 * G], atol=3e-6 * G)
    dopri = od.simulate(scene([lying_cylinder(0.1 - depth)], duration=0.05, integrator="dopri5"))
    assert dopri.complete
    assert dopri.stats["steps"] < 10_000


def quad_floor(path):
    """An STL of one flat quad, 4 m x 4 m at z = 0 (two triangles): a floor as exported."""
    vertices = np.array([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0.0)])
    trimesh.Trimesh(vertices, [(0, 1, 2), (0, 2, 3)], process=False).export(path)
    return str(path)


def test_a_floor_given_as_one_flat_quad_holds_a_box_as_the_ground_does(tmp_path):
    """A box sliding at 0.5 m/s on a floor exported as one quad (a flat mesh: the old hull had
    no face, so the box met the floor at one point, yawed 4.6 degrees, sank 8 times as deep and
    felt 14 times the force) moves as on the ground plane: the same trajectory to 1e-6 m and
    1e-6 rad, four contacts, and at the end the same normal force, m g."""
    floor = quad_floor(tmp_path / "floor.stl")
    sliding = {**box("box", 0.05 - G / (4 * K)), "velocity": [0.5, 0.0, 0.0]}
    on_ground = od.simulate(scene([sliding]))
    on_quad = od.simulate(
        scene(
            [sliding],
            world=[{"name": "floor", "shape": "mesh", "mesh": floor, "position": [0, 0, 0]}],
            ground_height=-1.0,
        )
    )
    assert on_ground.complete and on_quad.complete
    assert {on_quad.contacts.pair_names[p] for p in on_quad.contacts.pair} == {("box", "floor")}
    np.testing.assert_allclose(on_quad.q, on_ground.q, atol=1e-6)
    assert len(on_quad.contacts.at(len(on_quad.t) - 1)) == 4
    np.testing.assert_allclose(normal_force_on(on_quad, "box"), [0, 0, G], atol=1e-4 * G)
