"""A mesh's convex hull as the collision kernels read it: its vertices, the edge graph their
support points climb, and its faces, the polygons a face-on contact is clipped on.

    vertices            (V, 3) the hull's extreme points, in the mesh's frame {g} (m): the points
                        inside are dropped (the support function max_v d . v is the same
                        without them); the first `seeds` of them are the farthest along the 26
                        SEED_DIRECTIONS
    neighbor_start      (V + 1,) int; vertex v's neighbors along hull edges are
    neighbors           (E,) int       neighbors[neighbor_start[v]:neighbor_start[v + 1]]
    face_normal         (F, 3) each face's outward unit normal in {g}
    face_start          (F + 1,) int; face f's corners, counterclockwise seen from outside
    face_vertices       (L,) int        (about its normal), face_vertices[face_start[f]:...[f + 1]]
    vertex_face_start   (V + 1,) int; the faces that hold vertex v,
    vertex_faces        (W,) int        vertex_faces[vertex_face_start[v]:...[v + 1]]

A face is a plane's whole polygon: qhull's triangles that share an edge and a plane (normals
within COPLANAR) are merged, so that a box-shaped mesh has six four-cornered faces, and its
corners are the merged triangles' boundary, in order. Points that span no volume: a flat mesh (a
floor exported as one quad) is its polygon, with its edges and two faces, one each side; points
on a line are a segment, with one edge and no face.

On a convex polytope a vertex no neighbor of which lies farther along d is the farthest of all
(the edges at a vertex span the polytope's cone there), so the support point is found by walking
along edges (hill climbing, as coal does for its large convex shapes) instead of testing every
vertex. A walk starts from the best of the seeds, a few edges from any direction's farthest
vertex: from an arbitrary vertex it would cross the hull (~25 steps on the Panda's links).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from .._runtime.arrays import immutable

SEED_DIRECTIONS = np.array(
    [(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if x or y or z],
    dtype=float,
)
"""The 26 directions (the cube's faces, edges and corners) along which a hull's farthest vertices
start its climbs."""

COPLANAR = 1e-9
"""Two adjacent hull triangles are one face when 1 - n_1 . n_2 is below this (an angle of about
4.5e-5 rad): a box-shaped mesh's two triangles per side merge, a curved surface's do not."""


class Hull(NamedTuple):
    """A convex hull for the collision kernels (module docstring; every array read-only)."""

    vertices: np.ndarray
    neighbor_start: np.ndarray
    neighbors: np.ndarray
    seeds: int
    face_normal: np.ndarray
    face_start: np.ndarray
    face_vertices: np.ndarray
    vertex_face_start: np.ndarray
    vertex_faces: np.ndarray


def convex_hull(points) -> Hull:
    """The Hull of points (n, 3) (module docstring), computed once per set of points in a
    process (every Model.build asks again)."""
    points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
    return _hull_of(points.tobytes())


def _csr(groups, count):
    """(start (count + 1,), items) of the (group, item) int pairs (k, 2), sorted by group."""
    order = np.lexsort((groups[:, 1], groups[:, 0]))
    groups = groups[order]
    start = np.searchsorted(groups[:, 0], np.arange(count + 1)).astype(np.int64)
    return start, groups[:, 1].astype(np.int64)


def _faces(corners, triangles, equations, neighbors):
    """(face_normal, face_start, face_vertices, vertex_face_start, vertex_faces) of the hull
    whose triangles (T, 3) index corners (V, 3), with qhull's planes and triangle neighbors."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    normals = equations[:, :3]
    T = len(triangles)
    first = np.repeat(np.arange(T), 3)
    second = neighbors.ravel()
    same = np.einsum("ij,ij->i", normals[first], normals[second]) > 1.0 - COPLANAR
    graph = coo_matrix((np.ones(same.sum()), (first[same], second[same])), shape=(T, T))
    F, face_of = connected_components(graph, directed=False)
    # each triangle counterclockwise about its outward normal
    a, b, c = (corners[triangles[:, k]] for k in range(3))
    flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), normals) < 0
    triangles = np.where(flip[:, None], triangles[:, [0, 2, 1]], triangles)
    face_normal = np.zeros((F, 3))
    np.add.at(face_normal, face_of, normals)
    face_normal /= np.linalg.norm(face_normal, axis=1)[:, None]
    # a face's corners: its triangles' directed edges whose reverse is not in the face, chained
    tails = triangles.ravel()
    heads = triangles[:, [1, 2, 0]].ravel()
    owner = np.repeat(face_of, 3)
    V = len(corners)
    key = (owner * V + tails) * V + heads
    boundary = ~np.isin((owner * V + heads) * V + tails, key)
    loops = [[] for _ in range(F)]
    following = {}
    for f, tail, head in zip(owner[boundary], tails[boundary], heads[boundary], strict=True):
        following[f, tail] = head
        loops[f] = loops[f] or [tail]
    for f, loop in enumerate(loops):
        while (nxt := following[f, loop[-1]]) != loop[0]:
            loop.append(nxt)
    face_start = np.cumsum([0] + [len(loop) for loop in loops]).astype(np.int64)
    face_vertices = np.concatenate([np.array(loop, np.int64) for loop in loops])
    held = np.unique(np.stack([triangles.ravel(), np.repeat(face_of, 3)], axis=1), axis=0)
    vertex_face_start, vertex_faces = _csr(held, V)
    return face_normal, face_start, face_vertices, vertex_face_start, vertex_faces


def _flat_hull(points):
    """The Hull's parts (in its order) of points that span no volume. Points in a plane (a floor
    exported as one quad) are their polygon: its corners in order about the plane's normal m,
    each joined to the two beside it, and two faces, the polygon seen from either side (normal
    m, corners counterclockwise about it, and -m, the same corners the other way round), so
    that a face-on contact is clipped on the polygon as on a solid's face. Points on a line are
    its two ends joined by an edge; a single point is itself. Neither has a face."""
    from scipy.spatial import ConvexHull, QhullError

    centre = points.mean(axis=0)
    _, sigma, axes = np.linalg.svd(points - centre)
    none = np.zeros(0, np.int64)
    try:
        if len(sigma) < 2 or sigma[1] <= 1e-12 * sigma[0]:
            raise QhullError("the points span no area")
        corners = points[ConvexHull((points - centre) @ axes[:2].T).vertices]
    except QhullError:  # a line (its two ends) or a point
        along = (points - centre) @ axes[0]
        corners = np.unique(points[[np.argmin(along), np.argmax(along)]], axis=0)
        V = len(corners)
        start = np.arange(V + 1, dtype=np.int64) if V == 2 else np.zeros(V + 1, np.int64)
        neighbors = np.array([1, 0], np.int64) if V == 2 else none
        no_faces = (np.zeros((0, 3)), np.zeros(1, np.int64), none, np.zeros(V + 1, np.int64))
        return (corners, start, neighbors, V, *no_faces, none)
    # ConvexHull of 2-D points lists them counterclockwise about axes[0] x axes[1]
    m = np.cross(axes[0], axes[1])
    V = len(corners)
    ring = np.arange(V)
    neighbors = np.stack([(ring - 1) % V, (ring + 1) % V], axis=1).ravel().astype(np.int64)
    return (
        corners,
        np.arange(0, 2 * V + 1, 2, dtype=np.int64),
        neighbors,
        V,
        np.stack([m, -m]),
        np.array([0, V, 2 * V], np.int64),
        np.concatenate([ring, ring[::-1]]).astype(np.int64),
        np.arange(0, 2 * V + 1, 2, dtype=np.int64),
        np.tile([0, 1], V).astype(np.int64),
    )


@functools.lru_cache(maxsize=512)
def _hull_of(data):
    """convex_hull of the points whose float64 bytes are `data`."""
    from scipy.spatial import ConvexHull, QhullError

    points = np.frombuffer(data).reshape(-1, 3)
    try:
        hull = ConvexHull(points)
    except QhullError:
        parts = _flat_hull(points)
    else:
        corners = points[hull.vertices]
        seeds = np.unique(np.argmax(SEED_DIRECTIONS @ corners.T, axis=1))
        order = np.concatenate([seeds, np.setdiff1d(np.arange(len(corners)), seeds)])
        index = np.full(len(points), -1, np.int64)
        index[hull.vertices[order]] = np.arange(len(order))
        triangles = index[hull.simplices]
        edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
        edges = np.unique(np.concatenate([edges, edges[:, ::-1]]), axis=0)
        start, neighbors = _csr(edges, len(order))
        faces = _faces(corners[order], triangles, hull.equations, hull.neighbors)
        parts = (corners[order], start, neighbors, len(seeds), *faces)
    return Hull(*(p if isinstance(p, int) else immutable(p, p.dtype) for p in parts))
