"""What the readers say about collision and contact input that would otherwise be dropped or
misread without a word: a collision mesh that cannot be read, a mesh far from convex (used as
its convex hull), a <mesh scale> of 0, a <geometry> of two shapes, an SRDF pair of a link with
itself or a URDF given as the SRDF, objects and world entries in a scene without geometry
contact, and a contact pair override that matches no pair. Each is a warning or an error
naming the file, the element or the key."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import opendyn as od
from opendyn.io.concavity import gross_hollow

ARM = """\
<robot name="arm">
  <link name="base"><collision><geometry><box size="1 1 0.1"/></geometry></collision></link>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    {collision}
  </link>
  <link name="hand">
    <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0 0 1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""
BOX = '<collision name="slab"><geometry><box size="0.1 0.1 0.5"/></geometry></collision>'
GEOMETRY_CONTACT = {"geometry": "collision", "stiffness": 1e4, "friction": 0.5}


def arm(folder, collision=BOX, name="arm.urdf"):
    """A two-link arm whose link "arm" has `collision`; its path."""
    path = folder / name
    path.write_text(ARM.format(collision=collision))
    return path


def mesh_collision(filename, scale=None):
    scale = "" if scale is None else f' scale="{scale}"'
    return (
        f'<collision name="shell"><geometry><mesh filename="{filename}"{scale}/></geometry>'
        "</collision>"
    )


def one_body(folder, collision, name="thing.urdf"):
    """A URDF of one free body with `collision`: an object for a scene."""
    path = folder / name
    path.write_text(
        '<robot name="thing"><link name="body"><inertial><mass value="1"/><inertia ixx="0.01" '
        'iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>' + collision
        + "</link></robot>"
    )
    return path


def boxes(*placed):
    """One mesh of boxes, each (extents, centre)."""
    return trimesh.util.concatenate(
        [
            trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c))
            for e, c in placed
        ]
    )


def room(width=4.0, height=2.5, wall=0.1):
    """A floor and four walls, closed boxes."""
    w, h, t = width, height, wall
    return boxes(
        ((w, w, t), (0, 0, -t / 2)),
        ((t, w, h), (w / 2, 0, h / 2)), ((t, w, h), (-w / 2, 0, h / 2)),
        ((w, t, h), (0, w / 2, h / 2)), ((w, t, h), (0, -w / 2, h / 2)),
    )


def open_room(width, height):
    """A floor and four walls, as open surfaces: two triangles each."""
    corners = np.array(
        [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [-1, -1, 1], [1, -1, 1], [1, 1, 1],
         [-1, 1, 1]], float
    ) * [width / 2, width / 2, height]
    faces = [[0, 2, 1], [0, 3, 2], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7],
             [2, 7, 6], [3, 0, 4], [3, 4, 7]]
    return trimesh.Trimesh(corners, faces, process=False)


def l_bracket(size=0.05, wall=0.003, depth=0.03):
    """An L of two plates `size` long and `wall` thick."""
    return boxes(
        ((size, depth, wall), (size / 2, 0, wall / 2)),
        ((wall, depth, size), (wall / 2, 0, size / 2)),
    )


def u_part(size=1.0, arm=0.1, thickness=0.2):
    """A U `size` square with arms `arm` wide: a deep slot."""
    s, a = size, arm
    return boxes(
        ((s, a, thickness), (0, -(s - a) / 2, 0)),
        ((a, s - a, thickness), (-(s - a) / 2, a / 2, 0)),
        ((a, s - a, thickness), ((s - a) / 2, a / 2, 0)),
    )


def stl(folder, mesh, name):
    path = folder / name
    mesh.export(path)
    return path


def messages(caught, category):
    """The messages of the `category` warnings among those pytest.warns `caught`."""
    return [str(w.message) for w in caught if issubclass(w.category, category)]


def quietly(read, *args, **kwargs):
    """read(*args, **kwargs) under warnings turned into errors: it must not warn."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return read(*args, **kwargs)


# --- a <collision> mesh that cannot be read --------------------------------------------------


def test_a_missing_collision_mesh_warns_naming_the_urdf_the_link_and_the_file(tmp_path):
    path = arm(tmp_path, mesh_collision("meshes/gone.stl"))
    with pytest.warns(od.URDFWarning) as caught:
        model = od.load_urdf(path)
    (text,) = messages(caught, od.URDFWarning)
    assert str(path) in text and '<link name="arm">' in text and "meshes/gone.stl" in text
    assert "not found" in text and "not in model.geometries" in text
    assert [g.link for g in model.geometries] == ["base", "hand"]
    assert len(model.report.unread_meshes) == 1 and "gone.stl" in model.report.unread_meshes[0]


def test_a_warned_load_warns_again_as_its_model_is_not_kept(tmp_path):
    path = arm(tmp_path, mesh_collision("gone.stl"))
    for _ in range(2):
        with pytest.warns(od.URDFWarning, match="gone.stl"):
            od.load_urdf(path)


@pytest.mark.parametrize("as_object", [False, True], ids=["robot", "object"])
def test_a_contact_with_only_unread_meshes_to_touch_names_them(tmp_path, as_object):
    """The robot's (or an object's) only moving geometry is a mesh that is missing: the contact
    has nothing to touch, and says that the mesh could not be read, not that the URDF has no
    <collision>."""
    urdf = str(one_body(tmp_path, mesh_collision("gone.stl")))
    if as_object:
        data = {"objects": [{"name": "thing", "urdf": urdf}]}
    else:
        data = {"robot": {"urdf": urdf, "floating_base": True}}
    data["effects"] = {"gravity": True, "contact": GEOMETRY_CONTACT}
    with pytest.warns(od.URDFWarning), pytest.raises(od.SceneError) as e:
        od.scene_from_dict(data)
    text = str(e.value)
    assert "effects.contact" in text and "could not be read" in text and "gone.stl" in text
    assert urdf in text and ("objects[0].urdf" in text) == as_object
    assert "give the robot <collision> elements" not in text


def test_a_contact_whose_objects_urdf_has_no_collision_names_the_object(tmp_path):
    """The scene's only object is a URDF without <collision>: the message names it, not the
    robot's geometry."""
    urdf = str(one_body(tmp_path, ""))
    data = {"objects": [{"name": "thing", "urdf": urdf}], "effects": {"contact": GEOMETRY_CONTACT}}
    with pytest.raises(od.SceneError) as e:
        od.scene_from_dict(data)
    text = str(e.value)
    assert "nothing can touch" in text and "the object 'thing'" in text
    assert "without <collision> elements" in text and "give the robot" not in text


def test_a_contact_whose_pairs_are_all_disabled_names_them(tmp_path):
    """Every pair the box could touch (the ground, the table) disabled: the message names the
    [[effects.contact.pairs]] entries that take them out, not the geometry."""
    off = [{"a": "box", "b": "ground", "enabled": False},
           {"a": "box", "b": "table", "enabled": False}]
    data = {**OBJECTS, "effects": {"contact": {**GEOMETRY_CONTACT, "pairs": off}}}
    with pytest.raises(od.SceneError) as e:
        od.scene_from_dict(data)
    text = str(e.value)
    assert "nothing can touch" in text and "enabled = false" in text
    assert "pairs[0] (a = 'box', b = 'ground')" in text
    assert "pairs[1] (a = 'box', b = 'table')" in text and "<collision>" not in text


# --- <mesh scale> and <geometry> -------------------------------------------------------------


def test_a_mesh_scale_of_zero_or_not_finite_is_refused_and_a_negative_one_mirrors(tmp_path):
    """Refused, naming the file, the link and the value; a negative factor mirrors the mesh, as
    the URDFs of left and right limbs use it (Talos, TIAGo, Centauro)."""
    stl(tmp_path, trimesh.creation.box(extents=(1, 1, 1)), "cube.stl")
    for scale in ["0 0 0", "1 0 1", "0", "nan 1 1", "1 inf 1", "1 2"]:
        path = arm(tmp_path, mesh_collision("cube.stl", scale))
        with pytest.raises(od.URDFError) as e:
            od.load_urdf(path)
        text = str(e.value)
        assert str(path) in text and '<link name="arm">' in text and f"scale={scale!r}" in text
        assert "finite factors other than 0" in text
    model = quietly(od.load_urdf, arm(tmp_path, mesh_collision("cube.stl", "1 -2 1")))
    mesh = next(g for g in model.geometries if g.shape == "mesh")
    assert mesh.size == (1.0, -2.0, 1.0)
    np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), [1, 2, 1])


def test_a_mesh_scale_of_four_factors_is_read_by_its_first_three_with_a_warning(tmp_path):
    """pybullet_data's racecar gives its meshes four factors."""
    stl(tmp_path, trimesh.creation.box(extents=(1, 1, 1)), "cube.stl")
    path = arm(tmp_path, mesh_collision("cube.stl", "2 1 1 1"))
    with pytest.warns(od.URDFWarning) as caught:
        model = od.load_urdf(path)
    (text,) = messages(caught, od.URDFWarning)
    assert str(path) in text and '<link name="arm">' in text and "scale='2 1 1 1'" in text
    assert "the first three are used" in text
    assert next(g for g in model.geometries if g.shape == "mesh").size == (2.0, 1.0, 1.0)


@pytest.mark.parametrize(
    "element, words",
    [
        ('<collision><geometry><mesh filename="cube.stl" scale="a b c"/></geometry></collision>',
         "<collision> <mesh> (line 6): scale='a b c' holds what is not a number"),
        ('<visual><geometry><mesh filename="cube.stl" scale="a b c"/></geometry></visual>',
         "<visual> <mesh> (line 6): scale='a b c'"),
        ('<collision><geometry><cylinder length="1"/></geometry></collision>',
         "<collision> <cylinder> (line 6): no radius: a <cylinder> needs radius and length"),
        ('<visual><geometry><box/></geometry></visual>', "<visual> <box> (line 6): no size"),
    ],
)
def test_a_shape_without_its_numbers_is_refused_naming_the_link_and_element(
    tmp_path, element, words
):
    path = arm(tmp_path, element)
    with pytest.raises(od.URDFError) as e:
        od.load_urdf(path)
    text = str(e.value)
    assert f'{path}: <link name="arm"> {words}' in text and "could not parse" not in text


@pytest.mark.parametrize(
    "name, content",
    [("corrupt.stl", b"solid x\nfacet normal garbage\n" + b"\x00\x01" * 40),
     ("truncated.stl", b"\x00" * 80 + b"\x05\x00\x00\x00" + b"\x01" * 20),
     ("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n")],
)
def test_a_mesh_without_triangles_says_so_not_that_it_has_no_vertices(tmp_path, name, content):
    (tmp_path / name).write_bytes(content)
    with pytest.warns(od.URDFWarning) as caught:
        od.load_urdf(arm(tmp_path, mesh_collision(name)))
    (text,) = messages(caught, od.URDFWarning)
    assert name in text and "no triangles could be read" in text and "no vertices" not in text


def test_a_folder_given_as_a_mesh_an_srdf_or_a_world_mesh_is_named_a_folder(tmp_path):
    (tmp_path / "meshes.stl").mkdir()
    with pytest.warns(od.URDFWarning) as caught:
        od.load_urdf(arm(tmp_path, mesh_collision("meshes.stl")))
    (text,) = messages(caught, od.URDFWarning)
    assert "is the folder" in text and "not found" not in text
    with pytest.raises(od.URDFError, match="is a folder, not an SRDF file"):
        od.load_urdf(arm(tmp_path), srdf=tmp_path / "meshes.stl")
    world = {"name": "w", "shape": "mesh", "mesh": str(tmp_path / "meshes.stl"), "size": [1] * 3}
    with pytest.raises(od.SceneError) as e:
        od.scene_from_dict({**OBJECTS, "world": [world], "effects": {"contact": GEOMETRY_CONTACT}})
    assert "world[0].mesh" in str(e.value) and "is a folder, not a mesh file" in str(e.value)


def test_a_geometry_of_two_shapes_is_read_by_its_first_as_pinocchio_reads_it(tmp_path):
    collision = (
        '<collision><geometry><sphere radius="0.1"/><box size="1 2 3"/></geometry></collision>'
    )
    path = arm(tmp_path, collision)
    with pytest.warns(od.URDFWarning) as caught:
        model = od.load_urdf(path)
    (text,) = messages(caught, od.URDFWarning)
    assert str(path) in text and '<link name="arm">' in text and "(<sphere>, <box>)" in text
    assert [g.shape for g in model.geometries if g.link == "arm"] == ["sphere"]
    assert [s.geometry for s in model.collision_spheres if s.link == "arm"] == ["sphere"]
    assert any("<geometry> holds 2 shapes" in line for line in model.report.ignored)
    pin = pytest.importorskip("pinocchio")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pin_model = pin.buildModelFromUrdf(str(path))
        objects = pin.buildGeomFromUrdf(pin_model, str(path), pin.COLLISION).geometryObjects
    arm_objects = [o for o in objects if pin_model.frames[o.parentFrame].name == "arm"]
    assert [type(o.geometry).__name__ for o in arm_objects] == ["Sphere"]


# --- the SRDF --------------------------------------------------------------------------------


def test_an_srdf_pair_of_a_link_with_itself_warns_naming_the_srdf_and_its_line(tmp_path):
    srdf = tmp_path / "arm.srdf"
    srdf.write_text(
        '<robot name="arm">\n<disable_collisions link1="base" link2="hand"/>\n'
        '<disable_collisions link1="hand" link2="hand" reason="Never"/>\n</robot>\n'
    )
    with pytest.warns(od.URDFWarning) as caught:
        model = od.load_urdf(arm(tmp_path), srdf=srdf)
    (text,) = messages(caught, od.URDFWarning)
    assert str(srdf) in text and "line 3" in text and "'hand' with itself" in text
    assert model.collision_pairs.tolist() == []  # base-hand disabled; base-arm, arm-hand adjacent


def test_a_urdf_given_as_the_srdf_is_refused_as_a_urdf(tmp_path):
    other = arm(tmp_path, name="other.urdf")
    with pytest.raises(od.URDFError, match="is a URDF, not an SRDF") as e:
        od.load_urdf(arm(tmp_path), srdf=other)
    assert str(other) in str(e.value)
    scene = tmp_path / "scene.toml"
    scene.write_text('[robot]\nurdf = "arm.urdf"\nsrdf = "other.urdf"\n')
    with pytest.raises(od.SceneError, match=r"robot\.srdf: .*is a URDF, not an SRDF"):
        od.load_scene(scene)
    # an SRDF of groups alone (no <disable_collisions>) is still an SRDF
    groups = tmp_path / "groups.srdf"
    groups.write_text('<robot name="arm"><group name="all"><link name="arm"/></group></robot>')
    assert len(quietly(od.load_urdf, arm(tmp_path), srdf=groups).collision_pairs) == 1


# --- meshes far from convex ------------------------------------------------------------------


@pytest.mark.parametrize(
    "mesh",
    [
        room(),
        room(20.0, 3.0),  # a wide floor against the walls' height
        open_room(4.0, 2.5),
        open_room(8.0, 2.5),
        l_bracket(),
        u_part(),
        boxes(((0.4, 0.4, 0.01), (0, 0, 0)), ((0.01, 0.4, 0.2), (0.2, 0, 0.1)),
              ((0.01, 0.4, 0.2), (-0.2, 0, 0.1)), ((0.4, 0.01, 0.2), (0, 0.2, 0.1)),
              ((0.4, 0.01, 0.2), (0, -0.2, 0.1))),  # a bin
    ],
    ids=["room", "wide room", "open room", "wide open room", "L bracket", "U", "bin"],
)
def test_a_grossly_concave_mesh_has_a_deep_hollow_in_its_hull(tmp_path, mesh):
    hollow = gross_hollow(str(stl(tmp_path, mesh, "part.stl")))
    assert hollow is not None
    assert hollow.depth >= 0.1 * hollow.size


@pytest.mark.parametrize(
    "mesh",
    [
        trimesh.creation.box(extents=(1, 2, 3)),
        trimesh.creation.cylinder(0.1, 1.0),
        trimesh.creation.icosphere(),
        boxes(((1, 1, 0.2), (0, 0, 0.1)), ((0.5, 1, 0.2), (0.25, 0, 0.3))),  # a step
        boxes(((1, 0.4, 0.4), (0.5, 0.2, 0)), ((0.4, 0.6, 0.4), (0.2, 0.7, 0))),  # a thick L
        trimesh.creation.torus(0.1, 0.03),
    ],
    ids=["box", "cylinder", "sphere", "step", "thick L", "torus"],
)
def test_a_convex_or_mildly_concave_mesh_has_none(tmp_path, mesh):
    assert gross_hollow(str(stl(tmp_path, mesh, "part.stl"))) is None


@pytest.mark.parametrize(
    "mesh",
    [trimesh.creation.box(extents=(4, 4, 0.2)), trimesh.creation.cylinder(0.5, 2.0),
     trimesh.creation.icosphere()],
    ids=["slab", "post", "ball"],
)
def test_a_convex_world_mesh_has_none(tmp_path, mesh):
    assert gross_hollow(str(stl(tmp_path, mesh, "part.stl")), environment=True) is None


@pytest.mark.parametrize(
    "mesh",
    [
        boxes(((3, 6, 0.1), (0, 0, -0.05)), ((0.1, 6, 2.5), (1.5, 0, 1.25)),
              ((0.1, 6, 2.5), (-1.5, 0, 1.25)), ((3, 0.1, 2.5), (0, 3, 1.25)),
              ((3, 0.1, 2.5), (0, -3, 1.25))),  # a room narrower than twice its height
        boxes(((2, 10, 0.1), (0, 0, -0.05)), ((0.1, 10, 2.5), (1, 0, 1.25)),
              ((0.1, 10, 2.5), (-1, 0, 1.25))),  # a corridor
        boxes(*[((1, 0.4, 0.02), (0, 0, z)) for z in (0, 0.4, 0.8, 1.2)],
              ((0.02, 0.4, 1.2), (0.5, 0, 0.6)), ((0.02, 0.4, 1.2), (-0.5, 0, 0.6)),
              ((1, 0.02, 1.2), (0, 0.2, 0.6))),  # a shelf
        boxes(*[((1, 0.3 * (3 - k), 0.15), (0, 0.15 * k, 0.075 + 0.15 * k)) for k in range(3)]),
    ],
    ids=["narrow room", "corridor", "shelf", "stairs"],
)
def test_the_world_is_held_to_any_hollow_that_a_thing_could_enter(tmp_path, mesh):
    """Robots and objects move in the world's hollows: there a hollow a tenth of the mesh's
    size across is gross, though a link of that shape would not be."""
    path = str(stl(tmp_path, mesh, "world.stl"))
    assert gross_hollow(path) is None
    assert gross_hollow(path, environment=True) is not None


def test_a_room_as_a_world_mesh_warns_that_it_is_its_convex_hull(tmp_path):
    stl(tmp_path, room(), "room.stl")
    data = {
        "objects": [{"name": "box", "shape": "box", "size": [0.2, 0.2, 0.2], "mass": 1.0,
                     "position": [0.0, 0.0, 0.5]}],
        "world": [{"name": "room", "shape": "mesh", "mesh": "room.stl"}],
        "effects": {"gravity": True, "contact": GEOMETRY_CONTACT},
    }
    with pytest.warns(od.SceneWarning) as caught:
        od.scene_from_dict(data, base_dir=tmp_path)
    (text,) = messages(caught, od.SceneWarning)
    assert "world[0].mesh" in text and "room.stl" in text and "convex hull" in text
    assert "one [[world]] entry each" in text


def test_a_concave_collision_mesh_is_reported_and_warned_of_where_contact_uses_it(tmp_path):
    """Loading a robot for its dynamics does not warn of its meshes' shapes (the report names a
    concave one); a scene whose contact uses the collision geometry warns, naming the URDF, the
    link and the file."""
    stl(tmp_path, l_bracket(), "bracket.stl")
    path = arm(tmp_path, mesh_collision("bracket.stl"))
    model = quietly(od.load_urdf, path)
    (line,) = model.report.hollow_meshes
    assert "<link name=\"arm\"> <collision> 'shell'" in line and "bracket.stl" in line
    assert "convex hull" in line and "<collision> element each" in line
    assert line in model.report.transformed
    data = {"robot": {"urdf": str(path)}, "effects": {"gravity": True, "contact": GEOMETRY_CONTACT}}
    with pytest.warns(od.SceneWarning) as caught:
        od.scene_from_dict(data)
    (text,) = messages(caught, od.SceneWarning)
    assert "effects.contact.geometry" in text and str(path) in text and "bracket.stl" in text


def test_a_concave_mesh_of_an_object_urdf_warns_naming_its_urdf(tmp_path):
    stl(tmp_path, u_part(0.3, 0.03, 0.06), "u.stl")
    urdf = one_body(tmp_path, mesh_collision("u.stl"))
    data = {"objects": [{"name": "thing", "urdf": str(urdf)}],
            "effects": {"gravity": True, "contact": GEOMETRY_CONTACT}}
    with pytest.warns(od.SceneWarning, match=rf"{urdf}: .*'shell': the mesh .*u\.stl is far"):
        od.scene_from_dict(data)


def test_of_example_robot_data_only_grossly_concave_links_are_reported(monkeypatch):
    """TIAGo's base is a shell, open below, and its hull fills it; the UR5's, the Panda's,
    Solo12's, Talos's, ANYmal's and Go2's links are mildly concave at most. Loading any of them
    warns of nothing."""
    if "tiago" not in od.available_robots():
        pytest.skip("example-robot-data is not installed")
    monkeypatch.setenv("OPENDYN_MODEL_CACHE", "0")  # build each, measuring its meshes
    report = quietly(od.load_urdf, "tiago", check_inertia=False).report
    (text,) = [line for line in report.hollow_meshes if "base_collision.stl" in line]
    assert '<link name="base_link">' in text and "is far from convex" in text
    for robot in ["ur5", "panda", "solo12", "talos_full_v2", "anymal", "go2"]:
        assert not quietly(od.load_urdf, robot, check_inertia=False).report.hollow_meshes, robot


# --- objects and the world without geometry contact -------------------------------------------

OBJECTS = {
    "objects": [{"name": "box", "shape": "box", "size": [0.2, 0.2, 0.2], "mass": 1.0,
                 "position": [0.0, 0.0, 0.5]}],
    "world": [{"name": "table", "shape": "box", "size": [1.0, 1.0, 0.1],
               "position": [0.0, 0.0, 0.3]}],
}


def test_objects_and_world_entries_without_geometry_contact_warn_naming_them():
    points = {"stiffness": 1e4, "friction": 0.5, "points": [{"frame": "box"}]}
    for contact, why in ((None, "the scene has no [effects.contact]"), (points, "points")):
        effects = {"gravity": True} if contact is None else {"gravity": True, "contact": contact}
        with pytest.warns(od.SceneWarning) as caught:
            od.scene_from_dict({**OBJECTS, "effects": effects})
        (text,) = messages(caught, od.SceneWarning)
        assert "effects.contact.geometry" in text and 'geometry = "collision"' in text
        assert "objects 'box'" in text and "world entries 'table'" in text and why in text
    quietly(od.scene_from_dict, {**OBJECTS, "effects": {"contact": GEOMETRY_CONTACT}})


# --- [[effects.contact.pairs]] that match no pair -------------------------------------------


@pytest.mark.parametrize(
    "a, b, why",
    [
        ("box", "box", "name the same"),
        ("table", "shelf", "neither moves"),
        ("table", "ground", "neither moves"),
        ("base", "table", "neither moves"),
        ("arm", "hand", "a body and its parent"),
    ],
)
def test_a_pair_override_that_matches_no_pair_is_refused_naming_it(tmp_path, a, b, why):
    """Beside overrides that match pairs, one of them of the robot's own pairs (base and hand,
    off without self_collision, switched on here)."""
    data = {
        "robot": {"urdf": str(arm(tmp_path))},
        **OBJECTS,
        "world": [*OBJECTS["world"], {"name": "shelf", "shape": "box", "size": [1, 1, 0.1],
                                      "position": [2.0, 0.0, 0.3]}],
        "effects": {"contact": {**GEOMETRY_CONTACT, "pairs": [
            {"a": "box", "b": "table", "friction": 0.1}, {"a": "hand", "b": "base"},
            {"a": a, "b": b, "enabled": False}]}},
    }
    with pytest.raises(od.SceneError) as e:
        od.scene_from_dict(data)
    text = str(e.value)
    assert "effects.contact.pairs[2]" in text and f"a = {a!r} and b = {b!r}" in text
    assert "match no pair" in text and why in text
