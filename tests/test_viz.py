"""Playback (opendyn.viz): the URDF's visual geometry, the meshcat scene and its animation, the
self-contained page as headless Chromium draws it, and the live viewer.

Independent truths: the double pendulum's closed-form kinematics (robots/double_pendulum.urdf:
the elbow at (-L1 sin q1, 0, 2 - L1 cos q1), link 1 turned by q1 about y), the pinhole camera
model for where a point appears on the screenshot, and files written here by hand.
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
from opendyn.urdf import shipped_robots_dir

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


def test_live_viewer_serves_the_robot_and_its_animation(meshcat):
    """A browser that connects to the viewer's URL receives the pendulum's geometry and the
    animation over the websocket (meshcat's protocol: msgpack commands)."""
    import umsgpack
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    t = np.linspace(0.0, 1.0, 11)
    url = viz.view(od.load_urdf("double_pendulum"), t, np.column_stack([t, -t]))
    assert url.startswith("http://") and url.endswith("/static/")
    ws_url = "ws://" + url[len("http://") : -len("static/")]

    bobs = {"/meshcat/double_pendulum/link1/visual_1", "/meshcat/double_pendulum/link2/visual_2"}

    async def receive():
        """The scene's commands, until the two bobs and the animation have arrived."""
        connection = await websocket_connect(ws_url)
        commands = []
        while not (
            bobs <= {c["path"] for c in commands if c["type"] == "set_object"}
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
    }
