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
from opendyn.errors import SceneError
from opendyn.io.scene.files import shipped_scenes
from opendyn.io.urdf import shipped_robots_dir
from opendyn.multibody.joints import FREE

G = 9.81


def scene(name, **changes):
    """A shipped scene, with [effects.contact] keys changed."""
    path = shipped_scenes()[name]
    data = tomllib.loads(path.read_text())
    data["effects"]["contact"].update(changes)
    return od.scene_from_dict(data, source=str(path), base_dir=path.parent)


def force_on(traj, k, a, b):
    """The sum of the forces (3,) N, world axes, that geometry a applies to geometry b at
    sample k, from the trajectory's contact table (a row's force is what its a applies to its
    b)."""
    rows = traj.contacts.at(k)
    total = np.zeros(3)
    for pair, force in zip(rows.pair, rows.force):
        names = rows.pair_names[pair]
        if names == (a, b):
            total += force
        elif names == (b, a):
            total -= force
    return total


def test_box_on_table_rests_on_its_weight():
    s = scene("box_on_table")
    traj = od.simulate(s)
    assert traj.complete
    drift = np.abs(traj.q[:, :3] - traj.q[0, :3]).max()
    assert drift < 1e-4  # m over 5 s
    # at rest the table's forces carry the weight: sum f = (0, 0, m g) to 1e-6 relative, at
    # the four bottom corners
    k = len(traj.t) - 1
    assert np.allclose(force_on(traj, k, "table", "box"), [0, 0, G], rtol=0, atol=1e-6 * G)
    last = traj.contacts.at(k)
    assert len(last) == 4 and set(last.a) | set(last.b) == {"box", "table"}
    assert np.allclose(np.abs(last.point[:, :2]), 0.1) and np.allclose(last.normal[:, 2], -1.0)
    # the springs' energy is in E: the balance closes with the dampers as passive work
    assert np.abs(traj.energy_error).max() < 1e-6


def test_each_box_of_a_stack_carries_the_weight_above_it():
    traj = od.simulate(scene("box_stack"))
    assert traj.complete
    k = len(traj.t) - 1
    for a, b, carried in (("ground", "bottom", 3), ("bottom", "middle", 2), ("middle", "top", 1)):
        f = force_on(traj, k, a, b)
        assert np.allclose(f, [0.0, 0.0, carried * G], rtol=0, atol=1e-6 * carried * G), (a, b)
    # no pair that does not touch has a row
    touching = {traj.contacts.pair_names[p] for p in traj.contacts.pair}
    assert touching == {("bottom", "middle"), ("middle", "top"), ("bottom", "ground")}


def test_the_contact_table_is_saved_loaded_and_written_as_csv_and_parquet(tmp_path):
    traj = od.simulate(scene("box_stack").replace_run(duration=0.05))
    table = traj.contacts
    loaded = od.Trajectory.load(traj.save(tmp_path / "run.npz")).contacts
    for name in ("sample", "pair", "point", "normal", "force", "depth"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(table, name))
    assert loaded.pair_names == table.pair_names
    traj.to_csv(tmp_path / "run.csv")
    lines = (tmp_path / "run.contacts.csv").read_text().splitlines()
    assert lines[0] == "sample,t,pair,a,b,x,y,z,nx,ny,nz,fx,fy,fz,depth"
    assert len(lines) == 1 + len(table)
    first = lines[1].split(",")
    assert (first[3], first[4]) == table.pair_names[table.pair[0]]
    assert float(first[-1]) == table.depth[0]
    pq = pytest.importorskip("pyarrow.parquet")
    columns = pq.read_table(table.to_parquet(tmp_path / "c.parquet", traj.t)).to_pydict()
    np.testing.assert_array_equal(columns["fz"], table.force[:, 2])
    assert columns["a"] == list(table.a)


def test_a_box_on_an_incline_holds_or_slides_as_coulomb_says():
    theta = math.radians(20.0)
    held = od.simulate(scene("box_incline"))  # mu = 0.5 > tan 20
    assert held.complete
    assert np.linalg.norm(held.q[-1, :3] - held.q[0, :3]) < 3e-5  # m (measured 23 um)
    mu = 0.2
    slid = od.simulate(scene("box_incline", friction=mu, slip_velocity=1e-3))
    assert slid.complete
    downhill = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    s = (slid.q[:, :3] - slid.q[0, :3]) @ downhill
    window = (slid.t >= 0.2) & (slid.t <= 0.9)  # on the ramp: 0.6 m of its 0.9 m
    a_fit = np.polyfit(slid.t[window], s[window], 2)[0] * 2.0
    expected = G * (math.sin(theta) - mu * math.cos(theta))
    # the contact guide's 2e-6 (measured 2.2e-6; the friction's secant alone in implicit
    # Euler's damping matrix slid it 2.4e-3 slow, its tangent alone 1.1e-6 fast)
    assert a_fit == pytest.approx(expected, rel=3e-6)


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


def test_an_arm_driven_into_itself_stops_only_with_self_collision():
    stopped = od.simulate(scene("arm_self_collision"))
    passed = od.simulate(scene("arm_self_collision", self_collision=False))
    assert stopped.complete and passed.complete
    elbow = list(stopped.joint_names).index("elbow_joint")
    # od.distances puts the first overlap of the wrist with the upper arm at 2.65-2.7 rad
    assert 2.6 < stopped.q[-1, elbow] < 2.72
    assert passed.q[-1, elbow] == pytest.approx(3.0, abs=0.01)
    pairs = {stopped.contacts.pair_names[p] for p in stopped.contacts.pair}
    assert pairs and all(a.startswith("upper_arm") or b.startswith("upper_arm") for a, b in pairs)
    assert len(passed.contacts) == 0
    assert stopped.contacts.deepest()[0] < 0.005  # m: the spring holds the PD torque


def test_solo12_lands_on_a_step_and_stands():
    traj = od.simulate(scene("solo12_step"))
    assert traj.complete and np.all(np.isfinite(traj.q))
    last = np.flatnonzero(traj.t >= traj.t[-1] - 1.0)
    assert np.abs(traj.qd[last]).max() < 0.1  # rad/s, m/s: at rest
    assert np.ptp(traj.q[last, 2]) < 5e-4  # m: the trunk holds its height
    weight = float(np.sum(od.load_urdf("solo12", floating_base=True).mass)) * G
    for k in last[::10]:
        rows = traj.contacts.at(k)
        touching = {name for p in rows.pair for name in rows.pair_names[p]}
        assert touching - {"upper_step", "lower_step"} == {
            "FL_FOOT_0", "FR_FOOT_0", "HL_FOOT_0", "HR_FOOT_0"
        }
        # the steps carry the weight: every row's b is a step, its force what the foot puts
        # on it
        assert all(rows.pair_names[p][1].endswith("step") for p in rows.pair)
        assert -rows.force[:, 2].sum() == pytest.approx(weight, rel=0.01)
    # the front feet stand 7 cm higher: the trunk pitches up, about 10 degrees
    pitch = Rotation.from_quat(traj.q[-1, 3:7]).as_euler("xyz")[1]
    assert -0.25 < pitch < -0.1


def test_a_start_deep_inside_another_body_is_refused_naming_both():
    data = tomllib.loads(shipped_scenes()["box_on_table"].read_text())
    data["objects"][0]["position"] = [0.0, 0.0, 0.42]  # 3 cm into the table
    with pytest.raises(SceneError, match="'box' starts 0.03 m inside 'table'.*J"):
        od.simulate(od.scene_from_dict(data))


def test_a_humanoid_falls_over_onto_the_floor_with_its_whole_collision_model():
    s = scene("humanoid_fall")
    assert sum(g.shape == "mesh" for g in s.model.geometries) == 24  # the links' hulls
    traj = od.simulate(s)
    assert traj.complete and np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.qd))
    # the guide's numbers: the balance closed to 6e-5 J of E about 200 J at rtol 1e-6 (measured
    # 6.06e-5 J), no link deeper in the floor than 2.8 mm at any step (measured 2.77 mm; 1.76 mm
    # at the samples)
    assert np.abs(traj.energy_error).max() < 7e-5
    assert traj.q[-1, 2] < 0.2  # the pelvis lies on the floor
    touching = {traj.contacts.pair_names[p] for p in traj.contacts.pair}
    assert all(b == "ground" for _, b in touching) and len(touching) >= 4
    assert traj.contacts.deepest()[0] <= traj.contact_extremes.deepest < 2.8e-3  # m


def test_the_simulator_and_rollouts_take_a_scene_of_objects():
    s = scene("box_stack").replace_run(duration=0.2)
    sim = od.Simulator(s)
    sim.step(None, 0.2)
    runs = od.rollout(s, q0=np.stack([s.q0, s.q0]))
    traj = od.simulate(s)
    # the same step three ways: the stack at rest where simulate leaves it
    np.testing.assert_allclose(sim.q, traj.q[-1], atol=1e-12)
    assert np.all(runs.complete)
    np.testing.assert_allclose(runs.q[:, -1], [traj.q[-1]] * 2, atol=1e-12)
