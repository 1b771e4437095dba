"""Support functions: the point of a convex shape farthest along a direction d,

    s_X(d) = argmax_{x in X} d . x,

the only thing GJK and EPA ask of a shape (Gilbert, Johnson and Keerthi 1988; van den Bergen,
Collision Detection in Interactive 3D Environments, 2003, 4.3). A shape is the tuple
(code, size, hull, T) of opendyn.multibody.shapes: its code, size (3,) in metres, its convex hull
(MESH; empty arrays otherwise) and its pose T = [R p] in the world. A hull is the tuple

    (vertices (V, 3) in {g}, neighbor_start (V + 1,) int, neighbors (E,) int, seeds, hint (1,),
     faces)

of a multibody.hulls.Hull's arrays with a hint, the vertex its last support point was, and faces
= (face_normal, face_start, face_vertices, vertex_face_start, vertex_faces) (features.py reads
them). A mesh's support walks along the hull's edges to the farthest vertex (hill climbing: on a
convex polytope a vertex with no farther neighbor is the farthest of all), from the best of the
hint and the seeds (the farthest vertices along 26 fixed directions), a few steps instead of a
test of every vertex; a hull without edges (flat) tests every vertex.

A sphere and a capsule are given by their core, a point or a segment, and a radius r: the shape
is core (+) ball(r), so s_X(d) = s_core(d) + r d/|d|. GJK and EPA run on the cores and the
radii are added afterwards (as coal and MuJoCo do), which makes those shapes exact polytopes for
the iteration. A halfspace has no bounded support; the narrow phase treats it in closed form.

    s(d) in the world = R s_local(R^T d) + p
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED, UNCOUNTED_INLINE
from ...multibody.shapes import BOX, CAPSULE, CYLINDER, MESH, SPHERE
from .vectors import sub, to_local, to_world

# a shape code that no branch knows (a halfspace has no bounded support) is an error, never the
# wrong shape: the branch a new shape forgot would otherwise be a sphere's or a point's physics
UNKNOWN_SHAPE = (
    "opendyn: a collision shape code without a support function (opendyn.multibody.shapes: "
    "SPHERE, BOX, CYLINDER, CAPSULE, MESH have one; a HALFSPACE is met by its closed forms)"
)


@njit(**UNCOUNTED)
def core_radius(code, size):
    """r: the radius a sphere's or capsule's core is inflated by; 0 for every other shape."""
    if code == SPHERE or code == CAPSULE:
        return size[0]
    return 0.0


@njit(**UNCOUNTED_INLINE)
def climb(vertices, start, neighbors, seeds, hint, d):
    """The index of the hull vertex of largest d . v (d in {g}), by hill climbing from the best
    of the hint and the first `seeds` vertices; the hint is left at the vertex found (module
    docstring). Every vertex is tested when the hull has no edges."""
    flat = start[start.shape[0] - 1] == start[0]
    k = hint[0]
    best = d[0] * vertices[k, 0] + d[1] * vertices[k, 1] + d[2] * vertices[k, 2]
    for v in range(vertices.shape[0] if flat else seeds):
        h = d[0] * vertices[v, 0] + d[1] * vertices[v, 1] + d[2] * vertices[v, 2]
        if h > best:
            best, k = h, v
    while True:
        here = k
        for e in range(start[here], start[here + 1]):
            v = neighbors[e]
            h = d[0] * vertices[v, 0] + d[1] * vertices[v, 1] + d[2] * vertices[v, 2]
            if h > best:
                best, k = h, v
        if k == here:
            hint[0] = k
            return k


@njit(**UNCOUNTED_INLINE)
def local_core_support(code, size, vertices, start, neighbors, seeds, hint, d):
    """s_core(d) in {g} for d in {g}, the hull by its parts (vertices, neighbor_start as start,
    neighbors, seeds, hint):
      sphere    the centre, 0
      capsule   the end of its segment along d: (0, 0, sign(d_z) length/2)
      box       (sign(d_x) x/2, sign(d_y) y/2, sign(d_z) z/2)
      cylinder  (r d_xy/|d_xy|, sign(d_z) length/2); the cap's centre when d_xy = 0
      mesh      the hull's vertex of largest d . v
    (sign(0) = +1: any point of a supporting face is a support point). Any other code raises
    ValueError (UNKNOWN_SHAPE)."""
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
        k = climb(vertices, start, neighbors, seeds, hint, d)
        return (vertices[k, 0], vertices[k, 1], vertices[k, 2])
    if code == SPHERE:
        return (0.0, 0.0, 0.0)  # the centre
    raise ValueError(UNKNOWN_SHAPE)


@njit(**UNCOUNTED_INLINE)
def core_support(shape, d):
    """s_core(d) in the world for a shape tuple (code, size, hull, T), d a world direction:
    R s_local(R^T d) + p."""
    code, size, (vertices, start, neighbors, seeds, hint, _), T = shape
    d_g = to_local(T, d)
    return to_world(T, local_core_support(code, size, vertices, start, neighbors, seeds, hint, d_g))


@njit(**UNCOUNTED_INLINE)
def difference_support(a, b, d):
    """The support of the cores' Minkowski difference A - B along d, and its two parts:
    (w, s_A(d), s_B(-d)) with w = s_A(d) - s_B(-d)."""
    sa = core_support(a, d)
    sb = core_support(b, (-d[0], -d[1], -d[2]))
    return sub(sa, sb), sa, sb
