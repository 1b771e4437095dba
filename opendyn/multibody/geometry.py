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

from collections import namedtuple
from dataclasses import dataclass, fields

import numpy as np

from .._runtime.arrays import immutable
from .hulls import convex_hull
from .shapes import SHAPE_NAMES

SIZE_LENGTHS = {"sphere": 1, "box": 3, "cylinder": 2, "capsule": 2, "mesh": 3, "halfspace": 0}
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

    def __repr__(self) -> str:
        """One line: the name, link, shape and size, where it sits in the link's frame, and for
        a mesh its hull's vertex count and file (the vertices themselves are `.vertices`)."""
        mesh = ""
        if self.vertices is not None:
            mesh = f", hull of {len(self.vertices)} vertices, mesh_path={self.mesh_path!r}"
        xyz = ", ".join(f"{x:.4g}" for x in self.placement[:3, 3])
        return (
            f"Geometry(name={self.name!r}, link={self.link!r}, shape={self.shape!r}, "
            f"size={self.size}, at ({xyz}) m in the link's frame{mesh})"
        )


@dataclass(frozen=True, eq=False)
class GeometryTable:
    """The geometries of a model as the compiled collision kernels read them (G geometries, V
    hull vertices in all; every array immutable):

      body          (G,) int, the body each geometry moves with (-1: the fixed world)
      T_body_geom   (G, 4, 4) T_{b,g} = T_{b,L} T_{L,g}, the geometry's frame in its body's (m)
      code          (G,) int, the shape's code (opendyn.multibody.shapes: SPHERE, BOX, ...)
      size          (G, 3) the shape's size row as shapes.py lays it out (unused entries 0)
      vertex_range  (G, 2) int, [first, stop) of the geometry's hull vertices (the rows of
                    `vertices`, `neighbor_start` and `vertex_face_start`; empty for the shapes
                    that have none)
      face_range    (G, 2) int, [first, stop) of its hull faces (rows of `face_normal` and
                    `face_start`)
      seeds         (G,) int, how many of a hull's first vertices are its seeds
      vertices, neighbor_start, neighbors, face_normal, face_start, face_vertices,
      vertex_face_start, vertex_faces
                    every mesh's Hull (hulls.py) one after the other: the starts are positions
                    in the arrays they index, the indices they lead to count from the
                    geometry's own first vertex or face (0 = its first)
      hull_box      (G, 6) a hull's axis-aligned box in {g}, lo (3,) then hi (3,) (m); zeros
                    for the shapes that have no hull
    """

    body: np.ndarray
    T_body_geom: np.ndarray
    code: np.ndarray
    size: np.ndarray
    vertex_range: np.ndarray
    face_range: np.ndarray
    seeds: np.ndarray
    vertices: np.ndarray
    neighbor_start: np.ndarray
    neighbors: np.ndarray
    face_normal: np.ndarray
    face_start: np.ndarray
    face_vertices: np.ndarray
    vertex_face_start: np.ndarray
    vertex_faces: np.ndarray
    hull_box: np.ndarray

    @classmethod
    def of(cls, geometries, frames_by_name) -> GeometryTable:
        """The table of `geometries`, each on the frame of its link in {name: Frame}."""
        count = len(geometries)
        body = np.empty(count, dtype=np.int64)
        T_body_geom = np.empty((count, 4, 4))
        code = np.empty(count, dtype=np.int64)
        size = np.zeros((count, 3))
        hulls = [convex_hull(g.vertices) if g.vertices is not None else None for g in geometries]
        for k, g in enumerate(geometries):
            frame = frames_by_name[g.link]
            body[k] = frame.body
            T_body_geom[k] = frame.T_body_frame @ g.placement
            code[k] = SHAPE_NAMES.index(g.shape)
            size[k, : len(g.size)] = g.size
        packed = _packed([h for h in hulls if h is not None])
        V = np.cumsum([0] + [len(h.vertices) if h else 0 for h in hulls])
        F = np.cumsum([0] + [len(h.face_normal) if h else 0 for h in hulls])
        ranges = np.stack([V[:-1], V[1:]], axis=1), np.stack([F[:-1], F[1:]], axis=1)
        seeds = np.array([h.seeds if h else 0 for h in hulls], dtype=np.int64)
        hull_box = np.array(
            [np.concatenate([h.vertices.min(0), h.vertices.max(0)]) if h else np.zeros(6)
             for h in hulls]
        ).reshape(count, 6)
        arrays = (body, T_body_geom, code, size, *ranges, seeds, *packed, hull_box)
        return cls(*(immutable(a, a.dtype) for a in arrays))

    def arrays(self) -> GeometryArrays:
        """The table as the compiled kernels take it: a GeometryArrays, its fields by name."""
        return GeometryArrays(*(getattr(self, f.name) for f in fields(self)))


def _packed(hulls):
    """The Hulls' arrays one after the other, in GeometryTable's order: the starts shifted to
    positions in the concatenated arrays they index (GeometryTable)."""
    vertices = [np.zeros((0, 3))] + [h.vertices for h in hulls]
    face_normal = [np.zeros((0, 3))] + [h.face_normal for h in hulls]
    columns = []
    for start, items in (
        ("neighbor_start", "neighbors"),
        ("face_start", "face_vertices"),
        ("vertex_face_start", "vertex_faces"),
    ):
        starts, offset = [np.zeros(1, np.int64)], 0
        for h in hulls:
            starts.append(getattr(h, start)[1:] + offset)
            offset += len(getattr(h, items))
        columns.append(np.concatenate(starts))
        columns.append(np.concatenate([np.zeros(0, np.int64)] + [getattr(h, items) for h in hulls]))
    neighbor_start, neighbors, face_start, face_vertices, vertex_face_start, vertex_faces = columns
    return (
        np.concatenate(vertices),
        neighbor_start,
        neighbors,
        np.concatenate(face_normal),
        face_start,
        face_vertices,
        vertex_face_start,
        vertex_faces,
    )


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


GeometryArrays = namedtuple("GeometryArrays", [f.name for f in fields(GeometryTable)])
"""A GeometryTable's arrays as a named record, which the compiled kernels read by field name
(table.body, table.code, ...): the same fields, in the same order."""
