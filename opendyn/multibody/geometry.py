"""The collision geometry of a robot: one Geometry per URDF ``<collision>`` element, the pairs
checked by default, and the same geometry packed for the compiled collision kernels.

A geometry is a convex shape (opendyn.multibody.shapes) in its own frame {g}, placed in the frame
of a URDF link {L} by ``placement = T_{L,g}``. The link is a frame of a body {b} (itself, or the
body a fixed joint lumps it into; -1 the fixed world) at T_{b,L}, so the geometry moves with that
body at

    T_{b,g} = T_{b,L} T_{L,g}              T_{s,g}(q) = T_{s,b}(q) T_{b,g}

Default pairs (``collision_pairs``): every two geometries on different bodies, except a body and
its parent (they touch at the joint by construction), except the link pairs an SRDF disables.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .._runtime.arrays import immutable
from .shapes import SHAPE_NAMES

SIZE_LENGTHS = {"sphere": 1, "box": 3, "cylinder": 2, "capsule": 2, "mesh": 3}
"""How many numbers each shape's `size` holds (see Geometry)."""


@dataclass(frozen=True, eq=False)
class Geometry:
    """One ``<collision>`` element of a URDF link: a convex shape placed in the link's frame.

    Fields:
      name       the ``<collision name=...>``, or "<link>_<k>" for the k-th unnamed one of a link
      link       the URDF link's name (a frame of the model, also when a fixed joint lumps the
                 link into the body above it: the geometry moves with that body)
      shape      "sphere", "box", "cylinder", "capsule" or "mesh"
      size       sphere (r,); box (x, y, z) full edge lengths as in the URDF; cylinder and capsule
                 (r, length) along the geometry's z axis (a capsule: the segment of that length
                 swept by a ball of radius r); mesh (sx, sy, sz), the scale of its file (metres,
                 or factors for a mesh)
      placement  (4, 4) T_{L,g}, the geometry's frame in the link's frame (the ``<origin>``)
      vertices   mesh: (n, 3) the vertices of the mesh's convex hull in the geometry's frame,
                 scaled (metres); None for the other shapes
      mesh_path  mesh: the file the vertices were read from; None otherwise
    """

    name: str
    link: str
    shape: str
    size: tuple[float, ...]
    placement: np.ndarray
    vertices: np.ndarray | None = None
    mesh_path: str | None = None

    def __post_init__(self):
        if self.shape not in SIZE_LENGTHS:
            raise ValueError(
                f"Geometry {self.name!r}: shape {self.shape!r} is not one of "
                f"{', '.join(SIZE_LENGTHS)}"
            )
        size = tuple(float(s) for s in np.ravel(self.size))
        if len(size) != SIZE_LENGTHS[self.shape]:
            raise ValueError(
                f"Geometry {self.name!r}: a {self.shape} has {SIZE_LENGTHS[self.shape]} sizes, "
                f"got {len(size)}"
            )
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "placement", immutable(self.placement).reshape(4, 4))
        if self.vertices is not None:
            object.__setattr__(self, "vertices", immutable(self.vertices).reshape(-1, 3))
        elif self.shape == "mesh":
            raise ValueError(f"Geometry {self.name!r}: a mesh needs the vertices of its hull")


@dataclass(frozen=True, eq=False)
class GeometryTable:
    """The geometries of a model as the compiled collision kernels read them (G geometries, V
    hull vertices in all; every array immutable):

      body          (G,) int, the body each geometry moves with (-1: the fixed world)
      T_body_geom   (G, 4, 4) T_{b,g} = T_{b,L} T_{L,g}, the geometry's frame in its body's (m)
      code          (G,) int, the shape's code (opendyn.multibody.shapes: SPHERE, BOX, ...)
      size          (G, 3) the shape's size row as shapes.py lays it out (unused entries 0)
      vertex_range  (G, 2) int, [first, stop) of the geometry's hull vertices in `vertices`
                    (empty for the shapes that have none)
      vertices      (V, 3) every mesh's hull vertices, in its geometry's frame {g} (m)
      neighbor_start  (V + 1,) int, hull vertex v's neighbors on its hull are
                    neighbors[neighbor_start[v]:neighbor_start[v + 1]]
      neighbors     (E,) int, each an index into its own geometry's hull (0 = its first vertex)
      seeds         (G,) int, how many of a hull's first vertices are its seeds: its farthest
                    along the 26 directions of SEED_DIRECTIONS (hull_graph)
    """

    body: np.ndarray
    T_body_geom: np.ndarray
    code: np.ndarray
    size: np.ndarray
    vertex_range: np.ndarray
    vertices: np.ndarray
    neighbor_start: np.ndarray
    neighbors: np.ndarray
    seeds: np.ndarray

    @classmethod
    def of(cls, geometries, frames_by_name) -> GeometryTable:
        """The table of `geometries`, each on the frame of its link in {name: Frame}."""
        count = len(geometries)
        body = np.empty(count, dtype=np.int64)
        T_body_geom = np.empty((count, 4, 4))
        code = np.empty(count, dtype=np.int64)
        size = np.zeros((count, 3))
        vertex_range = np.zeros((count, 2), dtype=np.int64)
        seeds = np.zeros(count, dtype=np.int64)
        hulls, starts, neighbors, first, edges = [], [np.zeros(1, np.int64)], [], 0, 0
        for k, g in enumerate(geometries):
            frame = frames_by_name[g.link]
            body[k] = frame.body
            T_body_geom[k] = frame.T_body_frame @ g.placement
            code[k] = SHAPE_NAMES.index(g.shape)
            size[k, : len(g.size)] = g.size
            if g.vertices is not None:
                hull, start, around, seeds[k] = hull_graph(g.vertices)
                hulls.append(hull)
                starts.append(start[1:] + edges)
                neighbors.append(around)
                vertex_range[k] = first, first + len(hull)
                first, edges = first + len(hull), edges + len(around)
            else:
                vertex_range[k] = first, first
        vertices = np.concatenate(hulls) if hulls else np.zeros((0, 3))
        neighbor_start = np.concatenate(starts)
        neighbors = np.concatenate(neighbors) if neighbors else np.zeros(0, np.int64)
        arrays = (body, T_body_geom, code, size, vertex_range, vertices, neighbor_start, neighbors)
        return cls(*(immutable(a, a.dtype) for a in (*arrays, seeds)))


SEED_DIRECTIONS = np.array(
    [(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if x or y or z],
    dtype=float,
)
"""The 26 directions (the cube's faces, edges and corners) along which a hull's farthest vertices
start its climbs (hull_graph)."""


def hull_graph(points):
    """The convex hull of points (n, 3) as the collision kernels climb it: (vertices (V, 3),
    neighbor_start (V + 1,) int, neighbors (E,) int, seeds int), the hull's vertices (its extreme
    points: the points inside are dropped, the support function max_v d . v is the same without
    them), for each vertex v the vertices it shares a hull edge with,
    neighbors[neighbor_start[v]:neighbor_start[v + 1]], and how many of the first vertices are
    seeds, the farthest along the 26 SEED_DIRECTIONS.

    On a convex polytope a vertex no neighbor of which lies farther along d is the farthest of
    all (the edges at a vertex span the polytope's cone there), so the support point is found by
    walking along edges (hill climbing, as coal does for its large convex shapes) instead of by
    testing every vertex. A walk starts from the best of the seeds (and of where the last walk
    ended), a few edges from any direction's farthest vertex: from an arbitrary vertex it would
    cross the hull, measured ~25 steps on the Panda's links. Points that span no volume (a flat
    mesh) keep all their distinct points and no edges: the kernels then test every vertex.
    The graph of the same points is computed once per process (every Model.build asks again).
    """
    points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
    return _graph_of(points.tobytes())


@functools.lru_cache(maxsize=512)
def _graph_of(data):
    """hull_graph of the points whose float64 bytes are `data`, its arrays read-only."""
    from scipy.spatial import ConvexHull, QhullError

    points = np.frombuffer(data).reshape(-1, 3)
    try:
        hull = ConvexHull(points)
    except QhullError:
        flat = np.unique(points, axis=0)
        graph = (flat, np.zeros(len(flat) + 1, np.int64), np.zeros(0, np.int64))
        return (*(immutable(a, a.dtype) for a in graph), 0)
    corners = points[hull.vertices]
    seeds = np.unique(np.argmax(SEED_DIRECTIONS @ corners.T, axis=1))
    order = np.concatenate([seeds, np.setdiff1d(np.arange(len(corners)), seeds)])
    index = np.full(len(points), -1, np.int64)
    index[hull.vertices[order]] = np.arange(len(order))
    triangles = index[hull.simplices]
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    edges = np.unique(np.concatenate([edges, edges[:, ::-1]]), axis=0)  # sorted by vertex
    start = np.searchsorted(edges[:, 0], np.arange(len(order) + 1)).astype(np.int64)
    graph = (corners[order], start, edges[:, 1])
    return (*(immutable(a, a.dtype) for a in graph), len(seeds))


def default_pairs(table: GeometryTable, parent, disabled_links=frozenset(), links=()):
    """(P, 2) int, the pairs (a, b), a < b, of geometries checked by default: on two different
    bodies, neither body the other's parent (parent: (nb,) the bodies' parents, -1 the world,
    whose geometries are the parent of the root's children's), and the links (links[a],
    links[b]) not a pair in `disabled_links` (a set of frozensets of two link names).
    """
    body = table.body
    pairs = []
    for a in range(len(body)):
        for b in range(a + 1, len(body)):
            ba, bb = body[a], body[b]
            if ba == bb:
                continue
            if (bb >= 0 and parent[bb] == ba) or (ba >= 0 and parent[ba] == bb):
                continue
            if disabled_links and frozenset((links[a], links[b])) in disabled_links:
                continue
            pairs.append((a, b))
    return immutable(np.array(pairs, dtype=np.int64).reshape(-1, 2), np.int64)
