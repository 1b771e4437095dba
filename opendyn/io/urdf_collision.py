"""A URDF's ``<collision>`` elements -> the model's Geometries (opendyn.multibody.geometry).

Every ``<collision>`` of every link, by link in the URDF's order, then in document order: its
``<origin>`` (xyz, rpy: R = Rz(yaw) Ry(pitch) Rx(roll)) is the geometry's placement in the
link's frame, its shape one of

  <sphere radius>            -> "sphere" (r,)
  <box size="x y z">         -> "box" (x, y, z), full edge lengths
  <cylinder radius length>   -> "cylinder" (r, length), axis z
  <capsule radius length>    -> "capsule" (r, length), axis z (Pinocchio's extension)
  <mesh filename scale>      -> "mesh" (sx, sy, sz), its convex hull's vertices, scaled

Pinocchio's ``<collision_checking><capsule name=.../></collision_checking>`` inside a link makes
the cylinder of that <collision name> a capsule of the same radius and length (the report says
so); its ``<convex name>`` changes nothing, every mesh being its convex hull.

A mesh file that cannot be found or read leaves its geometry out of the model and is a line of
the fidelity report naming the link and the file; the report counts the geometries by shape,
loaded and not.
"""

from __future__ import annotations

import collections
import os
import pathlib

import numpy as np

from ..errors import URDFError
from ..multibody.geometry import Geometry
from ..spatial.algebra import rpy_matrix
from .meshes import MeshError, hull_vertices, resolve_mesh
from .urdf_xml import check_values, where

_ATTRIBUTES = {  # shape -> its attributes, each with its count of numbers
    "sphere": (("radius", 1),),
    "box": (("size", 3),),
    "cylinder": (("radius", 1), ("length", 1)),
    "capsule": (("radius", 1), ("length", 1)),
}


def read_geometries(file, root, report) -> tuple[Geometry, ...]:
    """The Geometries of the <collision> elements of a URDF's checked XML tree `root` (read from
    `file`), what was read and not in the FidelityReport `report`. Raises URDFError naming the
    element for a size that is not a number, not finite or negative."""
    urdf_dir = pathlib.Path(os.path.abspath(file)).parent
    geometries, loaded, missing = [], collections.Counter(), []
    for link in root.iterchildren("link"):
        capsules = {el.get("name") for el in link.iterfind("collision_checking/capsule")}
        for k, el in enumerate(link.iterchildren("collision")):
            shape_el = el.find("geometry/*")
            name = el.get("name") or f"{link.get('name')}_{k}"
            placement = _origin(file, el.find("origin"))
            if shape_el.tag != "mesh":
                shape, size = shape_el.tag, _size(file, shape_el)
                if shape == "cylinder" and el.get("name") in capsules:
                    shape = "capsule"
                    report.transformed.append(
                        f"<link name=\"{link.get('name')}\"> <collision name=\"{name}\">: the "
                        f"cylinder is a capsule (<collision_checking> <capsule>)"
                    )
                geometries.append(Geometry(name, link.get("name"), shape, size, placement))
                loaded[shape] += 1
                continue
            try:
                path, scale, vertices = _mesh(file, urdf_dir, shape_el)
            except MeshError as e:
                missing.append(f"<link name=\"{link.get('name')}\"> <collision> {name!r}: {e}")
                continue
            geometries.append(
                Geometry(name, link.get("name"), "mesh", scale, placement, vertices, path)
            )
            loaded["mesh"] += 1
    _report(report, loaded, missing)
    return tuple(geometries)


def _origin(file, el) -> np.ndarray:
    """T (4, 4) of an <origin xyz rpy> (identity when absent)."""
    T = np.eye(4)
    if el is None:
        return T
    for attr in ("xyz", "rpy"):
        if el.get(attr) is not None:
            check_values(file, el, attr, el.get(attr), 3)
    T[:3, 3] = [float(v) for v in el.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in el.get("rpy", "0 0 0").split()]
    T[:3, :3] = rpy_matrix(rpy)  # Rz Ry Rx
    return T


def _size(file, el) -> tuple[float, ...]:
    """The size of a sphere, box, cylinder or capsule element, checked: numbers, >= 0."""
    size = []
    for attr, count in _ATTRIBUTES[el.tag]:
        text = el.get(attr)
        if text is None:
            raise URDFError(f"{file}: {where(el)}: <{el.tag}> has no {attr}")
        check_values(file, el, attr, text, count)
        size.extend(float(v) for v in text.split())
    if any(s < 0 for s in size):
        raise URDFError(f"{file}: {where(el)}: <{el.tag}> has a negative size {size}")
    return tuple(size)


def _mesh(file, urdf_dir, el):
    """(path, scale, hull vertices (n, 3) scaled) of a <mesh filename scale> element; MeshError
    naming the file when it cannot be found or read."""
    filename = el.get("filename") or ""
    scale = (1.0, 1.0, 1.0)
    if el.get("scale") is not None:
        text = el.get("scale")
        try:
            check_values(file, el, "scale", text, 3)
        except URDFError:
            check_values(file, el, "scale", text, 1)  # one number scales all three axes
            text = " ".join([text] * 3)
        scale = tuple(float(v) for v in text.split())
    if not filename:
        raise MeshError("a <mesh> without a filename")
    path, tried = resolve_mesh(filename, urdf_dir)
    if path is None:
        looked = f" (looked in: {', '.join(tried[:4])}{', ...' if len(tried) > 4 else ''})"
        raise MeshError(f"mesh file {filename!r} not found" + (looked if tried else ""))
    return path, scale, hull_vertices(path, scale)


def _report(report, loaded, missing):
    """The report's lines: the geometries read, by shape, and each one left out."""
    if loaded:
        counts = ", ".join(f"{n} {shape}" for shape, n in sorted(loaded.items()))
        report.honoured.append(
            f"{sum(loaded.values())} <collision> geometries in model.geometries ({counts}; "
            f"meshes as their convex hulls)"
        )
    if missing:
        report.ignored.append(
            f"{len(missing)} <collision> mesh{'es' * (len(missing) > 1)} that could not be "
            f"read, not in model.geometries:\n      " + "\n      ".join(missing)
        )
