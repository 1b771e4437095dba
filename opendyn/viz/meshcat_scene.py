"""The meshcat scene of a motion: every URDF link's visual geometry, posed over time.

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

meshcat is an optional dependency (``pip install 'opendyn[viz]'``), imported only when a scene is
built (``_meshcat``).
"""

from __future__ import annotations

import math
import os
import pathlib
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..algorithm.configuration import normalize
from ..algorithm.kinematics import frame_pose
from ..multibody.joints import FREE
from .motion import _continuous, _directions, _quaternions_xyzw, _turn_z_onto, resample
from .visuals import PlaybackWarning, Visual, _stand_in

MESHCAT_HINT = "playback needs meshcat: pip install 'opendyn[viz]'"
ARROW_RGBA = (0.9, 0.1, 0.1, 1.0)  # red, the contact-force arrows
GROUND_RGBA = (0.8, 0.82, 0.85, 0.6)  # light grey-blue, slightly transparent
GROUND_THICKNESS = 0.02  # m, of the slab whose top face is the ground
PLANE_WIDTH = 4.0  # m, the square drawn of a world plane


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
    if v.shape == "capsule":
        import trimesh

        capsule = trimesh.creation.capsule(height=v.size[1], radius=v.size[0])
        return mg.TriangularMeshGeometry(capsule.vertices, capsule.faces), np.eye(4)
    if v.shape == "halfspace":  # a slab whose top face is the plane
        return mg.Box([PLANE_WIDTH, PLANE_WIDTH, GROUND_THICKNESS]), _translation(
            0.0, 0.0, -GROUND_THICKNESS / 2
        )
    if v.shape == "hull":
        from scipy.spatial import ConvexHull, QhullError

        try:
            faces = ConvexHull(v.vertices).simplices
        except QhullError:  # a flat hull: drawn as its points' fan
            faces = np.array([(0, k, k + 1) for k in range(1, len(v.vertices) - 1)])
        return mg.TriangularMeshGeometry(v.vertices, faces), np.eye(4)
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
    if np.any(model.jtype == FREE):
        Q = normalize(model, Q)  # a floating base's or an object's quaternion between samples
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
    """Radius of a ball about the visual's origin that holds a primitive or a hull (0 for
    meshes)."""
    if v.shape == "box":
        return 0.5 * float(np.linalg.norm(v.size))
    if v.shape == "cylinder":
        return math.hypot(v.size[0], 0.5 * v.size[1])
    if v.shape == "capsule":
        return v.size[0] + 0.5 * v.size[1]
    if v.shape == "sphere":
        return v.size[0]
    if v.shape == "hull":
        return float(np.max(np.linalg.norm(v.vertices, axis=1)))
    return 0.0
