"""Support functions: the point of a convex shape farthest along a direction d,

    s_X(d) = argmax_{x in X} d . x,

the only thing GJK and EPA ask of a shape (Gilbert, Johnson and Keerthi 1988; van den Bergen,
Collision Detection in Interactive 3D Environments, 2003, 4.3). A shape is the tuple
(code, size, vertices, T) of opendyn.multibody.shapes: its code, size (3,) in metres, the convex
hull's vertices (V, 3) in {g} (MESH; (0, 3) otherwise) and its pose T = [R p] in the world.

A sphere and a capsule are given by their core, a point or a segment, and a radius r: the shape
is core (+) ball(r), so s_X(d) = s_core(d) + r d/|d|. GJK and EPA run on the cores and the
radii are added afterwards (as coal and MuJoCo do), which makes those shapes exact polytopes for
the iteration. A halfspace has no bounded support; the narrow phase treats it in closed form.

    s(d) in the world = R s_local(R^T d) + p
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import JIT
from ...multibody.shapes import BOX, CAPSULE, CYLINDER, MESH, SPHERE
from .vectors import sub, to_local, to_world


@njit(**JIT)
def core_radius(code, size):
    """r: the radius a sphere's or capsule's core is inflated by; 0 for every other shape."""
    if code == SPHERE or code == CAPSULE:
        return size[0]
    return 0.0


@njit(**JIT)
def local_core_support(code, size, vertices, d):
    """s_core(d) in {g} for d in {g}:
      sphere    the centre, 0
      capsule   the end of its segment along d: (0, 0, sign(d_z) length/2)
      box       (sign(d_x) x/2, sign(d_y) y/2, sign(d_z) z/2)
      cylinder  (r d_xy/|d_xy|, sign(d_z) length/2); the cap's centre when d_xy = 0
      mesh      the hull's vertex of largest d . v
    (sign(0) = +1: any point of a supporting face is a support point)."""
    if code == BOX:
        return (
            math.copysign(0.5 * size[0], d[0]),
            math.copysign(0.5 * size[1], d[1]),
            math.copysign(0.5 * size[2], d[2]),
        )
    if code == CYLINDER:
        rho = math.sqrt(d[0] * d[0] + d[1] * d[1])
        z = math.copysign(0.5 * size[1], d[2])
        if rho > 0.0:
            return (size[0] * d[0] / rho, size[0] * d[1] / rho, z)
        return (0.0, 0.0, z)
    if code == CAPSULE:
        return (0.0, 0.0, math.copysign(0.5 * size[1], d[2]))
    if code == MESH:
        best, k = -math.inf, 0
        for v in range(vertices.shape[0]):
            h = d[0] * vertices[v, 0] + d[1] * vertices[v, 1] + d[2] * vertices[v, 2]
            if h > best:
                best, k = h, v
        return (vertices[k, 0], vertices[k, 1], vertices[k, 2])
    return (0.0, 0.0, 0.0)  # SPHERE: the centre


@njit(**JIT)
def core_support(shape, d):
    """s_core(d) in the world, d a world direction: R s_local(R^T d) + p."""
    code, size, vertices, T = shape
    return to_world(T, local_core_support(code, size, vertices, to_local(T, d)))


@njit(**JIT)
def difference_support(a, b, d):
    """The support of the cores' Minkowski difference A - B along d, and its two parts:
    (w, s_A(d), s_B(-d)) with w = s_A(d) - s_B(-d)."""
    sa = core_support(a, d)
    sb = core_support(b, (-d[0], -d[1], -d[2]))
    return sub(sa, sb), sa, sb
