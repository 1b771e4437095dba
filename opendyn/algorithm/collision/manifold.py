"""Contact manifolds against a halfspace: up to four contact points, each with its own depth, so
that a shape resting face-on (a box on the ground, a cylinder standing on its cap) is held at
several points instead of one (MuJoCo's plane routines, engine_collision_primitive.c, do the
same: a box's vertices under the plane, a cylinder's cap by points of its rim).

For the halfspace b = {x : n . (x - p) <= 0} (n = z_g of b) the candidate points x_k of shape a
are
  box       its 8 vertices
  mesh      its hull's vertices
  cylinder  4 points of the rim of each cap: the deepest, the opposite one and the two between
            (exact for a cap resting on the plane: it rests on all four; a cylinder lying on its
            side rests on the deepest point of each cap, its two ends)
  capsule   its segment's two ends, less r n
  sphere    its centre less r n
each at signed distance d_k = n . (x_k - p) (none when the shape's support point along -n is
beyond the margin: a hull's vertices are scanned only when it reaches the plane); those with
d_k <= margin are contacts, the four deepest kept, each written as a row of the narrow phase's
out layout: (d_k, x_k, x_k - d_k n, -n) (the normal from a towards the halfspace). (A hull
resting flat on many vertices keeps the four deepest by rounding, not its support polygon: the
support-polygon reduction of the face contacts, clipping.reduce_to_four, made a humanoid lying
on the floor step so slowly under DOPRI5 that it is not used here yet.)
"""

from __future__ import annotations

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from ...multibody.shapes import BOX, CAPSULE, CYLINDER, MESH, SPHERE
from .closed_forms import DISTANCE, room_by_depth, write_inflated
from .support import UNKNOWN_SHAPE, core_radius, core_support
from .vectors import axis, axpy, cross, dot, norm, origin, scale, sub, to_world

MAX_CONTACTS = 4


@njit(**UNCOUNTED)
def candidate_count(code, hull):
    """How many candidate points shape `code` offers (module docstring)."""
    if code == BOX:
        return 8
    if code == MESH:
        return hull[0].shape[0]
    if code == CYLINDER:
        return 8
    if code == CAPSULE:
        return 2
    if code == SPHERE:
        return 1
    raise ValueError(UNKNOWN_SHAPE)


@njit(**UNCOUNTED)
def candidate(code, size, hull, T, n, k):
    """Candidate point k of the shape at pose T against a plane of normal n (world)."""
    if code == BOX:
        corner = (
            0.5 * size[0] * (1.0 if k & 1 else -1.0),
            0.5 * size[1] * (1.0 if k & 2 else -1.0),
            0.5 * size[2] * (1.0 if k & 4 else -1.0),
        )
        return to_world(T, corner)
    if code == MESH:
        vertices = hull[0]
        return to_world(T, (vertices[k, 0], vertices[k, 1], vertices[k, 2]))
    z = axis(T, 2)
    if code == CYLINDER:
        # a cap (k < 4: +z_g's, else -z_g's), and in it the rim's direction most against n, u;
        # then u turned by k quarter turns about z: u, z x u, -u, -z x u
        cap = axpy((0.5 if k < 4 else -0.5) * size[1], z, origin(T))
        u = axpy(dot(n, z), z, scale(n, -1.0))  # -n less its part along z
        length = norm(u)
        u = scale(u, 1.0 / length) if length > 1e-12 else axis(T, 0)
        side = cross(z, u)
        quarter = k % 4
        direction = (
            u
            if quarter == 0
            else (side if quarter == 1 else (scale(u, -1.0) if quarter == 2 else scale(side, -1.0)))
        )
        return axpy(size[0], direction, cap)
    if code == CAPSULE:
        end = axpy((0.5 if k == 0 else -0.5) * size[1], z, origin(T))
        return axpy(-size[0], n, end)
    if code == SPHERE:
        return axpy(-size[0], n, origin(T))
    raise ValueError(UNKNOWN_SHAPE)


@njit(**UNCOUNTED)
def halfspace_contacts(a, T_b, margin, contacts):
    """Up to MAX_CONTACTS contacts of shape a (code, size (3,), hull (support.py), pose T_a)
    with the halfspace of pose T_b: rows of contacts (MAX_CONTACTS, OUT_SIZE) as the module
    docstring lays out, the deepest first, of the candidates at signed distance <= margin
    (metres). Returns how many rows were written."""
    code_a, size_a, hull_a, T_a = a
    n = axis(T_b, 2)
    p = origin(T_b)
    # the shape's deepest point, its support along -n (a hull's by climbing its edges): when
    # even that is beyond the margin, no candidate is nearer (a mesh's hull is not scanned)
    deepest = core_support(a, scale(n, -1.0))
    if dot(n, sub(deepest, p)) - core_radius(code_a, size_a) > margin:
        return 0
    count = 0
    for k in range(candidate_count(code_a, hull_a)):
        x = candidate(code_a, size_a, hull_a, T_a, n, k)
        d = dot(n, sub(x, p))
        if d > margin or (count == MAX_CONTACTS and d >= contacts[count - 1, DISTANCE]):
            continue
        r = room_by_depth(contacts, min(count, MAX_CONTACTS - 1), d)  # the last falls off when full
        write_inflated(contacts[r], x, axpy(-d, n, x), scale(n, -1.0), 0.0, 0.0)
        count = min(count + 1, MAX_CONTACTS)
    return count
