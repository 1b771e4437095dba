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

A mesh file that cannot be found or read leaves its geometry out of the model: a URDFWarning and
a line of the fidelity report name the link and the file (report.unread_meshes lists them). A
mesh far from convex (opendyn.io.concavity) is a line of the report's "transformed" and of
report.hollow_meshes, and a SceneWarning of every scene whose contact uses the collision
geometry (a model for its dynamics alone is not held up by its meshes' shapes). A <geometry> of two shapes or more is read as urdfdom, Pinocchio and yourdfpy read
it, by its first shape, with a URDFWarning naming the others. A <mesh scale> must be three
non-zero finite numbers, or one for all three axes (a negative one mirrors the mesh); of four
(pybullet_data's racecar) the first three are read, with a URDFWarning. The report
counts the geometries by shape, loaded and not.
"""

from __future__ import annotations

import collections
import math
import os
import pathlib

import numpy as np

from ..errors import URDFError
from ..multibody.geometry import Geometry
from ..spatial.algebra import rpy_matrix
from .concavity import gross_hollow
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
            shape_el, *others = el.iterfind("geometry/*")
            name = el.get("name") or f"{link.get('name')}_{k}"
            label = f"<link name=\"{link.get('name')}\"> <collision> {name!r}"
            if others:
                report.warn("ignored", _first_shape_only(label, el, [shape_el, *others]))
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
            scale = _scale(file, label, shape_el, report)
            try:
                path, vertices = _mesh(urdf_dir, shape_el, scale)
                hollow = gross_hollow(path, scale)
            except MeshError as e:
                missing.append(f"{label}: {e}")
                continue
            if hollow is not None:  # a warning where the hull meets things: the scene's
                line = f"{label}: the mesh {path} is far from convex: " + hollow.note(
                    "one <collision> element each"
                )
                report.transformed.append(line)
                report.hollow_meshes.append(line)
            geometries.append(
                Geometry(name, link.get("name"), "mesh", scale, placement, vertices, path)
            )
            loaded["mesh"] += 1
    _report(report, loaded, missing)
    return tuple(geometries)


def _first_shape_only(label, el, shapes) -> str:
    """The report's line for a <geometry> of several shapes, read by its first."""
    tags = ", ".join(f"<{shape.tag}>" for shape in shapes)
    return (
        f"{label} (line {el.sourceline}): its <geometry> holds {len(shapes)} shapes ({tags}) "
        f"where the URDF spec allows one; the first, <{shapes[0].tag}>, is used (as urdfdom, "
        f"Pinocchio and yourdfpy read it), the others are not"
    )


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


def _scale(file, label, el, report) -> tuple[float, float, float]:
    """The scale of a <mesh> element (of the <collision> `label` names): three numbers, or one
    for all three axes; (1, 1, 1) when absent. Four numbers (pybullet_data's racecar) are read
    by their first three, with a URDFWarning (`report`). Raises
    URDFError naming the file, the link and the value for anything else: a factor that is not a
    number, is not finite, or is 0 (it flattens the mesh). A negative factor mirrors the mesh,
    as URDFs of left and right limbs use it."""
    text = el.get("scale")
    if text is None:
        return (1.0, 1.0, 1.0)
    try:
        factors = [float(v) for v in text.split()]
    except ValueError:
        factors = []
    if len(factors) == 4:
        report.warn(
            "transformed",
            f"{label} <mesh filename=\"{el.get('filename')}\"> (line {el.sourceline}): "
            f"scale={text!r} has 4 factors where the URDF spec has 3; the first three are used "
            f"and the fourth is ignored",
        )
        factors = factors[:3]
    if len(factors) in (1, 3) and all(math.isfinite(v) and v != 0.0 for v in factors):
        return tuple(factors * (3 // len(factors)))
    raise URDFError(
        f"{file}: {label} <mesh filename=\"{el.get('filename')}\"> (line {el.sourceline}): "
        f"scale={text!r}: expected three finite factors other than 0, or one for all three "
        f"axes (0 flattens the mesh; a negative factor mirrors it)"
    )


def _mesh(urdf_dir, el, scale):
    """(path, hull vertices (n, 3) scaled) of a <mesh filename> element; MeshError naming the
    file when it cannot be found or read."""
    filename = el.get("filename") or ""
    if not filename:
        raise MeshError("a <mesh> without a filename")
    path, tried = resolve_mesh(filename, urdf_dir)
    folder = tried and not filename.startswith("package://") and os.path.isdir(tried[0])
    if path is None and folder:
        raise MeshError(f"mesh {filename!r} is the folder {tried[0]}, not a mesh file")
    if path is None:
        looked = f" (looked in: {', '.join(tried[:4])}{', ...' if len(tried) > 4 else ''})"
        raise MeshError(f"mesh file {filename!r} not found" + (looked if tried else ""))
    return path, hull_vertices(path, scale)


def _report(report, loaded, missing):
    """The report's lines: the geometries read, by shape, and each one left out."""
    if loaded:
        counts = ", ".join(f"{n} {shape}" for shape, n in sorted(loaded.items()))
        report.honoured.append(
            f"{sum(loaded.values())} <collision> geometries in model.geometries ({counts}; "
            f"meshes as their convex hulls)"
        )
    if missing:
        report.unread_meshes.extend(missing)
        report.warn(
            "ignored",
            f"{len(missing)} <collision> mesh{'es' * (len(missing) > 1)} that could not be "
            f"read, not in model.geometries:\n      " + "\n      ".join(missing),
        )
