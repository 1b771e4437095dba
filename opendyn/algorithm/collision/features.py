"""Contact features: the part of a convex shape's boundary farthest along a direction u, the
face, edge or point two shapes touch by (Bullet's polyhedral contact clipping and MuJoCo's
multi-point convex contacts pick the same features to clip):

  face   a face whose outward normal N has N . u >= FACE_ON: its corners, counterclockwise seen
         from outside (about N)
           box       the face of the axis most along u
           cylinder  the cap facing u, as a regular CAP_CORNERS-gon inscribed in its rim, its
                     first corner the rim's point farthest along u
           mesh      the hull face of largest N . u among those that hold the support vertex
                     (a face of more than MAX_CORNERS corners: MAX_CORNERS of them, evenly)
  edge   a segment perpendicular to u within EDGE_ON (|e . u| <= EDGE_ON |e|), both its ends
         as far along u:
           box       the edge along the axis least along u
           cylinder  the side's line farthest along u
           capsule   its core segment (the radius is added by the caller)
           mesh      the support vertex and its neighbor farthest along u
  point  the support point, otherwise (and always for a sphere: its centre)

The tolerances make a shape resting on another a face or an edge contact before it is exactly
flat, so that a support does not flicker between one point and several as it settles: FACE_ON =
cos 18 degrees, EDGE_ON = sin 18 degrees. Each of a feature's points is a real point of the
shape's core; how far it is from the other shape is the clipping's business (face_contacts.py).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from ...multibody.shapes import BOX, CAPSULE, CYLINDER, MESH
from .support import climb, local_core_support
from .vectors import axis, axpy, dot, norm, origin, put, rotate, scale, sub, to_local, to_world

FACE_ON = math.cos(math.radians(18.0))
EDGE_ON = math.sin(math.radians(18.0))
CAP_CORNERS = 8
MAX_CORNERS = 32


@njit(**UNCOUNTED)
def box_feature(size, T, d, u, work, first):
    """box's feature along u (d = R^T u): module docstring; returns (count, N)."""
    h = (0.5 * size[0], 0.5 * size[1], 0.5 * size[2])
    k, m = 0, 0
    for i in range(3):
        if abs(d[i]) > abs(d[k]):
            k = i
        if abs(d[i]) < abs(d[m]):
            m = i
    if abs(d[k]) >= FACE_ON:
        s = 1.0 if d[k] >= 0.0 else -1.0
        i, j = (k + 1) % 3, (k + 2) % 3
        centre = axpy(s * h[k], axis(T, k), origin(T))
        signs = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))  # counterclockwise about e_k
        for r in range(4):
            sign_i, sign_j = signs[r if s > 0.0 else 3 - r]
            corner = axpy(sign_j * h[j], axis(T, j), axpy(sign_i * h[i], axis(T, i), centre))
            put(work, first + r, 0, corner)
        return 4, scale(axis(T, k), s)
    local = (math.copysign(h[0], d[0]), math.copysign(h[1], d[1]), math.copysign(h[2], d[2]))
    vertex = to_world(T, local)
    put(work, first, 0, vertex)
    if abs(d[m]) > EDGE_ON:
        return 1, u
    put(work, first + 1, 0, axpy(-2.0 * local[m], axis(T, m), vertex))  # the edge's other end
    return 2, u


@njit(**UNCOUNTED)
def cylinder_feature(size, T, d, u, work, first):
    """cylinder's feature along u (d = R^T u): module docstring; returns (count, N)."""
    r, half = size[0], 0.5 * size[1]
    rho = math.sqrt(d[0] * d[0] + d[1] * d[1])
    c_x, c_y = (d[0] / rho, d[1] / rho) if rho > 1e-6 else (1.0, 0.0)
    if abs(d[2]) >= FACE_ON:
        s = 1.0 if d[2] >= 0.0 else -1.0
        for k in range(CAP_CORNERS):  # counterclockwise about s z from the rim's deepest point
            angle = s * 2.0 * math.pi * k / CAP_CORNERS
            cos, sin = math.cos(angle), math.sin(angle)
            rim = (r * (c_x * cos - c_y * sin), r * (c_x * sin + c_y * cos), s * half)
            put(work, first + k, 0, to_world(T, rim))
        return CAP_CORNERS, rotate(T, (0.0, 0.0, s))
    if abs(d[2]) > EDGE_ON:
        put(work, first, 0, to_world(T, (r * c_x, r * c_y, math.copysign(half, d[2]))))
        return 1, u
    for k in range(2):
        put(work, first + k, 0, to_world(T, (r * c_x, r * c_y, half if k else -half)))
    return 2, u


@njit(**UNCOUNTED)
def mesh_feature(hull, T, d, u, work, first):
    """A mesh's feature along u (d = R^T u) on its hull's faces and edges: module docstring;
    returns (count, N)."""
    vertices, start, neighbors, seeds, hint, faces = hull
    normals, face_start, face_vertices, vertex_face_start, vertex_faces = faces
    v = climb(vertices, start, neighbors, seeds, hint, d)
    best, face = FACE_ON, -1
    for e in range(vertex_face_start[v], vertex_face_start[v + 1]):
        f = vertex_faces[e]
        along = d[0] * normals[f, 0] + d[1] * normals[f, 1] + d[2] * normals[f, 2]
        if along >= best:
            best, face = along, f
    if face >= 0:
        corners = face_start[face + 1] - face_start[face]
        count = min(corners, MAX_CORNERS)
        for i in range(count):
            c = face_vertices[face_start[face] + (i * corners) // count]
            put(work, first + i, 0, to_world(T, (vertices[c, 0], vertices[c, 1], vertices[c, 2])))
        return count, rotate(T, (normals[face, 0], normals[face, 1], normals[face, 2]))
    x = (vertices[v, 0], vertices[v, 1], vertices[v, 2])
    put(work, first, 0, to_world(T, x))
    w, highest = -1, -math.inf
    for e in range(start[v], start[v + 1]):
        y = (vertices[neighbors[e], 0], vertices[neighbors[e], 1], vertices[neighbors[e], 2])
        if dot(d, y) > highest:
            w, highest = neighbors[e], dot(d, y)
    if w < 0:
        return 1, u
    y = (vertices[w, 0], vertices[w, 1], vertices[w, 2])
    if dot(d, x) - highest > EDGE_ON * norm(sub(y, x)):
        return 1, u
    put(work, first + 1, 0, to_world(T, y))
    return 2, u


@njit(**UNCOUNTED)
def feature(shape, u, work, first):
    """The contact feature of shape (code, size, hull, T: support.py) along the world unit
    direction u, its points (world, m) into work rows first.. (columns 0-2): a face's corners
    (count >= 3), an edge's two ends or the support point (module docstring). Returns (count, N),
    N the face's outward unit normal in the world, u for an edge or a point."""
    code, size, hull, T = shape
    d = to_local(T, u)
    if code == BOX:
        return box_feature(size, T, d, u, work, first)
    if code == CYLINDER:
        return cylinder_feature(size, T, d, u, work, first)
    if code == MESH:
        return mesh_feature(hull, T, d, u, work, first)
    if code == CAPSULE and abs(d[2]) <= EDGE_ON:
        for k in range(2):
            put(work, first + k, 0, to_world(T, (0.0, 0.0, (0.5 if k else -0.5) * size[1])))
        return 2, u
    vertices, start, neighbors, seeds, hint, _ = hull
    x = local_core_support(code, size, vertices, start, neighbors, seeds, hint, d)
    put(work, first, 0, to_world(T, x))
    return 1, u
