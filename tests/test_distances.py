"""od.distances and od.collisions on robots: against coal on every example-robot-data robot with
<collision> at random configurations (geometries placed by Pinocchio), and against closed forms on
boxes and spheres written here."""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest

import opendyn as od
from opendyn.algorithm.collision.queries import CollisionWork

# the robots' tests need the reference (Pinocchio places the geometries, coal measures them) and
# example-robot-data; the closed forms at the end need nothing but opendyn
REFERENCE = all(importlib.util.find_spec(name) for name in ("pinocchio", "coal"))
needs_reference = pytest.mark.skipif(not REFERENCE, reason="needs pin (Pinocchio and coal)")
if REFERENCE:
    from coal_reference import check_against_coal, random_q
    from test_geometry import URDFS
else:
    URDFS = []

CASES = [pytest.param(p, False, id=pathlib.Path(p).stem) for p in URDFS] + [
    pytest.param(p, True, id="solo12-floating_base")
    for p in URDFS
    if pathlib.Path(p).stem == "solo12"
]


@pytest.mark.parametrize("path, floating_base", CASES)
def test_distances_match_coal_at_random_configurations(path, floating_base):
    """Every default pair of every example-robot-data robot with <collision> at random
    configurations within the joint limits (more where there are fewer pairs; Solo12 also on a
    floating base at a random pose): as many geometries as Pinocchio's, matched by link and k-th
    <collision>; the signed distance and normal of coal on the same shapes (meshes as hulls) at
    Pinocchio's placements, to 1e-6 m apart and 1e-5 m in penetration, our normal realising our
    depth; where coal errs in penetration (its points disagree with its depth, or a search over
    directions finds less overlap than its depth), the least overlap over all directions."""
    model = od.load_urdf(path, floating_base=floating_base, check_inertia=False)
    pairs = len(model.collision_pairs)
    configurations = int(np.clip(2000 // max(pairs, 1), 2, 10))
    checked = check_against_coal(model, configurations, seed=1)
    assert sum(checked.values()) == configurations * pairs, checked
    # coal is the reference for at least 19 pairs in 20, and most pairs are apart
    errs = checked["coal wrong"] + checked["coal inconsistent"]
    assert errs <= 0.05 * configurations * pairs, checked
    assert checked["separated"] >= configurations * pairs // 2, checked


@needs_reference
def test_pairs_a_subset_and_bad_pairs_are_named():
    model = od.load_urdf("panda")
    q = od.neutral(model)
    every = od.distances(model, q)
    some = od.distances(model, q, pairs=model.collision_pairs[[3, 7, 11]])
    np.testing.assert_array_equal(some.distance, every.distance[[3, 7, 11]])
    np.testing.assert_array_equal(some.normal, every.normal[[3, 7, 11]])
    count = len(model.geometries)
    for bad in ([[0, count]], [[2, 2]], [[-1, 3]], [[0.0, 1.0]], [0, 1, 2]):
        with pytest.raises(ValueError, match="pairs"):
            od.distances(model, q, pairs=bad)
    with pytest.raises(ValueError, match="one configuration"):
        od.distances(model, np.zeros((2, model.nq)))
    with pytest.raises(ValueError, match="q"):
        od.distances(model, np.full(model.nq, np.nan))
    with pytest.raises(ValueError, match="margin"):
        od.collisions(model, q, margin=-1.0)


@needs_reference
def test_data_holds_the_records_arrays_and_gives_the_same_answer():
    model = od.load_urdf("panda")
    data = od.Data(model)
    rng = np.random.default_rng(2)
    q1, q2 = random_q(model, rng), random_q(model, rng)
    first = od.distances(model, q1, data=data)
    kept = first.distance.copy()
    second = od.distances(model, q2, data=data)
    assert np.shares_memory(first.distance, second.distance)  # the Data's arrays, reused
    np.testing.assert_array_equal(second.distance, od.distances(model, q2).distance)
    np.testing.assert_array_equal(kept, od.distances(model, q1).distance)
    contacts = od.collisions(model, q2, margin=0.01, data=data)
    kept = data.kept(("collision work", len(model.collision_pairs)), CollisionWork.of)
    assert isinstance(kept, CollisionWork)
    np.testing.assert_array_equal(contacts.distance, od.collisions(model, q2, margin=0.01).distance)


def _two_bodies(tmp_path, lower, upper):
    """Two bodies on prismatic z joints from the world (siblings: their pair is checked):
    `lower` and `upper` are their <collision> geometry elements."""
    inertial = (
        '<inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    joint = (
        '<joint name="{0}" type="prismatic"><parent link="world"/><child link="{0}_link"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
    )
    text = (
        '<robot name="two"><link name="world"/>'
        f'<link name="lower_link">{inertial}<collision><geometry>{lower}</geometry></collision>'
        f'</link><link name="upper_link">{inertial}<collision><geometry>{upper}</geometry>'
        f"</collision></link>{joint.format('lower')}{joint.format('upper')}</robot>"
    )
    path = tmp_path / "two.urdf"
    path.write_text(text)
    return od.load_urdf(path)


def test_a_box_resting_on_a_box_is_held_at_four_corners(tmp_path):
    """A 0.2 m cube 1 cm into a 1 x 1 x 0.1 slab, face on face: four contacts at the cube's lower
    corners (x, y = +-0.1), each 1 cm deep, the normal along z from the slab up."""
    model = _two_bodies(tmp_path, '<box size="1 1 0.1"/>', '<box size="0.2 0.2 0.2"/>')
    assert model.collision_pairs.tolist() == [[0, 1]]
    q = np.array([0.0, 0.05 + 0.1 - 0.01])  # slab top at 0.05; the cube's bottom 1 cm below
    contacts = od.collisions(model, q)
    assert len(contacts.distance) == 4
    np.testing.assert_allclose(contacts.distance, -0.01, atol=1e-12)
    np.testing.assert_allclose(contacts.normal, np.tile([0, 0, 1.0], (4, 1)), atol=1e-12)
    corners = sorted(map(tuple, np.round(contacts.point_b[:, :2], 12)))
    assert corners == [(-0.1, -0.1), (-0.1, 0.1), (0.1, -0.1), (0.1, 0.1)]
    np.testing.assert_allclose(contacts.point_b[:, 2], 0.04, atol=1e-12)  # the cube's corners
    np.testing.assert_allclose(contacts.depth, 0.01, atol=1e-12)


def test_a_margin_reports_what_is_near_and_nothing_beyond(tmp_path):
    """The cube 2 cm above the slab: no contact within 1 cm (its bounding box is apart too),
    within 3 cm its four lower corners, each 2 cm away (face on face, as resting), and
    od.distances says the same 2 cm."""
    model = _two_bodies(tmp_path, '<box size="1 1 0.1"/>', '<box size="0.2 0.2 0.2"/>')
    q = np.array([0.0, 0.05 + 0.1 + 0.02])
    assert len(od.collisions(model, q, margin=0.01).distance) == 0
    near = od.collisions(model, q, margin=0.03)
    assert len(near.distance) == 4
    corners = sorted(map(tuple, np.round(near.point_b[:, :2], 12)))
    assert corners == [(-0.1, -0.1), (-0.1, 0.1), (0.1, -0.1), (0.1, 0.1)]
    np.testing.assert_allclose(near.point_b[:, 2], 0.07, atol=1e-12)
    np.testing.assert_allclose(near.distance, 0.02, atol=1e-12)
    np.testing.assert_allclose(od.distances(model, q).distance, [0.02], atol=1e-12)


def test_a_sphere_on_a_box_touches_at_one_point(tmp_path):
    """A ball of radius 0.1 whose centre is 0.09 above the slab's top: one contact, 1 cm deep,
    on the slab at the ball's foot."""
    model = _two_bodies(tmp_path, '<box size="1 1 0.1"/>', '<sphere radius="0.1"/>')
    contacts = od.collisions(model, np.array([0.0, 0.05 + 0.09]))
    assert len(contacts.distance) == 1
    np.testing.assert_allclose(contacts.distance, [-0.01], atol=1e-12)
    np.testing.assert_allclose(contacts.point_a, [[0, 0, 0.05]], atol=1e-12)
    np.testing.assert_allclose(contacts.point_b, [[0, 0, 0.04]], atol=1e-12)
    np.testing.assert_allclose(contacts.normal, [[0, 0, 1.0]], atol=1e-12)


@needs_reference
def test_collisions_are_the_pairs_closer_than_the_margin():
    """On the Panda at random configurations, the pairs od.collisions reports are exactly the
    pairs od.distances finds closer than the margin (the broad phase drops none of them)."""
    model = od.load_urdf("panda")
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = random_q(model, rng)
        d = od.distances(model, q)
        near = {tuple(p) for p, x in zip(d.pairs.tolist(), d.distance) if x < 0.02}
        assert {tuple(p) for p in od.collisions(model, q, margin=0.02).pairs.tolist()} == near
