"""How far a collision mesh is from its convex hull, which opendyn uses in its place.

Every collision mesh (a URDF's ``<collision>``, a scene's ``[[world]]`` mesh) is the convex hull
of its vertices (opendyn.io.meshes). Where the mesh is hollow (a room's floor and walls, a U, an
L, a bin) the hull fills the hollow in, and whatever is put there is pushed out of it. The hollows
are measured from the hull's surface: at the centre of each of the hull's triangles and edges,
the distance d to the nearest point of the mesh's triangles, so that the ball of radius d about
that point holds none of the mesh. The triangles are sampled every SPACING of the hull's size (d
comes out at most twice that too large) and the nearest point then found exactly on the nearest
sample's triangle. This needs no closed surface (a room is often a floor and walls, open above)
and no orientation of the faces. A hollow is *gross* where, at some point,

    d >= GAP_OF_SIZE * size   and   d >= GAP_OF_WIDTH * width,    or
    d >= FLOOR * size         and   d >= THROUGH * width,

with size the diagonal of the hull's bounding box and width the hull's extent along the way
into the hollow (from the nearest point of the mesh to the point of the hull): a hollow whose
mouth holds a ball half the hull's size across and that reaches over a third of its width (a
U, an L), or one through nine tenths of the hull's width, however shallow beside its size (a
room or a bin: a wide floor against the walls' height). A scene's [[world]] mesh is the
environment that the robot and the objects move in, and in its hollows (a corridor, a shelf,
stairs): there any hollow is gross whose mouth holds a ball a tenth of the hull's size across,
d >= FLOOR * size.

The thresholds separate such parts from robot links, which are often mildly concave: of the
381 collision meshes (file and scale) of example-robot-data's robots, 7 are gross by this rule,
each visibly so: two rings (Alex's gripper yaw links), the letters of the G1's logo, Alex's
spine link, the PR2's shoulder-lift and elbow-flex shells, and TIAGo's base shell. A thick L,
a step or a torus is not.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass

import numpy as np

from .meshes import mesh_hull, read_mesh

GAP_OF_SIZE = 0.25
GAP_OF_WIDTH = 0.35
THROUGH = 0.9
FLOOR = 0.05
SPACING = 0.02
MAX_POINTS = 50_000  # about this many samples at most: coarser beyond (many large triangles)


@dataclass(frozen=True)
class Hollow:
    """The deepest gross hollow of a mesh in its convex hull (module docstring), in the mesh's
    frame, scaled: `depth` m, how far the hull's surface lies from the mesh at `point` (3,) m, a
    point of the hull's surface; `size` m, the diagonal of the hull's bounding box."""

    depth: float
    point: tuple[float, float, float]
    size: float

    def note(self, parts: str) -> str:
        """What the hull does with the mesh, and the cure: split it into convex `parts`."""
        x, y, z = self.point
        return (
            f"it is used as its convex hull, which lies up to {self.depth:.3g} m from the "
            f"mesh's surface (at ({x:.3g}, {y:.3g}, {z:.3g}) m in the mesh's frame; the hull "
            f"is {self.size:.3g} m across), so whatever is in the mesh's hollows is pushed out "
            f"of them; split it into convex parts, {parts}"
        )


def gross_hollow(path: str, scale=(1.0, 1.0, 1.0), environment=False) -> Hollow | None:
    """The deepest gross hollow of the mesh in `path` with each coordinate multiplied by `scale`
    (the URDF's ``<mesh scale>``), or None when its hull is close to it everywhere (or it has
    no triangles or spans no volume); `environment`: the mesh is a scene's [[world]] entry
    (module docstring). Kept for the process, per file and scale. Raises MeshError naming the
    file when it cannot be read."""
    stat = os.stat(path)
    scale = tuple(float(s) for s in np.broadcast_to(np.asarray(scale, dtype=float), 3))
    return _file_hollow(path, stat.st_mtime_ns, stat.st_size, scale, bool(environment))


@functools.lru_cache(maxsize=512)
def _file_hollow(path, mtime_ns, size, scale, environment):
    """gross_hollow of a mesh file, measured once per (path, mtime, size, scale, role)."""
    vertices, faces = read_mesh(path)
    corners, facets, neighbors = mesh_hull(path, scale)
    if len(faces) == 0 or facets is None:  # no surface, or a flat one: its own hull
        return None
    triangles = vertices[faces] * np.asarray(scale)
    return _deepest_hollow(triangles, corners, facets, neighbors, environment)


def _deepest_hollow(triangles, corners, facets, neighbors, environment) -> Hollow | None:
    """The deepest gross hollow of the mesh of `triangles` (T, 3, 3) in its hull: vertices
    `corners` (n, 3), qhull's triangles `facets` and their `neighbors` (mesh_hull); with
    `environment` every hollow FLOOR deep is gross."""
    from scipy.spatial import cKDTree
    from trimesh.triangles import closest_point

    size = float(np.linalg.norm(np.ptp(corners, axis=0)))
    points = _hull_points(corners, facets, neighbors, FLOOR * size)
    if len(points) == 0:
        return None
    surface, on = _surface_points(triangles, SPACING * size)
    depth, nearest = cKDTree(surface).query(points)
    far = depth >= FLOOR * size
    if not far.any():
        return None
    # the nearest point of the sample's triangle: the way in, exactly (a sample a little aside
    # would tilt it, and the width of a wide hull along it with it)
    points = points[far]
    with np.errstate(all="ignore"):  # a degenerate triangle: its corner, the sample, stays
        exact = closest_point(triangles[on[nearest[far]]], points)
    exact = np.where(np.isfinite(exact), exact, surface[nearest[far]])
    depth = np.linalg.norm(points - exact, axis=1)
    width = np.ptp((points - exact) / depth[:, None] @ corners.T, axis=1)  # along the way in
    gross = (depth >= GAP_OF_SIZE * size) & (depth >= GAP_OF_WIDTH * width)
    gross |= (depth >= THROUGH * width) | (environment & (depth >= FLOOR * size))
    if not gross.any():
        return None
    k = int(np.argmax(np.where(gross, depth, -1.0)))
    return Hollow(float(depth[k]), tuple(float(x) for x in points[k]), size)


def _hull_points(corners, facets, neighbors, reach) -> np.ndarray:
    """The centres of the hull's triangles and edges (qhull's `facets`, and the facet across
    the edge opposite each corner, `neighbors`) that lie `reach` or more from every corner: the
    corners are the mesh's vertices, so that a point nearer one is nearer the mesh."""
    ends = corners[facets]
    centre = ends.mean(axis=1)
    far = np.linalg.norm(ends - centre[:, None], axis=2).min(axis=1) >= reach
    f, k = np.nonzero(neighbors > np.arange(len(facets))[:, None])  # each edge once
    a, b = corners[facets[f, (k + 1) % 3]], corners[facets[f, (k + 2) % 3]]
    long = np.linalg.norm(b - a, axis=1) >= 2 * reach
    return np.concatenate([centre[far], 0.5 * (a[long] + b[long])])


def _surface_points(triangles, spacing) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 3), the triangle of each (N,)): points of the triangles (T, 3, 3) within
    twice `spacing` of any point of theirs: the centre of a triangle shorter than that; on a
    longer one, rows parallel to its longest edge, `spacing` apart, with points `spacing` apart
    along each (a long thin triangle gets a few rows, not a square grid); of these, one in each
    cube of half the spacing. Beyond about MAX_POINTS the spacing is widened."""
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2)  # corners k-1, k
    longest = edges.max(axis=1)
    small, big = np.flatnonzero(longest <= spacing), np.flatnonzero(longest > spacing)
    apex = (np.argmax(edges[big], axis=1) + 1) % 3  # the corner opposite the longest edge
    apex, base0, base1 = (triangles[big, (apex + k) % 3] for k in range(3))
    length = longest[big]
    height = np.linalg.norm(np.cross(base1 - base0, apex - base0), axis=1) / length
    spacing *= max(1.0, np.sqrt(np.sum(length * (height / spacing + 1)) / spacing / MAX_POINTS))
    # rows from the longest edge (w = 0) to the apex (w = 1), points along each (t)
    row_of, w = _steps(np.maximum(np.ceil(height / spacing), 1).astype(np.int64) + 1)
    point_of, t = _steps(np.ceil((1 - w) * length[row_of] / spacing).astype(np.int64) + 1)
    on, w, t = row_of[point_of], w[point_of, None], t[:, None]
    start, end = base0[on] + w * (apex[on] - base0[on]), base1[on] + w * (apex[on] - base1[on])
    points = np.concatenate([triangles[small].mean(axis=1), start + t * (end - start)])
    on = np.concatenate([small, big[on]])
    # one point in each cube of half the spacing: a fine mesh's many small triangles in few
    cell = np.floor((points - points.min(axis=0)) / (0.5 * spacing)).astype(np.int64)
    span = cell.max(axis=0) + 1
    kept = np.unique(cell[:, 0] + span[0] * (cell[:, 1] + span[1] * cell[:, 2]), return_index=True)
    return points[kept[1]], on[kept[1]]


def _steps(counts) -> tuple[np.ndarray, np.ndarray]:
    """(group (N,), place (N,)): for groups of counts[i] items each, the group of each item and
    its place k / (counts[i] - 1), from 0 to 1 (0 in a group of one)."""
    group = np.repeat(np.arange(len(counts)), counts)
    k = np.arange(len(group)) - np.repeat(np.cumsum(counts) - counts, counts)
    return group, k / np.maximum(counts[group] - 1, 1)
