"""Mesh files of a URDF: finding the file a ``<mesh filename>`` names, and reading the vertices
of its convex hull.

Collision meshes are used as their convex hulls (as Pinocchio's coal and MuJoCo use them): the
hull of a mesh's vertices, scaled. A COLLADA file's ``<unit meter=...>`` scales its vertices
into metres (the COLLADA specification; a file in millimetres says 0.001).
"""

from __future__ import annotations

import functools
import os
import pathlib
from urllib.parse import unquote, urlparse

import numpy as np

from .._runtime.signals import held_interrupt

MESH_FORMATS = ("stl", "dae", "obj")  # the mesh files opendyn reads (trimesh; pycollada: dae)


class MeshError(ValueError):
    """A mesh file that cannot be read (its message says which file and why)."""


def resolve_mesh(filename: str, urdf_dir) -> tuple[str | None, list[str]]:
    """The file a URDF mesh name refers to: (absolute path or None, the places tried).

    ``package://PKG/rest``: ``DIR/rest`` for the first folder DIR named PKG among the URDF's
    folder and its parents, the children of those folders, the ROS_PACKAGE_PATH entries and
    their children, and ``AMENT_PREFIX_PATH/share``. (example-robot-data names its meshes
    ``package://example-robot-data/robots/...``: a parent of its URDFs is that folder.)
    ``file:///abs`` and absolute paths are used as they are; other names are relative to the
    URDF's folder.
    """
    urdf_dir = pathlib.Path(urdf_dir)
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://") :].partition("/")
        tried = []
        for root in _package_candidates(pkg, urdf_dir):
            candidate = root / rest
            tried.append(str(root))
            if candidate.is_file():
                return str(candidate.resolve()), tried
        return None, tried
    if filename.startswith("file://"):
        parsed = urlparse(filename)
        path = pathlib.Path(unquote(parsed.netloc + parsed.path))
    elif "://" in filename:
        return None, []
    else:
        path = pathlib.Path(filename)
    if not path.is_absolute():
        path = urdf_dir / path
    return (str(path.resolve()) if path.is_file() else None), [str(path)]


def mesh_files(urdf_file) -> list[str]:
    """The mesh files a URDF names that exist (each <mesh filename> of its visuals and
    collisions, resolve_mesh'd), as absolute paths; [] for a file that is not readable XML."""
    from xml.etree import ElementTree

    try:
        root = ElementTree.parse(urdf_file).getroot()
    except (OSError, ElementTree.ParseError):
        return []
    folder = pathlib.Path(urdf_file).resolve().parent
    found = (resolve_mesh(mesh.get("filename") or "", folder)[0] for mesh in root.iter("mesh"))
    return sorted({path for path in found if path})


def _package_candidates(pkg, urdf_dir):
    """Folders that may be the package PKG, in search order (existing ones only, no repeats)."""
    seen = set()

    def emit(folder):
        if folder not in seen and folder.is_dir():
            seen.add(folder)
            yield folder

    for parent in (urdf_dir, *urdf_dir.parents):
        if parent.name == pkg:
            yield from emit(parent)
        yield from emit(parent / pkg)
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            root = pathlib.Path(entry)
            if root.name == pkg:
                yield from emit(root)
            yield from emit(root / pkg)
    for entry in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if entry:
            yield from emit(pathlib.Path(entry) / "share" / pkg)


def hull_vertices(path: str, scale=(1.0, 1.0, 1.0)) -> np.ndarray:
    """(n, 3) the vertices of the convex hull of the mesh in `path` (STL, OBJ or COLLADA), each
    coordinate multiplied by `scale` (the URDF's ``<mesh scale>``), in the mesh's frame (m).

    A linear map takes a hull's vertices to the hull's of the mapped points, so the file's hull
    is computed once (and kept for the process) and scaled on each call. A mesh whose points
    span no volume (a flat or degenerate mesh) keeps all its distinct points: the support
    function max_v d . v, all the collision kernels ask of a hull, is the same over them.
    Raises MeshError naming the file and the reason when it cannot be read.
    """
    return mesh_hull(path, scale)[0]


def mesh_hull(path: str, scale=(1.0, 1.0, 1.0)):
    """(vertices (n, 3) as hull_vertices gives them, facets (m, 3), neighbors (m, 3)): the
    convex hull of the mesh in `path`, with qhull's triangles (rows of indices of `vertices`)
    and, for each corner of a triangle, the triangle across the edge opposite it; facets and
    neighbors are None for a mesh that spans no volume. A scale keeps the facets (a linear map
    of non-zero determinant keeps a hull's faces)."""
    stat = os.stat(path)
    vertices, facets, neighbors = _file_hull(path, stat.st_mtime_ns, stat.st_size)
    return vertices * np.asarray(scale, dtype=float), facets, neighbors


@functools.lru_cache(maxsize=512)
def _file_hull(path, mtime_ns, size):
    """The unscaled hull of a mesh file (mesh_hull), computed once per (path, mtime, size)."""
    from scipy.spatial import ConvexHull, QhullError

    points = _file_mesh(path, mtime_ns, size)[0]
    try:
        hull = ConvexHull(points)
    except QhullError:  # flat or degenerate: every distinct point supports the same hull
        return _read_only(np.unique(points, axis=0)), None, None
    index = np.full(len(points), -1)
    index[hull.vertices] = np.arange(len(hull.vertices))
    return (
        _read_only(points[hull.vertices]),
        _read_only(index[hull.simplices]),
        _read_only(hull.neighbors.copy()),
    )


def _read_only(array):
    array.setflags(write=False)
    return array


def read_mesh(path: str) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3) in metres, faces (m, 3) int, rows of vertex indices) of the mesh in
    `path` (STL, OBJ or COLLADA), in its file's frame, both read-only; kept for the last few
    files read. Raises MeshError naming the file and the reason when it cannot be read or has
    no vertices or non-finite ones."""
    stat = os.stat(path)
    return _file_mesh(path, stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=8)  # the hull and the hollow of one file read it once
def _file_mesh(path, mtime_ns, size):
    """The checked vertices and faces of a mesh file, read once per (path, mtime, size)."""
    vertices, faces = _vertices_and_faces(path)
    if len(vertices) == 0:
        raise MeshError(
            f"{path}: no triangles could be read from it: the file is empty, truncated or "
            "corrupt, or (an OBJ) gives vertices but no faces; export the mesh again with its faces"
        )
    if not np.all(np.isfinite(vertices)):
        raise MeshError(f"{path}: the mesh has non-finite vertices")
    return _read_only(vertices), _read_only(faces)


def _vertices_and_faces(path):
    """Every vertex of a mesh file in its file's frame, in metres (COLLADA: times its unit),
    and its triangles."""
    suffix = pathlib.Path(path).suffix.lower().lstrip(".")
    if suffix not in MESH_FORMATS:
        raise MeshError(f"{path}: a .{suffix} file; collision meshes are STL, OBJ or COLLADA (DAE)")
    with held_interrupt():  # importing trimesh swallows Ctrl-C
        import trimesh
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as e:  # trimesh and pycollada raise many kinds on a bad file
        raise MeshError(f"{path}: could not be read as a mesh ({type(e).__name__}: {e})") from None
    vertices = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=float)
    faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    return vertices * (_collada_unit(path) if suffix == "dae" else 1.0), faces


def _collada_unit(path) -> float:
    """A COLLADA file's metres per unit (its asset's ``<unit meter>``; 1 when absent)."""
    import collada

    try:
        unit = collada.Collada(path, ignore=[collada.common.DaeError]).assetInfo.unitmeter
    except Exception as e:  # pycollada raises its own and lxml's errors on a bad file
        raise MeshError(f"{path}: could not be read as COLLADA ({type(e).__name__}: {e})") from None
    return 1.0 if unit is None else float(unit)
