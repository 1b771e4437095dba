"""Collision against coal on example-robot-data robots: Pinocchio reads the same URDF and
places the same geometries (meshes as the convex hulls of their points), coal measures each
pair, and opendyn's od.distances is compared with it pair by pair (tests/test_distances.py and
scripts/check_collision.py)."""

from __future__ import annotations

import pathlib

import coal
import numpy as np
import pinocchio as pin
from collision_shapes import NO_VERTICES, depth_by_directions, overlap, surface_distance
from test_geometry import _by_link

import opendyn as od
from opendyn.multibody.shapes import BOX, CAPSULE, CYLINDER, MESH, SHAPE_NAMES, SPHERE

ON_SURFACE = 1e-9  # m: how far a witness point may lie from its own shape
# where a cylinder's curved side takes part, GJK and EPA converge to their tolerances: EPA's
# points sit up to 2e-8 m off on the robots (test_witness_points.CURVED says more)
CURVED = 5e-7


def coal_hull(points):
    """coal's Convex of the hull of `points`. Not Pinocchio's `geometry.convex` itself: coal's
    distance on the Convex that buildConvexRepresentation gives is wrong for some meshes (Solo12's
    base_link and HL_UPPER_LEG at the neutral configuration: +0.108 m, while the hulls overlap by
    3.5 mm, which a scan of 200,000 separating directions confirms and coal gives on
    Convex.convexHull of the same points: -0.00353 m)."""
    vertices = coal.StdVec_Vec3s()
    for v in np.asarray(points):
        vertices.append(v)
    return coal.Convex.convexHull(vertices, False, None)


def reference(model):
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
            g = coal_hull(g.convex.points())
        shapes.append(g)
    theirs = _by_link(
        range(len(geometry.geometryObjects)),
        lambda i: pin_model.frames[geometry.geometryObjects[i].parentFrame].name,
    )
    index = [theirs[g.link][k] for g, k in kth(model.geometries)]
    return pin_model, geometry, index, shapes


def as_shape(g):
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


def kth(geometries):
    """(geometry, k): k-th <collision> of its link."""
    seen = {}
    for g in geometries:
        k = seen[g.link] = seen.get(g.link, -1) + 1
        yield g, k


def pin_q(model, pin_model, q):
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


def coal_distance(shape_a, T_a, shape_b, T_b):
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    request.gjk_tolerance, request.epa_tolerance = 1e-12, 1e-12
    request.gjk_max_iterations, request.epa_max_iterations = 1000, 1000
    d = coal.distance(shape_a, T_a, shape_b, T_b, request, result)
    return d, result.getNearestPoint1(), result.getNearestPoint2(), np.array(result.normal)


def random_q(model, rng):
    lower = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    upper = np.where(np.isfinite(model.upper), model.upper, np.pi)
    q = od.neutral(model)
    q[model.q_index] = rng.uniform(lower, upper)
    if model.floating_base:
        q[:3] = rng.normal(size=3)
        quat = rng.normal(size=4)
        q[3:7] = quat / np.linalg.norm(quat)
    return q


def own_shape(g):
    """(code, size (3,), vertices) of one of our Geometries, as collision_shapes takes them."""
    size = np.zeros(3)
    size[: len(g.size)] = g.size
    return SHAPE_NAMES.index(g.shape), size, g.vertices


def check_against_coal(model, configurations, seed, worst=None):
    """Every default pair at `configurations` random configurations against coal on Pinocchio's
    geometries, and every witness point on its own shape (our geometry at Pinocchio's placement)
    to ON_SURFACE, apart, touching or penetrating: {kind: count} of the pairs compared, by what
    they were compared with. `worst`, a dict, collects the largest errors met by kind."""
    pin_model, geometry, index, shapes = reference(model)
    assert len(geometry.geometryObjects) == len(model.geometries)
    ours_shapes = [own_shape(g) for g in model.geometries]
    pin_data, geometry_data = pin_model.createData(), pin.GeometryData(geometry)
    rng = np.random.default_rng(seed)
    worst = {} if worst is None else worst

    def note(kind, error):
        worst[kind] = max(worst.get(kind, 0.0), float(error))

    checked = {"separated": 0, "penetrating": 0, "coal inconsistent": 0, "coal wrong": 0}
    for _ in range(configurations):
        q = random_q(model, rng)
        pin.updateGeometryPlacements(
            pin_model, pin_data, geometry, geometry_data, pin_q(model, pin_model, q)
        )
        ours = od.distances(model, q)
        # the same world poses (Pinocchio's kinematics) before the same shapes
        np.testing.assert_allclose(
            np.linalg.norm(ours.point_b - ours.point_a, axis=1), np.abs(ours.distance), atol=1e-9
        )
        for p, (a, b) in enumerate(model.collision_pairs):
            i, j = index[a], index[b]
            d, n = ours.distance[p], ours.normal[p]
            d_c, p1, p2, n_c = coal_distance(
                shapes[i], geometry_data.oMg[i], shapes[j], geometry_data.oMg[j]
            )
            what = (model.geometries[a].name, model.geometries[b].name, q.tolist())
            curved = CYLINDER in (ours_shapes[a][0], ours_shapes[b][0])
            for k, point in ((a, ours.point_a[p]), (b, ours.point_b[p])):
                T = geometry_data.oMg[index[k]].homogeneous
                off = abs(surface_distance(ours_shapes[k], T, point))
                note(f"witness point off its shape{', a cylinder' if curved else ''}", off)
                assert off <= (CURVED if curved else ON_SURFACE), (what, k, off)
            if d_c > 0:  # separated: the distance to 1e-6, and the normal (unique)
                note("distance, separated", abs(d - d_c))
                assert abs(d - d_c) <= 1e-6, (what, d, d_c)
                if d_c > 1e-4:
                    assert np.max(np.abs(n - n_c)) <= 1e-4, (what, n, n_c)
                checked["separated"] += 1
                continue
            A = as_shape(shapes[i]), geometry_data.oMg[i].homogeneous
            B = as_shape(shapes[j]), geometry_data.oMg[j].homogeneous
            # our normal realises our depth: b moved by -d along n leaves a (test_collision_pairs)
            assert abs(overlap(*A, *B, n) + d) < 5e-5, (what, overlap(*A, *B, n), d)
            consistent = np.linalg.norm(p2 - p1 - d_c * n_c) < 1e-6
            if consistent and abs(d - d_c) <= 1e-5:  # penetrating: the depth to 1e-5
                note("distance, penetrating", abs(d - d_c))
                checked["penetrating"] += 1
                continue
            # coal errs on deep contacts of cylinders: -DBL_MAX, points that disagree with its
            # depth (a sphere deep in a cylinder), or a depth too large (anymal-kinova's
            # LH_THIGH_0 - RH_THIGH_1: 0.1423 m, while b leaves a by 0.0250 m along our normal,
            # the least overlap the search finds). The least overlap over all directions judges.
            least = -depth_by_directions(*A, *B, [n, n_c] if consistent else [n])
            note("depth where coal errs, against the least overlap", abs(d - least))
            assert abs(d - least) <= 1e-5, (what, d, least, d_c)
            if consistent:  # coal's depth is not the least: the search found less
                assert least > d_c + 1e-5, (what, d, least, d_c)
            checked["coal wrong" if consistent else "coal inconsistent"] += 1
    return checked
