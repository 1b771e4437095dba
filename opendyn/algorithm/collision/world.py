"""The geometries in the world and the broad phase: where each geometry is at q, and which
pairs are near enough for the narrow phase.

    T_{s,g}(q) = T_{s,b}(q) T_{b,g}          (T_{s,b} from forward kinematics; b = -1: identity)

A geometry's axis-aligned bounding box in {s} is read off its support function along the world
axes e_i:

    hi_i = e_i . s(e_i),     lo_i = e_i . s(-e_i)        (s(d) = s_core(d) + r d, |d| = 1)

and a pair reaches the narrow phase only when its boxes, grown by a margin, overlap: the cost of
a query follows the pairs that are near, not all pairs (a box test is six comparisons).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED, UNCOUNTED_INLINE
from ...multibody.shapes import HALFSPACE
from .support import core_radius, core_support

LO, HI = 0, 3  # a bounding box row (6,): lo (3,) then hi (3,), metres in {s}


@njit(**UNCOUNTED)
def place_geometries(R_s, p_s, table, T_sg):
    """T_sg (G, 3, 4) <- [R p] of T_{s,g} = T_{s,b} T_{b,g} for every geometry, with the bodies'
    world poses R_s (nb, 3, 3), p_s (nb, 3) and table = (body (G,), T_body_geom (G, 4, 4), ...)
    (GeometryTable's arrays in its order)."""
    body, T_bg = table[0], table[1]
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
    table's rows of geometry k with hints[k] (support.py): table = GeometryTable's arrays in its
    order (body, T_body_geom, code, size, vertex_range, face_range, seeds, vertices,
    neighbor_start, neighbors, face_normal, face_start, face_vertices, vertex_face_start,
    vertex_faces)."""
    v0, v1 = table[4][k, 0], table[4][k, 1]
    f0, f1 = table[5][k, 0], table[5][k, 1]
    faces = (table[10][f0:f1], table[11][f0 : f1 + 1], table[12], table[13][v0 : v1 + 1], table[14])
    hull = (table[7][v0:v1], table[8][v0 : v1 + 1], table[9], table[6][k], hints[k : k + 1], faces)
    return (table[2][k], table[3][k], hull, T_sg[k])


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
        r = core_radius(shape[0], shape[1])
        for i in range(3):
            e = (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0)
            boxes[k, HI + i] = core_support(shape, e)[i] + r
            boxes[k, LO + i] = core_support(shape, (-e[0], -e[1], -e[2]))[i] - r


@njit(**UNCOUNTED_INLINE)
def boxes_near(boxes, a, b, margin):
    """Whether the bounding boxes of geometries a and b, grown by margin (m), overlap."""
    for i in range(3):
        if boxes[a, LO + i] > boxes[b, HI + i] + margin:
            return False
        if boxes[b, LO + i] > boxes[a, HI + i] + margin:
            return False
    return True
