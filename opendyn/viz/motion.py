"""The motion as playback draws it: t (K,) s and q (K, nq) (and the contact points and forces)
checked, resampled by linear interpolation to the frame rate; rotations as quaternion tracks whose
signs are continuous, and the directions of the contact-force arrows.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

DEFAULT_FPS = 30.0


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
