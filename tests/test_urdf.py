"""load_urdf: rejected inputs (URDFError naming file, element and problem) and loader behaviour
checked against hand-computed expectations.

URDFs are built from small string helpers (`link`, `joint`, `robot`, `chain`) and written to
pytest's tmp_path. URDF conventions used by the hand computations: an origin is
T = (R, xyz) with R = Rz(yaw) Ry(pitch) Rx(roll); a joint's child frame at q is
T_origin exp([A] q); an inertial origin places the centre of mass and the axes of <inertia>.
"""

from __future__ import annotations

import itertools
import os
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import opendyn as od

RNG = np.random.default_rng(20240611)
METHODS = ("aba", "crba", "newton_euler")
LIMIT = {"lower": -2.0, "upper": 2.0, "effort": 10.0, "velocity": 3.0}


# --- URDF text builders ---------------------------------------------------------------------


def _text(value) -> str:
    """An attribute value: strings as written (to inject "nan", "abc"), numbers space-joined."""
    if isinstance(value, str):
        return value
    return " ".join(repr(float(v)) for v in np.atleast_1d(value))


def _element(tag, attrs) -> str:
    if attrs is None:
        return ""
    return f"<{tag} " + " ".join(f'{k}="{_text(v)}"' for k, v in attrs.items()) + "/>"


def link(
    name, mass=1.0, xyz=(0, 0, 0), rpy=(0, 0, 0), inertia=(0.1, 0.1, 0.1, 0, 0, 0), extra=""
) -> str:
    """A <link>; mass=None leaves out <inertial>. inertia = (ixx, iyy, izz, ixy, ixz, iyz)."""
    if mass is None:
        return f'<link name="{name}">{extra}</link>'
    moments = dict(zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), inertia))
    return (
        f'<link name="{name}"><inertial>{_element("origin", {"xyz": xyz, "rpy": rpy})}'
        f"{_element('mass', {'value': mass})}{_element('inertia', moments)}</inertial>"
        f"{extra}</link>"
    )


def joint(
    name,
    parent,
    child,
    type="revolute",
    xyz=(0, 0, 0),
    rpy=(0, 0, 0),
    axis=(0, 0, 1),
    limit=LIMIT,
    dynamics=None,
    mimic=None,
    extra="",
) -> str:
    """A <joint>; parent, child, axis, limit = None leave that element out."""
    return (
        f'<joint name="{name}" type="{type}">'
        + _element("parent", None if parent is None else {"link": parent})
        + _element("child", None if child is None else {"link": child})
        + _element("origin", {"xyz": xyz, "rpy": rpy})
        + _element("axis", None if axis is None else {"xyz": axis})
        + _element("limit", limit)
        + _element("dynamics", dynamics)
        + _element("mimic", mimic)
        + extra
        + "</joint>"
    )


def collision(shape, attrs, xyz=(0, 0, 0), rpy=(0, 0, 0)) -> str:
    """A <collision> of one shape (sphere, box, cylinder, mesh) at an origin."""
    return (
        f"<collision>{_element('origin', {'xyz': xyz, 'rpy': rpy})}"
        f"<geometry>{_element(shape, attrs)}</geometry></collision>"
    )


def robot(*elements) -> str:
    return '<?xml version="1.0"?>\n<robot name="testbot">\n' + "\n".join(elements) + "\n</robot>\n"


def chain(n=2, joints=None, links=None, extra=()) -> str:
    """A generic 3-D serial chain base -> link1 -> ... -> link<n> through joints j1 ... j<n>.

    joints / links: {k: keyword overrides for joint k / link k}; extra: more elements.
    """
    joints, links = joints or {}, links or {}
    parts = [link("base", mass=4.0)]
    for k in range(1, n + 1):
        parts.append(
            link(
                f"link{k}",
                **{
                    "mass": 1.0 + 0.5 * k,
                    "xyz": (0.05 * k, -0.1, 0.2),
                    "rpy": (0.1, 0.2 * k, -0.3),
                    "inertia": (0.02 + 0.01 * k, 0.03, 0.04, 0.002, -0.001, 0.003),
                    **links.get(k, {}),
                },
            )
        )
        parts.append(
            joint(
                **{
                    "name": f"j{k}",
                    "parent": f"link{k - 1}" if k > 1 else "base",
                    "child": f"link{k}",
                    "xyz": (0.1, 0.05 * k, 0.3),
                    "rpy": (0.2 * k, -0.1, 0.4),
                    "axis": ((0, 0, 1), (0, 1, 0), (1, 0, 0))[k % 3],
                    **joints.get(k, {}),
                }
            )
        )
    return robot(*parts, *extra)


def write_urdf(tmp_path, text, name="robot.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def load(tmp_path, text, name="robot.urdf", **kwargs) -> od.Model:
    return od.load_urdf(write_urdf(tmp_path, text, name), **kwargs)


# --- hand computations -----------------------------------------------------------------------


def rot(axis, angle):
    """Rotation about a coordinate axis "x", "y" or "z"."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def rpy_matrix(rpy):
    return rot("z", rpy[2]) @ rot("y", rpy[1]) @ rot("x", rpy[0])


def transform(xyz=(0, 0, 0), R=np.eye(3)):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, xyz
    return T


def random_state(nv):
    return RNG.uniform(-1.5, 1.5, (3, nv))


# --- A. rejected inputs ----------------------------------------------------------------------

BAD_URDFS = [
    ("malformed_xml", '<robot name="r"><link name="base"></robot>', ["malformed XML", "link"], {}),
    ("root_not_robot", '<model name="m"/>', ["<model>", "expected <robot>"], {}),
    (
        "unknown_parent_link",
        chain(joints={2: {"parent": "ghost"}}),
        ['<joint name="j2">', 'parent link "ghost"', "not a <link>"],
        {},
    ),
    (
        "unknown_child_link",
        chain(joints={2: {"child": "ghost"}}),
        ['<joint name="j2">', 'child link "ghost"', "not a <link>"],
        {},
    ),
    (
        "missing_parent",
        chain(joints={2: {"parent": None}}),
        ['<joint name="j2">', "missing <parent"],
        {},
    ),
    (
        "missing_child",
        chain(joints={2: {"child": None}}),
        ['<joint name="j2">', "missing <child"],
        {},
    ),
    (
        "cycle",
        robot(
            link("a"),
            link("b"),
            link("c"),
            joint("a_to_b", "a", "b"),
            joint("b_to_c", "b", "c"),
            joint("c_to_a", "c", "a"),
        ),
        ['<joint name="a_to_b">', '<joint name="b_to_c">', '<joint name="c_to_a">', "cycle"],
        {},
    ),
    (
        "cycle_beside_a_tree",
        chain(extra=[link("a"), link("b"), joint("a_to_b", "a", "b"), joint("b_to_a", "b", "a")]),
        ['<joint name="a_to_b">', '<joint name="b_to_a">', "cycle", "cannot be reached"],
        {},
    ),
    (
        "two_roots",
        chain(extra=[link("loose_a"), link("loose_b"), joint("loose", "loose_a", "loose_b")]),
        ['<link name="base">', '<link name="loose_a">', "2 root links"],
        {},
    ),
    (
        "link_with_two_parents",
        chain(extra=[joint("j3", "base", "link2")]),
        ['<link name="link2">', '<joint name="j2">', '<joint name="j3">', "child of two joints"],
        {},
    ),
    (
        "duplicate_link",
        chain(extra=[link("link1")]),
        ['<link name="link1">', "duplicate link name"],
        {},
    ),
    (
        "duplicate_joint",
        chain(extra=[link("link3"), joint("j1", "link2", "link3")]),
        ['<joint name="j1">', "duplicate joint name"],
        {},
    ),
    *[
        (
            f"{kind}_joint",
            chain(joints={2: {"type": kind}}),
            [
                '<joint name="j2">',
                f"'{kind}' is not supported",
                "supported types: revolute, continuous, prismatic, floating, fixed",
            ],
            {},
        )
        for kind in ("planar", "telescopic")
    ],
    (
        "negative_mass",
        chain(links={2: {"mass": -1.0}}),
        ['<link name="link2"> <inertial>', "mass must be non-negative"],
        {},
    ),
    (
        "inertia_not_positive_definite",
        chain(links={2: {"inertia": (-1, 1, 1, 0, 0, 0)}}),
        ['<link name="link2"> <inertial>', "positive semi-definite", "check_inertia=False"],
        {},
    ),
    (
        "inertia_violates_triangle_inequality",
        chain(links={2: {"inertia": (1, 1, 3, 0, 0, 0)}}),
        ['<link name="link2"> <inertial>', "triangle inequality", "check_inertia=False"],
        {},
    ),
    (
        "nan_in_origin_xyz",
        chain(joints={2: {"xyz": "0 nan 0"}}),
        ['<joint name="j2"> <origin>', "xyz='0 nan 0'", "not finite"],
        {},
    ),
    (
        "nan_in_axis",
        chain(joints={2: {"axis": "0 0 NaN"}}),
        ['<joint name="j2"> <axis>', "xyz='0 0 NaN'", "not finite"],
        {},
    ),
    (
        "nan_mass",
        chain(links={2: {"mass": "nan"}}),
        ['<link name="link2"> <mass>', "value='nan'", "not finite"],
        {},
    ),
    (
        "nan_in_inertia",
        chain(links={2: {"inertia": (0.1, "nan", 0.1, 0, 0, 0)}}),
        ['<link name="link2"> <inertia>', "iyy='nan'", "not finite"],
        {},
    ),
    (
        "nan_in_limit",
        chain(joints={2: {"limit": {**LIMIT, "upper": "nan"}}}),
        ['<joint name="j2"> <limit>', "upper='nan'", "not finite"],
        {},
    ),
    (
        "word_in_rpy",
        chain(joints={2: {"rpy": "0 abc 0"}}),
        ['<joint name="j2"> <origin>', "rpy='0 abc 0'", "not a number"],
        {},
    ),
    (
        "unexpanded_xacro_in_origin",
        chain(joints={2: {"xyz": "$(arg x) 0 0"}}),
        ['<joint name="j2"> <origin>', "xyz='$(arg x) 0 0'", "unexpanded xacro substitution"],
        {},
    ),
    (
        "two_values_in_xyz",
        chain(joints={2: {"xyz": "1 2"}}),
        ['<joint name="j2"> <origin>', "xyz='1 2'", "must have 3 values"],
        {},
    ),
    (
        "zero_axis",
        chain(joints={2: {"axis": (0, 0, 0)}}),
        ['<joint name="j2"> <axis', "the axis is zero"],
        {},
    ),
    (
        "negative_damping",
        chain(joints={2: {"dynamics": {"damping": -0.5}}}),
        ['<joint name="j2"> <dynamics>', "negative damping"],
        {},
    ),
    (
        "nan_collision_sphere_radius",
        chain(links={2: {"extra": collision("sphere", {"radius": "nan"})}}),
        ['<link name="link2"> <sphere>', "radius='nan'", "not finite"],
        {},
    ),
    (
        "word_in_collision_box_origin",
        chain(links={2: {"extra": collision("box", {"size": (1, 1, 1)}, rpy="0 x 0")}}),
        ['<link name="link2"> <origin>', "rpy='0 x 0'", "not a number"],
        {},
    ),
    (
        "negative_collision_sphere_radius",
        chain(links={2: {"extra": collision("sphere", {"radius": -0.1})}}),
        ['<link name="link2"> <collision> <sphere>', "negative radius -0.1"],
        {},
    ),
    (
        "negative_collision_box_size",
        chain(links={2: {"extra": collision("box", {"size": (0.1, -0.2, 0.3)})}}),
        ['<link name="link2"> <collision> <box>', "negative size 0.1 -0.2 0.3"],
        {},
    ),
    (
        "mimic_of_unknown_joint",
        chain(joints={2: {"mimic": {"joint": "ghost"}}}),
        ['<joint name="j2"> <mimic joint="ghost">', "not a moving joint"],
        {"mimic": True},
    ),
    (
        "mimic_cycle",
        chain(joints={1: {"mimic": {"joint": "j2"}}, 2: {"mimic": {"joint": "j1"}}}),
        ['<joint name="j1"> <mimic>', "cycle through j1, j2"],
        {"mimic": True},
    ),
    (
        "mimic_of_itself",
        chain(joints={2: {"mimic": {"joint": "j2"}}}),
        ['<joint name="j2"> <mimic>', "cycle"],
        {"mimic": True},
    ),
]


@pytest.mark.parametrize(
    "text, fragments, kwargs", [c[1:] for c in BAD_URDFS], ids=[c[0] for c in BAD_URDFS]
)
def test_bad_urdf_raises_urdf_error_naming_file_element_and_problem(
    tmp_path, text, fragments, kwargs
):
    path = write_urdf(tmp_path, text, "bad_robot.urdf")
    with pytest.raises(od.URDFError) as info:
        od.load_urdf(path, **kwargs)
    message = str(info.value)
    assert isinstance(info.value, ValueError)
    assert str(path) in message
    for fragment in fragments:
        assert fragment in message


def test_check_inertia_false_keeps_an_unphysical_inertia_and_reports_it(tmp_path):
    model = load(
        tmp_path,
        chain(links={2: {"inertia": (1, 1, 3, 0, 0, 0), "rpy": (0, 0, 0)}}),
        check_inertia=False,
    )
    assert model.nv == 2
    # G of link2 about its own frame: the inertia as written about the com, shifted by Steiner
    com, m = np.array([0.1, -0.1, 0.2]), 2.0
    expected = np.diag([1.0, 1.0, 3.0]) + m * (com @ com * np.eye(3) - np.outer(com, com))
    np.testing.assert_allclose(model.G[1][:3, :3], expected, atol=1e-12)
    kept = [line for line in model.report.honoured if "triangle inequality" in line]
    assert kept and '<link name="link2">' in kept[0] and "kept as written" in kept[0]
    assert "triangle inequality" in str(model.report)


def test_nonexistent_file_raises_urdf_error_naming_the_path(tmp_path):
    path = tmp_path / "missing.urdf"
    with pytest.raises(od.URDFError, match="no such URDF file") as info:
        od.load_urdf(path)
    assert str(path) in str(info.value)


def test_a_folder_given_as_the_urdf_is_named_as_a_folder(tmp_path):
    with pytest.raises(od.URDFError, match="is a folder, not a URDF file") as info:
        od.load_urdf(tmp_path)
    assert str(tmp_path) in str(info.value)


def test_unknown_robot_name_lists_closest_and_known_names():
    with pytest.raises(od.URDFError) as info:
        od.load_urdf("ur_5")
    message = str(info.value)
    assert "'ur_5'" in message and "not" in message
    assert "closest names: ur5" in message
    assert "known robots: " + sorted(od.available_robots())[0] in message


def test_floating_base_frees_the_root_link_and_counts_its_inertia(tmp_path):
    fixed = load(tmp_path, chain())
    model = load(tmp_path, chain(), floating_base=True)
    assert (model.nq, model.nv, model.nb) == (fixed.nq + 7, fixed.nv + 6, fixed.nb + 1)
    assert model.joint_names == fixed.joint_names
    assert model.body_names[0] == model.frames[0].name and model.body_joints[0] == "root_joint"
    assert model.frame_index("root_joint") == model.frame_index(model.body_names[0])
    assert any("floating base" in line for line in model.report.transformed)
    # the root link's inertia, ignored when welded, now moves with the base
    assert model.mass[0] > 0 and model.mass.sum() > fixed.mass.sum()


# --- B. loader behaviour ---------------------------------------------------------------------

# planar arm, both joints about z: shoulder at the mount, elbow at (L, 0, 0) of the upper arm,
# a tool welded to the forearm at (D, 0, 0) with a rotated frame
L, D = 0.7, 0.5
M1, C1, I1 = 2.0, 0.3, 0.05  # upper arm: mass, com on x, izz about the com
M2, C2, I2 = 1.5, 0.25, 0.02  # forearm
M_TOOL, I_TOOL = 0.8, 0.01  # tool: com at its origin, isotropic inertia
TOOL_RPY = (0.3, -0.2, 0.9)
MOUNT_XYZ = (0.1, 0.2, 0.3)


def planar_arm(base_mass=4.0, base_inertia=(1, 1, 1, 0, 0, 0), mount_mass=3.0):
    return robot(
        link("base", mass=base_mass, inertia=base_inertia),
        link("mount", mass=mount_mass),
        joint("base_to_mount", "base", "mount", type="fixed", xyz=MOUNT_XYZ, axis=None, limit=None),
        link("upper_arm", mass=M1, xyz=(C1, 0, 0), inertia=(0.04, 0.06, I1, 0, 0, 0)),
        joint("shoulder", "mount", "upper_arm"),
        link("forearm", mass=M2, xyz=(C2, 0, 0), inertia=(0.01, 0.015, I2, 0, 0, 0)),
        joint("elbow", "upper_arm", "forearm", xyz=(L, 0, 0)),
        link("tool", mass=M_TOOL, inertia=(I_TOOL,) * 3 + (0, 0, 0)),
        joint(
            "flange",
            "forearm",
            "tool",
            type="fixed",
            xyz=(D, 0, 0),
            rpy=TOOL_RPY,
            axis=None,
            limit=None,
        ),
    )


def planar_arm_mass_matrix(q2):
    """The 2R arm with the tool lumped into the forearm: mu its mass, s its first moment and b
    its inertia about the elbow axis."""
    a = I1 + M1 * C1**2
    mu, s = M2 + M_TOOL, M2 * C2 + M_TOOL * D
    b = I2 + M2 * C2**2 + I_TOOL + M_TOOL * D**2
    c = L * s * np.cos(q2)
    return np.array([[a + b + mu * L**2 + 2 * c, b + c], [b + c, b]])


def test_fixed_joint_child_is_lumped_into_the_body_above(tmp_path):
    model = load(tmp_path, planar_arm())
    assert (model.nv, model.nb) == (2, 2)
    assert model.joint_names == ("shoulder", "elbow")
    for q in random_state(2):
        np.testing.assert_allclose(
            od.mass_matrix(model, q), planar_arm_mass_matrix(q[1]), rtol=1e-12
        )
    assert any("'flange'" in line and "'tool'" in line for line in model.report.transformed)


def test_link_welded_by_fixed_joints_is_a_frame_at_parent_pose_times_offset(tmp_path):
    model = load(tmp_path, planar_arm())
    T_forearm_tool = transform((D, 0, 0), rpy_matrix(TOOL_RPY))
    for q in random_state(2):
        q12 = q[0] + q[1]
        T_tool = od.frame_pose(model, q, "tool")
        np.testing.assert_allclose(
            T_tool, od.frame_pose(model, q, "forearm") @ T_forearm_tool, atol=1e-12
        )
        p = np.array(MOUNT_XYZ) + [
            L * np.cos(q[0]) + D * np.cos(q12),
            L * np.sin(q[0]) + D * np.sin(q12),
            0,
        ]
        np.testing.assert_allclose(
            T_tool, transform(p, rot("z", q12) @ rpy_matrix(TOOL_RPY)), atol=1e-12
        )
        # space Jacobian: joints about z through the mount and through the elbow, v = -w x p
        elbow = np.array(MOUNT_XYZ) + [L * np.cos(q[0]), L * np.sin(q[0]), 0]
        J_s = np.array(
            [[0, 0, 1, MOUNT_XYZ[1], -MOUNT_XYZ[0], 0], [0, 0, 1, elbow[1], -elbow[0], 0]]
        ).T
        np.testing.assert_allclose(od.jacobian(model, q, "tool"), J_s, atol=1e-12)
        # body Jacobian: R J_b is (world angular velocity, velocity of the tool origin) per qd
        dp_dq = np.array(
            [[-(p - MOUNT_XYZ)[1], (p - MOUNT_XYZ)[0], 0], [-D * np.sin(q12), D * np.cos(q12), 0]]
        ).T
        R = T_tool[:3, :3]
        J_b = od.jacobian(model, q, "tool", expressed_in="body")
        np.testing.assert_allclose(R @ J_b[:3], [[0, 0], [0, 0], [1, 1]], atol=1e-12)
        np.testing.assert_allclose(R @ J_b[3:], dp_dq, atol=1e-12)
        # a link welded to the root is a fixed frame of the world
        np.testing.assert_allclose(od.frame_pose(model, q, "mount"), transform(MOUNT_XYZ))
        np.testing.assert_allclose(od.jacobian(model, q, "mount"), np.zeros((6, 2)))


def test_root_link_inertia_plays_no_part(tmp_path):
    variants = [
        (4.0, (1, 1, 1, 0, 0, 0), 3.0),
        (None, None, None),
        (50.0, (9, 8, 7, 0.5, 0, 0), 0.0),
    ]
    models = [
        load(tmp_path, planar_arm(b, i, m), f"arm{k}.urdf") for k, (b, i, m) in enumerate(variants)
    ]
    gravity = (3.0, -9.81, 1.0)  # with a component in the plane, so gravity torques are not 0
    q, qd, qdd = random_state(2)
    taus = [od.inverse_dynamics(m, q, qd, qdd, gravity=gravity) for m in models]
    assert np.linalg.norm(taus[0]) > 1.0
    for model, tau in zip(models[1:], taus[1:]):
        np.testing.assert_array_equal(od.mass_matrix(model, q), od.mass_matrix(models[0], q))
        np.testing.assert_array_equal(tau, taus[0])
    assert any(
        "'base'" in line and "welded to the fixed root" in line for line in models[0].report.ignored
    )


def test_inertial_origin_rpy_equals_counter_rotated_inertia_tensor(tmp_path):
    rpy = (0.4, -0.7, 1.1)
    moments = np.diag([0.1, 0.2, 0.25])
    I_rotated = rpy_matrix(rpy) @ moments @ rpy_matrix(rpy).T
    as_tensor = (*np.diag(I_rotated), I_rotated[0, 1], I_rotated[0, 2], I_rotated[1, 2])
    principal = (0.1, 0.2, 0.25, 0, 0, 0)
    rotated, tensor, unrotated = (
        load(tmp_path, chain(links={2: overrides}), f"{name}.urdf")
        for name, overrides in (
            ("rotated", {"rpy": rpy, "inertia": principal}),
            ("tensor", {"rpy": (0, 0, 0), "inertia": as_tensor}),
            ("unrotated", {"rpy": (0, 0, 0), "inertia": principal}),
        )
    )
    np.testing.assert_allclose(rotated.G, tensor.G, atol=1e-12)
    q, qd, qdd = random_state(2)
    np.testing.assert_allclose(od.mass_matrix(rotated, q), od.mass_matrix(tensor, q), atol=1e-12)
    np.testing.assert_allclose(
        od.inverse_dynamics(rotated, q, qd, qdd),
        od.inverse_dynamics(tensor, q, qd, qdd),
        atol=1e-12,
    )
    assert not np.allclose(od.mass_matrix(rotated, q), od.mass_matrix(unrotated, q))


def test_joint_origin_rpy_rotates_the_joint_frame(tmp_path):
    xyz, rpy, m, l, izz = (0.2, -0.1, 0.5), (np.pi / 2, 0.3, -0.6), 2.0, 0.4, 0.03
    model = load(
        tmp_path,
        robot(
            link("base"),
            link("arm", mass=m, xyz=(l, 0, 0), inertia=(0.01, 0.02, izz, 0, 0, 0)),
            joint("hinge", "base", "arm", xyz=xyz, rpy=rpy),
        ),
    )
    R0, g = rpy_matrix(rpy), np.array([0, 0, -9.81])
    w = R0[:, 2]  # the joint axis z of the joint frame, in the world
    q, qd, qdd = random_state(1)
    T = transform(xyz, R0) @ transform(R=rot("z", q[0]))
    np.testing.assert_allclose(od.frame_pose(model, q, "arm"), T, atol=1e-12)
    r_com = T[:3, :3] @ [l, 0, 0]
    # tau = (izz + m l^2) qdd + dU/dq, U = -m g . r_com, d r_com/dq = w x r_com (one joint: no
    # Coriolis term)
    tau = (izz + m * l**2) * qdd - m * g @ np.cross(w, r_com)
    np.testing.assert_allclose(od.inverse_dynamics(model, q, qd, qdd), tau, rtol=1e-12)


@pytest.mark.parametrize("kind, axis", [("revolute", (0, 0, 2)), ("prismatic", (0, 3, 4))])
def test_non_unit_axis_gives_the_unit_axis_dynamics_and_is_reported(tmp_path, kind, axis):
    length = np.linalg.norm(axis)
    scaled, unit = (
        load(tmp_path, chain(joints={2: {"type": kind, "axis": a}}), f"{n}.urdf")
        for n, a in (("scaled", axis), ("unit", np.divide(axis, length)))
    )
    np.testing.assert_allclose(scaled.A, unit.A, atol=1e-15)
    q, qd, qdd = random_state(2)
    np.testing.assert_allclose(
        od.inverse_dynamics(scaled, q, qd, qdd), od.inverse_dynamics(unit, q, qd, qdd), rtol=1e-12
    )
    np.testing.assert_allclose(od.mass_matrix(scaled, q), od.mass_matrix(unit, q), rtol=1e-12)
    assert any(f"'j2' normalised (length {length:g})" in line for line in scaled.report.transformed)
    assert not any("normalised" in line for line in unit.report.transformed)


def test_missing_axis_means_x_axis(tmp_path):
    missing, x_axis = (
        load(tmp_path, chain(joints={1: {"axis": axis}}), f"{n}.urdf")
        for n, axis in (("missing", None), ("x", (1, 0, 0)))
    )
    np.testing.assert_array_equal(missing.A[0], [1, 0, 0, 0, 0, 0])
    q = random_state(2)[0]
    np.testing.assert_array_equal(od.mass_matrix(missing, q), od.mass_matrix(x_axis, q))


def test_link_without_inertial_is_massless(tmp_path):
    model = load(tmp_path, chain(links={2: {"mass": None}}))
    one_joint = load(tmp_path, chain(n=1), "one_joint.urdf")
    np.testing.assert_array_equal(model.G[1], np.zeros((6, 6)))
    q = random_state(2)[0]
    expected = np.zeros((2, 2))
    expected[0, 0] = od.mass_matrix(one_joint, q[:1])[0, 0]
    np.testing.assert_allclose(od.mass_matrix(model, q), expected, atol=1e-12)
    assert any("massless" in line and "link2" in line for line in model.report.transformed)


def test_limits_velocity_effort_damping_friction_are_floats_on_the_model(tmp_path):
    model = load(
        tmp_path,
        chain(
            joints={
                1: {
                    "limit": {"lower": -1.5, "upper": 2.5, "effort": 40, "velocity": 3},
                    "dynamics": {"damping": 0.7, "friction": 0.2},
                },
                2: {"type": "continuous", "limit": {"effort": 12, "velocity": 5}},
                3: {"type": "prismatic", "limit": None, "dynamics": {"friction": 1.5}},
            },
            n=3,
        ),
    )
    expected = {
        "lower": [-1.5, -np.inf, -np.inf],
        "upper": [2.5, np.inf, np.inf],
        "effort_limit": [40, 12, np.inf],
        "velocity_limit": [3, 5, np.inf],
        "damping": [0.7, 0, 0],
        "friction": [0.2, 0, 1.5],
    }
    for name, values in expected.items():
        array = getattr(model, name)
        assert array.dtype == np.float64, name
        np.testing.assert_array_equal(array, values, err_msg=name)
    assert model.continuous.dtype == bool
    np.testing.assert_array_equal(model.continuous, [False, True, False])


def test_continuous_joint_has_infinite_limits_even_if_the_urdf_gives_some(tmp_path):
    model = load(tmp_path, chain(joints={1: {"type": "continuous"}}))
    assert model.lower[0] == -np.inf and model.upper[0] == np.inf
    assert (model.lower[1], model.upper[1]) == (LIMIT["lower"], LIMIT["upper"])


def test_joint_names_are_depth_first_over_the_tree_not_file_order(tmp_path):
    model = load(
        tmp_path,
        robot(
            link("base"),
            link("arm"),
            link("hand"),
            link("finger"),
            link("leg"),
            link("foot"),
            joint("wrist", "arm", "hand"),
            joint("hip", "base", "leg"),
            joint("knuckle", "hand", "finger"),
            joint("shoulder", "base", "arm"),
            joint("ankle", "leg", "foot"),
        ),
    )
    # children of a link in file order: base -> (hip, shoulder)
    assert model.joint_names == ("hip", "ankle", "shoulder", "wrist", "knuckle")
    assert model.body_names == ("leg", "foot", "arm", "hand", "finger")
    np.testing.assert_array_equal(model.parent, [-1, 0, -1, 2, 3])


MIMICS = {
    # j2 = -1.5 j1 + 0.3
    "single": (
        {2: {"mimic": {"joint": "j1", "multiplier": -1.5, "offset": 0.3}}},
        [[1, 0], [-1.5, 0], [0, 1]],
        [0, 0.3, 0],
    ),
    # j2 = -1.5 j1 + 0.3, j3 = 2 j2 - 0.1 = -3 j1 + 0.5
    "chained": (
        {
            2: {"mimic": {"joint": "j1", "multiplier": -1.5, "offset": 0.3}},
            3: {"mimic": {"joint": "j2", "multiplier": 2, "offset": -0.1}},
        },
        [[1], [-1.5], [-3]],
        [0, 0.3, 0.5],
    ),
}


@pytest.mark.parametrize("joints, K, o", MIMICS.values(), ids=MIMICS.keys())
def test_mimic_joints_are_coupled_only_on_request(tmp_path, joints, K, o):
    K, o = np.array(K, dtype=float), np.array(o)
    path = write_urdf(tmp_path, chain(n=3, joints=joints))
    free, coupled = od.load_urdf(path), od.load_urdf(path, mimic=True)
    assert free.nv == 3 and free.joint_names == ("j1", "j2", "j3")
    assert any("mimic" in line and "independent" in line for line in free.report.ignored)
    assert coupled.nv == K.shape[1]
    assert coupled.joint_names == tuple(
        n for n in ("j1", "j2", "j3") if n not in {f"j{k}" for k in joints}
    )
    assert any("mimic joint 'j2'" in line for line in coupled.report.transformed)
    q, qd, qdd = random_state(coupled.nv)
    q_full, qd_full, qdd_full = K @ q + o, K @ qd, K @ qdd
    np.testing.assert_allclose(
        od.mass_matrix(coupled, q), K.T @ od.mass_matrix(free, q_full) @ K, rtol=1e-10, atol=1e-12
    )
    np.testing.assert_allclose(
        od.inverse_dynamics(coupled, q, qd, qdd),
        K.T @ od.inverse_dynamics(free, q_full, qd_full, qdd_full),
        rtol=1e-10,
        atol=1e-12,
    )


def test_model_without_moving_joints_returns_empty_arrays(tmp_path):
    model = load(
        tmp_path,
        robot(
            link("base"),
            link("plate", mass=2.0),
            joint("weld", "base", "plate", type="fixed", xyz=(0, 0, 1)),
        ),
    )
    assert (model.nq, model.nv, model.joint_names) == (0, 0, ())
    empty = np.zeros(0)
    assert od.inverse_dynamics(model, empty, empty, empty).shape == (0,)
    assert od.mass_matrix(model, empty).shape == (0, 0)
    for method in METHODS:
        assert od.forward_dynamics(model, empty, empty, empty, method=method).shape == (0,)
    np.testing.assert_array_equal(od.frame_pose(model, empty, "plate"), transform((0, 0, 1)))


@pytest.mark.parametrize("name, nv", [("ur5", 6), ("panda", 9)])
def test_robot_names_resolve_to_example_robot_data(name, nv):
    robots = od.available_robots()
    assert os.path.isfile(robots[name])
    model = od.load_urdf(name)
    assert model.nv == nv
    assert model.source == robots[name]


def test_fidelity_report_lists_lumped_and_ignored_content(tmp_path):
    text = chain(
        links={1: {"extra": collision("cylinder", {"radius": 0.1, "length": 0.5})}},
        joints={
            2: {
                "extra": '<safety_controller soft_lower_limit="-1" soft_upper_limit="1" '
                'k_velocity="1"/>'
            }
        },
        extra=[
            link("flange_link", mass=None),
            joint("flange", "link2", "flange_link", type="fixed", axis=None, limit=None),
            '<transmission name="t1"><type>SimpleTransmission</type></transmission>',
            '<gazebo reference="link1"><material>Gazebo/Grey</material></gazebo>',
        ],
    )
    report = load(tmp_path, text).report
    assert any("'flange'" in line and "merged" in line for line in report.transformed)
    for tag in ("collision", "safety_controller", "transmission", "gazebo"):
        assert any(f"1 <{tag}>" in line for line in report.ignored), tag
    printed = str(report)
    assert printed.startswith("URDF fidelity report for")
    assert all(line in printed for line in report.honoured + report.transformed + report.ignored)
    plain = str(load(tmp_path, chain(), "plain.urdf").report)
    assert not any(tag in plain for tag in ("transmission", "gazebo", "collision", "safety"))


# --- C. singular mass matrix -----------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
def test_joint_with_nothing_massive_below_makes_forward_dynamics_raise(tmp_path, method):
    model = load(tmp_path, chain(links={2: {"mass": None}}))
    zero = np.zeros(2)
    with pytest.raises(od.SingularMassMatrixError) as info:
        od.forward_dynamics(model, zero, zero, zero, method=method)
    assert isinstance(info.value, ValueError)
    assert "'j2'" in str(info.value) and "'j1'" not in str(info.value)


def test_an_inertia_of_rounding_noise_counts_as_zero(tmp_path):
    """icub's head states ixz = 2.4e-35 and every other entry 0: eigenvalues +-2.4e-35, a point
    mass up to rounding, so it loads and behaves as a point mass."""
    noise = load(tmp_path, chain(1, links={1: {"inertia": (0, 0, 0, 0, 2.4e-35, 0)}}))
    point = load(tmp_path, chain(1, links={1: {"inertia": (0, 0, 0, 0, 0, 0)}}), name="p.urdf")
    q = np.array([0.3])
    np.testing.assert_allclose(od.mass_matrix(noise, q), od.mass_matrix(point, q), rtol=1e-15)


def test_an_invalid_inertia_welded_to_the_root_is_reported_not_refused(tmp_path):
    """The root link's inertia plays no part in a fixed-base model (anymal's base states a
    rod-like inertia 3e-6 > 0 + 0): it is listed as ignored, and the model loads."""
    model = load(
        tmp_path,
        chain(1).replace(
            link("base", mass=4.0), link("base", mass=4.0, inertia=(1, 1, 3, 0, 0, 0))
        ),
    )
    assert model.nv == 1
    assert any("base" in line and "triangle" in line for line in model.report.ignored)


def test_an_inertia_at_the_triangle_bound_written_to_six_digits_loads(tmp_path):
    """A thin rod (principal moments I, I, 0: I1 + I2 = I3 exactly) in a rotated frame, written
    to 6 significant digits as URDFs usually are: rounding moves the moments by about 1e-6 of
    the largest, which is not a physically invalid inertia."""
    R = rpy_matrix((0.3, -0.7, 1.1))
    I = R @ np.diag([0.0, 0.02, 0.02]) @ R.T
    written = tuple(
        float(f"{v:.6g}") for v in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    )
    moments = np.linalg.eigvalsh(
        np.array(
            [
                [written[0], written[3], written[4]],
                [written[3], written[1], written[5]],
                [written[4], written[5], written[2]],
            ]
        )
    )
    assert moments[0] < 0 or moments[2] > moments[0] + moments[1]  # rounding broke the bound
    model = load(tmp_path, chain(1, links={1: {"inertia": written}}))
    assert model.nv == 1


def test_a_joint_name_finds_the_frame_of_its_child_link(tmp_path):
    """The URDF joint frame is its child link's frame (moving and fixed joints alike); a link
    that shares a joint's name keeps its own frame."""
    model = load(
        tmp_path,
        chain(
            2,
            extra=[
                link("tool", mass=None),
                joint(
                    "tool_joint",
                    "link2",
                    "tool",
                    type="fixed",
                    xyz=(0, 0, 0.2),
                    axis=None,
                    limit=None,
                ),
            ],
        ),
    )
    q = np.array([0.4, -0.9])
    for joint_name, child in (("j1", "link1"), ("j2", "link2"), ("tool_joint", "tool")):
        np.testing.assert_array_equal(
            od.frame_pose(model, q, joint_name), od.frame_pose(model, q, child)
        )
    assert "j1" not in model.frame_names
    clash = load(tmp_path, chain(2, joints={2: {"name": "link1"}}), name="clash.urdf")
    T_link1 = od.frame_pose(clash, q, "link1")
    np.testing.assert_array_equal(T_link1, od.frame_pose(clash, q, "j1"))
    assert not np.allclose(T_link1, od.frame_pose(clash, q, "link2"))


# --- D. collision spheres --------------------------------------------------------------------


def spheres_of(model):
    """(link, position, radius, geometry) of each collision sphere, in order."""
    return [(c.link, tuple(c.position), c.radius, c.geometry) for c in model.collision_spheres]


def test_a_collision_sphere_sits_at_its_origin_xyz_and_the_rpy_does_not_move_it(tmp_path):
    xyz = (0.03, -0.02, -0.25)
    models = [
        load(
            tmp_path,
            chain(links={2: {"extra": collision("sphere", {"radius": 0.04}, xyz, rpy)}}),
            name=f"{k}.urdf",
        )
        for k, rpy in enumerate([(0.7, -1.1, 2.3), (0, 0, 0)])
    ]
    for model in models:
        assert spheres_of(model) == [("link2", xyz, 0.04, "sphere")]
    sphere = models[0].collision_spheres[0]
    assert models[0].frame_names[models[0].frame_index(sphere.link)] == "link2"
    with pytest.raises(ValueError):
        sphere.position[0] = 1.0


def test_a_box_collision_gives_its_eight_corners_through_the_origin_transform(tmp_path):
    size, xyz, rpy = np.array([0.2, 0.1, 0.06]), np.array([0.1, -0.2, 0.3]), (0.3, -0.5, 0.9)
    model = load(
        tmp_path, chain(links={1: {"extra": collision("box", {"size": size}, xyz, rpy)}})
    )
    R = Rotation.from_euler("xyz", rpy).as_matrix()  # URDF rpy: extrinsic x, then y, then z
    signs = list(itertools.product((-1, 1), repeat=3))  # the documented order, z fastest
    expected = [xyz + R @ (np.array(sign) * size / 2) for sign in signs]
    corners = model.collision_spheres
    assert [(c.link, c.radius, c.geometry) for c in corners] == [("link1", 0.0, "box corner")] * 8
    np.testing.assert_allclose([c.position for c in corners], expected, atol=1e-15)
    np.testing.assert_allclose(
        [np.linalg.norm(c.position - xyz) for c in corners],
        np.full(8, np.linalg.norm(size) / 2),
        rtol=1e-14,
    )


def test_meshes_and_cylinders_give_no_spheres_and_the_report_counts_each_kind(tmp_path):
    """Spheres follow the links in URDF order (here not the tree's depth-first order), then the
    <collision> elements in document order."""
    model = load(
        tmp_path,
        robot(
            link("base"),
            link(
                "b",
                extra=collision("sphere", {"radius": 0.01}, (0, 0, 0.1))
                + collision("mesh", {"filename": "package://bot/foot.stl"})
                + collision("cylinder", {"radius": 0.02, "length": 0.3})
                + collision("sphere", {"radius": 0.02}, (0, 0, -0.1)),
            ),
            link(
                "a",
                extra=collision("cylinder", {"radius": 0.05, "length": 0.1})
                + collision("box", {"size": (0.1, 0.2, 0.3)}),
            ),
            joint("ja", "base", "a"),
            joint("jb", "a", "b"),
        ),
    )
    assert model.joint_names == ("ja", "jb")
    assert [(c.link, c.geometry) for c in model.collision_spheres] == [
        ("b", "sphere"),
        ("b", "sphere"),
    ] + [("a", "box corner")] * 8
    assert [c.radius for c in model.collision_spheres[:2]] == [0.01, 0.02]
    report = model.report
    assert any(
        "1 box" in line and "2 <collision> spheres" in line and "10 spheres in all" in line
        for line in report.honoured
    )
    assert any(
        "2 <collision> cylinders and 1 mesh (no contact points" in line for line in report.ignored
    )
    assert not any("no contact model" in line for line in report.ignored)
    only_meshes = load(
        tmp_path, chain(links={1: {"extra": collision("mesh", {"filename": "a.stl"})}}), "m.urdf"
    )
    assert only_meshes.collision_spheres == ()
    assert not any("collision" in line for line in only_meshes.report.honoured)


FOOT_URDF = robot(
    link("base", extra=collision("sphere", {"radius": 0.05}, (0.2, 0, 0))),
    link("leg"),
    link("foot", mass=None, extra=collision("sphere", {"radius": 0.02}, (0, 0, 0.1))),
    link("toe"),
    joint("hip", "base", "leg", xyz=(0, 0, 1), rpy=(0, 0, np.pi / 2)),
    joint("ankle", "leg", "foot", type="fixed", xyz=(0.5, 0, 0), rpy=(0, np.pi / 2, 0)),
    joint("toe_joint", "foot", "toe", mimic={"joint": "hip", "multiplier": 2.0}),
)


@pytest.mark.parametrize("kwargs", [{}, {"floating_base": True}, {"mimic": True}])
def test_spheres_of_a_link_merged_by_a_fixed_joint_name_it_and_sit_in_its_frame(
    tmp_path, kwargs
):
    """foot is welded to leg: its sphere keeps foot's name and its position in foot's frame.
    By hand at q = 0: Ry(pi/2) (0, 0, 0.1) + (0.5, 0, 0) = (0.6, 0, 0) in leg; Rz(pi/2) of that
    + (0, 0, 1) = (0, 0.6, 1) in the world. The root's sphere is kept, on the root link."""
    model = load(tmp_path, FOOT_URDF, **kwargs)
    assert spheres_of(model) == [
        ("base", (0.2, 0.0, 0.0), 0.05, "sphere"),
        ("foot", (0.0, 0.0, 0.1), 0.02, "sphere"),
    ]
    assert model.frames[model.frame_index("foot")].body == model.body_names.index("leg")
    q = od.neutral(model)
    for sphere, world in zip(model.collision_spheres, [(0.2, 0, 0), (0, 0.6, 1)]):
        np.testing.assert_allclose(
            od.frame_pose(model, q, sphere.link) @ [*sphere.position, 1], [*world, 1], atol=1e-15
        )


def urdf_collisions(path):
    """(link, shape element, origin xyz) of every <collision>, read from the file itself."""
    out = []
    for link_el in ET.parse(path).getroot().iter("link"):
        for c in link_el.iter("collision"):
            origin = c.find("origin")
            xyz = [0.0] * 3 if origin is None else [float(v) for v in origin.get("xyz").split()]
            out.append((link_el.get("name"), c.find("geometry")[0], tuple(xyz)))
    return out


@pytest.mark.parametrize(
    "name, count, sphere_links, radius",
    [
        ("go1", 4, {"FR_foot", "FL_foot", "RR_foot", "RL_foot"}, 0.02),
        ("g1_29dof_rev_1_0", 8, {"left_ankle_roll_link", "right_ankle_roll_link"}, 0.005),
    ],
)
def test_example_robot_data_feet_carry_the_spheres_their_urdf_gives(
    name, count, sphere_links, radius
):
    model = od.load_urdf(name)
    in_file = urdf_collisions(model.source)
    file_spheres = [
        (link, xyz, float(shape.get("radius")))
        for link, shape, xyz in in_file
        if shape.tag == "sphere"
    ]
    boxes = sum(1 for _, shape, _ in in_file if shape.tag == "box")
    assert len(file_spheres) == count
    assert {link for link, _, _ in file_spheres} == sphere_links
    assert {r for _, _, r in file_spheres} == {radius}
    assert [
        (c.link, tuple(c.position), c.radius)
        for c in model.collision_spheres
        if c.geometry == "sphere"
    ] == file_spheres
    assert len(model.collision_spheres) == len(file_spheres) + 8 * boxes
    for c in model.collision_spheres:
        model.frame_index(c.link)



# --- E. URDFs written for other tools --------------------------------------------------------


def same_dynamics(a, b):
    """Whether two models have the same M(q) and g(q) at random configurations."""
    for q in RNG.uniform(-1.5, 1.5, (3, a.nq)):
        np.testing.assert_allclose(od.mass_matrix(a, q), od.mass_matrix(b, q), rtol=1e-14)
        np.testing.assert_allclose(od.gravity_forces(a, q), od.gravity_forces(b, q), rtol=1e-14)


def bullet_style(text, blank="\n\n  \n"):
    """A URDF text as Bullet's robots open: blank lines, then <?xml version='0.0' ?>."""
    return blank + text.replace('<?xml version="1.0"?>', "<?xml version='0.0' ?>")


def test_xml_version_0_0_and_blank_lines_before_the_declaration_load(tmp_path):
    """Bullet's robots open with <?xml version="0.0" ?>, some after blank lines: XML refuses
    both, robotics tools read them. The model is the one the same file with a plain
    declaration gives, the report says what was tolerated, and the line number in an error
    is still the file's own."""
    plain = load(tmp_path, chain(), "plain.urdf")
    model = load(tmp_path, bullet_style(chain()))
    same_dynamics(model, plain)
    assert "XML declaration version '0.0' read as 1.0" in model.report.transformed
    assert "whitespace before the XML declaration (3 lines) skipped" in model.report.transformed
    assert not any("XML" in line for line in plain.report.transformed)
    bad = bullet_style(chain(joints={2: {"xyz": "1 x 0"}}))
    line = next(k for k, row in enumerate(bad.splitlines(), 1) if 'xyz="1 x 0"' in row)
    with pytest.raises(od.URDFError, match=rf"<origin> \(line {line}\): xyz='1 x 0' is not a"):
        load(tmp_path, bad, "bad.urdf")


def test_nul_bytes_after_the_document_load(tmp_path):
    """pybullet's humanoid ends in a NUL byte, where a C string ends: read as the end."""
    path = tmp_path / "nul.urdf"
    path.write_bytes(chain().encode() + b"\0\n\0")
    model = od.load_urdf(path)
    same_dynamics(model, load(tmp_path, chain(), "plain.urdf"))
    assert "NUL bytes after the end of the document skipped" in model.report.transformed


@pytest.mark.parametrize("blank", ["", "\n"])
def test_byte_order_mark_loads(tmp_path, blank):
    """A UTF-8 byte-order mark before the declaration (and blank lines) is read as UTF-8."""
    path = tmp_path / "bom.urdf"
    path.write_bytes(b"\xef\xbb\xbf" + bullet_style(chain(), blank).encode())
    same_dynamics(od.load_urdf(path), load(tmp_path, chain(), "plain.urdf"))


def test_plane_and_cdf_collision_are_reported_ignored(tmp_path):
    """Bullet's <plane> and <cdf> (and a <geometry> with no shape) are not URDF geometry: each
    <collision> or <visual> holding one is read as absent and listed as ignored, by link; the
    spheres of the spec beside them still give contact points, and playback draws the
    visuals it can."""
    from opendyn import viz

    sphere = collision("sphere", {"radius": 0.04}, (0, 0, 0.1))
    plane = '<collision><geometry><plane normal="0 0 1"/></geometry></collision>'
    cdf = '<collision><geometry><cdf filename="box.cdf"/></geometry></collision>'
    visuals = (
        '<visual><geometry><plane normal="0 0 1"/></geometry></visual>'
        '<visual><geometry><box size="1 1 1"/></geometry></visual>'
        "<visual><geometry/></visual>"
    )
    plain = load(tmp_path, chain(links={2: {"extra": sphere}}), "plain.urdf")
    model = load(
        tmp_path,
        chain(links={1: {"extra": plane + cdf + visuals}, 2: {"extra": plane + sphere}}),
    )
    same_dynamics(model, plain)
    assert spheres_of(model) == spheres_of(plain)
    spec = "outside the URDF spec (box, cylinder, sphere, mesh), not read"
    assert set(model.report.ignored) - set(plain.report.ignored) == {
        f"2 <collision> elements with <geometry> <plane>, {spec}: links 'link1', 'link2'",
        f"1 <collision> element with <geometry> <cdf>, {spec}: link 'link1'",
        f"1 <visual> element with <geometry> <plane>, {spec}: link 'link1'",
        f"1 <visual> element with no <geometry> shape, {spec}: link 'link1'",
        "1 <visual> elements (used only for playback)",
    }
    with warnings.catch_warnings():
        warnings.simplefilter("error", viz.PlaybackWarning)
        (box,) = viz.load_visuals(model)
    assert (box.link, box.shape) == ("link1", "box")


def test_lower_above_upper_is_unlimited_and_reported(tmp_path):
    """Bullet reads <limit lower="1" upper="-1"> as "no limit" (pybullet's cube_no_rotation):
    the joint keeps its type, its effort and velocity limits, and has no position limits;
    the report names it. Its dynamics are Pinocchio's for the same file (which keeps the
    numbers as written, and never uses position limits in M or g)."""
    pytest.importorskip("pinocchio")
    from pin_adapter import PinOracle

    inverted = {**LIMIT, "lower": 1.0, "upper": -1.0}
    joints = {1: {"limit": inverted}, 3: {"type": "prismatic"}}
    path = write_urdf(tmp_path, chain(3, joints=joints))
    model = od.load_urdf(path)
    np.testing.assert_array_equal(model.lower, [-np.inf, -2.0, -2.0])
    np.testing.assert_array_equal(model.upper, [np.inf, 2.0, 2.0])
    np.testing.assert_array_equal(model.effort_limit, [10.0] * 3)
    np.testing.assert_array_equal(model.velocity_limit, [3.0] * 3)
    assert not model.continuous[0] and model.jtype[0] == od.multibody.joints.REVOLUTE
    assert [line for line in model.report.transformed if "lower" in line] == [
        "joint 'j1': <limit> lower 1 > upper -1, Bullet's convention for no limit: taken as "
        "unlimited (its effort and velocity limits kept)"
    ]
    P = PinOracle(path, model)
    for q in RNG.uniform(-1.5, 1.5, (3, model.nq)):
        np.testing.assert_allclose(od.mass_matrix(model, q), P.mass_matrix(q), atol=1e-12)
        np.testing.assert_allclose(od.gravity_forces(model, q), P.gravity_forces(q), atol=1e-12)


def test_inertia_error_lists_every_bad_link(tmp_path):
    """One error names every link whose inertia no rigid body has, each with its problem, not
    just the first (xarm6 and mini_cheetah break the triangle inequality on several links);
    check_inertia=False keeps those of mass >= 0, so then only the negative mass is refused."""
    text = chain(
        4,
        links={
            1: {"inertia": (1, 1, 3, 0, 0, 0)},
            2: {"inertia": (-1, 1, 1, 0, 0, 0)},
            4: {"mass": -1.0},
        },
    )
    path = write_urdf(tmp_path, text)
    with pytest.raises(od.URDFError) as info:
        od.load_urdf(path)
    head, *rows = str(info.value).splitlines()
    assert head == (
        f"{path}: 3 links have an inertia that no rigid body has (load_urdf(..., "
        f"check_inertia=False) keeps those of mass >= 0 as written):"
    )
    assert [row.split(":")[0] for row in rows] == [
        f'  <link name="link{k}"> <inertial>' for k in (1, 2, 4)
    ]
    assert "triangle inequality" in rows[0] and "positive semi-definite" in rows[1]
    assert "mass must be non-negative" in rows[2]
    with pytest.raises(od.URDFError) as info:
        od.load_urdf(path, check_inertia=False)
    assert str(info.value) == (
        f'{path}: <link name="link4"> <inertial>: mass must be non-negative, got -1.0; no '
        f"rigid body has it"
    )


# base -> j1 -> link1 (massive) -> j2 -> link2 (massless) -> j3 -> link3 (massless), and
# base -> j4 -> link4, a point mass on j4's axis: j2, j3 and j4 move nothing with inertia
MASSLESS_JOINTS = robot(
    link("base"),
    link("link1", xyz=(0.3, 0, 0)),
    link("link2", mass=None),
    link("link3", mass=None),
    link("link4", mass=2.0, inertia=(0, 0, 0, 0, 0, 0)),
    joint("j1", "base", "link1", axis=(0, 1, 0)),
    joint("j2", "link1", "link2", xyz=(0.5, 0, 0), axis=(0, 1, 0)),
    joint("j3", "link2", "link3", xyz=(0.5, 0, 0), type="prismatic", axis=(1, 0, 0)),
    joint("j4", "base", "link4", xyz=(0, 0.2, 0), axis=(0, 0, 1)),
)


def test_singular_mass_matrix_names_every_massless_joint(tmp_path):
    """Every joint whose column of M is zero is named, whichever method, state or run meets
    the singular M first (ABA's pivots fail at the deepest massless body, Cholesky's at the
    first); a joint that moves something is not named."""
    model = load(tmp_path, MASSLESS_JOINTS)
    named = "joints 'j2', 'j3', 'j4', so their accelerations are undetermined"
    q, zero = np.array([0.3, -0.4, 0.1, 0.7]), np.zeros(4)
    calls = [
        lambda method: od.forward_dynamics(model, q, zero, zero, method=method),
        lambda method: od.forward_dynamics(model, np.tile(q, (3, 1)), zero, zero, method=method),
    ]
    for call, method in itertools.product(calls, METHODS):
        with pytest.raises(od.SingularMassMatrixError, match=named) as info:
            call(method)
        assert info.value.joints == ["j2", "j3", "j4"] and info.value.together == []
        assert "'j1'" not in str(info.value)
    with pytest.raises(od.SingularMassMatrixError, match=named):
        od.task_space_mass_matrix(model, q, "link1")
    with pytest.raises(od.SimulationError, match=f"singular mass matrix at t = .*{named}"):
        od.simulate(od.default_scene(str(model.source), duration=0.1))
    settings = {
        "robot": {"urdf": str(model.source)},
        "run": {"duration": 0.01, "dt": 1e-3},
        "effects": {"gravity": True, "armature": {"values": {"j3": 0.1}}},
    }
    with pytest.raises(od.SimulationError, match="joints 'j2', 'j4', so their"):
        od.simulate(od.scene_from_dict(settings))


def test_joints_that_move_one_body_together_are_named_as_a_combination(tmp_path):
    """Two prismatic joints along x with nothing between them: each moves the mass, so no
    column of M is zero, but j1 forward and j2 back by as much move nothing. The error says
    so and names no joint as massless."""
    model = load(
        tmp_path,
        robot(
            link("base"),
            link("slider", mass=None),
            link("body"),
            joint("j1", "base", "slider", type="prismatic", axis=(1, 0, 0)),
            joint("j2", "slider", "body", type="prismatic", axis=(1, 0, 0)),
        ),
    )
    with pytest.raises(od.SingularMassMatrixError) as info:
        od.forward_dynamics(model, np.zeros(2), np.zeros(2), np.zeros(2))
    assert info.value.joints == [] and info.value.together == ["j1", "j2"]
    assert "every joint moves some inertia, but joints 'j1', 'j2' moving together, with " in str(
        info.value
    )
    assert "ratio (1, -1)" in str(info.value) or "ratio (-1, 1)" in str(info.value)
