"""Playback (opendyn.viz): the URDF's visual geometry, the meshcat scene and its animation, the
ground and contact-force arrows, the self-contained page as headless Chromium draws it, the live
viewer, and the plot's contact panel.

Independent truths: the double pendulum's closed-form kinematics (robots/double_pendulum.urdf:
the elbow at (-L1 sin q1, 0, 2 - L1 cos q1), link 1 turned by q1 about y), the pinhole camera
model for where a point appears on the screenshot, scipy's rotations, and files and contact
records written here by hand.
"""

from __future__ import annotations

import base64
import math
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import opendyn as od
from opendyn import viz
from opendyn.io.urdf import shipped_robots_dir

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
WIDTH, HEIGHT = 800, 600

TETRAHEDRON_STL = """solid tetra
facet normal 0 0 -1
 outer loop
  vertex 0 0 0
  vertex 0 1 0
  vertex 1 0 0
 endloop
endfacet
facet normal 0 -1 0
 outer loop
  vertex 0 0 0
  vertex 1 0 0
  vertex 0 0 1
 endloop
endfacet
facet normal -1 0 0
 outer loop
  vertex 0 0 0
  vertex 0 0 1
  vertex 0 1 0
 endloop
endfacet
facet normal 0.577 0.577 0.577
 outer loop
  vertex 1 0 0
  vertex 0 1 0
  vertex 0 0 1
 endloop
endfacet
endsolid tetra
"""

TETRAHEDRON_OBJ = """v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
f 1 3 2
f 1 2 4
f 1 4 3
f 2 3 4
"""


@pytest.fixture
def meshcat():
    return pytest.importorskip("meshcat")


def one_link_urdf(visuals: str, materials: str = "") -> str:
    """A robot with one revolute joint about z; ``visuals`` go into the moving link "arm"."""
    return f"""<?xml version="1.0"?>
<robot name="one_link">
  {materials}
  <link name="base"/>
  <joint name="j" type="revolute">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0 0 1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
    {visuals}
  </link>
</robot>
"""


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def page_commands(html: str) -> list[dict]:
    """The meshcat commands a page applies, decoded (msgpack) in order."""
    import umsgpack

    return [
        umsgpack.unpackb(base64.b64decode(b64))
        for b64 in re.findall(r'^command\("([A-Za-z0-9+/=]*)"\);$', html, re.M)
    ]


def objects_by_path(commands):
    return {c["path"]: c["object"] for c in commands if c["type"] == "set_object"}


def transforms_by_path(commands):
    """Each node's (4, 4) transform (meshcat sends the matrix column-major)."""
    return {
        c["path"]: np.array(c["matrix"], dtype=float).reshape(4, 4).T
        for c in commands
        if c["type"] == "set_transform"
    }


def clips_by_path(commands):
    """Each animated node's tracks: {path: {track name: (key times (F,) s, values (F, n))}}."""
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    return {
        a["path"]: {
            tr["name"]: (
                np.array([k["time"] for k in tr["keys"]]) / a["clip"]["fps"],
                np.array([k["value"] for k in tr["keys"]], dtype=float),
            )
            for tr in a["clip"]["tracks"]
        }
        for a in animation["animations"]
    }


def metres_per_newton(html):
    """The arrows' scale the page states in its title, "... X N per Y m"."""
    title = re.search(r"<title>(.*)</title>", html).group(1)
    newtons, metres = re.search(r" ([\d.e+-]+) N per ([\d.e+-]+) m\)$", title).groups()
    return float(metres) / float(newtons)


def rot_y(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


# --------------------------------------------------------------------------------------------
# parsing the URDF's visual geometry


def test_box_cylinder_sphere_and_meshes_are_parsed_with_origin_scale_and_colour(tmp_path):
    write(tmp_path / "meshes" / "tetra.stl", TETRAHEDRON_STL)
    write(tmp_path / "meshes" / "tetra.obj", TETRAHEDRON_OBJ)
    urdf = write(
        tmp_path / "one_link.urdf",
        one_link_urdf(
            materials='<material name="red"><color rgba="1 0 0 1"/></material>',
            visuals="""
    <visual><origin xyz="0.1 0.2 0.3" rpy="0 0 1.5707963267948966"/>
      <geometry><box size="0.1 0.2 0.3"/></geometry><material name="red"/></visual>
    <visual><geometry><cylinder radius="0.05" length="0.4"/></geometry>
      <material name="green"><color rgba="0 1 0 0.5"/></material></visual>
    <visual><geometry><sphere radius="0.07"/></geometry></visual>
    <visual><geometry><mesh filename="meshes/tetra.stl" scale="2 3 4"/></geometry></visual>
    <visual><geometry><mesh filename="meshes/tetra.obj"/></geometry></visual>
""",
        ),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", viz.PlaybackWarning)
        box, cyl, sphere, stl, obj = viz.load_visuals(od.load_urdf(urdf))
    assert all(v.link == "arm" for v in (box, cyl, sphere, stl, obj))
    assert (box.shape, box.size, box.rgba) == ("box", (0.1, 0.2, 0.3), (1.0, 0.0, 0.0, 1.0))
    np.testing.assert_allclose(box.T_link_visual[:3, 3], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(
        box.T_link_visual[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12
    )
    assert (cyl.shape, cyl.size, cyl.rgba) == ("cylinder", (0.05, 0.4), (0.0, 1.0, 0.0, 0.5))
    assert (sphere.shape, sphere.size, sphere.rgba) == ("sphere", (0.07,), viz.DEFAULT_RGBA)
    assert (stl.shape, stl.size) == ("mesh", (2.0, 3.0, 4.0))
    assert stl.mesh_path == str((tmp_path / "meshes" / "tetra.stl").resolve())
    assert (obj.shape, obj.size) == ("mesh", (1.0, 1.0, 1.0))
    assert obj.mesh_path.endswith("tetra.obj")
    assert all(v.note == "" for v in (box, cyl, sphere, stl, obj))


def test_the_page_holds_each_geometry_with_urdf_cylinders_turned_onto_z(tmp_path, meshcat):
    """meshcat cylinders lie along y; the node transform must send y to the URDF's z axis.
    Mesh scales go into the node transform; the mesh files' bytes are inlined."""
    write(tmp_path / "tetra.stl", TETRAHEDRON_STL)
    write(tmp_path / "tetra.obj", TETRAHEDRON_OBJ)
    urdf = write(
        tmp_path / "one_link.urdf",
        one_link_urdf(
            """
    <visual><origin xyz="0 0 0.5" rpy="0 0 0"/>
      <geometry><cylinder radius="0.05" length="0.4"/></geometry></visual>
    <visual><geometry><mesh filename="tetra.stl" scale="2 3 4"/></geometry></visual>
    <visual><geometry><mesh filename="tetra.obj"/></geometry></visual>
"""
        ),
    )
    model = od.load_urdf(urdf)
    html = viz.write_html(model, [0.0], [[0.0]], tmp_path / "page.html").read_text()
    commands = page_commands(html)
    objects, transforms = objects_by_path(commands), transforms_by_path(commands)
    cylinder = objects["/meshcat/one_link/arm/visual_0"]["geometries"][0]
    assert cylinder["type"] == "CylinderGeometry"
    assert (cylinder["height"], cylinder["radiusTop"]) == (0.4, 0.05)
    T_cyl = transforms["/meshcat/one_link/arm/visual_0"]
    np.testing.assert_allclose(T_cyl[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(T_cyl[:3, 3], [0, 0, 0.5])

    stl = objects["/meshcat/one_link/arm/visual_1"]["geometries"][0]
    assert (stl["type"], stl["format"]) == ("_meshfile", "stl")
    assert bytes(stl["data"].data) == TETRAHEDRON_STL.encode()
    np.testing.assert_allclose(transforms["/meshcat/one_link/arm/visual_1"], np.diag([2, 3, 4, 1]))
    obj = objects["/meshcat/one_link/arm/visual_2"]["geometries"][0]
    assert (obj["type"], obj["format"], obj["data"]) == ("_meshfile", "obj", TETRAHEDRON_OBJ)
    # the moving link sits 1 m above the base (the joint origin) at q = 0
    np.testing.assert_allclose(transforms["/meshcat/one_link/arm"][:3, 3], [0, 0, 1])


def test_missing_mesh_warns_naming_link_and_file_and_the_page_is_still_written(tmp_path, meshcat):
    urdf = write(
        tmp_path / "one_link.urdf",
        one_link_urdf(
            '<visual><geometry><mesh filename="meshes/nowhere.stl"/></geometry></visual>'
        ),
    )
    model = od.load_urdf(urdf)
    with pytest.warns(viz.PlaybackWarning, match=r"link 'arm'.*meshes/nowhere\.stl.*not found"):
        page = viz.write_html(model, [0.0, 1.0], [[0.0], [1.0]], tmp_path / "page.html")
    html = page.read_text()
    assert html.startswith("<!DOCTYPE html>")
    box = objects_by_path(page_commands(html))["/meshcat/one_link/arm/visual_0"]["geometries"][0]
    assert box["type"] == "BoxGeometry"  # the stand-in
    with pytest.warns(viz.PlaybackWarning):
        (stand_in,) = viz.load_visuals(model)
    assert stand_in.shape == "box" and "nowhere.stl" in stand_in.note


@pytest.mark.parametrize(
    "name, content, why",
    [
        ("part.mesh", "ogre", r"part\.mesh.*playback reads STL, DAE, OBJ"),
        ("empty.stl", "", r"empty\.stl.*could not be read \(the file is empty\)"),
        ("broken.dae", "<COLLADA><unclosed>", r"broken\.dae.*not a well-formed Collada"),
    ],
)
def test_unusable_mesh_warns_and_becomes_a_stand_in(tmp_path, meshcat, name, content, why):
    write(tmp_path / name, content)
    urdf = write(
        tmp_path / "one_link.urdf",
        one_link_urdf(f'<visual><geometry><mesh filename="{name}"/></geometry></visual>'),
    )
    with pytest.warns(viz.PlaybackWarning, match=why):
        page = viz.write_html(od.load_urdf(urdf), [0.0], [[0.0]], tmp_path / "page.html")
    geometry = objects_by_path(page_commands(page.read_text()))["/meshcat/one_link/arm/visual_0"]
    assert geometry["geometries"][0]["type"] == "BoxGeometry"


def test_package_file_and_relative_mesh_names_resolve(tmp_path, monkeypatch):
    stl = write(tmp_path / "ws" / "my_pkg" / "meshes" / "part.stl", TETRAHEDRON_STL).resolve()
    urdf_dir = (tmp_path / "elsewhere" / "urdf").resolve()
    urdf_dir.mkdir(parents=True)
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    path, _ = viz.resolve_mesh("package://my_pkg/meshes/part.stl", urdf_dir)
    assert path is None
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    assert viz.resolve_mesh("package://my_pkg/meshes/part.stl", urdf_dir)[0] == str(stl)
    # a URDF inside the package finds it among its parents, without any environment
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    inside = (tmp_path / "ws" / "my_pkg" / "urdf").resolve()
    inside.mkdir()
    assert viz.resolve_mesh("package://my_pkg/meshes/part.stl", inside)[0] == str(stl)
    assert viz.resolve_mesh(f"file://{stl}", urdf_dir)[0] == str(stl)
    assert viz.resolve_mesh("../meshes/part.stl", inside)[0] == str(stl)
    assert viz.resolve_mesh("http://example.com/part.stl", urdf_dir) == (None, [])


def test_example_robot_data_meshes_resolve_without_warnings():
    robots = od.available_robots()
    if "ur5" not in robots:
        pytest.skip("example-robot-data is not installed")
    model = od.load_urdf("ur5")
    with warnings.catch_warnings():
        warnings.simplefilter("error", viz.PlaybackWarning)
        visuals = viz.load_visuals(model)
    links_with_geometry = {v.link for v in visuals}
    assert {"base_link", "shoulder_link", "forearm_link", "wrist_3_link"} <= links_with_geometry
    for v in visuals:
        assert v.shape == "mesh" and v.note == ""
        assert v.mesh_path.lower().endswith((".dae", ".stl"))
        assert "example-robot-data" in v.mesh_path


def test_urdf_without_visuals_gets_a_sphere_per_moving_body(tmp_path):
    from lxml import etree

    tree = etree.parse(str(shipped_robots_dir() / "double_pendulum.urdf"))
    for visual in list(tree.getroot().iter("visual")):
        visual.getparent().remove(visual)
    tree.write(str(tmp_path / "bare.urdf"))
    model = od.load_urdf(tmp_path / "bare.urdf")
    with pytest.warns(viz.PlaybackWarning, match="no link has a <visual>"):
        visuals = viz.load_visuals(model)
    assert [v.link for v in visuals] == ["link1", "link2"]
    assert all(v.shape == "sphere" for v in visuals)


# --------------------------------------------------------------------------------------------
# the motion


def test_animation_follows_the_double_pendulums_closed_form_kinematics(tmp_path, meshcat):
    """q1 = 0.5 t (linear, so the resampling is exact): the elbow (link 2's frame) is at
    (-sin q1, 0, 2 - cos q1) and link 1 is turned by q1 about y."""
    model = od.load_urdf("double_pendulum")
    t = np.linspace(0.0, 2.0, 41)
    q = np.column_stack([0.5 * t, -0.25 * t])
    html = viz.write_html(model, t, q, tmp_path / "page.html", fps=10).read_text()
    (animation,) = [c for c in page_commands(html) if c["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in animation["animations"]}
    assert set(clips) == {"/meshcat/double_pendulum/link1", "/meshcat/double_pendulum/link2"}
    tracks = {tr["name"]: tr["keys"] for tr in clips["/meshcat/double_pendulum/link2"]["tracks"]}
    times = (
        np.array([k["time"] for k in tracks[".position"]])
        / clips["/meshcat/double_pendulum/link2"]["fps"]
    )
    np.testing.assert_allclose(times, np.linspace(0.0, 2.0, 21))  # 10 frames a second
    q1 = 0.5 * times
    elbow = np.array([k["value"] for k in tracks[".position"]])
    np.testing.assert_allclose(
        elbow, np.column_stack([-np.sin(q1), 0 * q1, 2 - np.cos(q1)]), atol=1e-12
    )
    link1 = {tr["name"]: tr["keys"] for tr in clips["/meshcat/double_pendulum/link1"]["tracks"]}
    for key, angle in zip(link1[".quaternion"], q1):
        x, y, z, w = key["value"]  # three.js order
        np.testing.assert_allclose(
            abs(np.dot([x, y, z, w], [0, math.sin(angle / 2), 0, math.cos(angle / 2)])), 1.0
        )


def test_resampling_interpolates_linearly_to_the_frame_rate():
    t = np.array([0.0, 0.1, 0.5, 1.0])
    q = np.column_stack([3 * t + 1, -t])
    times, Q = viz.resample(t, q, fps=20)
    np.testing.assert_allclose(times, np.linspace(0, 1, 21))
    np.testing.assert_allclose(Q, np.column_stack([3 * times + 1, -times]))
    times, Q = viz.resample(t[:1], q[:1], fps=20)
    assert times.shape == (1,) and Q.shape == (1, 2)


def test_default_frame_rate_is_the_trajectorys_own_at_most_30(tmp_path, meshcat):
    model = od.load_urdf("double_pendulum")

    def key_count(t):
        q = np.zeros((len(t), 2))
        html = viz.write_html(model, t, q, tmp_path / "page.html").read_text()
        (anim,) = [c for c in page_commands(html) if c["type"] == "set_animation"]
        return len(anim["animations"][0]["clip"]["tracks"][0]["keys"])

    assert key_count(np.linspace(0, 2, 201)) == 61  # 100 Hz -> 30 fps
    assert key_count(np.linspace(0, 2, 21)) == 21  # 10 Hz stays 10 fps


def test_bad_motion_arguments_are_named(tmp_path, meshcat):
    model = od.load_urdf("double_pendulum")
    out = tmp_path / "page.html"
    with pytest.raises(ValueError, match=r"q must have shape \(K, nq\) = \(3, 2\)"):
        viz.write_html(model, [0, 1, 2], np.zeros((3, 3)), out)
    with pytest.raises(ValueError, match="t must be non-decreasing"):
        viz.write_html(model, [0, 2, 1], np.zeros((3, 2)), out)
    with pytest.raises(ValueError, match=r"q has non-finite entries, first at sample 1"):
        viz.write_html(model, [0, 1, 2], [[0, 0], [np.nan, 0], [0, 0]], out)
    with pytest.raises(ValueError, match="fps must be a positive number"):
        viz.write_html(model, [0, 1], np.zeros((2, 2)), out, fps=0)
    assert not out.exists()


def test_missing_meshcat_names_the_install_command(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "meshcat", None)
    model = od.load_urdf("double_pendulum")
    with pytest.raises(ImportError, match=re.escape("pip install 'opendyn[viz]'")):
        viz.write_html(model, [0.0], [[0.0, 0.0]], tmp_path / "page.html")
    with pytest.raises(ImportError, match="playback needs meshcat"):
        viz.view(model, [0.0], [[0.0, 0.0]])


def test_the_page_loads_nothing_from_the_network(tmp_path, meshcat):
    model = od.load_urdf("double_pendulum")
    html = viz.write_html(model, [0.0], [[0.0, 0.0]], tmp_path / "page.html").read_text()
    assert not re.search(r"<(script|link|img|iframe)[^>]+(src|href)\s*=", html, re.I)
    tail = html[html.rindex("<script>") :]  # after meshcat's viewer: the scene and camera
    code = re.sub(r'^command\("[A-Za-z0-9+/=]*"\);$', "", tail, flags=re.M)
    assert "fetch(" not in code and "http" not in code and "XMLHttpRequest" not in code


# --------------------------------------------------------------------------------------------
# ground contact


def swing(samples=21, duration=2.0):
    """(t (K,), q (K, 2)) of the double pendulum, q1 = 0.5 t, q2 = -0.25 t."""
    t = np.linspace(0.0, duration, samples)
    return t, np.column_stack([0.5 * t, -0.25 * t])


def test_each_contact_force_is_an_arrow_from_its_point_along_it_at_the_stated_scale(
    tmp_path, meshcat
):
    """Point 0 stands still under 100 N straight up for t < 1 s and nothing after; point 1
    moves under a force that turns. At every key (the samples: 10 per second, fps 10) the
    arrow's shaft starts at the point, the node's z axis is along f / |f|, the head sits on
    the shaft's end, and its tip is at p + s f for the scale s the page's title states; where
    the force is zero, shaft and head are scaled to nothing."""
    from scipy.spatial.transform import Rotation

    t, q = swing()
    points = np.zeros((len(t), 2, 3))
    points[:, 0] = [0.5, 0.3, 0.0]
    points[:, 1] = np.column_stack([0.1 * t, -0.2 + 0 * t, 0.05 + 0 * t])
    forces = np.zeros((len(t), 2, 3))
    forces[t < 1.0, 0] = [0.0, 0.0, 100.0]
    forces[:, 1] = np.column_stack([30 * np.sin(2 * t), -20 + 0 * t, 60 + 10 * t])
    page = viz.write_html(
        od.load_urdf("double_pendulum"),
        t,
        q,
        tmp_path / "c.html",
        fps=10,
        contact=(0.0, points, forces),
    )
    html = page.read_text()
    commands = page_commands(html)
    objects, transforms = objects_by_path(commands), transforms_by_path(commands)
    parts = {
        f"/ContactForces/point_{p}/{part}"
        for p in (0, 1)
        for part in ("shaft/cylinder", "head/cone")
    }
    assert {path for path in objects if path.startswith("/ContactForces")} == parts
    cone = objects["/ContactForces/point_0/head/cone"]["geometries"][0]
    shaft = objects["/ContactForces/point_0/shaft/cylinder"]["geometries"][0]
    assert cone["radiusTop"] == 0.0 and shaft["height"] == 1.0
    head = cone["height"]
    # the cylinder spans z in [0, 1] of its node, the cone z in [0, head] with its tip up
    for path, centre in (("shaft/cylinder", 0.5), ("head/cone", head / 2)):
        T = transforms[f"/ContactForces/point_0/{path}"]
        np.testing.assert_allclose(T[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-12)
        np.testing.assert_allclose(T[:3, 3], [0, 0, centre], atol=1e-12)

    scale = metres_per_newton(html)
    mantissa = 1 / scale / 10 ** math.floor(math.log10(1 / scale))
    assert min(abs(mantissa - m) for m in (1, 2, 5)) < 1e-9, "N per m is not 1, 2 or 5 x 10^n"
    assert 0.2 < scale * np.linalg.norm(forces, axis=-1).max() < 1.0  # a robot 2.3 m across
    clips = clips_by_path(commands)
    for p in (0, 1):
        tracks = clips[f"/ContactForces/point_{p}/shaft"]
        heads = clips[f"/ContactForces/point_{p}/head"]
        for name in (".position", ".quaternion", ".scale"):
            np.testing.assert_allclose(tracks[name][0], t, atol=1e-12)
            np.testing.assert_allclose(heads[name][0], t, atol=1e-12)
        base, length = tracks[".position"][1], tracks[".scale"][1][:, 2]
        np.testing.assert_allclose(base, points[:, p], atol=1e-12)
        along = Rotation.from_quat(tracks[".quaternion"][1]).apply([0.0, 0.0, 1.0])
        np.testing.assert_allclose(
            Rotation.from_quat(heads[".quaternion"][1]).apply([0.0, 0.0, 1.0]), along, atol=1e-12
        )
        np.testing.assert_allclose(
            heads[".position"][1], base + length[:, None] * along, atol=1e-12
        )
        k = heads[".scale"][1]
        tip = heads[".position"][1] + k[:, 2:] * head * along
        magnitude = np.linalg.norm(forces[:, p], axis=1)
        on = magnitude > 0
        np.testing.assert_allclose(along[on], forces[on, p] / magnitude[on, None], atol=1e-12)
        np.testing.assert_allclose(tip[on], points[on, p] + scale * forces[on, p], atol=1e-12)
        np.testing.assert_allclose(tracks[".scale"][1][on, :2], k[on, :2])  # one thickness
        assert np.all(tracks[".scale"][1][~on] == 0) and np.all(k[~on] == 0)


def test_the_arrows_follow_the_force_between_samples_as_q_does(tmp_path, meshcat):
    """Samples every 0.5 s, playback at 10 fps: the keys between samples carry the linearly
    interpolated force (a force growing linearly in time grows linearly along the arrow)."""
    t, q = swing(samples=5)
    points = np.tile([0.2, 0.0, 0.0], (len(t), 1, 1))
    forces = np.zeros((len(t), 1, 3))
    forces[:, 0, 2] = 40.0 * t
    html = viz.write_html(
        od.load_urdf("double_pendulum"),
        t,
        q,
        tmp_path / "c.html",
        fps=10,
        contact=(0.0, points, forces),
    ).read_text()
    commands = page_commands(html)
    head = objects_by_path(commands)["/ContactForces/point_0/head/cone"]["geometries"][0]["height"]
    heads = clips_by_path(commands)["/ContactForces/point_0/head"]
    times, position = heads[".position"]
    np.testing.assert_allclose(times, np.linspace(0.0, 2.0, 21), atol=1e-12)
    tip_z = position[:, 2] + heads[".scale"][1][:, 2] * head
    np.testing.assert_allclose(tip_z, metres_per_newton(html) * 40.0 * times, atol=1e-12)


def test_contact_draws_the_ground_at_its_height_and_moves_the_grid_onto_it(tmp_path, meshcat):
    t, q = swing()
    points = np.tile([0.5, 0.3, 0.3], (len(t), 1, 1))
    forces = np.tile([0.0, 0.0, 50.0], (len(t), 1, 1))
    html = viz.write_html(
        od.load_urdf("double_pendulum"), t, q, tmp_path / "c.html", contact=(0.3, points, forces)
    ).read_text()
    commands = page_commands(html)
    objects, transforms = objects_by_path(commands), transforms_by_path(commands)
    slab = objects["/Ground"]["geometries"][0]
    assert slab["type"] == "BoxGeometry" and min(slab["width"], slab["height"]) >= 20.0
    top = transforms["/Ground"][2, 3] + slab["depth"] / 2
    assert 0.3 - 5e-3 < top < 0.3  # just under the grid and the contact points
    grid = objects["/Grid"]["geometries"][0]["data"]["attributes"]["position"]["array"]
    z = np.frombuffer(grid.data, dtype=np.float32).reshape(-1, 3)[:, 2]
    np.testing.assert_allclose(z, 0.3 - 1e-3, atol=1e-6)
    words = re.search(r'<div id="opendyn-caption"[^>]*>([^<]*)</div>', html).group(1)
    assert (
        words.startswith("red arrows: contact forces, ") and words in html[: html.index("</title>")]
    )


def test_a_run_that_never_touches_draws_the_ground_and_no_visible_arrow(tmp_path, meshcat):
    """Zero forces throughout (and a scene without contact points): the ground is drawn, the
    arrows are scaled to nothing at every key, and the page says there is no contact force."""
    model = od.load_urdf("double_pendulum")
    t, q = swing()
    for count in (2, 0):
        nothing = np.zeros((len(t), count, 3))
        html = viz.write_html(
            model, t, q, tmp_path / f"{count}.html", contact=(0.0, nothing, nothing)
        ).read_text()
        commands = page_commands(html)
        assert "/Ground" in objects_by_path(commands)
        assert "(red arrows: contact forces, none in this run)</title>" in html
        clips = clips_by_path(commands)
        arrows = [path for path in clips if path.startswith("/ContactForces/")]
        assert len(arrows) == 2 * count
        for path in arrows:
            assert np.all(clips[path][".scale"][1] == 0)


def test_without_contact_the_page_has_no_ground_arrows_or_caption(tmp_path, meshcat):
    t, q = swing()
    html = viz.write_html(od.load_urdf("double_pendulum"), t, q, tmp_path / "p.html").read_text()
    commands = page_commands(html)
    assert not [c for c in commands if c["path"].startswith(("/Ground", "/ContactForces"))]
    assert set(clips_by_path(commands)) == {
        "/meshcat/double_pendulum/link1",
        "/meshcat/double_pendulum/link2",
    }
    assert "<title>double_pendulum - opendyn</title>" in html and "opendyn-caption" not in html
    grid = objects_by_path(commands)["/Grid"]["geometries"][0]["data"]["attributes"]["position"]
    z = np.frombuffer(grid["array"].data, dtype=np.float32).reshape(-1, 3)[:, 2]
    np.testing.assert_allclose(z, -1e-3, atol=1e-6)


def test_bad_contact_arguments_are_named(tmp_path, meshcat):
    model = od.load_urdf("double_pendulum")
    t, q = swing(samples=3)
    out = tmp_path / "page.html"
    good = np.zeros((3, 2, 3))
    with pytest.raises(ValueError, match=r"contact must be None or \(ground_height, points"):
        viz.write_html(model, t, q, out, contact=(0.0, good))
    with pytest.raises(ValueError, match=r"points must have shape \(3, P, 3\).*\(3, 2, 2\)"):
        viz.write_html(model, t, q, out, contact=(0.0, np.zeros((3, 2, 2)), good))
    with pytest.raises(ValueError, match=r"forces must have shape \(3, P, 3\).*\(4, 2, 3\)"):
        viz.write_html(model, t, q, out, contact=(0.0, good, np.zeros((4, 2, 3))))
    with pytest.raises(ValueError, match=r"points \(3, 2, 3\) and forces \(3, 1, 3\) differ"):
        viz.write_html(model, t, q, out, contact=(0.0, good, np.zeros((3, 1, 3))))
    with pytest.raises(ValueError, match="ground_height must be finite"):
        viz.write_html(model, t, q, out, contact=(np.nan, good, good))
    with pytest.raises(ValueError, match="forces has non-finite entries"):
        viz.write_html(model, t, q, out, contact=(0.0, good, np.full((3, 2, 3), np.inf)))
    assert not out.exists()


# --------------------------------------------------------------------------------------------
# headless Chromium


def chromium():
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("headless Chromium is not installed (no chromium on PATH; .ci/run installs it)")


def screenshot(target: str, out, budget_ms: int = 2000) -> np.ndarray:
    """(HEIGHT, WIDTH, 3) RGB in [0, 1] of a page in headless Chromium with software WebGL and
    every host unresolvable (a page that needs the network shows nothing)."""
    import matplotlib.image

    out.parent.mkdir(parents=True, exist_ok=True)
    command = [
        chromium(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--enable-unsafe-swiftshader",
        "--host-resolver-rules=MAP * ~NOTFOUND",
        "--proxy-server=127.0.0.1:9",
        f"--user-data-dir={out.parent / (out.stem + '-profile')}",
        f"--window-size={WIDTH},{HEIGHT}",
        f"--virtual-time-budget={budget_ms}",
        f"--screenshot={out}",
        target,
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=180)
    assert out.is_file(), f"chromium wrote no screenshot: {done.stderr[-2000:]}"
    image = matplotlib.image.imread(out)[..., :3]
    assert image.shape == (HEIGHT, WIDTH, 3)
    return image


def orange(image) -> np.ndarray:
    """Pixels of the bob's orange (rgba 0.95 0.45 0.1 in the URDF), lit or shaded: red high,
    green about half, blue low."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return (r > 0.55) & (g > 0.2) & (g < 0.65) & (b < 0.3) & (r - g > 0.25)


def camera_of(html):
    """(eye, target, vertical fov in rad) the page's script gives its camera (three.js world)."""

    def numbers(pattern):
        return np.array([float(x) for x in re.search(pattern, html).group(1).split(",")])

    eye = numbers(r"camera\.position\.set\(([^)]*)\)")
    target = numbers(r"controls\.target\.set\(([^)]*)\)")
    fov = math.radians(float(re.search(r"camera\.fov = ([\d.]+)", html).group(1)))
    return eye, target, fov


def project(p_s, eye, target, fov):
    """Pixel (column, row) of a world point (z up) seen by a pinhole camera at ``eye`` looking
    at ``target`` (three.js coordinates, y up)."""
    p = np.array([p_s[0], p_s[2], -p_s[1]])
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = p - eye
    depth = rel @ forward
    x_ndc = (rel @ right) / (depth * math.tan(fov / 2) * WIDTH / HEIGHT)
    y_ndc = (rel @ up) / (depth * math.tan(fov / 2))
    return (x_ndc + 1) / 2 * WIDTH, (1 - y_ndc) / 2 * HEIGHT


def test_chromium_draws_the_pendulum_bob_where_kinematics_puts_it(tmp_path, meshcat):
    """Still pose q = (0.9, -1.4): link 1's orange bob, centred at (-sin q1, 0, 2 - cos q1),
    appears on the screenshot where the page's camera projects that point. The same page with
    the bob grey instead is the reference: the pixels orange in one and not the other are the
    bob's."""
    q = np.array([[0.9, -1.4]])
    text = (shipped_robots_dir() / "double_pendulum.urdf").read_text()
    grey = write(tmp_path / "grey_bob.urdf", text.replace("0.95 0.45 0.1 1", "0.5 0.5 0.5 1"))
    shots = {}
    for name, model in (("orange", od.load_urdf("double_pendulum")), ("grey", od.load_urdf(grey))):
        page = viz.write_html(model, [0.0], q, tmp_path / f"{name}.html")
        shots[name] = screenshot(page.as_uri(), tmp_path / f"{name}.png")
    html = (tmp_path / "orange.html").read_text()
    for mine, other in zip(camera_of(html), camera_of((tmp_path / "grey.html").read_text())):
        np.testing.assert_array_equal(mine, other)  # the same view
    bob = orange(shots["orange"]) & ~orange(shots["grey"])
    assert bob.sum() > 300, f"only {bob.sum()} pixels of the bob's orange"
    assert orange(shots["grey"]).sum() < 0.2 * bob.sum()
    rows, cols = np.nonzero(bob)
    expected = project([-math.sin(0.9), 0.0, 2 - math.cos(0.9)], *camera_of(html))
    assert math.dist((cols.mean(), rows.mean()), expected) < 8.0


def test_chromium_plays_the_motion_at_the_times_of_the_trajectory(tmp_path, meshcat):
    """The pendulum swings q1 = 1.2 sin(pi t / 2), q2 = 0.3 sin(pi t) over 4 s. Stopped at
    t = 1 s (q1 = 1.2) and at t = 3 s (q1 = -1.2) with the page's own time control, the
    orange bob is drawn where the closed form puts it, (-sin q1, 0, 2 - cos q1)."""
    from scipy import ndimage

    t = np.linspace(0.0, 4.0, 401)
    q = np.column_stack([1.2 * np.sin(np.pi * t / 2), 0.3 * np.sin(np.pi * t)])
    html = viz.write_html(od.load_urdf("double_pendulum"), t, q, tmp_path / "swing.html")
    html = html.read_text()
    camera = camera_of(html)
    for time, q1 in ((1.0, 1.2), (3.0, -1.2)):
        stopped = html.replace(
            "</body>",
            f"<script>viewer.animator.pause(); viewer.animator.seek({time});</script>\n</body>",
        )
        page = write(tmp_path / f"at_{time:g}s.html", stopped)
        mask = orange(screenshot(page.as_uri(), tmp_path / f"at_{time:g}s.png"))
        labels, count = ndimage.label(mask)
        assert count > 0, f"no orange at t = {time} s"
        sizes = ndimage.sum(mask, labels, range(1, count + 1))
        largest = labels == 1 + int(np.argmax(sizes))
        assert largest.sum() > 200, f"the bob is only {largest.sum()} pixels at t = {time} s"
        rows, cols = np.nonzero(largest)
        expected = project([-math.sin(q1), 0.0, 2 - math.cos(q1)], *camera)
        assert math.dist((cols.mean(), rows.mean()), expected) < 8.0, (time, expected)


def red(image) -> np.ndarray:
    """Pixels of the arrows' red (0.9, 0.1, 0.1), lit or shaded: red well above green and
    blue (the bob's orange has green about half its red)."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return (r > 0.35) & (g < 0.3) & (b < 0.3) & (r - g > 0.3) & (np.abs(g - b) < 0.12)


def test_chromium_draws_an_upward_force_as_a_red_arrow_above_its_point(tmp_path, meshcat):
    """Still pose q = (0.9, -1.4) with 150 N straight up at p = (-0.1, 0.3, 0.9) (in front
    of the pendulum, inside the box the camera frames, so both pages have the same view):
    the pixels red on the page with contact and not on the page without are the arrow's; they
    run from where the camera projects p up to where it projects the tip p + (0, 0, s 150 N),
    s the scale the page states."""
    model = od.load_urdf("double_pendulum")
    q = np.array([[0.9, -1.4]])
    p = np.array([-0.1, 0.3, 0.9])
    contact = (0.0, p[None, None], np.array([[[0.0, 0.0, 150.0]]]))
    with_arrow = viz.write_html(model, [0.0], q, tmp_path / "arrow.html", contact=contact)
    without = viz.write_html(model, [0.0], q, tmp_path / "plain.html")
    html = with_arrow.read_text()
    camera = camera_of(html)
    for mine, other in zip(camera, camera_of(without.read_text())):
        np.testing.assert_array_equal(mine, other)
    shot = screenshot(with_arrow.as_uri(), tmp_path / "arrow.png")
    plain = screenshot(without.as_uri(), tmp_path / "plain.png")
    arrow = red(shot) & ~red(plain)
    assert arrow.sum() > 300, f"only {arrow.sum()} pixels of the arrow's red"
    rows, cols = np.nonzero(arrow)
    base = project(p, *camera)
    tip = project(p + [0.0, 0.0, 150.0 * metres_per_newton(html)], *camera)
    assert tip[1] < base[1] - 50  # the tip is well above the point on screen
    assert abs(rows.max() - base[1]) < 8.0 and abs(rows.min() - tip[1]) < 8.0
    assert abs(np.median(cols) - base[0]) < 8.0
    # the page without contact has nothing red along the arrow
    column = slice(int(base[0]) - 10, int(base[0]) + 11)
    assert red(plain)[int(tip[1]) : int(base[1]) + 1, column].sum() == 0


def test_chromium_draws_the_ur5_meshes_where_kinematics_puts_its_links(
    tmp_path, meshcat, monkeypatch
):
    """The UR5's DAE meshes (package://example-robot-data/...) are drawn: the pixels light grey
    on its page and not on the page of a copy whose meshes are all missing (small grey stand-in
    boxes) are the robot's, and the origin of every link frame (on a joint axis, inside the
    meshes) projects onto them."""
    if "ur5" not in od.available_robots():
        pytest.skip("example-robot-data is not installed")
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    model = od.load_urdf("ur5")
    q = np.array([0.0, -1.2, 1.5, -1.5, -1.57, 0.0])
    page = viz.write_html(model, [0.0], q[None], tmp_path / "ur5.html")
    image = screenshot(page.as_uri(), tmp_path / "ur5.png", budget_ms=4000)
    copy = write(tmp_path / "elsewhere" / "ur5_copy.urdf", Path(model.source).read_text())
    with pytest.warns(viz.PlaybackWarning, match="not found"):
        page_gone = viz.write_html(od.load_urdf(copy), [0.0], q[None], tmp_path / "gone.html")
    image_gone = screenshot(page_gone.as_uri(), tmp_path / "gone.png", budget_ms=4000)

    def light_grey(im):  # the default visual colour (0.72, 0.72, 0.75), lit or shaded
        return (np.ptp(im, axis=-1) < 0.08) & (im[..., 0] > 0.35)

    robot = light_grey(image) & ~light_grey(image_gone)
    assert robot.sum() > 20_000, f"only {robot.sum()} pixels of the robot's grey"
    rows, cols = np.nonzero(robot)
    camera = camera_of(page.read_text())
    for link in sorted({v.link for v in viz.load_visuals(model)}):
        col, row = project(od.frame_pose(model, q, link)[:3, 3], *camera)
        assert np.hypot(cols - col, rows - row).min() < 4.0, link


# --------------------------------------------------------------------------------------------
# the live viewer


def test_live_viewer_serves_the_robot_its_animation_and_the_contact_forces(meshcat):
    """A browser that connects to the viewer's URL receives the pendulum's geometry, the
    ground, a contact-force arrow and the animation of both over the websocket (meshcat's
    protocol: msgpack commands)."""
    import umsgpack
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    t = np.linspace(0.0, 1.0, 11)
    points = np.tile([0.5, 0.0, 0.0], (len(t), 1, 1))
    forces = np.tile([0.0, 0.0, 20.0], (len(t), 1, 1))
    url = viz.view(
        od.load_urdf("double_pendulum"), t, np.column_stack([t, -t]), contact=(0.0, points, forces)
    )
    assert url.startswith("http://") and url.endswith("/static/")
    ws_url = "ws://" + url[len("http://") : -len("static/")]

    bobs = {"/meshcat/double_pendulum/link1/visual_1", "/meshcat/double_pendulum/link2/visual_2"}
    contact = {
        "/Ground",
        "/ContactForces/point_0/shaft/cylinder",
        "/ContactForces/point_0/head/cone",
    }

    async def receive():
        """The scene's commands, until the two bobs, the ground, the arrow and the animation
        have arrived."""
        connection = await websocket_connect(ws_url)
        commands = []
        while not (
            bobs | contact <= {c["path"] for c in commands if c["type"] == "set_object"}
            and any(c["type"] == "set_animation" for c in commands)
        ):
            message = await connection.read_message()
            assert message is not None, f"the viewer closed the connection after {commands}"
            commands.append(umsgpack.unpackb(message))
        connection.close()
        return commands

    commands = IOLoop.current().run_sync(receive, timeout=60)
    objects = {c["path"]: c["object"] for c in commands if c["type"] == "set_object"}
    bob = objects["/meshcat/double_pendulum/link1/visual_1"]
    assert bob["geometries"][0]["type"] == "CylinderGeometry"
    assert bob["materials"][0]["color"] == 0xF2731A  # rgba 0.95 0.45 0.1 of the URDF
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    assert {a["path"] for a in animation["animations"]} == {
        "/meshcat/double_pendulum/link1",
        "/meshcat/double_pendulum/link2",
        "/ContactForces/point_0/shaft",
        "/ContactForces/point_0/head",
    }


# --------------------------------------------------------------------------------------------
# the plot's contact panel


def test_the_plot_with_contact_adds_a_panel_of_the_normal_forces_and_their_sum(
    tmp_path, monkeypatch
):
    """The same record with and without contact: one more panel, whose lines are each point's
    f_z over time and their sum, named in the legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image
    import matplotlib.pyplot as plt

    model = od.load_urdf("double_pendulum")
    t, q = swing()
    zeros = np.zeros(len(t))
    forces = np.zeros((len(t), 2, 3))
    forces[t < 1.0, 0, 2] = 10.0
    forces[:, 1] = np.column_stack([zeros + 1.0, zeros, 5.0 * t])
    record = {"t": t, "q": q, "qd": np.zeros_like(q), "tau": np.zeros_like(q)}
    record.update(kinetic=zeros, potential=zeros, work_applied=zeros, work_passive=zeros)
    record["joint_names"] = model.joint_names
    figures, close = [], plt.close
    monkeypatch.setattr(plt, "close", figures.append)  # keep the figures to look at
    plain = od.Trajectory(**record).plot(tmp_path / "plain.png")
    touching = od.Trajectory(
        **record,
        contact_names=("left_foot", "right_foot"),
        contact_point=np.zeros((len(t), 2, 3)),
        contact_force=forces,
        ground_height=0.0,
    ).plot(tmp_path / "contact.png")
    without, with_contact = (figure.axes for figure in figures)
    assert len(with_contact) == len(without) + 1
    panel = with_contact[-1]
    assert "normal force" in panel.get_ylabel() and "(N)" in panel.get_ylabel()
    lines = {line.get_label(): line for line in panel.get_lines()}
    assert set(lines) == {"left_foot", "right_foot", "sum"}
    for label, expected in (
        ("left_foot", forces[:, 0, 2]),
        ("right_foot", forces[:, 1, 2]),
        ("sum", forces[:, :, 2].sum(axis=1)),
    ):
        np.testing.assert_array_equal(lines[label].get_xdata(), t)
        np.testing.assert_array_equal(lines[label].get_ydata(), expected)
    legend = [text.get_text() for text in panel.get_legend().get_texts()]
    assert legend == ["left_foot", "right_foot", "sum"]
    # the PNG is a panel taller
    tall = matplotlib.image.imread(touching).shape[0] - matplotlib.image.imread(plain).shape[0]
    assert tall == matplotlib.image.imread(plain).shape[0] // 3
    for figure in figures:
        close(figure)


def test_the_collision_page_draws_each_collision_shape_where_the_link_holds_it(tmp_path, meshcat):
    """collision=True draws model.geometries: a capsule of its radius and length along z, a mesh
    as its convex hull (the tetrahedron's four corners, scaled), placed by its <origin>."""
    write(tmp_path / "tetra.stl", TETRAHEDRON_STL)
    urdf = write(
        tmp_path / "one_link.urdf",
        one_link_urdf(
            """
    <collision><origin xyz="0 0 0.5" rpy="0 0 0"/>
      <geometry><capsule radius="0.05" length="0.4"/></geometry></collision>
    <collision><geometry><mesh filename="tetra.stl" scale="2 3 4"/></geometry></collision>
"""
        ),
    )
    model = od.load_urdf(urdf)
    html = viz.write_html(model, [0.0], [[0.0]], tmp_path / "page.html", collision=True)
    commands = page_commands(html.read_text())
    objects, transforms = objects_by_path(commands), transforms_by_path(commands)
    capsule = objects["/meshcat/one_link/arm/visual_0"]["geometries"][0]
    points = np.frombuffer(capsule["data"]["attributes"]["position"]["array"].data, np.float32)
    points = points.reshape(-1, 3)
    np.testing.assert_allclose(points.min(axis=0), [-0.05, -0.05, -0.25], atol=1e-6)
    np.testing.assert_allclose(points.max(axis=0), [0.05, 0.05, 0.25], atol=1e-6)
    np.testing.assert_allclose(transforms["/meshcat/one_link/arm/visual_0"][:3, 3], [0, 0, 0.5])
    hull = objects["/meshcat/one_link/arm/visual_1"]["geometries"][0]
    corners = np.frombuffer(hull["data"]["attributes"]["position"]["array"].data, np.float32)
    tetra = np.array(model.geometries[1].vertices)
    assert sorted(map(tuple, corners.reshape(-1, 3))) == sorted(
        map(tuple, tetra.astype(np.float32))
    )
    np.testing.assert_allclose(np.ptp(tetra, axis=0), [2, 3, 4])  # TETRAHEDRON_STL spans 1 m
