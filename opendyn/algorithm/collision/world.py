"""The geometries in the world and the broad phase: where each geometry is at q, and which
pairs are near enough for the narrow phase.

    T_{s,g}(q) = T_{s,b}(q) T_{b,g}          (T_{s,b} from forward kinematics; b = -1: identity)

A geometry's axis-aligned bounding box in {s} is read off its support function along the world
axes e_i:

    hi_i = e_i . s(e_i),     lo_i = e_i . s(-e_i)        (s(d) = s_core(d) + r d, |d| = 1)

except a hull's, which would take six climbs over its vertices: its box in {g} (centre c,
half-widths h; GeometryTable.hull_box) turned into {s}, a box that holds the hull's own,

    c_s = R c + p,     h_s,i = sum_j |R_ij| h_j             (T_{s,g} = [R p])

and a pair reaches the narrow phase only when its boxes, grown by a margin, overlap: the cost of
a query follows the pairs that are near, not all pairs (a box test is six comparisons). A
halfspace's box is all of space; a shape reaches it only when the lowest corner of the shape's
box along the plane's normal n is within the margin of the plane (n . x <= n . p + margin, p a
point of it).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED, UNCOUNTED_INLINE
from ...multibody.shapes import HALFSPACE, MESH
from .support import core_radius, core_support

LO, HI = 0, 3  # a bounding box row (6,): lo (3,) then hi (3,), metres in {s}


@njit(**UNCOUNTED)
def place_geometries(R_s, p_s, table, T_sg):
    """T_sg (G, 3, 4) <- [R p] of T_{s,g} = T_{s,b} T_{b,g} for every geometry, with the bodies'
    world poses R_s (nb, 3, 3), p_s (nb, 3) and table a GeometryArrays (opendyn.multibody.
    geometry: body (G,), T_body_geom (G, 4, 4), ...)."""
    body, T_bg = table.body, table.T_body_geom
    for k in range(body.shape[0]):
        b = body[k]
        for r in range(3):
            for c in range(4):
                if b < 0:
                    T_sg[k, r, c] = T_bg[k, r, c]
                else:
                    T_sg[k, r, c] = (
                        R_s[b, r, 0] * T_bg[k, 0, c]
                        + R_s[b, r, 1] * T_bg[k, 1, c]
                        + R_s[b, r, 2] * T_bg[k, 2, c]
                    )
            if b >= 0:
                T_sg[k, r, 3] += p_s[b, r]


@njit(**UNCOUNTED_INLINE)
def shape_of(table, hints, T_sg, k):
    """Geometry k as the narrow phase's shape tuple (code, size (3,), hull, T), its hull the
    table's rows of geometry k with hints[k] (support.py): table a GeometryArrays
    (opendyn.multibody.geometry)."""
    v0, v1 = table.vertex_range[k, 0], table.vertex_range[k, 1]
    f0, f1 = table.face_range[k, 0], table.face_range[k, 1]
    faces = (
        table.face_normal[f0:f1], table.face_start[f0 : f1 + 1], table.face_vertices,
        table.vertex_face_start[v0 : v1 + 1], table.vertex_faces,
    )
    hull = (
        table.vertices[v0:v1], table.neighbor_start[v0 : v1 + 1], table.neighbors,
        table.seeds[k], hints[k : k + 1], faces,
    )
    return (table.code[k], table.size[k], hull, T_sg[k])


@njit(**UNCOUNTED)
def bounding_boxes(table, hints, T_sg, boxes):
    """boxes (G, 6) <- every geometry's bounding box in {s} (module docstring), lo then hi
    (a halfspace's: all of space);
    hints (G,) int, each hull's climbing start (support.py)."""
    for k in range(boxes.shape[0]):
        shape = shape_of(table, hints, T_sg, k)
        if shape[0] == HALFSPACE:  # unbounded: near everything
            for i in range(3):
                boxes[k, LO + i], boxes[k, HI + i] = -math.inf, math.inf
            continue
        if shape[0] == MESH:
            hull_box_in_world(table.hull_box[k], T_sg[k], boxes[k])
            continue
        r = core_radius(shape[0], shape[1])
        for i in range(3):
            e = (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0)
            boxes[k, HI + i] = core_support(shape, e)[i] + r
            boxes[k, LO + i] = core_support(shape, (-e[0], -e[1], -e[2]))[i] - r


@njit(**UNCOUNTED_INLINE)
def hull_box_in_world(box_g, T_sg, box_s):
    """box_s (6,) <- the box in {s} that holds the box box_g (6,) of {g} (lo then hi), for
    T_sg (3, 4) = [R p] (module docstring)."""
    for i in range(3):
        c, h = T_sg[i, 3], 0.0
        for j in range(3):
            c += T_sg[i, j] * 0.5 * (box_g[LO + j] + box_g[HI + j])
            h += abs(T_sg[i, j]) * 0.5 * (box_g[HI + j] - box_g[LO + j])
        box_s[LO + i], box_s[HI + i] = c - h, c + h


@njit(**UNCOUNTED_INLINE)
def pair_near(code, T_sg, boxes, a, b, margin):
    """Whether geometries a and b (code (G,) their shapes) may be within margin (m): their
    boxes overlap, or, against a halfspace, the other's box reaches its plane (module
    docstring)."""
    if code[a] == HALFSPACE and code[b] != HALFSPACE:
        return box_reaches_plane(T_sg[a], boxes, b, margin)
    if code[b] == HALFSPACE and code[a] != HALFSPACE:
        return box_reaches_plane(T_sg[b], boxes, a, margin)
    return boxes_near(boxes, a, b, margin)


@njit(**UNCOUNTED_INLINE)
def box_reaches_plane(T_plane, boxes, k, margin):
    """Whether box k's lowest corner along the normal n (T_plane's z axis) of the plane through
    T_plane's origin p is within margin of it: sum_i min(n_i lo_i, n_i hi_i) <= n . p + margin."""
    low, height = 0.0, 0.0
    for i in range(3):
        n = T_plane[i, 2]
        low += min(n * boxes[k, LO + i], n * boxes[k, HI + i])
        height += n * T_plane[i, 3]
    return low <= height + margin


@njit(**UNCOUNTED_INLINE)
def boxes_near(boxes, a, b, margin):
    """Whether the bounding boxes of geometries a and b, grown by margin (m), overlap."""
    for i in range(3):
        if boxes[a, LO + i] > boxes[b, HI + i] + margin:
            return False
        if boxes[b, LO + i] > boxes[a, HI + i] + margin:
            return False
    return True
