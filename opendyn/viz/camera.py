"""Where playback's camera stands: the box the geometry of a built scene sweeps over the motion,
seen from the side where it is widest, by the page's camera (``_camera``) or meshcat's live
viewer's (``_live_camera``).
"""

from __future__ import annotations

import math

import numpy as np

CAMERA_FOV = 45.0  # degrees, vertical field of view of the page's camera


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
