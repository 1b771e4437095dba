"""The visual geometry of a URDF's links, ready to draw: ``load_visuals(model) -> [Visual]``.

Boxes, cylinders and spheres are drawn as written; a mesh file is found by ``resolve_mesh``
(``package://``, ``file://``, absolute or relative names). What cannot be drawn as written (a
missing or unreadable mesh, a model without visuals) warns (PlaybackWarning) and becomes a grey
stand-in.
"""

from __future__ import annotations

import os
import pathlib
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..io.meshes import MESH_FORMATS, resolve_mesh


DEFAULT_RGBA = (0.72, 0.72, 0.75, 1.0)  # light grey, for visuals without a <material> colour
STAND_IN_RGBA = (0.5, 0.5, 0.5, 1.0)
STAND_IN_SIZE = 0.05  # m, edge of the grey box drawn in place of an unusable mesh
COLLISION_RGBA = (0.9, 0.45, 0.1, 0.6)  # translucent orange, for the collision geometry
OBJECT_RGBA = (0.25, 0.5, 0.85, 1.0)  # blue, a scene's objects
WORLD_RGBA = (0.62, 0.58, 0.52, 1.0)  # warm grey, a scene's static world


class PlaybackWarning(UserWarning):
    """Visual geometry that cannot be drawn as written (a missing or unreadable mesh, ...);
    a stand-in is drawn instead."""


@dataclass(frozen=True, eq=False)
class Visual:
    """One ``<visual>`` element of a URDF link, ready to draw.

    Fields:
      link           name of the URDF link (a frame of the model) the geometry is attached to
      T_link_visual  (4, 4) pose of the geometry in the link frame, the ``<visual> <origin>``
                     (metres)
      shape          "box", "cylinder", "sphere", "mesh", and for the collision geometry
                     "capsule", "hull" and "halfspace" (a world plane: the solid below the
                     visual frame's xy plane)
      size           box: (x, y, z) edge lengths; cylinder and capsule: (radius, length), the
                     axis along the z axis of the visual frame; sphere: (radius,); all in
                     metres; mesh and hull: (sx, sy, sz) scale factors
      mesh_path      mesh: the resolved file (absolute path); None otherwise
      vertices       hull: (n, 3) the convex hull's vertices in the visual frame (m, scaled)
      rgba           (4,) colour in [0, 1], from the ``<material>`` (by name or inline), else a
                     default grey
      note           "" for geometry drawn as written; otherwise why a stand-in (a small grey
                     box) replaces it, the same text as the PlaybackWarning issued
    """

    link: str
    T_link_visual: np.ndarray
    shape: str
    size: tuple[float, ...]
    mesh_path: str | None = None
    rgba: tuple[float, float, float, float] = DEFAULT_RGBA
    note: str = field(default="")
    vertices: np.ndarray | None = None


def load_visuals(model) -> list[Visual]:
    """The visual geometry of every link of the URDF ``model`` was loaded from.

    Reads ``model.source`` again (with yourdfpy) for each link's ``<visual>`` elements: origin,
    geometry (box, cylinder, sphere, or an STL / DAE / OBJ mesh with its scale) and material
    colour. Mesh file names may be ``package://PKG/...`` (PKG is searched for among the folders
    above the URDF file and their children, in ROS_PACKAGE_PATH and under
    ``AMENT_PREFIX_PATH/share``), ``file://...``, absolute, or relative to the URDF's folder.

    Meshes are drawn in the ``<material>`` colour (or grey): the colours and textures inside
    DAE and OBJ files are not used.

    A mesh that is missing, not found, or of another format issues a PlaybackWarning naming
    the link and the file, and becomes a small grey box (its ``note`` says why); nothing
    raises. A model without a URDF file, or a URDF without any ``<visual>``, gets a grey
    sphere at the frame of each moving body (with a PlaybackWarning).

    Returns the visuals in URDF order (links, then their ``<visual>`` elements).
    """
    source = getattr(model, "source", "") or ""
    if not source or not os.path.isfile(source):
        return _body_stand_ins(
            model, f"model {model.name!r} has no URDF file to read visual geometry from"
        )
    robot = _parse_urdf(source)
    if robot is None:
        return _body_stand_ins(model, f"{source}: the URDF could not be parsed for <visual>")
    named_colours = {
        m.name: tuple(float(c) for c in m.color.rgba)
        for m in (robot.materials or [])
        if m.name and m.color is not None and m.color.rgba is not None
    }
    urdf_dir = pathlib.Path(os.path.abspath(source)).parent
    visuals = []
    for link in robot.links:
        for v in link.visuals:
            visual = _visual(source, urdf_dir, link.name, v, named_colours)
            if visual is not None:
                visuals.append(visual)
    if not visuals:
        return _body_stand_ins(model, f"{source}: no link has a <visual>")
    return visuals


def collision_visuals(model) -> list[Visual]:
    """The collision geometry of the model (``model.geometries``), ready to draw in a
    translucent orange: each mesh as the convex hull the collision queries use. A model without
    collision geometry gets a grey sphere at the frame of each moving body (with a
    PlaybackWarning)."""
    if not model.geometries:
        return _body_stand_ins(model, f"model {model.name!r} has no collision geometry")
    return [_geometry_visual(g, COLLISION_RGBA) for g in model.geometries]


def _geometry_visual(g, rgba) -> Visual:
    """A collision Geometry drawn in `rgba`: a mesh as its convex hull."""
    shape = "hull" if g.shape == "mesh" else g.shape
    return Visual(g.link, g.placement, shape, g.size, rgba=rgba, vertices=g.vertices)


def scene_visuals(model, collision=False) -> list[Visual]:
    """What playback draws of a model: with `collision`, its collision geometry
    (collision_visuals); else the robot's visual geometry (load_visuals; none for a scene of
    objects alone) and the scene's objects and static world (world_visuals)."""
    if collision:
        return collision_visuals(model)
    robotless = not model.source and model.nb == len(model.objects)
    return ([] if robotless else load_visuals(model)) + world_visuals(model)


def world_visuals(model) -> list[Visual]:
    """The scene's objects (model.objects: their collision geometry, in blue) and its static
    world entries (model.world, in warm grey), ready to draw; a plane as a slab whose top face
    is the plane. [] for a robot alone."""
    from ..multibody.assembly import object_of

    body = model.geometry_table.body
    visuals = []
    for k, g in enumerate(model.geometries):
        if object_of(model, body[k]) is not None:
            rgba = OBJECT_RGBA
        elif g.link in model.world:
            rgba = WORLD_RGBA
        else:
            continue  # the robot's: its visual geometry stands for it
        visuals.append(_geometry_visual(g, rgba))
    return visuals


def _parse_urdf(source):
    """The yourdfpy robot of the URDF file, read as load_urdf reads it; None (with a
    PlaybackWarning) when it cannot be read."""
    from ..errors import URDFError
    from ..io.urdf_xml import read_urdf

    try:
        return read_urdf(source)[1]
    except URDFError as e:  # the model loaded, so the file changed since; never fatal here
        warnings.warn(f"the URDF could not be read again: {e}", PlaybackWarning)
        return None


def _body_stand_ins(model, why):
    """A grey sphere at each moving body's frame, scaled to the robot's size."""
    names = list(model.body_names)
    warnings.warn(f"{why}; drawing a grey sphere at each moving body's frame", PlaybackWarning)
    reach = float(np.linalg.norm(model.p_home, axis=1).sum()) if model.nb else 0.0
    radius = max(0.02, 0.05 * reach)
    return [
        Visual(name, np.eye(4), "sphere", (radius,), rgba=STAND_IN_RGBA, note=why) for name in names
    ]


def _visual(source, urdf_dir, link, v, named_colours):
    T = np.array(v.origin, dtype=float) if v.origin is not None else np.eye(4)
    g = v.geometry
    rgba = _colour(v.material, named_colours)
    if g is None:
        return None
    if g.box is not None:
        return Visual(link, T, "box", tuple(float(s) for s in np.ravel(g.box.size)), rgba=rgba)
    if g.cylinder is not None:
        return Visual(
            link, T, "cylinder", (float(g.cylinder.radius), float(g.cylinder.length)), rgba=rgba
        )
    if g.sphere is not None:
        return Visual(link, T, "sphere", (float(g.sphere.radius),), rgba=rgba)
    if g.mesh is None:
        return None
    scale = np.ones(3) if g.mesh.scale is None else np.broadcast_to(g.mesh.scale, (3,))
    scale = tuple(float(s) for s in scale)
    filename = g.mesh.filename or ""
    path, tried = resolve_mesh(filename, urdf_dir)
    why = ""
    if path is None and filename.startswith("package://") and not tried:
        pkg = filename[len("package://") :].partition("/")[0]
        why = (
            f"not found: no folder named {pkg!r} above the URDF, nor in ROS_PACKAGE_PATH or "
            f"AMENT_PREFIX_PATH/share"
        )
    elif path is None:
        where = f" (looked in: {', '.join(tried[:6])}{', ...' if len(tried) > 6 else ''})"
        why = "not found" + (where if tried else "")
    elif pathlib.Path(path).suffix.lower().lstrip(".") not in MESH_FORMATS:
        why = (
            f"is a {pathlib.Path(path).suffix or 'suffix-less'} file (playback reads STL, DAE, OBJ)"
        )
    elif not os.access(path, os.R_OK):
        why = "cannot be read (permission denied)"
    if why:
        return _stand_in(source, link, T, filename, why)
    return Visual(link, T, "mesh", scale, mesh_path=path, rgba=rgba)


def _stand_in(source, link, T_link_visual, filename, why):
    note = (
        f"{source}: link {link!r}: mesh file {filename!r} {why}; drawn as a small grey box instead"
    )
    warnings.warn(note, PlaybackWarning, stacklevel=3)
    return Visual(link, T_link_visual, "box", (STAND_IN_SIZE,) * 3, rgba=STAND_IN_RGBA, note=note)


def _colour(material, named_colours):
    if material is None:
        return DEFAULT_RGBA
    if material.color is not None and material.color.rgba is not None:
        return tuple(float(c) for c in np.clip(material.color.rgba, 0.0, 1.0))
    return named_colours.get(material.name, DEFAULT_RGBA)
