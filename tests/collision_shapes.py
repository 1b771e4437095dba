"""Shapes for the collision kernels' tests: a shape as (code, size, vertices), its pose
T = [R p], the kernels' hull of a mesh's points, and pair_distance's result as a tuple."""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize
from scipy.spatial import ConvexHull, QhullError
from scipy.spatial.transform import Rotation

from opendyn._runtime.kernel_cache import kernel_cache
from opendyn.multibody.shapes import BOX, CAPSULE, CYLINDER, HALFSPACE, MESH, SPHERE

with kernel_cache():
    from opendyn.algorithm.collision import mesh_hull, no_hull, pair_distance, work_array

NO_VERTICES = np.zeros((0, 3))
WORK = work_array()


def pose(R=None, p=(0.0, 0.0, 0.0)):
    """T = [R p], (4, 4) (R the identity unless given)."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = np.eye(3) if R is None else R, p
    return T


def shape(code, size, vertices=NO_VERTICES):
    return code, np.asarray(size, dtype=float), vertices


def random_shape(code, rng):
    """(code, size, vertices) of random proportions, and its bounding radius."""
    r, length = rng.uniform(0.05, 0.3), rng.uniform(0.1, 0.6)
    if code == SPHERE:
        return shape(code, (r, 0, 0)), r
    if code == BOX:
        size = rng.uniform(0.1, 0.6, 3)
        return shape(code, size), np.linalg.norm(size) / 2
    if code in (CYLINDER, CAPSULE):
        return shape(code, (r, length, 0)), np.hypot(r, length / 2) + (r if code == CAPSULE else 0)
    if code == MESH:
        points = rng.normal(size=(40, 3)) * rng.uniform(0.05, 0.3, 3)
        vertices = np.ascontiguousarray(points[ConvexHull(points).vertices])
        return shape(code, (1, 1, 1), vertices), np.linalg.norm(vertices, axis=1).max()
    return shape(HALFSPACE, (0, 0, 0)), 0.0


def hull(vertices):
    """The kernels' hull of `vertices` (support.py): its graph, faces and a climbing hint."""
    if len(vertices) == 0:
        return no_hull()
    return mesh_hull(vertices)


def distance(a, T_a, b, T_b):
    """(status, d, p_A, p_B, n) of shapes a and b (tuples (code, size, vertices)) at T_a, T_b."""
    out = np.full(10, np.nan)
    status = pair_distance(a[0], a[1], hull(a[2]), T_a, b[0], b[1], hull(b[2]), T_b, out, WORK)
    return status, out[0], out[1:4], out[4:7], out[7:10]


def rot(axis, angle):
    return Rotation.from_rotvec(np.asarray(axis, float) * angle).as_matrix()


def surface_distance(a, T, x):
    """The signed distance of world point x to shape a at T (zero on its surface)."""
    code, size, vertices = a
    y = T[:3, :3].T @ (x - T[:3, 3])
    if code == SPHERE:
        return np.linalg.norm(y) - size[0]
    if code == BOX:
        q = np.abs(y) - size / 2
        return np.linalg.norm(np.maximum(q, 0)) + min(q.max(), 0.0)
    if code == CYLINDER:
        q = np.array([np.hypot(y[0], y[1]) - size[0], abs(y[2]) - size[1] / 2])
        return np.linalg.norm(np.maximum(q, 0)) + min(q.max(), 0.0)
    if code == CAPSULE:
        return np.linalg.norm(y - [0, 0, np.clip(y[2], -size[1] / 2, size[1] / 2)]) - size[0]
    if code == MESH:
        try:
            equations = ConvexHull(vertices).equations
        except QhullError:  # a flat mesh: its polygon
            return flat_distance(vertices, y)
        return (equations[:, :3] @ y + equations[:, 3]).max()  # zero exactly on the surface
    return y[2]


def flat_distance(vertices, y):
    """The distance of y from the polygon of coplanar vertices (its plane's distance and, beyond
    the polygon's edges, the distance to the nearest edge line)."""
    centre = vertices.mean(axis=0)
    _, _, axes = np.linalg.svd(vertices - centre)
    off_plane = (y - centre) @ axes[2]
    edges = ConvexHull((vertices - centre) @ axes[:2].T).equations
    outside = max((edges[:, :2] @ ((y - centre) @ axes[:2].T) + edges[:, 2]).max(), 0.0)
    return float(np.hypot(off_plane, outside))


def support_value(a, T, u):
    """h(u) = max_{x in a} u . x for unit directions u (N, 3): the support function's value."""
    code, size, vertices = a
    R, p = T[:3, :3], T[:3, 3]
    local = u @ R
    h = u @ p
    if code == SPHERE:
        return h + size[0]
    if code == BOX:
        return h + np.abs(local) @ size / 2
    if code == CYLINDER:
        return h + size[0] * np.hypot(local[:, 0], local[:, 1]) + size[1] / 2 * np.abs(local[:, 2])
    if code == CAPSULE:
        return h + size[1] / 2 * np.abs(local[:, 2]) + size[0]
    return h + (local @ vertices.T).max(axis=1)


def overlap(a, T_a, b, T_b, u):
    """o(u) = h_A(u) + h_B(-u): how far b must move along u to leave a. The penetration depth is
    min over unit u of o(u), and the minimiser is the normal."""
    u = np.atleast_2d(u)
    u = u / np.linalg.norm(u, axis=1)[:, None]
    values = support_value(a, T_a, u) + support_value(b, T_b, -u)
    return values if len(values) > 1 else values[0]


def depth_by_directions(a, T_a, b, T_b, guesses):
    """min_u o(u), searched over 4000 spread directions and the guesses, then refined by
    Nelder-Mead from the five best: an independent reference for the penetration depth."""
    k = np.arange(4000) + 0.5
    polar, azimuth = np.arccos(1 - 2 * k / 4000), np.pi * (1 + 5**0.5) * k
    directions = np.column_stack(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)]
    )
    directions = np.vstack([directions, *guesses])
    values = overlap(a, T_a, b, T_b, directions)
    best = np.inf
    for u in directions[np.argsort(values)[:5]]:
        found = minimize(
            lambda x: overlap(a, T_a, b, T_b, x),
            u,
            method="Nelder-Mead",
            options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000},
        )
        best = min(best, found.fun)
    return best
