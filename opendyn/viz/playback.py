"""Playback of a motion q(t) in meshcat: every URDF link's visual geometry, posed over time.

Each ``<visual>`` v of link L is drawn in the world frame {s} at

    T_sv(t) = T_sL(q(t)) T_Lv

with ``T_sL = frame_pose(model, q, L)`` and ``T_Lv`` the visual's ``<origin>`` (times the mesh
scale). The motion (t (K,) s, q (K, nq)) is resampled by linear interpolation to the page's
frame rate and stored as one meshcat animation clip per link (position and quaternion tracks),
so the browser interpolates between frames and the time slider scrubs the motion.

With ground contact the scene also draws the ground (the plane z = ground_height) and, at each
contact point, the force the ground applies there as a red arrow from the point along the force,
its length proportional to the force's magnitude (one scale for the whole run, stated on the
page), resampled and animated with the motion.

``write_html`` writes a self-contained page (meshcat's static export: the viewer's JavaScript,
the geometry and the animation inlined; no network access); ``view`` plays the same scene in a
live meshcat viewer. meshcat is an optional dependency (``pip install 'opendyn[viz]'``),
imported only when a playback function runs; the core never imports this module.
"""

from __future__ import annotations

import base64
import contextlib
import io
import math
import numbers
import os
import pathlib
import warnings
from dataclasses import dataclass, field
from urllib.parse import unquote, urlparse

import numpy as np

from .._runtime.files import atomic_write
from ..algorithm.configuration import normalize
from ..algorithm.kinematics import frame_pose

MESHCAT_HINT = "playback needs meshcat: pip install 'opendyn[viz]'"
MESH_FORMATS = ("stl", "dae", "obj")
DEFAULT_RGBA = (0.72, 0.72, 0.75, 1.0)  # light grey, for visuals without a <material> colour
STAND_IN_RGBA = (0.5, 0.5, 0.5, 1.0)
STAND_IN_SIZE = 0.05  # m, edge of the grey box drawn in place of an unusable mesh
DEFAULT_FPS = 30.0
CAMERA_FOV = 45.0  # degrees, vertical field of view of the page's camera
ARROW_RGBA = (0.9, 0.1, 0.1, 1.0)  # red, the contact-force arrows
GROUND_RGBA = (0.8, 0.82, 0.85, 0.6)  # light grey-blue, slightly transparent
GROUND_THICKNESS = 0.02  # m, of the slab whose top face is the ground


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
      shape          "box", "cylinder", "sphere" or "mesh"
      size           box: (x, y, z) edge lengths; cylinder: (radius, length), its axis along the
                     z axis of the visual frame; sphere: (radius,); all in metres;
                     mesh: (sx, sy, sz) scale factors
      mesh_path      mesh: the resolved file (absolute path); None otherwise
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


# --------------------------------------------------------------------------------------------
# URDF visual geometry


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


# --------------------------------------------------------------------------------------------
# the motion


def resample(t, q, fps):
    """The motion at an even frame rate, by linear interpolation of each coordinate.

    t: (K,) s, non-decreasing; q: (K, nq). Returns (times (F,) s from t[0], Q (F, nq)) with F
    frames evenly spaced over [t[0], t[-1]], both ends included, about ``fps`` per second. A
    floating base's quaternion is interpolated the same way and normalised by the caller
    (``_build_scene``), which is the normalised linear interpolation of rotations.
    """
    duration = float(t[-1] - t[0])
    if duration <= 0.0:
        return np.zeros(1), q[:1].copy()
    n = max(2, int(round(duration * fps)) + 1)
    times = np.linspace(0.0, duration, n)
    rel = t - t[0]
    Q = np.empty((n, q.shape[1]))
    for j in range(q.shape[1]):
        Q[:, j] = np.interp(times, rel, q[:, j])
    return times, Q


def _check_motion(model, t, q, fps):
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"t must be a non-empty 1-D array of times (K,) in s, got shape {t.shape}")
    if q.ndim == 1 and t.size == 1:
        q = q[None, :]
    if q.ndim != 2 or q.shape != (t.size, model.nq):
        raise ValueError(
            f"q must have shape (K, nq) = ({t.size}, {model.nq}) for {t.size} times and the "
            f"{model.nq} coordinates of {model.name!r}, got shape {q.shape}"
        )
    if not np.all(np.isfinite(t)):
        raise ValueError("t has non-finite entries")
    if np.any(np.diff(t) < 0):
        k = int(np.argmax(np.diff(t) < 0))
        raise ValueError(f"t must be non-decreasing; t[{k + 1}] = {t[k + 1]} < t[{k}] = {t[k]}")
    bad = ~np.all(np.isfinite(q), axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"q has non-finite entries, first at sample {k} (t = {t[k]} s)")
    if fps is None:
        duration = float(t[-1] - t[0])
        native = (t.size - 1) / duration if duration > 0 else DEFAULT_FPS
        fps = min(DEFAULT_FPS, native)
    elif not (
        isinstance(fps, numbers.Real)
        and not isinstance(fps, bool)
        and math.isfinite(fps)
        and fps > 0
    ):
        raise ValueError(f"fps must be a positive number of frames per second, got {fps!r}")
    return t, q, float(fps)


def _check_contact(t, contact):
    """``contact`` as (ground_height float m, points (K, P, 3) m, forces (K, P, 3) N), or None;
    ValueError naming what is wrong."""
    if contact is None:
        return None
    form = "contact must be None or (ground_height, points (K, P, 3), forces (K, P, 3))"
    try:
        ground_height, points, forces = contact
        ground_height = float(ground_height)
        points = np.asarray(points, dtype=float)
        forces = np.asarray(forces, dtype=float)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{form}: {e}") from None
    if not math.isfinite(ground_height):
        raise ValueError(f"contact: ground_height must be finite, got {ground_height}")
    for name, a in (("points", points), ("forces", forces)):
        if a.ndim != 3 or a.shape[0] != t.size or a.shape[2] != 3:
            raise ValueError(
                f"{form}: {name} must have shape ({t.size}, P, 3) for the {t.size} times, got "
                f"shape {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise ValueError(f"contact: {name} has non-finite entries")
    if forces.shape != points.shape:
        raise ValueError(f"{form}: points {points.shape} and forces {forces.shape} differ in shape")
    return ground_height, points, forces


def _quaternions_xyzw(R):
    """(F, 3, 3) rotations -> (F, 4) unit quaternions (x, y, z, w), signs made continuous."""
    from scipy.spatial.transform import Rotation

    return _continuous(Rotation.from_matrix(R).as_quat())


def _continuous(quat):
    """(F, 4) unit quaternions with signs flipped so that neighbours are on the same side
    (the browser interpolates between neighbours along the short way)."""
    if len(quat) > 1:
        flips = np.einsum("ij,ij->i", quat[1:], quat[:-1]) < 0
        sign = np.cumprod(np.where(flips, -1.0, 1.0))
        quat[1:] *= sign[:, None]
    return quat


def _turn_z_onto(d):
    """(F, 3) unit vectors -> (F, 4) quaternions (x, y, z, w) of the shortest turns taking the
    z axis onto them (half way between z and d: normalise (z x d, 1 + z . d)); -z is reached
    by a half turn about x."""
    quat = np.column_stack([-d[:, 1], d[:, 0], np.zeros(len(d)), 1.0 + d[:, 2]])
    quat[quat[:, 3] < 1e-9] = (1.0, 0.0, 0.0, 0.0)
    return quat / np.linalg.norm(quat, axis=1, keepdims=True)


def _directions(f):
    """(F, 3) forces -> (F, 3) unit vectors along them; where a force is zero, the direction of
    the last nonzero one before it (else the first after it; +z when all are zero), so that a
    vanishing arrow shrinks without turning."""
    size = np.linalg.norm(f, axis=1)
    nonzero = np.flatnonzero(size > 0)
    if nonzero.size == 0:
        return np.tile([0.0, 0.0, 1.0], (len(f), 1))
    last = np.searchsorted(nonzero, np.arange(len(f)), side="right") - 1
    source = nonzero[np.maximum(last, 0)]
    return f[source] / size[source, None]


# --------------------------------------------------------------------------------------------
# the meshcat scene


def _meshcat():
    try:
        import meshcat  # noqa: F401
        import meshcat.animation  # noqa: F401
        import meshcat.geometry  # noqa: F401
        import meshcat.visualizer  # noqa: F401
    except ImportError as e:
        raise ImportError(MESHCAT_HINT) from e
    return meshcat


def _node_name(name):
    return name.replace("/", "_") or "_"


def _rotation_x(angle):
    c, s = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[1:3, 1:3] = [[c, -s], [s, c]]
    return T


def _geometry(mg, v):
    """(meshcat geometry, T_visual_geometry) for one Visual; raises OSError/ValueError for a
    mesh file meshcat cannot read."""
    if v.shape == "box":
        return mg.Box(list(v.size)), np.eye(4)
    if v.shape == "sphere":
        return mg.Sphere(v.size[0]), np.eye(4)
    if v.shape == "cylinder":
        # meshcat (three.js) cylinders lie along y, URDF cylinders along z: turn y onto z
        radius, length = v.size
        return mg.Cylinder(length, radius), _rotation_x(math.pi / 2)
    loader = {
        "stl": mg.StlMeshGeometry,
        "dae": mg.DaeMeshGeometry,
        "obj": mg.ObjMeshGeometry,
    }[pathlib.Path(v.mesh_path).suffix.lower().lstrip(".")]
    if os.path.getsize(v.mesh_path) == 0:
        raise ValueError("the file is empty")
    if loader is mg.DaeMeshGeometry:  # the browser's Collada loader needs well-formed XML
        from lxml import etree

        try:
            etree.parse(v.mesh_path)
        except etree.XMLSyntaxError as e:
            raise ValueError(f"not a well-formed Collada (XML) file: {e}") from None
    return loader.from_file(v.mesh_path), np.diag([*v.size, 1.0])


def _material(mg, rgba):
    r, g, b, a = (min(max(float(c), 0.0), 1.0) for c in rgba)
    colour = (int(round(r * 255)) << 16) | (int(round(g * 255)) << 8) | int(round(b * 255))
    return mg.MeshPhongMaterial(color=colour, opacity=a, transparent=a < 1.0)


@dataclass
class _Scene:
    """What a built scene shows: the world positions of its geometry (for the camera) and the
    words that give the contact-force arrows' scale ("" without contact)."""

    points: list = field(default_factory=list)  # (N, 3) arrays of world points
    radii: list = field(default_factory=list)  # (N,) extent about each point
    arrows: str = ""


def _build_scene(vis, model, t, q, fps, visuals, contact=None):
    """Send the robot's geometry and its animation to a meshcat Visualizer ``vis``; with
    ``contact`` (``_check_contact``'s form), the ground and the contact-force arrows too."""
    mc = _meshcat()
    mg = mc.geometry
    times, Q = resample(t, q, fps)
    if model.floating_base:
        Q = normalize(model, Q)  # the base's quaternion between samples
    root = vis[_node_name(model.name)]
    root.delete()
    _ground_grid(vis, mg, 0.0 if contact is None else contact[0])
    scene = _Scene()
    by_link: dict[str, list[Visual]] = {}
    for v in visuals:
        by_link.setdefault(v.link, []).append(v)
    anim = mc.animation.Animation()
    for link, items in by_link.items():
        try:
            model.frame_index(link)
        except KeyError:
            warnings.warn(
                f"link {link!r} of the URDF is not a frame of model {model.name!r}; "
                f"its visual geometry is not drawn",
                PlaybackWarning,
            )
            continue
        node = root[_node_name(link)]
        for k, v in enumerate(items):
            try:
                geometry, T_vg = _geometry(mg, v)
            except (OSError, ValueError, UnicodeDecodeError) as e:
                v = _stand_in(
                    model.source, link, v.T_link_visual, v.mesh_path, f"could not be read ({e})"
                )
                geometry, T_vg = _geometry(mg, v)
            child = node[f"visual_{k}"]
            child.set_object(geometry, _material(mg, v.rgba))
            child.set_transform(v.T_link_visual @ T_vg)
        T_sL = np.asarray(frame_pose(model, Q, link)).reshape(len(times), 4, 4)
        node.set_transform(T_sL[0])
        if len(times) > 1 and model.frames[model.frame_index(link)].body >= 0:
            anim.clips[node.path] = _clip(
                mc.animation, times, T_sL[:, :3, 3], _quaternions_xyzw(T_sL[:, :3, :3])
            )
        for v in items:
            scene.points.append((T_sL @ v.T_link_visual)[:, :3, 3])
            scene.radii.append(np.full(len(times), _extent(v)))
    if contact is not None:
        ground_height, points, forces = contact
        shape = (len(t), 3 * points.shape[1])
        points, forces = (
            resample(t, a.reshape(shape), fps)[1].reshape(len(times), -1, 3)
            for a in (points, forces)
        )
        _ground(vis, mg, ground_height, points)
        _force_arrows(vis, mc, anim, scene, times, points, forces)
    if anim.clips:
        # a loop: the page plays the motion over and over (pause and scrub in the controls)
        vis.set_animation(anim, play=True, repetitions=10**9)
    return scene


def _ground_grid(vis, mg, height=0.0, half_width=10.0, cell=0.5):
    """Replace meshcat's ground grid by the same one (20 m square, 0.5 m cells, darker centre
    lines) drawn as one short segment per cell side, 1 mm below z = ``height`` (m; 0, the
    default, lets the world axes show; with contact the ground's height). Software WebGL
    (headless browsers) drops whole grid lines that pass behind the camera; short segments
    lose only the part behind it."""
    ticks = np.arange(-half_width, half_width + cell / 2, cell)
    a, b = np.meshgrid(ticks[:-1], ticks)  # segment start along a line, the line's offset
    a, b = a.ravel(), b.ravel()
    z = np.full_like(a, height - 1e-3)
    along_x = np.stack([np.stack([a, b, z], 1), np.stack([a + cell, b, z], 1)], 1)
    along_y = along_x[:, :, [1, 0, 2]]
    points = np.concatenate([along_x, along_y]).reshape(-1, 3)
    centre = np.abs(np.concatenate([b, b])) < cell / 4
    grey = np.where(np.repeat(centre, 2), 0.27, 0.53)
    colours = np.repeat(grey[:, None], 3, axis=1)
    vis["/Grid"].set_object(
        mg.LineSegments(
            mg.PointsGeometry(points.T.astype(np.float32), colours.T.astype(np.float32)),
            mg.LineBasicMaterial(vertexColors=True),
        )
    )


def _ground(vis, mg, height, points, margin=1.0):
    """The ground z = ``height`` (m): a light, slightly transparent slab whose top face is 2 mm
    below that plane (under the grid), a square about the origin that holds the contact
    ``points`` (F, P, 3) m with ``margin`` (m) to spare and is at least as wide as the grid."""
    reach = float(np.abs(points[..., :2]).max()) if points.size else 0.0
    half_width = max(10.0, reach + margin)
    slab = vis["/Ground"]
    slab.set_object(
        mg.Box([2 * half_width, 2 * half_width, GROUND_THICKNESS]), _material(mg, GROUND_RGBA)
    )
    slab.set_transform(_translation(0.0, 0.0, height - 2e-3 - GROUND_THICKNESS / 2))


def _force_arrows(vis, mc, anim, scene, times, points, forces):
    """One red arrow per contact point, animated: from the point p (F, P, 3) m along the force
    f (F, P, 3) N, of length |f| times one scale for the run (``_force_scale``, from the
    robot's size; the words go to ``scene.arrows``). The camera frames the robot's motion
    alone: the arrows start at its contact points and are at most 0.4 times its size.

    An arrow is two nodes under ``/ContactForces/point_<p>``, each posed by position, quaternion
    and scale tracks: "shaft", a cylinder of unit length along its node's z axis from the
    node's origin, at p, scaled by (k, k, L - k h); and "head", a cone of length h along z,
    at p + (L - k h) d, scaled by k, where L is the arrow's length, d = f / |f| and
    k = min(1, L / h): an arrow shorter than the head is a smaller copy of the head, and a
    zero force has scale zero (nothing drawn)."""
    mg = mc.geometry
    size = _robot_size(scene)
    largest = float(np.linalg.norm(forces, axis=-1).max(initial=0.0))
    per_newton, scene.arrows = _force_scale(largest, size)
    radius, head_radius, head = 0.01 * size, 0.025 * size, 0.08 * size
    material = _material(mg, ARROW_RGBA)
    lengths = per_newton * np.linalg.norm(forces, axis=-1)  # (F, P)
    k = np.minimum(1.0, lengths / head)
    shaft = lengths - k * head
    upright = _rotation_x(math.pi / 2)  # meshcat's cylinders and cones lie along y
    for p in range(points.shape[1]):
        d = _directions(forces[:, p])
        quat = _continuous(_turn_z_onto(d))
        node = vis["/ContactForces"][f"point_{p}"]
        node["shaft"]["cylinder"].set_object(mg.Cylinder(1.0, radius), material)
        node["shaft"]["cylinder"].set_transform(_translation(0.0, 0.0, 0.5) @ upright)
        node["head"]["cone"].set_object(
            mg.Cylinder(head, radiusTop=0.0, radiusBottom=head_radius), material
        )
        node["head"]["cone"].set_transform(_translation(0.0, 0.0, head / 2) @ upright)
        shaft_scale = np.column_stack([k[:, p], k[:, p], shaft[:, p]])
        _pose(mc.animation, anim, node["shaft"], times, points[:, p], quat, shaft_scale)
        tail = points[:, p] + shaft[:, p, None] * d
        head_scale = np.repeat(k[:, p, None], 3, axis=1)
        _pose(mc.animation, anim, node["head"], times, tail, quat, head_scale)


def _robot_size(scene, least=0.1):
    """The robot's size (m): the largest diagonal, over the frames, of the box that holds its
    geometry at one frame; at least ``least``."""
    if not scene.points:
        return least
    pts, rad = np.stack(scene.points), np.stack(scene.radii)[..., None]  # (V, F, 3), (V, F, 1)
    diagonal = np.linalg.norm((pts + rad).max(axis=0) - (pts - rad).min(axis=0), axis=1)
    return max(least, float(diagonal.max()))


def _force_scale(largest, size):
    """(metres of arrow per newton, the page's words for it) for the largest force of the run
    (N) and the robot's size (m): a round number of newtons per metre (1, 2 or 5 times a power
    of ten), the least at which the largest force's arrow is at most 0.4 times the robot's size
    (so it is longer than 0.16 times); stated per a power of ten metres no longer than that
    arrow, e.g. "100 N per 0.1 m"."""
    if largest <= 0.0:
        return 0.0, "red arrows: contact forces, none in this run"
    least = largest / (0.4 * size)
    power = 10.0 ** math.floor(math.log10(least))
    per_metre = next(m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= least * (1 - 1e-12))
    reference = 10.0 ** math.floor(math.log10(largest / per_metre))
    words = f"red arrows: contact forces, {per_metre * reference:g} N per {reference:g} m"
    return 1.0 / per_metre, words


def _pose(animation, anim, node, times, position, quat, scale):
    """Pose ``node`` at frame 0 by its position (F, 3), quaternion (F, 4) (x, y, z, w) and scale
    (F, 3), and animate all three over ``times`` in ``anim`` when there are several frames
    (``animation``: the meshcat.animation module)."""
    node.set_property("position", position[0].tolist())
    node.set_property("quaternion", quat[0].tolist())
    node.set_property("scale", scale[0].tolist())
    if len(times) > 1:
        anim.clips[node.path] = _clip(animation, times, position, quat, scale)


def _translation(x, y, z):
    T = np.eye(4)
    T[:3, 3] = x, y, z
    return T


def _clip(animation, times, position, quat, scale=None):
    """A meshcat clip with key times in seconds (clip fps 1): position (F, 3) and quaternion
    (F, 4) (x, y, z, w) tracks, and a scale (F, 3) track when given."""
    track = animation.AnimationTrack
    keys = times.tolist()
    tracks = {
        "position": track("position", "vector3", keys, position.tolist()),
        "quaternion": track("quaternion", "quaternion", keys, quat.tolist()),
    }
    if scale is not None:
        tracks["scale"] = track("scale", "vector3", keys, scale.tolist())
    return animation.AnimationClip(tracks=tracks, fps=1)


def _extent(v):
    """Radius of a ball about the visual's origin that holds a primitive (0 for meshes)."""
    if v.shape == "box":
        return 0.5 * float(np.linalg.norm(v.size))
    if v.shape == "cylinder":
        return math.hypot(v.size[0], 0.5 * v.size[1])
    if v.shape == "sphere":
        return v.size[0]
    return 0.0


def _bounds(scene):
    """(lo, hi) corners of a box that holds the geometry over the whole motion, padded."""
    if not scene.points:
        return -np.ones(3), np.ones(3)
    pts = np.concatenate(scene.points)
    rad = np.concatenate(scene.radii)
    lo, hi = (pts - rad[:, None]).min(axis=0), (pts + rad[:, None]).max(axis=0)
    pad = max(0.05 * float(np.linalg.norm(hi - lo)), 0.05)
    return lo - pad, hi + pad


def _corners(lo, hi):
    """(8, 3) corners of the box [lo, hi]."""
    return np.array(np.meshgrid(*zip(lo, hi))).reshape(3, -1).T


def _view_direction(lo, hi):
    """Unit vector from the robot towards the camera. Its azimuth faces the vertical plane in
    which the swept box is widest (a planar motion is seen face on); its elevation is 25 deg,
    up to 65 deg when the box is flat (a motion in the horizontal plane is seen from above)."""
    extent = np.maximum(hi - lo, 1e-9)
    thin = extent / float(extent.max())
    horizontal = np.array([1.0 - 0.8 * thin[0], 1.0 - 0.8 * thin[1]])
    horizontal /= np.linalg.norm(horizontal)
    elevation = math.radians(25.0 + 40.0 * (1.0 - thin[2]))
    return np.array([*(math.cos(elevation) * horizontal), math.sin(elevation)])


def _camera(scene, aspect=4 / 3):
    """(target (3,), camera position (3,)) in the world frame so the robot fills the view.

    The camera looks at the centre of the box swept by the geometry over the motion, from
    ``_view_direction``, at the least distance at which all eight corners of the box lie in
    the field of view (CAMERA_FOV vertically, ``aspect`` times wider), plus 5%.
    """
    lo, hi = _bounds(scene)
    centre = 0.5 * (lo + hi)
    back = _view_direction(lo, hi)
    right = np.cross(-back, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -back)
    tan_v = math.tan(math.radians(CAMERA_FOV) / 2)
    tan_h = aspect * tan_v
    distance = 0.0
    for corner in _corners(lo, hi):
        rel = corner - centre
        need = rel @ back + max(abs(rel @ right) / tan_h, abs(rel @ up) / tan_v)
        distance = max(distance, need)
    return centre, centre + 1.05 * distance * back


def _live_camera(scene):
    """Camera position (3,) in the world frame for meshcat's live viewer, whose camera always
    looks at the world origin (75 deg field of view): far enough that the ball about the
    origin holding the swept box fits."""
    lo, hi = _bounds(scene)
    radius = float(np.linalg.norm(_corners(lo, hi), axis=1).max())
    return radius / math.sin(math.radians(75.0) / 2) * _view_direction(lo, hi)


# --------------------------------------------------------------------------------------------
# the self-contained page


class _SceneRecorder:
    """Stands in for meshcat's viewer window: keeps the scene that a Visualizer's commands
    build (as meshcat's server does) and writes it out as meshcat's static HTML export, so no
    server process or network port is needed to write a page."""

    web_url = None

    def __init__(self):
        self.nodes: dict[tuple, bytes] = {}  # (kind, path[, property]) -> packed command
        self.animation: bytes | None = None

    def send(self, command):
        import umsgpack

        data = command.lower()
        packed = umsgpack.packb(data)
        kind, path = data["type"], data["path"]
        if kind == "delete":
            prefix = path.rstrip("/") + "/"
            self.nodes = {
                k: v for k, v in self.nodes.items() if k[1] != path and not k[1].startswith(prefix)
            }
        elif kind == "set_animation":
            self.animation = packed
        elif kind == "set_property":
            self.nodes[(kind, path, data["property"])] = packed
        else:
            if kind == "set_object":  # a new object forgets the old one's properties
                self.nodes = {
                    k: v
                    for k, v in self.nodes.items()
                    if not (k[0] == "set_property" and k[1] == path)
                }
            self.nodes[(kind, path)] = packed

    def commands(self):
        order = {"set_object": 0, "set_property": 1, "set_transform": 2}
        items = sorted(self.nodes.items(), key=lambda kv: order[kv[0][0]])
        out = [v for _, v in items]
        if self.animation is not None:
            out.append(self.animation)
        return out

    def page(self, title, camera, caption=""):
        """The page: ``title``, the (target, position) ``camera``, and a ``caption`` line at the
        bottom left (none when "")."""
        import meshcat

        js_file = pathlib.Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        viewer_js = js_file.read_text(encoding="utf-8")
        lines = [
            f'command("{base64.b64encode(packed).decode("ascii")}");' for packed in self.commands()
        ]
        target, position = camera
        return _PAGE.format(
            title=_html_escape(title),
            caption=_CAPTION.format(text=_html_escape(caption)) if caption else "",
            viewer_js=viewer_js,
            commands="\n".join(lines),
            target=_three_js(target),
            position=_three_js(position),
            fov=CAMERA_FOV,
        )

    def get_scene(self):  # what Visualizer.static_html() asks its window for
        return self.page("opendyn playback", (np.zeros(3), np.array([3.0, 0.0, 1.0])))


def _three_js(p_s):
    """A point of meshcat's world (z up) in three.js's world (y up), as JavaScript numbers."""
    x, y, z = (float(c) for c in p_s)
    return f"{x:.6g}, {z:.6g}, {-y:.6g}"


def _html_escape(text):
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


_CAPTION = """
<div id="opendyn-caption" style="position: absolute; left: 8px; bottom: 8px; padding: 2px 6px; \
font: 13px sans-serif; color: #222; background: rgba(255, 255, 255, 0.75);">{text}</div>"""

_PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ margin: 0; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>{caption}
<script>
{viewer_js}
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
// meshcat commands (msgpack, base64), applied in order without any fetch
function command(b64) {{
  var s = atob(b64), bytes = new Uint8Array(s.length);
  for (var i = 0; i < s.length; i++) bytes[i] = s.charCodeAt(i);
  try {{
    viewer.handle_command_bytearray(bytes);
  }} catch (e) {{
    console.error("opendyn playback: a scene command failed:", e);
  }}
}}
{commands}
// camera: orbiting about the robot's centre; its coordinates are three.js's world (y up),
// which is meshcat's world (z up) as (x, z, -y)
(function () {{
  var camera = viewer.camera;
  camera.fov = {fov};
  camera.position.set({position});
  viewer.controls.target.set({target});
  viewer.controls.update();
  viewer.set_dirty();
}})();
</script>
</body>
</html>
"""


def write_html(model, t, q, path, *, fps=None, contact=None) -> pathlib.Path:
    """Write a self-contained HTML page that plays the motion of ``model``.

    Args:
      model: the Model; its visual geometry is read from the URDF it was loaded from
        (``load_visuals``).
      t: (K,) sample times in s, non-decreasing.
      q: (K, nq) coordinates at those times (rad or m; a floating base's position and
        quaternion first: the base moves in the playback).
      path: the .html file to write.
      fps: frames per second of the animation (the motion is linearly interpolated to it);
        default the trajectory's own rate, at most 30.
      contact: None, or (ground_height, points, forces) sampled at the times t: the ground is
        the plane z = ground_height (m); points (K, P, 3) m, world frame, where each contact
        point touches (or would touch) the ground; forces (K, P, 3) N, world frame, the force
        the ground applies to the robot at each point. The page then draws the ground (a
        light slab, the grid moved onto it) and each force as a red arrow from its point,
        |f| times one scale for the run (a round number of newtons per metre, at which the
        largest force is drawn 0.16 to 0.4 times the robot's size), stated in the page's title
        and at its bottom left; the arrows are interpolated like q and vanish where the force
        is zero.

    The page is meshcat's static export (viewer JavaScript, geometry, meshes and animation
    inlined; it opens offline, from a file). It loops the motion; the controls at the top
    right pause it and scrub the time. Missing meshes warn (PlaybackWarning) and are drawn as
    small grey boxes. The page is written atomically (a temporary file beside it, then
    renamed): never left truncated. Returns the path written. Raises ImportError naming the
    install command without meshcat, ValueError naming the argument for bad t, q, fps or
    contact.
    """
    t, q, fps = _check_motion(model, t, q, fps)
    contact = _check_contact(t, contact)
    _meshcat()
    from meshcat.visualizer import Visualizer

    recorder = _SceneRecorder()
    vis = Visualizer(window=recorder)
    scene = _build_scene(vis, model, t, q, fps, load_visuals(model), contact)
    title = f"{model.name} - opendyn" + (f" ({scene.arrows})" if scene.arrows else "")
    out = pathlib.Path(path)
    with atomic_write(out) as f:
        f.write(recorder.page(title, _camera(scene), scene.arrows).encode("utf-8"))
    return out


def view(model, t, q, *, open_browser=False, fps=None, contact=None) -> str:
    """Play the motion of ``model`` in a live meshcat viewer; returns the viewer's URL.

    Starts a meshcat server (``meshcat.Visualizer()``, a subprocess that lives as long as this
    Python process), sends the visual geometry and the animation (t (K,) s, q (K, nq), and
    the ground and contact-force arrows for ``contact``, as in ``write_html``; the live viewer
    has no caption, so the arrows' scale is not stated there), and opens the page in a web
    browser when ``open_browser``. The scene stays on the server: a browser that connects
    later sees it and plays it.
    """
    t, q, fps = _check_motion(model, t, q, fps)
    contact = _check_contact(t, contact)
    _meshcat()
    from meshcat.visualizer import Visualizer

    with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL; we return it
        vis = Visualizer()
    scene = _build_scene(vis, model, t, q, fps, load_visuals(model), contact)
    eye = _live_camera(scene)
    # the camera's coordinates are three.js's world (y up): meshcat's (x, y, z) is (x, z, -y)
    vis["/Cameras/default/rotated/<object>"].set_property(
        "position", [float(eye[0]), float(eye[2]), float(-eye[1])]
    )
    if open_browser:
        vis.open()
    return vis.url()
