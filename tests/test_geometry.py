"""Collision geometry from the URDF (model.geometries, model.collision_pairs, load_urdf(srdf=)),
checked against Pinocchio's reading of the same files (pin.buildGeomFromUrdf, coal shapes,
meshes as their convex hulls) and against files written here."""

from __future__ import annotations

import collections
import importlib.metadata
import pathlib
import textwrap
import warnings

import numpy as np
import pytest

import opendyn as od
from opendyn.errors import URDFError
from opendyn.multibody.shapes import SHAPE_NAMES

pin = pytest.importorskip("pinocchio")
coal = pytest.importorskip("coal")


def _example_robot_data_urdfs_with_collision():
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return []
    paths = sorted(str(dist.locate_file(f)) for f in dist.files or [] if str(f).endswith(".urdf"))
    return [p for p in paths if "<collision" in pathlib.Path(p).read_text(errors="ignore")]


URDFS = _example_robot_data_urdfs_with_collision()


def _pinocchio_geometry(path):
    """(pin model, pin geometry model) of a URDF's <collision> elements, or None where
    Pinocchio cannot read it."""
    # meshes are package://example-robot-data/robots/...: the folder above example-robot-data
    package_dir = next(
        str(p.parent) for p in pathlib.Path(path).parents if p.name == "example-robot-data"
    )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = pin.buildModelFromUrdf(path)
            geometry = pin.buildGeomFromUrdf(model, path, pin.COLLISION, package_dirs=[package_dir])
    except (ValueError, RuntimeError):
        return None
    return model, geometry


def _by_link(items, link_of):
    """{link: [items in their order]}."""
    out = collections.defaultdict(list)
    for item in items:
        out[link_of(item)].append(item)
    return out


def _coal_shape(obj):
    """(shape, size, hull points or None) of a Pinocchio GeometryObject, in opendyn's terms."""
    g = obj.geometry
    if isinstance(g, coal.Sphere):
        return "sphere", (g.radius,), None
    if isinstance(g, coal.Box):
        return "box", tuple(2 * np.asarray(g.halfSide)), None
    if isinstance(g, coal.Capsule):
        return "capsule", (g.radius, 2 * g.halfLength), None
    if isinstance(g, coal.Cylinder):
        return "cylinder", (g.radius, 2 * g.halfLength), None
    if not isinstance(g, coal.ConvexBase):  # a mesh (BVH); <collision_checking> <convex>: a hull
        g.buildConvexRepresentation(False)
        g = g.convex
    return "mesh", tuple(obj.meshScale), np.array(g.points())


def _support(points, directions):
    """h(d) = max over the points of d . p, for each direction (rows)."""
    return np.max(directions @ points.T, axis=1)


@pytest.mark.parametrize("path", URDFS, ids=lambda p: pathlib.Path(p).stem)
def test_geometries_match_pinocchio(path):
    """Every <collision> of an example-robot-data URDF: the same geometries as Pinocchio's, matched
    by (link, k-th <collision> of the link): shape, size, placement in the link's frame and, for
    meshes, the convex hull through its support function in 64 random directions."""
    reference = _pinocchio_geometry(path)
    if reference is None:
        pytest.skip("Pinocchio does not read this URDF's geometry")
    pin_model, pin_geometry = reference
    model = od.load_urdf(path, check_inertia=False)
    if any("could not be read" in line for line in model.report.ignored):
        pytest.skip("a collision mesh of this URDF cannot be read")
    ours = _by_link(model.geometries, lambda g: g.link)
    theirs = _by_link(
        pin_geometry.geometryObjects, lambda o: pin_model.frames[o.parentFrame].name
    )
    assert {k: len(v) for k, v in ours.items()} == {k: len(v) for k, v in theirs.items()}
    directions = np.random.default_rng(0).normal(size=(64, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    for link, objects in theirs.items():
        for k, (g, obj) in enumerate(zip(ours[link], objects)):
            what = f"{link} <collision> {k}"
            shape, size, points = _coal_shape(obj)
            assert g.shape == shape, what
            np.testing.assert_allclose(g.size, size, rtol=1e-12, atol=1e-12, err_msg=what)
            # Pinocchio places a geometry in its parent joint's frame: T_{J,g} = T_{J,L} T_{L,g}
            T_JL = pin_model.frames[obj.parentFrame].placement.homogeneous
            T_Lg = np.linalg.solve(T_JL, obj.placement.homogeneous)
            np.testing.assert_allclose(g.placement, T_Lg, atol=1e-12, err_msg=what)
            if shape == "mesh":
                h_ours, h_pin = _support(g.vertices, directions), _support(points, directions)
                scale = np.max(np.abs(points))
                np.testing.assert_allclose(h_ours, h_pin, rtol=0, atol=2.4e-7 * scale, err_msg=what)


def test_the_geometry_check_covers_example_robot_data():
    """The comparison above reaches the robots the issue names and meshes of every format."""
    if not URDFS:
        pytest.skip("example-robot-data is not installed")
    names = {pathlib.Path(p).stem for p in URDFS}
    assert {"panda", "ur5_robot", "talos_full_v2", "solo12"} <= names
    suffixes = collections.Counter(
        pathlib.Path(g.mesh_path).suffix.lower()
        for p in URDFS
        for g in od.load_urdf(p, check_inertia=False).geometries
        if g.shape == "mesh"
    )
    assert {".stl", ".dae", ".obj"} <= set(suffixes)


def _pinocchio_disabled(path, srdf):
    """The link pairs Pinocchio's removeCollisionPairs takes out of addAllCollisionPairs."""
    pin_model, geometry = _pinocchio_geometry(path)
    link = [pin_model.frames[o.parentFrame].name for o in geometry.geometryObjects]
    geometry.addAllCollisionPairs()
    before = {frozenset((link[p.first], link[p.second])) for p in geometry.collisionPairs}
    pin.removeCollisionPairs(pin_model, geometry, srdf)
    after = {frozenset((link[p.first], link[p.second])) for p in geometry.collisionPairs}
    return before - after


@pytest.mark.parametrize(
    "robot, srdf",
    [("panda", "panda_description/srdf/panda.srdf"), ("talos", "talos_data/srdf/talos.srdf")],
)
def test_an_srdf_disables_the_pairs_pinocchio_disables(robot, srdf):
    """load_urdf(srdf=) removes exactly the link pairs Pinocchio's removeCollisionPairs removes,
    among the pairs both lists have (ours also leaves out a body and its parent)."""
    path = od.io.urdf.resolve_robot("talos_full_v2" if robot == "talos" else robot)
    srdf = str(pathlib.Path(path).parents[2] / srdf)
    model = od.load_urdf(path, check_inertia=False)
    with_srdf = od.load_urdf(path, check_inertia=False, srdf=srdf)
    links = [g.link for g in model.geometries]
    pairs = lambda m: {frozenset((links[a], links[b])) for a, b in m.collision_pairs}  # noqa: E731
    removed = pairs(model) - pairs(with_srdf)
    expected = _pinocchio_disabled(path, srdf) & pairs(model)
    assert removed and removed == expected
    assert len(with_srdf.collision_pairs) < len(model.collision_pairs)


ROBOT = """\
<robot name="blocks">
  <link name="base"><collision><geometry><box size="1 1 0.1"/></geometry></collision></link>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <collision name="rod"><origin xyz="0 0 0.5" rpy="0 1.5707963267948966 0"/>
      <geometry><capsule radius="0.05" length="0.8"/></geometry></collision>
    {extra}
  </link>
  <link name="hand">
    <collision><geometry><sphere radius="0.1"/></geometry></collision>
  </link>
  <link name="tip">
    <collision><geometry><cylinder radius="0.02" length="0.1"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0 0 1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="j3" type="fixed"><parent link="hand"/><child link="tip"/>
    <origin xyz="0 0 0.2"/></joint>
</robot>
"""


def _write(tmp_path, extra="", name="blocks.urdf"):
    path = tmp_path / name
    path.write_text(ROBOT.format(extra=extra))
    return path


def test_every_shape_its_link_and_its_body(tmp_path):
    """Shapes and sizes as written (a capsule too), placements from <origin>, a link lumped by a
    fixed joint keeps its name and moves with the body above it."""
    model = od.load_urdf(_write(tmp_path))
    assert [(g.name, g.link, g.shape, g.size) for g in model.geometries] == [
        ("base_0", "base", "box", (1.0, 1.0, 0.1)),
        ("rod", "arm", "capsule", (0.05, 0.8)),
        ("hand_0", "hand", "sphere", (0.1,)),
        ("tip_0", "tip", "cylinder", (0.02, 0.1)),
    ]
    R_y = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]])  # rpy (0, pi/2, 0)
    np.testing.assert_allclose(model.geometries[1].placement[:3, :3], R_y, atol=1e-15)
    np.testing.assert_allclose(model.geometries[1].placement[:3, 3], [0, 0, 0.5])
    table = model.geometry_table
    hand = model.body_names.index("hand")
    assert list(table.body) == [-1, model.body_names.index("arm"), hand, hand]
    np.testing.assert_allclose(table.T_body_geom[3][:3, 3], [0, 0, 0.2])  # tip on hand's body
    assert [SHAPE_NAMES[c] for c in table.code] == ["box", "capsule", "sphere", "cylinder"]
    np.testing.assert_array_equal(table.size[1], [0.05, 0.8, 0.0])


def test_default_pairs_leave_out_a_body_and_its_parent(tmp_path):
    """base (world) - arm: parent and child; arm - hand: parent and child; hand - tip: one body.
    What is left: base with hand and with tip."""
    model = od.load_urdf(_write(tmp_path))
    assert model.collision_pairs.tolist() == [[0, 2], [0, 3]]
    assert not model.collision_pairs.flags.writeable


def test_an_srdf_file_removes_its_link_pairs(tmp_path):
    srdf = tmp_path / "blocks.srdf"
    srdf.write_text(
        '<robot name="blocks"><disable_collisions link1="tip" link2="base" reason="Never"/>'
        '<disable_collisions link1="base" link2="gone" reason="Never"/></robot>'
    )
    model = od.load_urdf(_write(tmp_path), srdf=srdf)
    assert model.collision_pairs.tolist() == [[0, 2]]
    assert any("'gone'" in line for line in model.report.ignored)


@pytest.mark.parametrize(
    "content, words",
    [
        (None, "does not exist"),
        ("<robot><disable_collisions link1='a'", "could not be read as XML"),
        ("<srdf/>", "not <robot>"),
        ("<robot><disable_collisions link1='base'/></robot>", "needs both link1 and link2"),
    ],
)
def test_a_bad_srdf_is_named(tmp_path, content, words):
    srdf = tmp_path / "bad.srdf"
    if content is not None:
        srdf.write_text(content)
    with pytest.raises(URDFError, match=words) as e:
        od.load_urdf(_write(tmp_path), srdf=srdf)
    assert "bad.srdf" in str(e.value)


def test_a_mesh_that_cannot_be_read_is_a_report_line(tmp_path):
    """A missing mesh and a broken one: left out of model.geometries, each named in the report,
    never a silent drop; the rest load."""
    (tmp_path / "broken.stl").write_text("solid nothing\nthis is not an STL\n")
    extra = (
        '<collision><geometry><mesh filename="missing.stl"/></geometry></collision>'
        '<collision><geometry><mesh filename="broken.stl"/></geometry></collision>'
    )
    with pytest.warns(od.URDFWarning, match="missing.stl"):
        model = od.load_urdf(_write(tmp_path, extra))
    assert [g.shape for g in model.geometries] == ["box", "capsule", "sphere", "cylinder"]
    text = "\n".join(model.report.ignored)
    assert "2 <collision> meshes that could not be read" in text
    assert "missing.stl" in text and "broken.stl" in text


def test_a_mesh_is_its_scaled_convex_hull(tmp_path):
    """An OBJ cube of side 2 with a point inside: its hull is the 8 corners, scaled per axis."""
    corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    lines = [f"v {x} {y} {z}" for x, y, z in [*corners, (0.1, 0.2, 0.3)]]
    faces = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]
    lines += [f"f {a} {b} {c}\nf {a} {c} {d}" for a, b, c, d in faces]
    (tmp_path / "cube.obj").write_text("\n".join(lines) + "\n")
    extra = '<collision><geometry><mesh filename="cube.obj" scale="1 2 3"/></geometry></collision>'
    model = od.load_urdf(_write(tmp_path, extra))
    mesh = next(g for g in model.geometries if g.shape == "mesh")
    assert mesh.size == (1.0, 2.0, 3.0)
    expected = np.array(corners, dtype=float) * [1, 2, 3]
    assert sorted(map(tuple, mesh.vertices)) == sorted(map(tuple, expected))


def test_a_collada_unit_scales_its_vertices(tmp_path):
    """A COLLADA triangle written in millimetres (<unit meter="0.001">) is read in metres."""
    dae = textwrap.dedent(
        """\
        <?xml version="1.0" encoding="utf-8"?>
        <COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
          <asset><unit name="millimeter" meter="0.001"/><up_axis>Z_UP</up_axis></asset>
          <library_geometries><geometry id="g"><mesh>
            <source id="p"><float_array id="pa" count="12">0 0 0 100 0 0 0 200 0 0 0 300
              </float_array><technique_common><accessor source="#pa" count="4" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/>
              <param name="Z" type="float"/></accessor></technique_common></source>
            <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
            <triangles count="4"><input semantic="VERTEX" source="#v" offset="0"/>
              <p>0 2 1 0 1 3 0 3 2 1 2 3</p></triangles>
          </mesh></geometry></library_geometries>
          <library_visual_scenes><visual_scene id="s"><node id="n">
            <instance_geometry url="#g"/></node></visual_scene></library_visual_scenes>
          <scene><instance_visual_scene url="#s"/></scene>
        </COLLADA>
        """
    )
    (tmp_path / "tetra.dae").write_text(dae)
    extra = '<collision><geometry><mesh filename="tetra.dae"/></geometry></collision>'
    mesh = next(
        g for g in od.load_urdf(_write(tmp_path, extra)).geometries if g.shape == "mesh"
    )
    np.testing.assert_allclose(np.max(mesh.vertices, axis=0), [0.1, 0.2, 0.3], rtol=1e-12)


def test_the_report_counts_the_geometries_by_shape(tmp_path):
    model = od.load_urdf(_write(tmp_path))
    line = next(line for line in model.report.honoured if "model.geometries" in line)
    assert "4 <collision> geometries" in line
    assert "1 box, 1 capsule, 1 cylinder, 1 sphere" in line


def test_a_bad_collision_size_is_named(tmp_path):
    path = tmp_path / "bad.urdf"
    path.write_text(ROBOT.format(extra="").replace('radius="0.1"', 'radius="-0.1"'))
    with pytest.raises(URDFError, match="negative (size|radius)"):
        od.load_urdf(path)


def test_a_scene_reads_robot_srdf_beside_it(tmp_path):
    """[robot] srdf, relative to the scene file, reaches load_urdf; a missing one is named."""
    _write(tmp_path)
    (tmp_path / "blocks.srdf").write_text(
        '<robot name="blocks"><disable_collisions link1="base" link2="tip"/></robot>'
    )
    scene = tmp_path / "scene.toml"
    scene.write_text('[robot]\nurdf = "blocks.urdf"\nsrdf = "blocks.srdf"\n')
    assert od.load_scene(scene).model.collision_pairs.tolist() == [[0, 2]]
    scene.write_text('[robot]\nurdf = "blocks.urdf"\nsrdf = "gone.srdf"\n')
    with pytest.raises(od.SceneError, match=r"robot\.srdf.*no such SRDF file"):
        od.load_scene(scene)


def _clouds_for_hulls():
    """Points whose hulls' faces are checked: a cube with points inside and on its faces, a
    hexagonal prism, a random cloud, and every mesh of the Panda when example-robot-data is
    installed."""
    rng = np.random.default_rng(8)
    cube = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    cube = np.concatenate([cube, rng.uniform(-0.9, 0.9, (40, 3)), [(1, 0.2, 0.3), (0, 0, -1)]])
    angles = np.arange(6) * np.pi / 3
    ring = np.stack([np.cos(angles), np.sin(angles), np.zeros(6)], axis=1)
    clouds = {"cube": cube, "prism": np.concatenate([ring, ring + (0, 0, 2)])}
    clouds["random"] = rng.normal(size=(300, 3))
    try:
        importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return clouds
    for g in od.load_urdf("panda").geometries:
        if g.vertices is not None:
            clouds[g.name] = g.vertices
    return clouds


@pytest.mark.parametrize("name, points", list(_clouds_for_hulls().items()))
def test_a_hull_has_its_faces_as_polygons(name, points):
    """A hull's faces (multibody.hulls): each a supporting plane of the points (every corner at
    the support value h(N) = max_p N . p of its unit normal N, to the width the merge of nearly
    coplanar triangles allows, every point at or below it), its
    corners a convex polygon counterclockwise about N, the faces closing the hull (Euler:
    V - E + F = 2, E half the corners of all faces), each vertex listed under the faces that
    hold it; a cube's six faces of four corners, a hexagonal prism's two hexagons and six
    rectangles."""
    from opendyn.multibody.hulls import COPLANAR, convex_hull

    h = convex_hull(points)
    scale = np.abs(points).max()
    F = len(h.face_normal)
    loops = [h.face_vertices[h.face_start[f] : h.face_start[f + 1]] for f in range(F)]
    np.testing.assert_allclose(np.linalg.norm(h.face_normal, axis=1), 1.0, atol=1e-12)
    for f, loop in enumerate(loops):
        N, corners = h.face_normal[f], h.vertices[loop]
        support = (points @ N).max()
        # merged triangles are within an angle sqrt(2 COPLANAR) of each other: a corner is that
        # far from the plane across the face's width, at most
        width = np.linalg.norm(corners[:, None] - corners[None], axis=2).max()
        slack = np.sqrt(2 * COPLANAR) * width + 1e-12 * scale
        assert (corners @ N <= support + 1e-12 * scale).all()
        assert (corners @ N >= support - slack).all()
        turns = np.cross(np.roll(corners, -1, 0) - corners, np.roll(corners, -2, 0) - corners)
        assert (turns @ N >= -1e-9 * scale**2).all()
        assert (turns @ N).sum() > 0
        for v in loop:
            assert f in h.vertex_faces[h.vertex_face_start[v] : h.vertex_face_start[v + 1]]
    E = sum(len(loop) for loop in loops) / 2
    assert len(h.vertices) - E + F == 2
    if name == "cube":
        assert sorted(len(loop) for loop in loops) == [4] * 6
        np.testing.assert_allclose(np.abs(h.face_normal).sum(axis=1), 1.0, atol=1e-15)
    if name == "prism":
        assert sorted(len(loop) for loop in loops) == [4] * 6 + [6] * 2
