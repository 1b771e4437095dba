"""A rigid payload on a frame (Model.with_payload, a scene's [robot.payload]), each result
against a source that does not share its code:

  - Pinocchio: the same URDF with the payload's inertia added to the frame's parent joint by
    Pinocchio's own Inertia algebra (frame placement .act), then M(q), g(q) and inverse
    dynamics (CRBA, computeGeneralizedGravity, RNEA) at random states (UR5, Panda);
  - the URDF loader: a payload on a frame equals a fixed-joint child link carrying the same
    <inertial> at that frame, which the loader lumps into the body by its own path;
  - statics: the payload adds to the holding torques exactly its weight through the frame's
    body Jacobian, tau_extra = -J_b(frame)^T F_weight.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

import opendyn as od
from opendyn.errors import SceneError
from opendyn.io.scene.files import scene_from_dict, tomllib
from opendyn.io.scene.reader import _build
from opendyn.io.urdf import shipped_robots_dir
from opendyn.spatial.algebra import exp_so3

RTOL = 1e-10
N_STATES = 3


def rotated_inertia(moments, w):
    """R diag(moments) R^T with R = exp([w]): a physical inertia with off-diagonal entries."""
    R = exp_so3(w)
    return R @ np.diag(moments) @ R.T


# (robot, frame, mass kg, com m in the frame, inertia kg m^2 about the com in the frame's axes)
PAYLOADS = [
    ("ur5", "tool0", 2.5, (0.0, 0.0, 0.05), rotated_inertia((4e-3, 6e-3, 9e-3), (0.3, -0.7, 0.4))),
    (
        "panda",
        "panda_hand",
        1.2,
        (0.01, -0.02, 0.08),
        rotated_inertia((2e-3, 3e-3, 4e-3), (-0.5, 0.2, 0.9)),
    ),
]


def assert_close(ours, ref, what, rtol=RTOL):
    """max |ours - ref| <= rtol max(1, max |ref|)."""
    ours, ref = np.asarray(ours, dtype=float), np.asarray(ref, dtype=float)
    assert ours.shape == ref.shape, f"{what}: shape {ours.shape} != {ref.shape}"
    scale = max(1.0, float(np.abs(ref).max()))
    err = float(np.abs(ours - ref).max()) / scale
    assert err <= rtol, f"{what}: relative error {err:.3e} > {rtol:g}"


def pinocchio_with_payload(model, frame, mass, com, inertia):
    """Pinocchio's model of model.source with the payload added to the frame's parent joint:
    inertias[joint] += placement.act(Inertia(mass, com, inertia)), placement = the frame's
    pose in its joint (Pinocchio's own, read from the URDF)."""
    pin = pytest.importorskip("pinocchio")
    from pin_adapter import PinOracle

    oracle = PinOracle(model.source, model)
    placed = oracle.model.frames[oracle.frame_id(frame)]
    joint = placed.parentJoint
    payload = pin.Inertia(mass, np.asarray(com, dtype=float), np.asarray(inertia, dtype=float))
    oracle.model.inertias[joint] = oracle.model.inertias[joint] + placed.placement.act(payload)
    oracle.data = oracle.model.createData()
    return oracle


@pytest.mark.parametrize("robot, frame, mass, com, inertia", PAYLOADS, ids=["ur5", "panda"])
def test_dynamics_with_a_payload_equal_pinocchios(robot, frame, mass, com, inertia):
    """M(q), g(q) and inverse dynamics of the payload model equal Pinocchio's with the payload
    added there, to 1e-10; and the payload changes them (the comparison is not vacuous)."""
    base = od.load_urdf(robot)
    model = base.with_payload(frame, mass, com, inertia)
    oracle = pinocchio_with_payload(base, frame, mass, com, inertia)
    rng = np.random.default_rng(7)
    for k in range(N_STATES):
        q = rng.uniform(-np.pi, np.pi, model.nq)
        qd, qdd = rng.normal(size=(2, model.nv))
        M = od.mass_matrix(model, q)
        assert_close(M, oracle.mass_matrix(q), f"{robot} M(q) state {k}")
        assert_close(od.gravity_forces(model, q), oracle.gravity_forces(q), f"{robot} g {k}")
        assert_close(
            od.inverse_dynamics(model, q, qd, qdd),
            oracle.rnea(q, qd, qdd),
            f"{robot} inverse dynamics state {k}",
        )
        assert np.abs(M - od.mass_matrix(base, q)).max() > 1e-3


DOUBLE_PENDULUM = (shipped_robots_dir() / "double_pendulum.urdf").read_text()
# a frame welded to link2 at a pose with a rotation, for the payload to sit on
MOUNT = """
  <joint name="mount_joint" type="fixed">
    <parent link="link2"/>
    <child link="mount"/>
    <origin xyz="0.1 -0.2 -0.4" rpy="0.3 -0.5 1.1"/>
  </joint>
  <link name="mount"/>
"""
# the payload as a link on the mount: its <inertial> in the mount's frame
PAYLOAD_LINK = """
  <joint name="payload_joint" type="fixed">
    <parent link="mount"/>
    <child link="payload"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
  </joint>
  <link name="payload">
    <inertial>
      <origin xyz="{x} {y} {z}" rpy="0 0 0"/>
      <mass value="{mass}"/>
      <inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" izz="{izz}"/>
    </inertial>
  </link>
"""


def pendulum_urdf(tmp_path, name, extra):
    """The shipped double pendulum with `extra` links and joints, written to tmp_path."""
    path = tmp_path / name
    path.write_text(DOUBLE_PENDULUM.replace("</robot>", extra + "</robot>"))
    return path


def test_a_payload_equals_a_fixed_link_carrying_it(tmp_path):
    """with_payload on a rotated, offset frame gives the G arrays and M(q) of the URDF in which
    a fixed-joint child link of that frame carries the same <inertial> (which the loader
    lumps into link2's body); a joint name finds its child link's frame as well."""
    mass, com = 0.7, (0.05, -0.03, 0.12)
    I = rotated_inertia((0.001, 0.002, 0.0025), (0.4, 0.1, -0.6))
    entries = dict(
        ixx=I[0, 0], iyy=I[1, 1], izz=I[2, 2], ixy=I[0, 1], ixz=I[0, 2], iyz=I[1, 2]
    )
    text = PAYLOAD_LINK.format(
        x=com[0], y=com[1], z=com[2], mass=mass, **{k: repr(float(v)) for k, v in entries.items()}
    )
    mounted = od.load_urdf(pendulum_urdf(tmp_path, "mounted.urdf", MOUNT))
    reference = od.load_urdf(pendulum_urdf(tmp_path, "reference.urdf", MOUNT + text))
    model = mounted.with_payload("mount", mass, com, I)
    for field in ("G", "mass", "h", "I_o"):
        np.testing.assert_allclose(
            getattr(model, field), getattr(reference, field), rtol=0, atol=1e-14, err_msg=field
        )
    for q in np.random.default_rng(3).uniform(-np.pi, np.pi, (4, 2)):
        np.testing.assert_allclose(
            od.mass_matrix(model, q), od.mass_matrix(reference, q), rtol=0, atol=1e-13
        )
    by_joint = mounted.with_payload("mount_joint", mass, com, I)
    np.testing.assert_array_equal(by_joint.G, model.G)
    assert model.report is mounted.report and model.source == mounted.source


def test_a_payload_leaves_the_model_it_came_from_unchanged_and_frozen():
    base = od.load_urdf("double_pendulum")
    G_before = np.array(base.G)
    model = base.with_payload("tip", 1.5, (0.0, 0.0, -0.1))
    np.testing.assert_array_equal(base.G, G_before)
    assert model.mass[1] == base.mass[1] + 1.5
    assert not model.G.flags.writeable and not model.mass.flags.writeable


def test_a_zero_payload_gives_the_same_model():
    base = od.load_urdf("ur5")
    model = base.with_payload("tool0", 0.0, (0.1, 0.2, 0.3))
    for field in ("G", "mass", "h", "I_o", "S", "R_home", "p_home"):
        np.testing.assert_array_equal(getattr(model, field), getattr(base, field), err_msg=field)
    np.testing.assert_array_equal(model._fbuf, base._fbuf)
    np.testing.assert_array_equal(model._ibuf, base._ibuf)


def test_bad_payloads_are_refused_naming_the_argument():
    base = od.load_urdf("ur5")
    with pytest.raises(ValueError, match="'base_link'.*welded to the fixed world.*not move"):
        base.with_payload("base_link", 1.0)
    with pytest.raises(KeyError, match="'no_such_frame' is not a frame of model 'ur5'"):
        base.with_payload("no_such_frame", 1.0)
    for kwargs, fragment in (
        (dict(mass=-1.0), "mass must be non-negative"),
        (dict(mass=math.inf), "mass must be finite"),
        (dict(mass=math.nan), "mass must be finite"),
        (dict(mass=1.0, com=(0.0, 0.1)), r"com must have shape \(3,\)"),
        (dict(mass=1.0, inertia=[[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
         "inertia must be symmetric"),
        (dict(mass=1.0, inertia=np.diag([1.0, 1.0, 3.0])), "inertia violates the triangle"),
        (dict(mass=1.0, inertia=np.diag([-1.0, 1.0, 1.0])), "inertia must be positive semi"),
        (dict(mass=1.0, inertia=np.eye(2)), r"inertia must have shape \(3, 3\)"),
    ):
        with pytest.raises(ValueError, match=fragment):
            base.with_payload("tool0", **kwargs)


# --- scenes ------------------------------------------------------------------------------------

PANDA_SCENE = tomllib.loads((shipped_robots_dir() / "panda_computed_torque.toml").read_text())
HAND_PAYLOAD = {
    "frame": "panda_hand",
    "mass": 1.2,
    "com": [0.01, -0.02, 0.08],
    "inertia": {"ixx": 0.003, "iyy": 0.004, "izz": 0.002, "ixy": 0.0005, "iyz": -0.0002},
}


def panda_scene_with(payload):
    data = copy.deepcopy(PANDA_SCENE)
    data["robot"]["payload"] = payload
    return data


def test_a_scene_payload_weighs_on_the_joints_through_the_frames_jacobian():
    """The scene's model carries the payload: at q0 its holding torques g(q) grow by the
    payload's weight through the frame's body Jacobian, tau_extra = -J_b^T F_weight with
    F_weight = (c x f, f), f = R_sf^T m g (the weight in the frame's axes, acting at the com c);
    a 0.05 s run completes."""
    scene = scene_from_dict(panda_scene_with(HAND_PAYLOAD))
    base = od.load_urdf("panda")
    mass, c = HAND_PAYLOAD["mass"], np.array(HAND_PAYLOAD["com"])
    q0, g = scene.q0, scene.gravity
    R_sf = od.frame_pose(base, q0, "panda_hand")[:3, :3]
    f = R_sf.T @ (mass * g)
    F_weight = np.concatenate([np.cross(c, f), f])
    J_b = od.jacobian(base, q0, "panda_hand", expressed_in="body")
    tau_extra = od.gravity_forces(scene.model, q0, g) - od.gravity_forces(base, q0, g)
    assert_close(tau_extra, -J_b.T @ F_weight, "payload weight at q0")
    assert np.abs(tau_extra).max() > 1.0
    body = base.frames[base.frame_index("panda_hand")].body
    assert scene.model.mass[body] == pytest.approx(base.mass[body] + mass, rel=1e-15)
    I = np.array([[0.003, 0.0005, 0.0], [0.0005, 0.004, -0.0002], [0.0, -0.0002, 0.002]])
    np.testing.assert_array_equal(
        scene.model.G, base.with_payload("panda_hand", mass, c, I).G
    )
    assert dict(scene.settings["robot"]["payload"])["frame"] == "panda_hand"
    assert od.simulate(scene.replace_run(duration=0.05)).complete


def test_a_given_model_gets_the_scenes_payload():
    """_build with an already loaded model (default_scene's path, and a sweep's that loads the
    URDF once) still applies the scene's [robot.payload] to it."""
    base = od.load_urdf("panda")
    data = panda_scene_with({"frame": "panda_hand", "mass": 2.0})
    scene = _build(data, source="<sweep>", base_dir=None, model=base)
    body = base.frames[base.frame_index("panda_hand")].body
    assert scene.model.mass[body] == pytest.approx(base.mass[body] + 2.0, rel=1e-15)
    assert scene.model is not base
    plain = _build(copy.deepcopy(PANDA_SCENE), source="<sweep>", base_dir=None, model=base)
    assert plain.model is base


@pytest.mark.parametrize(
    "payload, key, fragment",
    [
        ({"frame": "panda_hand", "mas": 1.0}, "robot.payload.mas",
         "did you mean 'mass'?); valid keys in [robot.payload]: frame, mass, com, inertia"),
        ({"mass": 1.0}, "robot.payload.frame", "missing"),
        ({"frame": "panda_hand"}, "robot.payload.mass", "missing"),
        ({"frame": "panda_hnd", "mass": 1.0}, "robot.payload.frame", "did you mean 'panda_hand'"),
        ({"frame": "panda_link0", "mass": 1.0}, "robot.payload.frame", "welded to the fixed world"),
        ({"frame": "panda_hand", "mass": -1.0}, "robot.payload.mass", "expected a number >= 0"),
        ({"frame": "panda_hand", "mass": "1"}, "robot.payload.mass", "expected a number"),
        ({"frame": "panda_hand", "mass": 1.0, "com": [0.0, 0.1]}, "robot.payload.com",
         "expected a list of 3 numbers, found a list of 2"),
        ({"frame": "panda_hand", "mass": 1.0, "inertia": {"ixx": 1.0, "iyy": 1.0, "izz": 3.0}},
         "robot.payload.inertia", "triangle inequality"),
        ({"frame": "panda_hand", "mass": 1.0, "inertia": {"ixx": 1.0, "izx": 0.1}},
         "robot.payload.inertia.izx", "valid keys in [robot.payload.inertia]: ixx, iyy, izz"),
        ({"frame": "panda_hand", "mass": 1.0, "inertia": {"ixx": math.nan}},
         "robot.payload.inertia.ixx", "finite"),
        ({"frame": "panda_hand", "mass": 1.0, "inertia": [0.1, 0.1, 0.1]},
         "robot.payload.inertia", "expected a table {ixx, iyy, izz, ixy, ixz, iyz}"),
        ("panda_hand", "robot.payload", "expected a table"),
    ],
)
def test_bad_scene_payloads_name_the_key(payload, key, fragment):
    with pytest.raises(SceneError) as info:
        scene_from_dict(panda_scene_with(payload), source="payload.toml")
    message = str(info.value)
    assert message.startswith(f"payload.toml: {key}: "), message
    assert fragment in message, message
