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
    stat = os.stat(path)
    return _file_hull(path, stat.st_mtime_ns, stat.st_size) * np.asarray(scale, dtype=float)


@functools.lru_cache(maxsize=512)
def _file_hull(path, mtime_ns, size):
    """The unscaled hull vertices of a mesh file, read once per (path, mtime, size)."""
    from scipy.spatial import ConvexHull, QhullError

    points = _vertices(path)
    if len(points) == 0:
        raise MeshError(f"{path}: the mesh has no vertices")
    if not np.all(np.isfinite(points)):
        raise MeshError(f"{path}: the mesh has non-finite vertices")
    try:
        points = points[ConvexHull(points).vertices]
    except QhullError:  # flat or degenerate: every distinct point supports the same hull
        points = np.unique(points, axis=0)
    points.setflags(write=False)
    return points


def _vertices(path):
    """Every vertex of a mesh file in its file's frame, in metres (COLLADA: times its unit)."""
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
    return vertices * (_collada_unit(path) if suffix == "dae" else 1.0)


def _collada_unit(path) -> float:
    """A COLLADA file's metres per unit (its asset's ``<unit meter>``; 1 when absent)."""
    import collada

    try:
        unit = collada.Collada(path, ignore=[collada.common.DaeError]).assetInfo.unitmeter
    except Exception as e:  # pycollada raises its own and lxml's errors on a bad file
        raise MeshError(f"{path}: could not be read as COLLADA ({type(e).__name__}: {e})") from None
    return 1.0 if unit is None else float(unit)
