"""Objects, static world geometry and the contact between collision geometries
([[objects]], [[world]], [effects.contact] geometry = "collision"): the shipped scenes against
what statics and Coulomb's law say, momentum conserved between two bodies, and the scene
reader's checks."""

import math

import tomllib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import opendyn as od
from opendyn.algorithm.geometry_contact import geometry_contact_on_poses, geometry_room
from opendyn.algorithm.kinematics import forward_kinematics
from opendyn.errors import SceneError
from opendyn.io.scene.files import shipped_scenes
from opendyn.io.urdf import shipped_robots_dir
from opendyn.multibody.joints import FREE
from opendyn.sim.effects import geometry_contact

G = 9.81


def scene(name, **changes):
    """A shipped scene, with [effects.contact] keys changed."""
    path = shipped_scenes()[name]
    data = tomllib.loads(path.read_text())
    data["effects"]["contact"].update(changes)
    return od.scene_from_dict(data, source=str(path), base_dir=path.parent)


def pair_force(s, q, qd, a, b):
    """The force (3,) N, world axes, that the pairs between the geometries named a and b apply
    to b's object at (q, qd): the generalized force of those pairs alone, on b's free joint
    (its linear part is the force in b's axes)."""
    model = s.model
    table, pairs, law = geometry_contact.pack(s.contact, model)
    names = [g.link for g in model.geometries] + ["ground"]
    keep = [k for k, (i, j) in enumerate(pairs) if {names[i], names[j]} == {a, b}]
    assert keep, f"no pair {a}-{b}"
    contacts = (table, pairs[keep], law[keep])
    work = model.data()._work
    forward_kinematics(model._ibuf, model._fbuf, work, np.array(q, dtype=float))
    tau = np.zeros(model.nv)
    unused = np.zeros((0, 0))
    geometry_contact_on_poses(
        model._ibuf, model._fbuf, work, contacts, geometry_room(len(names), model.nv),
        np.array(qd, dtype=float), tau, (unused, unused, np.bool_(False)), None,
    )
    body = model.body_names.index(b)
    iq, iv = model.iq[body], model.iv[body]
    R_sb = Rotation.from_quat(q[iq + 3 : iq + 7]).as_matrix()
    return R_sb @ tau[iv + 3 : iv + 6]


def test_box_on_table_rests_on_its_weight():
    s = scene("box_on_table")
    traj = od.simulate(s)
    assert traj.complete
    drift = np.abs(traj.q[:, :3] - traj.q[0, :3]).max()
    assert drift < 1e-4  # m over 5 s
    # at rest the table's forces carry the weight: sum f = (0, 0, m g) to 1e-6 relative
    f = pair_force(s, traj.q[-1], traj.qd[-1], "table", "box")
    assert np.allclose(f, [0.0, 0.0, 1.0 * G], rtol=0, atol=1e-6 * G)
    # nothing on the ground: the box stands on the table
    assert np.allclose(pair_force(s, traj.q[-1], traj.qd[-1], "ground", "box"), 0.0)
    # the springs' energy is in E: the balance closes with the dampers as passive work
    assert np.abs(traj.energy_error).max() < 1e-6


def test_each_box_of_a_stack_carries_the_weight_above_it():
    s = scene("box_stack")
    traj = od.simulate(s)
    assert traj.complete
    q, qd = traj.q[-1], traj.qd[-1]
    for a, b, carried in (("ground", "bottom", 3), ("bottom", "middle", 2), ("middle", "top", 1)):
        f = pair_force(s, q, qd, a, b)
        assert np.allclose(f, [0.0, 0.0, carried * G], rtol=0, atol=1e-6 * carried * G), (a, b)
    # equal and opposite: what pushes the middle box up pushes the bottom one down
    up = pair_force(s, q, qd, "bottom", "middle")
    down = pair_force(s, q, qd, "middle", "bottom")
    assert np.allclose(up, -down, rtol=0, atol=1e-12)


def test_a_box_on_an_incline_holds_or_slides_as_coulomb_says():
    theta = math.radians(20.0)
    held = od.simulate(scene("box_incline"))  # mu = 0.5 > tan 20
    assert held.complete
    assert np.linalg.norm(held.q[-1, :3] - held.q[0, :3]) < 1e-4
    mu = 0.2
    slid = od.simulate(scene("box_incline", friction=mu, slip_velocity=1e-3))
    assert slid.complete
    downhill = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    s = (slid.q[:, :3] - slid.q[0, :3]) @ downhill
    window = (slid.t >= 0.2) & (slid.t <= 0.9)  # on the ramp: 0.6 m of its 0.9 m
    a_fit = np.polyfit(slid.t[window], s[window], 2)[0] * 2.0
    expected = G * (math.sin(theta) - mu * math.cos(theta))
    assert a_fit == pytest.approx(expected, rel=0.01)


def two_spheres(**contact):
    return od.scene_from_dict(
        {
            "objects": [
                {"name": "left", "shape": "sphere", "size": [0.1], "mass": 1.0,
                 "position": [-0.3, 0.0, 1.0], "velocity": [1.0, 0.1, 0.0],
                 "angular_velocity": [0.0, 0.0, 3.0]},
                {"name": "right", "shape": "box", "size": [0.2, 0.2, 0.2], "mass": 3.0,
                 "position": [0.3, 0.02, 1.0], "rpy": [0.1, 0.2, 0.3],
                 "velocity": [-0.5, 0.0, 0.0]},
            ],
            "run": {"duration": 1.0, "integrator": "dopri5", "rtol": 1e-10, "atol": 1e-12,
                    "output_dt": 0.01},
            "effects": {
                "contact": {"geometry": "collision", "stiffness": 1e5, "damping": 20.0,
                            "friction": 0.5, **contact}
            },
        }
    )


def momenta(model, q, qd):
    """(linear (N, 3) N s, angular about the world origin (N, 3) N m s, v_world (N, bodies, 3))
    of the objects at the samples: sum of m v and of c x m v + R I_c omega_b."""
    linear, angular, velocities = np.zeros((len(q), 3)), np.zeros((len(q), 3)), []
    for i in np.flatnonzero(model.jtype == FREE):
        iq, iv = model.iq[i], model.iv[i]
        R = Rotation.from_quat(q[:, iq + 3 : iq + 7]).as_matrix()
        v = np.einsum("nij,nj->ni", R, qd[:, iv + 3 : iv + 6])
        spin = np.einsum("nij,jk,nk->ni", R, model.I_o[i], qd[:, iv : iv + 3])
        linear += model.mass[i] * v
        angular += np.cross(q[:, iq : iq + 3], model.mass[i] * v) + spin
        velocities.append(v)
    return linear, angular, np.stack(velocities, axis=1)


def test_two_objects_that_collide_keep_their_momentum():
    """Equal and opposite forces at one point: the linear momentum and the angular momentum
    about any point of two free bodies that hit each other (spinning, off centre, with
    friction) stay what they were, to the integrator's tolerance."""
    s = two_spheres()
    traj = od.simulate(s)
    assert traj.complete
    linear, angular, v = momenta(s.model, traj.q, traj.qd)
    assert np.abs(linear - linear[0]).max() < 1e-8
    assert np.abs(angular - angular[0]).max() < 1e-8
    # they did hit: the sphere moving at 1 m/s along x lost most of it to the box
    assert v[-1, 0, 0] < 0.0 < v[0, 0, 0]


def test_objects_name_their_coordinates_and_start_where_the_scene_puts_them():
    s = two_spheres()
    m = s.model
    assert m.objects == ("left", "right")
    assert m.q_names[:7] == tuple(f"left.{n}" for n in ("x", "y", "z", "qx", "qy", "qz", "qw"))
    assert m.v_names[6:] == ("right.wx", "right.wy", "right.wz", "right.vx", "right.vy", "right.vz")
    assert not m.floating_base
    assert np.allclose(s.q0[:3], [-0.3, 0.0, 1.0])
    # the inertia of a uniform box: m (b^2 + c^2) / 12 about each axis
    assert np.allclose(np.diag(m.I_o[1]), 3.0 * 0.08 / 12.0)
    # world-frame velocities become the body twist: v_b = R^T v_s
    R = Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).as_matrix()
    assert np.allclose(R @ s.qd0[9:12], [-0.5, 0.0, 0.0])


def test_a_pair_switched_off_lets_the_box_fall_through_the_table():
    s = scene("box_on_table", pairs=[{"a": "box", "b": "table", "enabled": False}])
    traj = od.simulate(s.replace_run(duration=0.5))
    assert traj.complete
    assert traj.q[-1, 2] < 0.35  # through the table top at 0.4 m, towards the ground


def box(name, **keys):
    return {"name": name, "shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, **keys}


def geometry_contact_with(**keys):
    return {"contact": {"geometry": "collision", "stiffness": 1, "friction": 0, **keys}}


@pytest.mark.parametrize(
    "change, key, words",
    [
        ({"objects": [box("b", shape="cone")]}, "objects[0].shape", "box"),
        ({"objects": [box("b", size=[1, 1])]}, "objects[0].size", "3"),
        ({"objects": [box("b", size=[1, 0, 1])]}, "objects[0].size", "> 0"),
        ({"objects": [{"name": "b", "shape": "box", "size": [1, 1, 1]}]}, "objects[0].mass",
         "missing"),
        ({"objects": [box("ground")]}, "objects[0].name", "reserved"),
        ({"objects": [box("a"), box("a")]}, "objects[1].name", "already"),
        ({"objects": [box("b", rpy=[0, 0, 0], orientation=[0, 0, 0, 1])]}, "objects[0].rpy",
         "both"),
        ({"world": [{"name": "w", "shape": "plane", "size": [1, 1, 1]}]}, "world[0].size",
         "plane"),
        ({"world": [{"name": "w", "shape": "mesh"}]}, "world[0].mesh", "missing"),
        ({"world": [{"name": "w", "shape": "box", "size": [1, 1, 1], "mesh": "a.stl"}]},
         "world[0].mesh", "only"),
        ({"effects": {"contact": {"stiffness": 1, "friction": 0, "points": "urdf",
                                  "self_collision": True}}},
         "effects.contact.self_collision", "geometry"),
        ({"effects": geometry_contact_with(points="urdf")}, "effects.contact.points",
         "give one"),
        ({"effects": geometry_contact_with(pairs=[{"a": "box", "b": "nothing"}])},
         "effects.contact.pairs[0].b", "no collision geometry"),
        ({"effects": geometry_contact_with(pairs=[{"a": "box", "b": "ground", "friction": -1}])},
         "effects.contact.pairs[0].friction", ">= 0"),
    ],
)
def test_the_reader_names_what_is_wrong(change, key, words):
    data = {"objects": [box("box", position=[0, 0, 1])]}
    data.update(change)
    with pytest.raises(SceneError) as e:
        od.scene_from_dict(data)
    assert key in str(e.value) and words in str(e.value)


def test_a_robot_without_collision_geometry_has_nothing_to_touch():
    with pytest.raises(SceneError, match="nothing can touch"):
        od.scene_from_dict(
            {
                "robot": {"urdf": str(shipped_robots_dir() / "four_bar.urdf")},
                "effects": geometry_contact_with(),
            }
        )


def test_linearize_refuses_the_geometry_contact_naming_it():
    with pytest.raises(ValueError, match="geometry = \"collision\""):
        od.linearize(scene("box_on_table"))
