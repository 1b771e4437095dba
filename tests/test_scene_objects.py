"""A scene's model is the robot and its objects as one tree with several roots: objects from a
URDF (a floating base of their own, articulated or not) beside primitive ones, and what every
part of opendyn does with such a model (dynamics, payloads, rollouts, sweeps, linearize)."""

import warnings

import numpy as np
import pytest

import opendyn as od
from opendyn.errors import SceneError
from opendyn.io.urdf import shipped_robots_dir

ROBOTS = shipped_robots_dir()
# a free body with a flap on a hinge: a box 0.2 x 0.1 x 0.1 m of 1 kg and a plate 0.2 x 0.1 x
# 0.02 m of 0.5 kg hinged about y at the box's +x edge; both uniform, with collision boxes
HINGED = """<?xml version="1.0"?>
<robot name="hinged">
  <link name="body">
    <inertial><mass value="1.0"/>
      <inertia ixx="0.0016666666666666668" iyy="0.004166666666666667"
               izz="0.004166666666666667" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.1 0.1"/></geometry></collision>
  </link>
  <link name="flap">
    <inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
      <inertia ixx="0.00043333333333333337" iyy="0.0016833333333333333"
               izz="0.0020833333333333333" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.1 0 0"/><geometry><box size="0.2 0.1 0.02"/></geometry>
    </collision>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="body"/><child link="flap"/><origin xyz="0.1 0 0.04"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="0" velocity="10"/>
  </joint>
</robot>
"""


@pytest.fixture(scope="module")
def hinged(tmp_path_factory):
    path = tmp_path_factory.mktemp("objects") / "hinged.urdf"
    path.write_text(HINGED)
    return str(path)


def urdf_objects(hinged, **changes):
    """The UR5 with a crate (box.urdf) and a hinged body (HINGED, "door") beside it, in free
    fall (no contact), as a scene with `changes` at its top level."""
    data = {
        "robot": {"name": "ur5"},
        "objects": [
            {"name": "crate", "urdf": str(ROBOTS / "box.urdf"), "position": [0.6, 0.0, 0.5]},
            {"name": "door", "urdf": hinged, "position": [-0.6, 0.0, 1.0],
             "rpy": [0.1, 0.0, 0.2], "angular_velocity": [0.0, 1.0, 0.0]},
        ],
        "initial": {"q": {"door.hinge": 0.5, "shoulder_lift_joint": -1.0}},
        "run": {"duration": 0.3, "integrator": "rk4", "dt": 0.001},
        "effects": {"gravity": True},
    }
    data.update(changes)
    return od.scene_from_dict(data)


def door_scene(hinged):
    """The hinged body of urdf_objects as a robot of its own on a floating base, started as
    that scene starts it (its [initial] base keys)."""
    return od.scene_from_dict({
        "robot": {"urdf": hinged, "floating_base": True},
        "initial": {"base_position": [-0.6, 0.0, 1.0], "base_rpy": [0.1, 0.0, 0.2],
                    "base_angular_velocity": [0.0, 1.0, 0.0], "q": {"hinge": 0.5}},
        "run": {"duration": 0.3, "integrator": "rk4", "dt": 0.001},
        "effects": {"gravity": True},
    })


def test_a_urdf_object_names_its_links_joints_and_coordinates_after_itself(hinged):
    m = urdf_objects(hinged).model
    assert m.objects == ("crate", "door")
    assert m.body_names[6:] == ("crate", "door", "door.flap")
    assert m.q_names[6:13] == tuple(f"crate.{n}" for n in ("x", "y", "z", "qx", "qy", "qz", "qw"))
    assert m.q_names[-1] == m.joint_names[-1] == "door.hinge"
    assert "door.flap" in m.frame_names
    assert m.frame_index("door.hinge") == m.frame_index("door.flap")  # a joint names its child
    assert not m.floating_base  # the UR5 is fixed; the objects are not its base
    # the crate's mass and inertia are the URDF's
    assert m.mass[6] == pytest.approx(2.0)
    assert np.allclose(np.diag(m.I_o[6]), [2 * (0.01 + 0.0025) / 12, 2 * (0.04 + 0.0025) / 12,
                                           2 * (0.04 + 0.01) / 12])


def test_objects_do_not_make_a_fixed_arm_look_mobile(hinged):
    """The arm on a pedestal has one root of its own; the objects' roots are not its legs."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert not urdf_objects(hinged).model.floating_base
    assert not [w for w in caught if "mobile" in str(w.message)]


def test_each_root_of_the_tree_moves_as_it_would_alone(hinged):
    """Bodies of different trees exert no force on each other (no contact here): the mass
    matrix is block diagonal, each block that part's own, and each part's motion in the scene
    is its motion alone (the hinged body, the UR5 under gravity, the crate in free fall)."""
    s = urdf_objects(hinged)
    M = od.mass_matrix(s.model, s.q0)
    alone = od.load_urdf(hinged, floating_base=True)
    q_door = s.q0[13:]
    np.testing.assert_allclose(M[12:, 12:], od.mass_matrix(alone, q_door), atol=1e-13)
    assert np.all(M[:12, 12:] == 0.0) and np.all(M[:6, 6:] == 0.0)

    traj = od.simulate(s)
    assert traj.complete
    door_alone = od.simulate(door_scene(hinged))
    np.testing.assert_allclose(door_alone.q[0], q_door, atol=1e-15)
    np.testing.assert_allclose(traj.q[:, 13:], door_alone.q, atol=1e-12)
    arm = od.scene_from_dict({
        "robot": {"name": "ur5"},
        "initial": {"q": {"shoulder_lift_joint": -1.0}},
        "run": {"duration": 0.3, "integrator": "rk4", "dt": 0.001},
        "effects": {"gravity": True},
    })
    np.testing.assert_allclose(traj.q[:, :6], od.simulate(arm).q, atol=1e-12)
    # the crate falls freely: z = z0 - g t^2 / 2
    np.testing.assert_allclose(traj.q[:, 8], 0.5 - 0.5 * 9.81 * traj.t**2, atol=1e-12)


def test_a_urdf_box_moves_as_the_same_box_made_of_shape_and_mass():
    """box.urdf (2 kg, 0.2 x 0.1 x 0.05 m, its inertia written out as a uniform box's) and the
    primitive of that shape and mass, dropped spinning onto the ground: the same motion."""
    def drop(entry):
        return od.simulate(od.scene_from_dict({
            "objects": [{"name": "box", "position": [0.0, 0.0, 0.1], "rpy": [0.3, 0.2, 0.0],
                         "angular_velocity": [1.0, -2.0, 0.5], **entry}],
            "run": {"duration": 0.4, "integrator": "implicit_euler", "dt": 0.0005},
            "effects": {"gravity": True, "contact": {
                "geometry": "collision", "stiffness": 1e5, "damping": 300.0, "friction": 0.5}},
        }))

    from_urdf = drop({"urdf": str(ROBOTS / "box.urdf")})
    primitive = drop({"shape": "box", "size": [0.2, 0.1, 0.05], "mass": 2.0})
    assert from_urdf.complete and primitive.complete
    assert len(from_urdf.contacts) > 0  # it did land
    np.testing.assert_allclose(from_urdf.q, primitive.q, atol=1e-9)
    assert set(from_urdf.contacts.pair_names) == {("box_0", "ground")}


def test_a_urdf_objects_links_touch_the_world_under_their_own_names(hinged):
    s = urdf_objects(
        hinged,
        effects={"gravity": True, "contact": {"geometry": "collision", "stiffness": 1e4,
                                              "damping": 100.0, "friction": 0.5}},
        run={"duration": 0.6, "integrator": "implicit_euler", "dt": 0.001},
    )
    traj = od.simulate(s)
    assert traj.complete
    touching = {name for pair in traj.contacts.pair_names for name in pair}
    # a URDF's geometry is named after its link, as the robot's: "door.flap_0"
    assert {"crate_0", "door_0", "door.flap_0", "ground"} <= touching
    # the object's links never touch each other (an object is checked against others only)
    links = [g.link for g in s.model.geometries]
    for a, b in s.model.collision_pairs:
        assert {links[a], links[b]} != {"door", "door.flap"}


def test_a_pair_named_by_an_object_covers_all_of_its_links(hinged):
    effects = {"gravity": True, "contact": {
        "geometry": "collision", "stiffness": 1e4, "damping": 100.0, "friction": 0.5,
        "pairs": [{"a": "door", "b": "ground", "enabled": False}]}}
    traj = od.simulate(urdf_objects(
        hinged, effects=effects, run={"duration": 0.6, "integrator": "implicit_euler", "dt": 0.001}
    ))
    assert traj.complete
    on_ground = {a for a, b in traj.contacts.pair_names if b == "ground"}
    assert "crate_0" in on_ground and not on_ground & {"door_0", "door.flap_0"}
    assert traj.q[-1, 15] < -0.3  # the hinged body fell through the floor


@pytest.mark.parametrize(
    "entry, key, words",
    [
        ({"urdf": "box.urdf", "shape": "box"}, "objects[0].shape", "from the file"),
        ({"urdf": "box.urdf", "mass": 1.0}, "objects[0].mass", "from the file"),
        ({"urdf": "nothing.urdf"}, "objects[0].urdf", "no such URDF file"),
        ({"urdf": "t_handle_flip.toml"}, "objects[0].urdf", "t_handle_flip.toml"),
        ({}, "objects[0].shape", "urdf"),
    ],
)
def test_the_reader_names_what_is_wrong_with_a_urdf_object(entry, key, words):
    data = {"objects": [{"name": "thing", **entry}]}
    with pytest.raises(SceneError) as e:
        od.scene_from_dict(data, base_dir=ROBOTS)
    assert key in str(e.value) and words in str(e.value)


def test_an_entry_may_not_take_the_name_of_a_urdf_objects_link(hinged):
    data = {"objects": [{"name": "door", "urdf": hinged},
                        {"name": "door.flap", "shape": "sphere", "size": [0.1], "mass": 1.0}]}
    with pytest.raises(SceneError, match=r"objects\[1\]\.name.*already a frame"):
        od.scene_from_dict(data)


def test_a_payload_and_rollouts_take_a_scene_with_objects(hinged):
    s = urdf_objects(hinged)
    loaded = urdf_objects(hinged, robot={"name": "ur5", "payload": {"frame": "tool0", "mass": 2.0}})
    assert loaded.model.mass[5] == pytest.approx(s.model.mass[5] + 2.0)
    assert loaded.model.objects == s.model.objects
    runs = od.rollout(s, params={"initial.q.door.hinge": [0.5, 1.0]})
    assert np.all(runs.complete)
    # each run is simulate of its own variant, bit for bit
    one = od.simulate(urdf_objects(hinged, initial={"q": {"door.hinge": 1.0,
                                                          "shoulder_lift_joint": -1.0}}))
    np.testing.assert_array_equal(runs.q[1], one.q)
    assert runs.q[0, 0, -1] == 0.5 and runs.q[1, 0, -1] == 1.0


def test_linearize_takes_a_scene_with_objects(hinged):
    """At rest in free fall nothing but gravity acts: each object's linearisation is its own,
    and the object's free coordinates do not couple with the arm's."""
    s = urdf_objects(hinged)
    A, B = od.linearize(s)
    n = s.model.nv
    assert A.shape == (2 * n, 2 * n)
    assert B.shape == (2 * n, 7)  # the arm's six joints and the hinge: the free joints are not
    # no coupling between the arm (velocities 0..5) and the objects (6..), either way
    assert np.all(A[n:n + 6, 6:n] == 0.0) and np.all(A[n:n + 6, n + 6:] == 0.0)
    assert np.all(A[n + 6:, :6] == 0.0) and np.all(A[n + 6:, n:n + 6] == 0.0)
    # the hinged body's block is its linearisation alone
    A_door, B_door = od.linearize(door_scene(hinged))
    door = [*range(12, 19), *range(n + 12, n + 19)]
    np.testing.assert_allclose(A[np.ix_(door, door)], A_door, atol=1e-10)
    np.testing.assert_allclose(B[door, 6:], B_door, atol=1e-10)
