"""Playback of a motion q(t) in meshcat: every URDF link's visual geometry, posed over time.

``write_html`` writes a self-contained page (meshcat's static export: the viewer's JavaScript,
the geometry and the animation inlined; no network access); ``view`` plays the same scene in a
live meshcat viewer. meshcat is an optional dependency (``pip install 'opendyn[viz]'``),
imported only when a playback function runs; the core never imports this package.
"""

from __future__ import annotations

import contextlib
import io
import pathlib

from .._runtime.files import atomic_write
from .camera import _camera, _live_camera
from .meshcat_scene import _build_scene, _meshcat
from .motion import _check_contact, _check_motion
from .page import _SceneRecorder
from .visuals import scene_visuals


def write_html(model, t, q, path, *, fps=None, contact=None, collision=False) -> pathlib.Path:
    """Write a self-contained HTML page that plays the motion of ``model``.

    Args:
      model: the Model; its visual geometry is read from the URDF it was loaded from
        (``load_visuals``); a scene's objects and static world are drawn from their collision
        geometry (objects in blue, the world in grey: ``world_visuals``).
      t: (K,) sample times in s, non-decreasing.
      q: (K, nq) coordinates at those times (rad or m; a floating base's position and
        quaternion first: the base moves in the playback).
      path: the .html file to write.
      fps: frames per second of the animation (the motion is linearly interpolated to it);
        default the trajectory's own rate, at most 30.
      contact: None, or (ground_height, points, forces) sampled at the times t: the ground is
        the plane z = ground_height (m); points (K, P, 3) m, world frame, where each contact
        point touches (or would touch) the ground; forces (K, P, 3) N, world frame, the force
        the ground applies to the robot at each point (or, between collision geometries,
        ``ContactTable.slots``: the force on the moving body of each pair). The page then
        draws the ground (a light slab, the grid moved onto it) and each force as a red arrow
        from its point, |f| times one scale for the run (a round number of newtons per metre,
        at which the largest force is drawn 0.16 to 0.4 times the robot's size), stated in the
        page's title and at its bottom left; the arrows are interpolated like q and vanish
        where the force is zero.
      collision: True draws the collision geometry (``model.geometries``, meshes as their
        convex hulls, in translucent orange) instead of the visual geometry.

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
    visuals = scene_visuals(model, collision)
    scene = _build_scene(vis, model, t, q, fps, visuals, contact)
    title = f"{model.name} - opendyn" + (f" ({scene.arrows})" if scene.arrows else "")
    out = pathlib.Path(path)
    with atomic_write(out) as f:
        f.write(recorder.page(title, _camera(scene), scene.arrows).encode("utf-8"))
    return out


def view(model, t, q, *, open_browser=False, fps=None, contact=None, collision=False) -> str:
    """Play the motion of ``model`` in a live meshcat viewer; returns the viewer's URL.

    Starts a meshcat server (``meshcat.Visualizer()``, a subprocess that lives as long as this
    Python process), sends the visual geometry and the animation (t (K,) s, q (K, nq), and
    the ground and contact-force arrows for ``contact``, as in ``write_html``; the live viewer
    has no caption, so the arrows' scale is not stated there; with ``collision`` the collision
    geometry in place of the visual geometry, as in ``write_html``), and opens the page in a web
    browser when ``open_browser``. The scene stays on the server: a browser that connects
    later sees it and plays it.
    """
    t, q, fps = _check_motion(model, t, q, fps)
    contact = _check_contact(t, contact)
    _meshcat()
    from meshcat.visualizer import Visualizer

    with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL; we return it
        vis = Visualizer()
    visuals = scene_visuals(model, collision)
    scene = _build_scene(vis, model, t, q, fps, visuals, contact)
    eye = _live_camera(scene)
    # the camera's coordinates are three.js's world (y up): meshcat's (x, y, z) is (x, z, -y)
    vis["/Cameras/default/rotated/<object>"].set_property(
        "position", [float(eye[0]), float(eye[2]), float(-eye[1])]
    )
    if open_browser:
        vis.open()
    return vis.url()
