"""The narrow phase: the signed distance of two convex shapes, its nearest (or deepest) points
and normal, by a closed form where one exists and by GJK and EPA otherwise.

    status = pair_distance(code_a, size_a, hull_a, T_a, code_b, size_b, hull_b, T_b, out, work)

  code_X      int, a shape code of opendyn.multibody.shapes (SPHERE ... HALFSPACE)
  size_X      (3,) float64, the shape's size in metres, as shapes.py lays it out
  hull_X      a MESH's convex hull (support.py; `mesh_hull(points)` makes one), its hint reset
              to 0 here; `no_hull()` for the other shapes
  T_X         (3, 4) or (4, 4) float64, the pose of {g} in the world, [R p]
  out         (OUT_SIZE,) = (10,) float64, written: out[0] = d the signed distance (negative:
              the penetration depth), out[1:4] = p_A and out[4:7] = p_B the nearest points in
              the world (when d < 0, p_A on A's boundary deepest in B and p_B on B's deepest in
              A), out[7:10] = n the unit normal from a towards b; always p_B - p_A = d n, and
              when d < 0 moving b by -d n separates the shapes
  work        (ROWS, COLUMNS) float64 scratch (the GJK simplex, the EPA polytope): `work_array()`
  status      Status.OK, NO_CONVERGENCE (GJK or EPA stopped short of its tolerance; out holds
              its last estimate) or UNBOUNDED (two halfspaces)

It allocates nothing. Swapping a and b swaps p_A and p_B and negates n. The method by pair:

  sphere, capsule  x sphere, capsule     closed form (closest points of the cores)
  sphere x box                           closed form (the centre clamped to the box)
  box x box                              separating axes when they overlap (the witness points
                                         clipped on the faces that touch), GJK when separated
  anything x halfspace                   closed form (the support point along -n)
  every other pair                       GJK on the cores, EPA when the cores overlap
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from ..._runtime.status import Status
from ...multibody.hulls import convex_hull
from ...multibody.shapes import BOX, CAPSULE, HALFSPACE, SPHERE
from .box_box import box_box
from .box_manifold import box_witnesses
from .closed_forms import halfspace, rounded, sphere_box, swap_sides, write_inflated
from .epa import ROWS, epa
from .gjk import gjk
from .simplex import COLUMNS, A, B, weighted
from .support import core_radius
from .vectors import norm, scale, sub


def no_hull():
    """The hull of a shape that has none (every shape but MESH): empty arrays."""
    none = np.zeros(0, np.int64)
    faces = (np.zeros((0, 3)), np.zeros(1, np.int64), none, np.zeros(1, np.int64), none)
    return (np.zeros((0, 3)), np.zeros(1, np.int64), none, 0, np.zeros(1, np.int64), faces)


def mesh_hull(points):
    """The hull tuple of a MESH shape (support.py) made of points (n, 3) in its frame {g} (m):
    their convex hull (multibody.hulls.convex_hull) with a hint of its own."""
    h = convex_hull(points)
    faces = (h.face_normal, h.face_start, h.face_vertices, h.vertex_face_start, h.vertex_faces)
    return (h.vertices, h.neighbor_start, h.neighbors, h.seeds, np.zeros(1, np.int64), faces)


def work_array():
    """The scratch `pair_distance` needs: a (ROWS, COLUMNS) float64 array, made once."""
    return np.zeros((ROWS, COLUMNS))


@njit(**UNCOUNTED)
def convex(a, b, out, work):
    """GJK on the cores of a and b (c_B - c_A = d_core n), or EPA where they overlap
    (c_B - c_A = -depth n), then the radii added by closed_forms.write_inflated."""
    status, overlap, n = gjk(a, b, work)
    if overlap:
        status, _, normal, c_a, c_b = epa(a, b, work, n)
    else:
        c_a, c_b = weighted(work, n, A), weighted(work, n, B)
        gap = sub(c_b, c_a)
        normal = scale(gap, 1.0 / norm(gap))
    write_inflated(out, c_a, c_b, normal, core_radius(a[0], a[1]), core_radius(b[0], b[1]))
    return status


@njit(**UNCOUNTED)
def ordered_distance(a, b, out, work):
    """pair_distance for shapes a and b (tuples (code, size, hull, T)) with a's code at most
    b's: the closed forms of the table in the module docstring, else GJK and EPA."""
    code_a, code_b = a[0], b[0]
    if code_b == HALFSPACE:
        if code_a == HALFSPACE:
            return Status.UNBOUNDED.value
        halfspace(a, b, out)
        return Status.OK.value
    if (code_a == SPHERE or code_a == CAPSULE) and (code_b == SPHERE or code_b == CAPSULE):
        rounded(a, b, out)
        return Status.OK.value
    if code_a == SPHERE and code_b == BOX:
        sphere_box(a, b, out)
        return Status.OK.value
    if code_a == BOX and code_b == BOX:
        kind = box_box(a, b, 0.0, out)
        if kind >= 0:
            box_witnesses(a, b, kind, out, work)
            return Status.OK.value
    return convex(a, b, out, work)


@njit(**UNCOUNTED)
def pair_distance(code_a, size_a, hull_a, T_a, code_b, size_b, hull_b, T_b, out, work):
    """The signed distance of shapes a and b, their nearest points and normal into out (the
    module docstring gives every argument's shape, frame and unit). Returns a Status code.
    Each hull's hint is reset to its vertex 0 (a seed): the result does not depend on earlier
    calls."""
    hull_a[4][0] = 0
    hull_b[4][0] = 0
    a = (code_a, size_a, hull_a, T_a)
    b = (code_b, size_b, hull_b, T_b)
    if code_a <= code_b:
        return ordered_distance(a, b, out, work)
    status = ordered_distance(b, a, out, work)
    swap_sides(out)
    return status
