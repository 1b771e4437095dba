"""od.distances and od.collisions on robots: against coal on every example-robot-data robot with
<collision> at random configurations (geometries placed by Pinocchio), and against closed forms on
boxes and spheres written here."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

import opendyn as od
from opendyn.algorithm.collision.queries import CollisionWork
from opendyn.multibody.shapes import BOX, CAPSULE, CYLINDER, MESH, SPHERE

pin = pytest.importorskip("pinocchio")
coal = pytest.importorskip("coal")
from collision_shapes import NO_VERTICES, depth_by_directions, overlap
from test_geometry import URDFS, _by_link


def _hull(points):
    """coal's Convex of the hull of `points`. Not Pinocchio's `geometry.convex` itself: coal's
    distance on the Convex that buildConvexRepresentation gives is wrong for some meshes (Solo12's
    base_link and HL_UPPER_LEG at the neutral configuration: +0.108 m, while the hulls overlap by
    3.5 mm, which a scan of 200,000 separating directions confirms and coal gives on
    Convex.convexHull of the same points: -0.00353 m)."""
    vertices = coal.StdVec_Vec3s()
    for v in np.asarray(points):
        vertices.append(v)
    return coal.Convex.convexHull(vertices, False, None)


def _reference(model):
    """(pin model, geometry model, the pin index of each of our geometries, coal shapes by pin
    index): Pinocchio's reading of the URDF, meshes as hulls, a free base where ours floats."""
    path = model.source
    parents = pathlib.Path(path).parents
    share = next(str(p.parent) for p in parents if p.name == "example-robot-data")
    free = [pin.JointModelFreeFlyer()] if model.floating_base else []
    pin_model = pin.buildModelFromUrdf(path, *free)
    geometry = pin.buildGeomFromUrdf(pin_model, path, pin.COLLISION, package_dirs=[share])
    shapes = []
    for obj in geometry.geometryObjects:
        g = obj.geometry
        if isinstance(g, coal.BVHModelBase):
            g.buildConvexRepresentation(False)
            g = _hull(g.convex.points())
        shapes.append(g)
    theirs = _by_link(
        range(len(geometry.geometryObjects)),
        lambda i: pin_model.frames[geometry.geometryObjects[i].parentFrame].name,
    )
    index = [theirs[g.link][k] for g, k in _kth(model.geometries)]
    return pin_model, geometry, index, shapes


def _as_shape(g):
    """(code, size, vertices) of a coal shape, as test_collision_pairs' overlap takes them."""
    if isinstance(g, coal.Sphere):
        return SPHERE, np.array([g.radius]), NO_VERTICES
    if isinstance(g, coal.Box):
        return BOX, 2 * np.asarray(g.halfSide), NO_VERTICES
    if isinstance(g, coal.Capsule):
        return CAPSULE, np.array([g.radius, 2 * g.halfLength]), NO_VERTICES
    if isinstance(g, coal.Cylinder):
        return CYLINDER, np.array([g.radius, 2 * g.halfLength]), NO_VERTICES
    return MESH, np.ones(3), np.array(g.points())


def _kth(geometries):
    """(geometry, k): k-th <collision> of its link."""
    seen = {}
    for g in geometries:
        k = seen[g.link] = seen.get(g.link, -1) + 1
        yield g, k


def _pin_q(model, pin_model, q):
    """Our q in Pinocchio's order: the free joint's (p, quat xyzw) first in both, then the
    1-dof joints by name (the two libraries order a tree's children differently), a continuous
    joint's angle theta as Pinocchio's (cos theta, sin theta)."""
    q_pin = np.full(pin_model.nq, np.nan)
    start = 7 if model.floating_base else 0
    q_pin[:start] = q[:start]
    for k, name in enumerate(model.joint_names):
        assert pin_model.existJointName(name), name
        joint = pin_model.joints[pin_model.getJointId(name)]
        theta = q[model.q_index[k]]
        value = (np.cos(theta), np.sin(theta)) if model.continuous[k] else (theta,)
        assert joint.nq == len(value), (name, joint.shortname())
        q_pin[joint.idx_q : joint.idx_q + joint.nq] = value
    assert not np.any(np.isnan(q_pin)), "a coordinate of Pinocchio's is none of ours"
    return q_pin


def _coal(shape_a, T_a, shape_b, T_b):
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    request.gjk_tolerance, request.epa_tolerance = 1e-12, 1e-12
    request.gjk_max_iterations, request.epa_max_iterations = 1000, 1000
    d = coal.distance(shape_a, T_a, shape_b, T_b, request, result)
    return d, result.getNearestPoint1(), result.getNearestPoint2(), np.array(result.normal)


def _random_q(model, rng):
    lower = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    upper = np.where(np.isfinite(model.upper), model.upper, np.pi)
    q = od.neutral(model)
    q[model.q_index] = rng.uniform(lower, upper)
    if model.floating_base:
        q[:3] = rng.normal(size=3)
        quat = rng.normal(size=4)
        q[3:7] = quat / np.linalg.norm(quat)
    return q


def _check_against_coal(model, configurations, seed):
    """Every default pair at `configurations` random configurations against coal on Pinocchio's
    geometries: {kind: count} of the pairs compared, by what they were compared with."""
    pin_model, geometry, index, shapes = _reference(model)
    assert len(geometry.geometryObjects) == len(model.geometries)
    pin_data, geometry_data = pin_model.createData(), pin.GeometryData(geometry)
    rng = np.random.default_rng(seed)
    checked = {"separated": 0, "penetrating": 0, "coal inconsistent": 0, "coal wrong": 0}
    for _ in range(configurations):
        q = _random_q(model, rng)
        pin.updateGeometryPlacements(
            pin_model, pin_data, geometry, geometry_data, _pin_q(model, pin_model, q)
        )
        ours = od.distances(model, q)
        # the same world poses (Pinocchio's kinematics) before the same shapes
        np.testing.assert_allclose(
            np.linalg.norm(ours.point_b - ours.point_a, axis=1), np.abs(ours.distance), atol=1e-9
        )
        for p, (a, b) in enumerate(model.collision_pairs):
            i, j = index[a], index[b]
            d, n = ours.distance[p], ours.normal[p]
            d_c, p1, p2, n_c = _coal(
                shapes[i], geometry_data.oMg[i], shapes[j], geometry_data.oMg[j]
            )
            what = (model.geometries[a].name, model.geometries[b].name, q.tolist())
            if d_c > 0:  # separated: the distance to 1e-6, and the normal (unique)
                assert abs(d - d_c) <= 1e-6, (what, d, d_c)
                if d_c > 1e-4:
                    assert np.max(np.abs(n - n_c)) <= 1e-4, (what, n, n_c)
                checked["separated"] += 1
                continue
            A = _as_shape(shapes[i]), geometry_data.oMg[i].homogeneous
            B = _as_shape(shapes[j]), geometry_data.oMg[j].homogeneous
            # our normal realises our depth: b moved by -d along n leaves a (test_collision_pairs)
            assert abs(overlap(*A, *B, n) + d) < 5e-5, (what, overlap(*A, *B, n), d)
            consistent = np.linalg.norm(p2 - p1 - d_c * n_c) < 1e-6
            if consistent and abs(d - d_c) <= 1e-5:  # penetrating: the depth to 1e-5
                checked["penetrating"] += 1
                continue
            # coal errs on deep contacts of cylinders: -DBL_MAX, points that disagree with its
            # depth (a sphere deep in a cylinder), or a depth too large (anymal-kinova's
            # LH_THIGH_0 - RH_THIGH_1: 0.1423 m, while b leaves a by 0.0250 m along our normal,
            # the least overlap the search finds). The least overlap over all directions judges.
            reference = -depth_by_directions(*A, *B, [n, n_c] if consistent else [n])
            assert abs(d - reference) <= 1e-5, (what, d, reference, d_c)
            if consistent:  # coal's depth is not the least: the search found less
                assert reference > d_c + 1e-5, (what, d, reference, d_c)
            checked["coal wrong" if consistent else "coal inconsistent"] += 1
    return checked


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
    checked = _check_against_coal(model, configurations, seed=1)
    assert sum(checked.values()) == configurations * pairs, checked
    # coal is the reference for at least 19 pairs in 20, and most pairs are apart
    errs = checked["coal wrong"] + checked["coal inconsistent"]
    assert errs <= 0.05 * configurations * pairs, checked
    assert checked["separated"] >= configurations * pairs // 2, checked


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


def test_data_holds_the_records_arrays_and_gives_the_same_answer():
    model = od.load_urdf("panda")
    data = od.Data(model)
    rng = np.random.default_rng(2)
    q1, q2 = _random_q(model, rng), _random_q(model, rng)
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
    one within 3 cm, 2 cm away, and od.distances says the same 2 cm."""
    model = _two_bodies(tmp_path, '<box size="1 1 0.1"/>', '<box size="0.2 0.2 0.2"/>')
    q = np.array([0.0, 0.05 + 0.1 + 0.02])
    assert len(od.collisions(model, q, margin=0.01).distance) == 0
    near = od.collisions(model, q, margin=0.03)
    assert len(near.distance) >= 1
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


def test_collisions_are_the_pairs_closer_than_the_margin():
    """On the Panda at random configurations, the pairs od.collisions reports are exactly the
    pairs od.distances finds closer than the margin (the broad phase drops none of them)."""
    model = od.load_urdf("panda")
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = _random_q(model, rng)
        d = od.distances(model, q)
        near = {tuple(p) for p, x in zip(d.pairs.tolist(), d.distance) if x < 0.02}
        assert {tuple(p) for p in od.collisions(model, q, margin=0.02).pairs.tolist()} == near
