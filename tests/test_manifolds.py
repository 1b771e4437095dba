"""Contact manifolds, each check independent of the kernels' own output: a box, a cylinder and
a mesh on a halfspace, a box on a box (halfspace_contacts, box_contacts), and any two shapes
face-on or edge-on (face_contacts): a cylinder standing on its cap or lying on its side on a box,
a capsule lying on a box, a mesh's face on a box or on another mesh, each against the corners,
rim points or line ends worked out by hand; every contact on its own shape's surface, its depth
the narrow phase's, and one contact where the shapes meet at a point."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numba import njit
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from opendyn._runtime.kernel_cache import kernel_cache
from opendyn.multibody.shapes import BOX, CAPSULE, CYLINDER, HALFSPACE, MESH

with kernel_cache():
    from opendyn.algorithm.collision import (
        MAX_CONTACTS,
        box_contacts,
        face_contacts,
        halfspace_contacts,
        pair_distance,
    )

from collision_shapes import WORK, distance, hull, pose, rot, shape, surface_distance

# ---- contact manifolds on a halfspace ----------------------------------------------------------


def contacts_on_ground(a, T_a, margin=0.0):
    """The rows (d, p_A, p_B, n) of shape a's contacts with the ground z <= 0."""
    rows = np.full((MAX_CONTACTS, 10), np.nan)
    count = halfspace_contacts((a[0], a[1], hull(a[2]), T_a), pose(), margin, rows)
    return rows[:count]


def test_a_box_resting_on_the_ground_touches_at_its_four_bottom_corners():
    """A 0.4 x 0.6 x 0.2 box turned about z, its bottom 1 cm under the ground: its four bottom
    corners, each 1 cm deep, normal -z; tilted about its x axis by 0.1 rad, the two corners of the
    lower edge at depth h - 0.1 cos 0.1 - 0.3 sin 0.1, and the other two only when they sink."""
    box = shape(BOX, (0.4, 0.6, 0.2))
    R = rot((0, 0, 1), 0.3)
    rows = contacts_on_ground(box, pose(R, (0.2, 0.1, 0.09)))
    corners = np.array(
        [R @ (sx * 0.2, sy * 0.3, -0.1) + (0.2, 0.1, 0.09) for sx in (-1, 1) for sy in (-1, 1)]
    )
    assert len(rows) == 4
    np.testing.assert_allclose(rows[:, 0], -0.01, atol=1e-15)
    np.testing.assert_allclose(rows[:, 7:10], np.tile((0, 0, 1.0), (4, 1)) * -1)
    assert sorted(map(tuple, rows[:, 1:4].round(12))) == sorted(map(tuple, corners.round(12)))
    np.testing.assert_allclose(rows[:, 4:7], rows[:, 1:4] * (1, 1, 0), atol=1e-15)
    h = 0.12
    low = h - 0.1 * np.cos(0.1) - 0.3 * np.sin(0.1)
    rows = contacts_on_ground(box, pose(rot((1, 0, 0), 0.1), (0, 0, h)))
    np.testing.assert_allclose(rows[:, 0], [low, low])
    rows = contacts_on_ground(box, pose(rot((1, 0, 0), 0.1), (0, 0, h)), margin=0.1)
    assert len(rows) == 4 and rows[0, 0] == pytest.approx(low) and rows[3, 0] <= 0.1


@pytest.mark.parametrize("tilt", [0.0, 0.3])
def test_a_cylinder_cap_on_the_ground(tilt):
    """Cylinder r = 0.2, length 0.6, centre at height h, tilted by theta about x: the deepest
    contact is the lowest rim point (pair_distance's); standing 1 cm deep, four rim points of its
    bottom cap, each 1 cm deep."""
    cylinder, ground = shape(CYLINDER, (0.2, 0.6, 0)), shape(HALFSPACE, (0, 0, 0))
    T = pose(rot((1, 0, 0), tilt), (0.1, 0.2, 0.29))
    rows = contacts_on_ground(cylinder, T)
    _, d, p_a, _, _ = distance(cylinder, T, ground, pose())
    assert rows[0, 0] == pytest.approx(d, abs=1e-15) and d < 0
    if tilt:  # (standing, any point of the cap is as deep: pair_distance gives its centre)
        np.testing.assert_allclose(rows[0, 1:4], p_a, atol=1e-15)
    else:
        assert len(rows) == 4
        np.testing.assert_allclose(rows[:, 0], -0.01, atol=1e-15)
        np.testing.assert_allclose(np.hypot(rows[:, 1] - 0.1, rows[:, 2] - 0.2), 0.2)


def contacts_of_boxes(size_a, T_a, size_b, T_b):
    """The rows (d, p_A, p_B, n) of two boxes' contacts."""
    rows = np.full((MAX_CONTACTS, 10), np.nan)
    a, b = shape(BOX, size_a), shape(BOX, size_b)
    box_a, box_b = (a[0], a[1], hull(a[2]), T_a), (b[0], b[1], hull(b[2]), T_b)
    count = box_contacts(box_a, box_b, 0.0, rows, WORK)
    return rows[:count]


def test_a_box_a_hair_from_flat_keeps_its_corners_within_the_margin():
    """A 0.2 x 0.4 x 0.1 box on the slab, tilted by -1e-5 rad about y so that its bottom face's
    x = -0.1 edge is 1e-7 m into the slab and its x = +0.1 edge 1.9e-6 m above it: within a
    1e-3 m margin the manifold keeps all four corners, each at its own signed distance (a
    velocity-level step that lost the two above would let the box tip about the other two);
    without a margin only the two that overlap."""
    tilt = -1e-5
    R = rot((0, 1, 0), tilt)
    centre = np.array([0.0, 0.0, 0.15 - 1e-7]) - R @ (-0.1, 0.0, -0.05) + (-0.1, 0.0, -0.05)
    T = pose(R, centre)
    a, b = shape(BOX, (0.2, 0.4, 0.1)), SLAB
    for margin, count in ((1e-3, 4), (0.0, 2)):
        rows = np.full((MAX_CONTACTS, 10), np.nan)
        box_a, box_b = (a[0], a[1], hull(a[2]), T), (b[0], b[1], hull(b[2]), pose())
        found = box_contacts(box_a, box_b, margin, rows, WORK)
        assert found == count
        corners = [T[:3, :3] @ (sx * 0.1, sy * 0.2, -0.05) + T[:3, 3]
                   for sx in (-1, 1) for sy in (-1, 1)]
        expected = sorted(c[2] - 0.1 for c in corners)[:count]
        np.testing.assert_allclose(sorted(rows[:found, 0]), expected, atol=1e-15)


def test_boxes_a_hair_apart_give_their_four_corners_at_the_gap():
    """Two stacked boxes 1e-11 m apart, face on face (a hard contact's resting state, where
    GJK's and EPA's answers degrade: one gave a tilted normal and a 0.12 m depth): within a
    1e-3 m margin the separating axis gives the four corners, each at the 1e-11 m gap, normal
    +z; 1 mm apart, beyond a 0.5 mm margin, none."""
    a, b = shape(BOX, (0.2, 0.2, 0.1)), shape(BOX, (0.2, 0.2, 0.1))
    for gap, margin, count in ((1e-11, 1e-3, 4), (1e-3, 5e-4, 0)):
        T_b = pose(np.eye(3), (0.0, 0.0, 0.1 + gap))
        rows = np.full((MAX_CONTACTS, 10), np.nan)
        box_a, box_b = (a[0], a[1], hull(a[2]), pose()), (b[0], b[1], hull(b[2]), T_b)
        found = box_contacts(box_a, box_b, margin, rows, WORK)
        assert found == count
        if count:
            np.testing.assert_allclose(rows[:found, 0], gap, atol=1e-15)
            np.testing.assert_allclose(rows[:found, 7:10], np.tile((0, 0, 1.0), (4, 1)))


def test_a_box_resting_on_a_box_touches_at_four_points():
    """A 0.2 x 0.4 x 0.1 box on a 1 x 1 x 0.2 slab, 1 cm into its top (z = 0.1): (1) square on
    it, its four bottom corners, each 1 cm deep, normal -z from the box towards the slab;
    (2) turned 45 degrees about z, the same corners; (3) hanging over the slab's edge at
    x = 0.5, the two corners over the slab and the two points where the box's bottom edges
    cross x = 0.5; (4) tilted by 0.2 rad about x, the lower edge's two corners at its depth
    (pair_distance's); (5) apart, none."""
    box, slab = (0.2, 0.4, 0.1), (1.0, 1.0, 0.2)
    for turn in (0.0, np.pi / 4):
        R = rot((0, 0, 1), turn)
        rows = contacts_of_boxes(box, pose(R, (0.1, -0.05, 0.14)), slab, pose())
        corners = [
            R @ (sx * 0.1, sy * 0.2, -0.05) + (0.1, -0.05, 0.14) for sx in (-1, 1) for sy in (-1, 1)
        ]
        assert len(rows) == 4
        np.testing.assert_allclose(rows[:, 0], -0.01, atol=1e-14)
        np.testing.assert_allclose(rows[:, 7:10], np.tile((0.0, 0.0, -1.0), (4, 1)), atol=1e-15)
        found = sorted(map(tuple, rows[:, 1:4].round(12)))
        assert found == sorted(map(tuple, np.array(corners).round(12)))
        np.testing.assert_allclose(rows[:, 6], 0.1, atol=1e-14)  # p_B on the slab's top
    rows = contacts_of_boxes(box, pose(p=(0.45, 0.0, 0.14)), slab, pose())
    expected = [(0.35, -0.2), (0.35, 0.2), (0.5, -0.2), (0.5, 0.2)]
    assert sorted(map(tuple, rows[:, 1:3].round(12))) == expected
    np.testing.assert_allclose(rows[:, 0], -0.01, atol=1e-14)
    T = pose(rot((1, 0, 0), 0.2), (0.0, 0.0, 0.17))
    low = 0.17 - 0.05 * np.cos(0.2) - 0.2 * np.sin(0.2) - 0.1
    rows = contacts_of_boxes(box, T, slab, pose())
    assert len(rows) == 2
    np.testing.assert_allclose(rows[:, 0], low, atol=1e-14)
    assert distance(shape(BOX, box), T, shape(BOX, slab), pose())[1] == pytest.approx(low)
    assert len(contacts_of_boxes(box, pose(p=(0, 0, 0.3)), slab, pose())) == 0


# ---- face and edge contacts of any two shapes ------------------------------------------------


@njit
def _manifold(a, b, margin, rows, work):
    """The narrow phase's contact of a and b into rows[0], then face_contacts's manifold."""
    pair_distance(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], rows[0], work)
    if rows[0, 0] > margin:
        return 0
    return face_contacts(a, b, margin, rows, work)


def manifold(a, T_a, b, T_b, margin=0.0):
    """The rows (d, p_A, p_B, n) of the face or edge manifold of shapes a and b at T_a, T_b."""
    rows = np.full((MAX_CONTACTS, 10), np.nan)
    count = _manifold((*a[:2], hull(a[2]), T_a), (*b[:2], hull(b[2]), T_b), margin, rows, WORK)
    return rows[:count]


def check_rows(rows, a, T_a, b, T_b):
    """Every row: p_A on a's surface, p_B on b's, p_B - p_A = d n with n unit; the deepest row
    at the narrow phase's distance (to EPA's tolerance, 1e-9 m), and the rows sorted by depth."""
    for row in rows:
        d, p_a, p_b, n = row[0], row[1:4], row[4:7], row[7:10]
        assert abs(surface_distance(a, T_a, p_a)) < 1e-12
        assert abs(surface_distance(b, T_b, p_b)) < 1e-12
        np.testing.assert_allclose(p_b - p_a, d * n, atol=1e-15)
        assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-15)
    assert rows[0, 0] == pytest.approx(distance(a, T_a, b, T_b)[1], abs=1e-9)  # EPA's tolerance
    assert list(rows[:, 0]) == sorted(rows[:, 0])


def points(rows):
    """The rows (k, 3) as a sorted list of tuples rounded to 1e-12 m, to compare as sets."""
    return sorted(map(tuple, np.round(rows, 12)))


SLAB = shape(BOX, (1.0, 1.0, 0.2))  # at the origin: its top face at z = 0.1, x and y in [-0.5, 0.5]
CUBE = np.array(list(itertools.product((-0.1, 0.1), repeat=3)))


def test_a_cylinder_standing_on_a_box_touches_at_four_rim_points():
    """Cylinder r = 0.1, length 0.4, its bottom cap 2 mm into the slab's top, turned about z:
    four points of its rim, each 2 mm deep, normal -z, on the slab's top directly under them;
    as b of the pair, four rim points, normal +z. Overhanging the slab's edge at
    x = 0.5, the contacts stop at that edge. Tilted by 0.1 rad about x (within the face
    tolerance), the lowest rim point at its depth z_c - 0.2 cos 0.1 - 0.1 sin 0.1 - 0.1 first;
    tilted by 0.5 rad, the rim's lowest point alone."""
    cylinder = shape(CYLINDER, (0.1, 0.4))
    T = pose(rot((0, 0, 1), 0.7), (0.1, -0.2, 0.298))
    rows = manifold(cylinder, T, SLAB, pose())
    assert len(rows) == 4
    np.testing.assert_allclose(rows[:, 0], -0.002, atol=1e-15)
    np.testing.assert_allclose(rows[:, 7:10], np.tile((0.0, 0.0, -1.0), (4, 1)), atol=1e-15)
    np.testing.assert_allclose(np.hypot(rows[:, 1] - 0.1, rows[:, 2] + 0.2), 0.1, atol=1e-15)
    np.testing.assert_allclose(rows[:, 4:7], rows[:, 1:4] * (1, 1, 0) + (0, 0, 0.1), atol=1e-15)
    check_rows(rows, cylinder, T, SLAB, pose())
    swapped = manifold(SLAB, pose(), cylinder, T)
    assert len(swapped) == 4
    np.testing.assert_allclose(swapped[:, 0], -0.002, atol=1e-15)
    np.testing.assert_allclose(np.hypot(swapped[:, 4] - 0.1, swapped[:, 5] + 0.2), 0.1, atol=1e-15)
    np.testing.assert_allclose(swapped[:, 7:10], np.tile((0.0, 0.0, 1.0), (4, 1)), atol=1e-15)
    check_rows(swapped, SLAB, pose(), cylinder, T)
    T = pose(p=(0.45, 0.0, 0.298))
    rows = manifold(cylinder, T, SLAB, pose())
    assert len(rows) >= 3 and rows[:, 1].max() == pytest.approx(0.5, abs=1e-15)
    check_rows(rows, cylinder, T, SLAB, pose())
    T = pose(rot((1, 0, 0), 0.1), (0.0, 0.0, 0.3))
    rows = manifold(cylinder, T, SLAB, pose(), margin=0.05)
    low = 0.3 - 0.2 * np.cos(0.1) - 0.1 * np.sin(0.1) - 0.1
    assert rows[0, 0] == pytest.approx(low, abs=1e-12) and len(rows) == 4
    assert rows[-1, 0] <= 0.05
    check_rows(rows, cylinder, T, SLAB, pose())
    T = pose(rot((1, 0, 0), 0.5), (0.0, 0.0, 0.28))
    assert len(manifold(cylinder, T, SLAB, pose(), margin=0.05)) == 1


@pytest.mark.parametrize("code, size", [(CYLINDER, (0.1, 0.4)), (CAPSULE, (0.1, 0.4))])
def test_a_cylinder_or_a_capsule_lying_on_a_box_touches_at_both_ends(code, size):
    """Lying along y, its lowest line 2 mm into the slab's top: two contacts, at the ends of that
    line (y = y_c -+ 0.2), each 2 mm deep; along x over the slab's edge, the end beyond it cut at
    x = 0.5. Turned 0.5 rad about x (beyond the edge tolerance), one contact."""
    lying = shape(code, size)
    R = rot((1, 0, 0), np.pi / 2)  # its z axis along -y
    T = pose(R, (0.1, 0.05, 0.198))
    rows = manifold(lying, T, SLAB, pose())
    assert len(rows) == 2
    np.testing.assert_allclose(rows[:, 0], -0.002, atol=1e-15)
    ends = rows[np.argsort(rows[:, 2]), 1:4]  # the line's side from the narrow phase's normal
    np.testing.assert_allclose(ends, [(0.1, -0.15, 0.098), (0.1, 0.25, 0.098)], atol=1e-9)
    check_rows(rows, lying, T, SLAB, pose())
    T = pose(rot((0, 1, 0), np.pi / 2), (0.4, 0.0, 0.198))  # along x, from 0.2 to 0.6
    rows = manifold(lying, T, SLAB, pose())
    np.testing.assert_allclose(sorted(rows[:, 1]), [0.2, 0.5], atol=1e-15)
    check_rows(rows, lying, T, SLAB, pose())
    T = pose(rot((1, 0, 0), np.pi / 2 + 0.5), (0.1, 0.05, 0.25))
    assert len(manifold(lying, T, SLAB, pose(), margin=0.1)) == 1


def test_a_mesh_on_a_box_or_a_mesh_touches_at_its_face_corners():
    """A cube mesh (with points inside it and on its faces, which its hull drops) 3 mm into the
    slab's top, turned about z: its four bottom corners, each 3 mm deep, as for a box of the same
    size (box_contacts, checked by hand above); the slab as a mesh too; a hexagonal prism mesh: four
    of its six bottom corners, each 3 mm deep, spanning the largest area (the four of a
    rectangle of sides r and r sqrt 3)."""
    rng = np.random.default_rng(5)
    inside = rng.uniform(-0.09, 0.09, (30, 3))
    on_faces = np.array([(0.1, 0.02, -0.03), (0.0, -0.1, 0.05), (0.04, 0.0, 0.1)])
    cube = shape(MESH, (1, 1, 1), np.concatenate([CUBE, inside, on_faces]))
    R = rot((0, 0, 1), 0.4)
    T = pose(R, (0.2, 0.1, 0.197))
    corners = sorted(map(tuple, (CUBE[CUBE[:, 2] < 0] @ R.T + (0.2, 0.1, 0.197)).round(12)))
    slab_corners = itertools.product((-0.5, 0.5), (-0.5, 0.5), (-0.1, 0.1))
    slab_mesh = shape(MESH, (1, 1, 1), np.array(list(slab_corners)))
    for slab in (SLAB, slab_mesh):
        rows = manifold(cube, T, slab, pose())
        assert len(rows) == 4 and sorted(map(tuple, rows[:, 1:4].round(12))) == corners
        np.testing.assert_allclose(rows[:, 0], -0.003, atol=1e-14)
        check_rows(rows, cube, T, slab, pose())
    boxes = np.full((MAX_CONTACTS, 10), np.nan)
    size = np.full(3, 0.2)
    cube, slab = (BOX, size, hull([]), T), (BOX, SLAB[1], hull([]), pose())
    count = box_contacts(cube, slab, 0.0, boxes, WORK)
    assert count == 4 and sorted(map(tuple, boxes[:, 1:4].round(12))) == corners
    angles = np.arange(6) * np.pi / 3
    ring = np.stack([0.1 * np.cos(angles), 0.1 * np.sin(angles), np.zeros(6)], axis=1)
    prism = shape(MESH, (1, 1, 1), np.concatenate([ring + (0, 0, -0.1), ring + (0, 0, 0.1)]))
    T = pose(p=(0.0, 0.0, 0.197))
    rows = manifold(prism, T, SLAB, pose())
    bottom = ring + (0.0, 0.0, 0.097)
    assert len(rows) == 4
    np.testing.assert_allclose(rows[:, 0], -0.003, atol=1e-14)
    for p_a in rows[:, 1:4]:
        assert np.min(np.linalg.norm(bottom - p_a, axis=1)) < 1e-12
    xy = rows[:, 1:3] - rows[:, 1:3].mean(axis=0)
    area = ConvexHull(xy).volume
    assert area == pytest.approx(0.1 * 0.1 * np.sqrt(3), rel=1e-12)


def test_two_meshes_face_to_face_turned_touch_inside_both_faces():
    """Two cube meshes face to face, the upper turned 45 degrees about z and 1 mm into the lower:
    the overlap is an octagon; four of its corners, each 1 mm deep, inside both squares. A cube
    on its edge (turned 45 degrees about x) on another: an edge contact, its two ends."""
    cube = shape(MESH, (1, 1, 1), CUBE)
    T = pose(rot((0, 0, 1), np.pi / 4), (0.0, 0.0, 0.199))
    rows = manifold(cube, T, cube, pose())
    assert len(rows) == 4
    np.testing.assert_allclose(rows[:, 0], -0.001, atol=1e-14)
    for p_b in rows[:, 4:7]:
        assert max(abs(p_b[0]), abs(p_b[1])) <= 0.1 + 1e-15  # in the lower square
        assert abs(p_b[0]) + abs(p_b[1]) <= 0.1 * np.sqrt(2) + 1e-15  # in the upper one
    check_rows(rows, cube, T, cube, pose())
    T = pose(rot((1, 0, 0), np.pi / 4), (0.0, 0.0, 0.1 + 0.1 * np.sqrt(2) - 0.001))
    rows = manifold(cube, T, cube, pose())
    assert len(rows) == 2
    np.testing.assert_allclose(sorted(rows[:, 1]), [-0.1, 0.1], atol=1e-14)
    np.testing.assert_allclose(rows[:, 0], -0.001, atol=1e-14)
    check_rows(rows, cube, T, cube, pose())


def test_shapes_meeting_at_a_point_give_one_contact():
    """A box on its corner on the slab, a cylinder on its rim, two crossed lying cylinders: one
    contact each, the narrow phase's."""
    box = shape(BOX, (0.2, 0.2, 0.2))
    R = Rotation.align_vectors([(0.0, 0.0, -1.0)], [(1.0, 1.0, 1.0)])[0].as_matrix()
    T = pose(R, (0.0, 0.0, 0.1 + 0.1 * np.sqrt(3) - 0.001))  # corner (0.1, 0.1, 0.1) lowest
    rows = manifold(box, T, SLAB, pose())
    assert len(rows) == 1 and rows[0, 0] == pytest.approx(-0.001, abs=1e-12)
    cylinder = shape(CYLINDER, (0.1, 0.4))
    T = pose(rot((1, 0, 0), 0.6), (0.0, 0.0, 0.2))
    assert len(manifold(cylinder, T, SLAB, pose())) == 1
    along_x = pose(rot((0, 1, 0), np.pi / 2), (0.0, 0.0, 0.0))
    along_y = pose(rot((1, 0, 0), np.pi / 2), (0.0, 0.0, 0.199))
    rows = manifold(cylinder, along_x, cylinder, along_y)
    assert len(rows) == 1 and rows[0, 0] == pytest.approx(-0.001, abs=1e-9)  # EPA's tolerance


# ---- manifolds that hold still: continuous under small motions, lying shapes, flat meshes ------


def contact_points(rows):
    """The contact points p_A of rows, as a sorted list of rounded tuples (to compare sets)."""
    return sorted(map(tuple, rows[:, 1:4].round(9)))


def support_area(rows):
    """The area of the contact points' hull seen from above (m^2): the support polygon."""
    return ConvexHull(rows[:, 1:3]).volume


@pytest.mark.parametrize("yaw_degrees", range(0, 91, 5))
def test_a_box_on_a_turned_box_keeps_a_centred_support_polygon_under_tilts(yaw_degrees):
    """A 0.2 x 0.2 x 0.1 box on another, turned about the vertical by 0-90 degrees, 0.1 mm deep:
    the overlap is an octagon (a square at 0 and 90). The four points kept are the same four
    under tilts of 1e-9 to 1e-5 rad either way (the old reduction jumped to another four with a
    1e-5 rad tilt, between opposite corners), they span at least half the overlap's area (the
    support polygon's quadrilateral), and their centroid is within a quarter of the box's half
    width of the boxes' common axis (the old four sat to one side)."""
    box, size = shape(BOX, (0.2, 0.2, 0.1)), (0.2, 0.2, 0.1)
    R = rot((0, 0, 1), np.radians(yaw_degrees))
    T_top = pose(R, (0.0, 0.0, 0.1 - 1e-4))
    rows = contacts_of_boxes(size, pose(), size, T_top)
    assert len(rows) == 4
    np.testing.assert_allclose(rows[:, 0], -1e-4, atol=1e-12)
    check_rows(rows, box, pose(), box, T_top)
    # the overlap's area, by counting a fine grid's points inside both squares: 0.04 at 0
    # degrees, 0.08 (sqrt 2 - 1) at 45
    grid = np.stack(np.meshgrid(*[np.linspace(-0.1, 0.1, 401)] * 2), -1).reshape(-1, 2)
    both = grid[np.all(np.abs(grid @ R[:2, :2]) <= 0.1, axis=1)]
    overlap_area = len(both) / len(grid) * 0.04
    assert support_area(rows) >= 0.5 * overlap_area
    assert np.linalg.norm(rows[:, 1:3].mean(axis=0)) <= 0.025
    for axis_ in ((1, 0, 0), (0, 1, 0), (1, 1, 0)):
        for tilt in (1e-9, -1e-9, 1e-5, -1e-5):
            T = pose(rot(axis_, tilt) @ R, (0.0, 0.0, 0.1 - 1e-4))
            tilted = contacts_of_boxes(size, pose(), size, T)
            assert len(tilted) == 4, (axis_, tilt)
            np.testing.assert_allclose(
                contact_points(tilted), contact_points(rows), atol=2e-6, err_msg=str((axis_, tilt))
            )


def test_a_cylinder_lying_on_the_ground_rests_on_both_ends():
    """Cylinder r = 0.1, length 0.4, lying along y 1 mm into the ground: two contacts, the lowest
    rim points of its two caps, (x, -+0.2, -0.001), each 1 mm deep (the old candidates were one
    cap's rim, which flipped between the caps from one step to the next); rolled or pitched by
    1e-9 rad the same two; pitched by 0.1 rad, the lower end alone within a 0 margin."""
    cylinder = shape(CYLINDER, (0.1, 0.4))
    for roll in (0.0, 1e-9, -1e-9):
        for pitch in (0.0, 1e-9, -1e-9):
            R = rot((0, 1, 0), pitch) @ rot((1, 0, 0), np.pi / 2 + roll)
            rows = contacts_on_ground(cylinder, pose(R, (0.3, 0.0, 0.099)))
            assert len(rows) == 2, (roll, pitch)
            ends = rows[np.argsort(rows[:, 2]), 1:4]
            np.testing.assert_allclose(ends, [(0.3, -0.2, -0.001), (0.3, 0.2, -0.001)], atol=1e-9)
            np.testing.assert_allclose(rows[:, 0], -0.001, atol=1e-9)
            check_rows(rows, cylinder, pose(R, (0.3, 0.0, 0.099)), shape(HALFSPACE, (0, 0, 0)), pose())
    R = rot((1, 0, 0), np.pi / 2 + 0.1)
    rows = contacts_on_ground(cylinder, pose(R, (0.0, 0.0, 0.11)))
    assert len(rows) == 1


def test_a_box_on_a_flat_mesh_rests_on_its_corners_as_on_a_box():
    """A floor exported as one quad (four coplanar vertices: a hull without volume) is a face:
    a box 1 mm into it touches at its four bottom corners, each 1 mm deep, as on a box slab (the
    old hull had no face and gave the one deepest point); as a and as b of the pair; and the
    box hanging over the quad's edge is cut at that edge."""
    quad = shape(MESH, (1, 1, 1), np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0.0)]))
    box = shape(BOX, (0.2, 0.3, 0.1))
    T = pose(rot((0, 0, 1), 0.3), (0.2, -0.1, 0.049))
    corners = np.array(
        [T[:3, :3] @ (x, y, -0.05) + T[:3, 3] for x in (-0.1, 0.1) for y in (-0.15, 0.15)]
    )
    rows = manifold(box, T, quad, pose())
    assert len(rows) == 4
    np.testing.assert_allclose(contact_points(rows), sorted(map(tuple, corners.round(9))), atol=1e-9)
    np.testing.assert_allclose(rows[:, 0], -0.001, atol=1e-12)
    check_rows(rows, box, T, quad, pose())
    rows = manifold(quad, pose(), box, T)
    assert len(rows) == 4
    np.testing.assert_allclose(rows[:, 0], -0.001, atol=1e-12)
    check_rows(rows, quad, pose(), box, T)
    T = pose(p=(0.95, 0.0, 0.049))  # over the edge x = 1
    rows = manifold(box, T, quad, pose())
    assert len(rows) == 4
    np.testing.assert_allclose(sorted(rows[:, 1]), [0.85, 0.85, 1.0, 1.0], atol=1e-12)
