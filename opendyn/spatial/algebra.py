"""Spatial algebra of rigid bodies: the readable NumPy reference implementation.

This module provides the rotation and rigid-motion groups SO(3) and SE(3),
their exponential and logarithm maps, the adjoint representations, spatial
inertias and the Newton-Euler equations of a single rigid body, written for
clarity and exactness rather than speed. It follows the conventions of
Lynch & Park, "Modern Robotics: Mechanics, Planning, and Control" (2017),
chapters 3 and 8: twists are V = (omega, v) and wrenches are F = (m, f), with
the angular part first; homogeneous transforms are (4, 4) arrays
T = [[R, p], [0, 1]]; names carry their frames, so T_sb is the configuration
of frame {b} relative to {s}, V_b a twist expressed in {b} and Ad_T the (6, 6)
adjoint of T. Units are SI (m, rad, kg, s, N, N m).
"""

import numpy as np

_ROTATION_TOLERANCE = 1e-6
# URDF inertias are usually written to about 6 significant digits, and rounding them moves the
# principal moments by about 1e-6 of the largest: a violation below 1e-5 of it is rounding
_INERTIA_RELATIVE_TOLERANCE = 1e-5
_SKEW_RELATIVE_TOLERANCE = 1e-9
# below this (kg m^2: a milligram a micrometre from its axis) an inertia entry is rounding noise
_INERTIA_ABSOLUTE_TOLERANCE = 1e-18
_SERIES_THRESHOLD = 0.1


def _as_array(value, name, shape):
    """Return `value` as a finite float array of `shape`, else raise ValueError naming it;
    entries that are not real numbers (booleans, text such as "2.5", complex numbers,
    objects) are a TypeError naming it, never converted.

    A leading Ellipsis in `shape` allows any number of leading axes.
    """
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a numeric array, got {value!r}") from error
    if raw.dtype.kind not in "iuf":
        raise TypeError(
            f"{name} must be a number or an array of numbers (integers or floats), got "
            f"{type(value).__name__} {value!r}"
        )
    array = np.asarray(raw, dtype=float)  # a view of a float array: angular(V)[:] = ... writes V
    if shape and shape[0] is Ellipsis:
        trailing = tuple(shape[1:])
        matches = (
            array.ndim >= len(trailing) and array.shape[array.ndim - len(trailing) :] == trailing
        )
    else:
        matches = array.shape == tuple(shape)
    if not matches:
        raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array}")
    return array


def _as_rotation(R, name):
    """Return `R` as a (3, 3) rotation matrix, else raise ValueError naming it."""
    R = _as_array(R, name, (3, 3))
    if not np.allclose(R.T @ R, np.eye(3), rtol=0.0, atol=_ROTATION_TOLERANCE):
        raise ValueError(f"{name} must be orthonormal (R^T R = I), got {R}")
    if abs(np.linalg.det(R) - 1.0) > _ROTATION_TOLERANCE:
        raise ValueError(f"{name} must have determinant +1, got {np.linalg.det(R)}")
    return R


def _as_transform(T, name):
    """Return the rotation R (3, 3) and translation p (3,) of the homogeneous transform `T`."""
    T = _as_array(T, name, (4, 4))
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=_ROTATION_TOLERANCE):
        raise ValueError(f"{name} must have last row [0, 0, 0, 1], got {T[3]}")
    return _as_rotation(T[:3, :3], name), T[:3, 3]


def _as_symmetric(I, name):
    """Return `I` as an exactly symmetric (3, 3) matrix, else raise ValueError naming it."""
    I = _as_array(I, name, (3, 3))
    tolerance = _INERTIA_RELATIVE_TOLERANCE * np.abs(I).max()
    if np.abs(I - I.T).max() > tolerance:
        raise ValueError(f"{name} must be symmetric, got {I}")
    return 0.5 * (I + I.T)


def _as_rotational_inertia(I, name):
    """Return `I` as a physically valid rotational inertia, else raise ValueError naming it.

    Valid means symmetric, positive semi-definite, and principal moments satisfying the
    triangle inequality, each within a tolerance relative to the largest entry of `I` (plus an
    absolute 1e-18 kg m^2, so that an inertia of rounding noise, e.g. 2e-35, counts as zero).
    """
    I = _as_symmetric(I, name)
    moments = np.linalg.eigvalsh(I)
    tolerance = _INERTIA_RELATIVE_TOLERANCE * np.abs(I).max() + _INERTIA_ABSOLUTE_TOLERANCE
    if moments[0] < -tolerance:
        raise ValueError(f"{name} must be positive semi-definite, got principal moments {moments}")
    if moments[2] > moments[0] + moments[1] + tolerance:
        raise ValueError(
            f"{name} violates the triangle inequality of principal moments, got {moments}"
        )
    return I


def _as_twist(V, name):
    """Return `V` as a (6,) twist or wrench, else raise ValueError naming it."""
    return _as_array(V, name, (6,))


def _exp_coefficients(theta):
    """Return (sin t / t, (1 - cos t) / t^2, (t - sin t) / t^3) at t = theta >= 0, stably."""
    sin_ratio = np.sinc(theta / np.pi)
    cos_ratio = 0.5 * np.sinc(theta / (2.0 * np.pi)) ** 2
    if theta < _SERIES_THRESHOLD:
        t2 = theta * theta
        cubic_ratio = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0
    else:
        cubic_ratio = (theta - np.sin(theta)) / theta**3
    return sin_ratio, cos_ratio, cubic_ratio


def _log_coefficient(theta):
    """Return (1 - (t / 2) cot(t / 2)) / t^2 at t = theta in [0, pi], stably."""
    if theta < _SERIES_THRESHOLD:
        t2 = theta * theta
        return 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
    half = 0.5 * theta
    return (1.0 - half * np.cos(half) / np.sin(half)) / theta**2


def angular(V):
    """omega = V[..., :3], the angular part of twists (or moment part of wrenches) V.

    V: (..., 6) twists (omega, v) or wrenches (m, f), angular first.
    Returns a (..., 3) view, in the same frame and units as V (rad/s or N m).
    """
    return _as_array(V, "V", (..., 6))[..., :3]


def linear(V):
    """v = V[..., 3:], the linear part of twists (or force part of wrenches) V.

    V: (..., 6) twists (omega, v) or wrenches (m, f), angular first.
    Returns a (..., 3) view, in the same frame and units as V (m/s or N).
    """
    return _as_array(V, "V", (..., 6))[..., 3:]


def skew(w):
    """[w] = [[0, -w3, w2], [w3, 0, -w1], [-w2, w1, 0]], so that [w] x = w x x.

    w: (3,) vector. Returns the (3, 3) skew-symmetric matrix [w] in so(3).
    """
    w1, w2, w3 = _as_array(w, "w", (3,))
    return np.array([[0.0, -w3, w2], [w3, 0.0, -w1], [-w2, w1, 0.0]])


def unskew(W):
    """w = (W[2, 1], W[0, 2], W[1, 0]), the inverse of skew: unskew([w]) = w.

    W: (3, 3) skew-symmetric matrix (within 1e-9 relative to its largest entry).
    Returns the (3,) vector w.
    """
    W = _as_array(W, "W", (3, 3))
    if np.abs(W + W.T).max() > _SKEW_RELATIVE_TOLERANCE * np.abs(W).max():
        raise ValueError(f"W must be skew-symmetric, got {W}")
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def exp_so3(w):
    """R = exp([w]) = I + (sin t / t) [w] + ((1 - cos t) / t^2) [w]^2, t = |w|
    (Rodrigues, MR eq. 3.51).

    w: (3,) exponential coordinates omega_hat * theta (rad), omega_hat a unit axis.
    Returns the (3, 3) rotation matrix R in SO(3); w = 0 gives the identity.
    """
    w = _as_array(w, "w", (3,))
    sin_ratio, cos_ratio, _ = _exp_coefficients(np.linalg.norm(w))
    W = skew(w)
    return np.eye(3) + sin_ratio * W + cos_ratio * (W @ W)


def rpy_matrix(rpy):
    """R = Rz(yaw) Ry(pitch) Rx(roll): URDF's roll, pitch, yaw, rotations about the fixed x, y
    and z axes in that order (the URDF specification's <origin rpy>, ROS REP 103).

    rpy: (3,) angles (roll, pitch, yaw) (rad).
    Returns the (3, 3) rotation matrix R in SO(3).
    """
    roll, pitch, yaw = _as_array(rpy, "rpy", (3,))
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def log_so3(R):
    """w = log(R) with [w] = (t / (2 sin t)) (R - R^T), cos t = (tr R - 1) / 2 (MR Section 3.2.3.3).

    R: (3, 3) rotation matrix (orthonormal with determinant +1 within 1e-6).
    Returns the (3,) exponential coordinates w = omega_hat * theta, theta = |w| in [0, pi].
    theta is computed as atan2(sin, cos) so it stays exact near 0. For theta > pi / 2 the
    axis is taken, as in MR for theta = pi, from the column of
    omega_hat omega_hat^T = ((R + R^T) / 2 - cos t I) / (1 - cos t) with the largest
    diagonal entry, with its sign fixed by R - R^T; at theta = pi either sign is valid.
    """
    R = _as_rotation(R, "R")
    doubled_sin_axis = unskew(R - R.T)
    cos_theta = 0.5 * (np.trace(R) - 1.0)
    theta = np.arctan2(0.5 * np.linalg.norm(doubled_sin_axis), cos_theta)
    if cos_theta >= 0.0:
        return doubled_sin_axis / (2.0 * np.sinc(theta / np.pi))
    axis_outer = (0.5 * (R + R.T) - cos_theta * np.eye(3)) / (1.0 - cos_theta)
    k = np.argmax(np.diag(axis_outer))
    axis = axis_outer[:, k] / np.linalg.norm(axis_outer[:, k])
    if axis @ doubled_sin_axis < 0.0:
        axis = -axis
    return theta * axis


def twist_to_matrix(V):
    """[V] = [[[omega], v], [0, 0]], the se(3) matrix of the twist V = (omega, v).

    V: (6,) twist (rad/s, m/s) or exponential coordinates S * theta, in any frame.
    Returns the (4, 4) matrix [V] in se(3), in the same frame as V.
    """
    V = _as_twist(V, "V")
    matrix = np.zeros((4, 4))
    matrix[:3, :3] = skew(angular(V))
    matrix[:3, 3] = linear(V)
    return matrix


def exp_se3(V):
    """T = exp([V]) = [[exp([w]), (I + ((1 - cos t) / t^2) [w] + ((t - sin t) / t^3) [w]^2) v],
                       [0, 1]],  t = |w|  (MR eq. 3.88).

    V: (6,) exponential coordinates V = S * theta = (w, v), with w = omega * theta (rad)
    and v the linear part (m). The coefficients are evaluated by series for small t, so
    w = 0 gives the pure translation T = [[I, v], [0, 1]].
    Returns the (4, 4) homogeneous transform T in SE(3).
    """
    V = _as_twist(V, "V")
    w, v = angular(V), linear(V)
    _, cos_ratio, cubic_ratio = _exp_coefficients(np.linalg.norm(w))
    W = skew(w)
    T = np.eye(4)
    T[:3, :3] = exp_so3(w)
    T[:3, 3] = (np.eye(3) + cos_ratio * W + cubic_ratio * (W @ W)) @ v
    return T


def log_se3(T):
    """V = log(T) = (w, (I - [w] / 2 + ((1 - (t / 2) cot(t / 2)) / t^2) [w]^2) p),
    w = log_so3(R), t = |w|  (MR eqs. 3.91-3.92).

    T: (4, 4) homogeneous transform [[R, p], [0, 1]] (p in m).
    Returns the (6,) exponential coordinates V = S * theta = (w, v) with exp_se3(V) = T
    and theta = |w| in [0, pi]; near the identity the coefficient is evaluated by series,
    and a pure translation gives V = (0, p).
    """
    R, p = _as_transform(T, "T")
    w = log_so3(R)
    W = skew(w)
    v = (np.eye(3) - 0.5 * W + _log_coefficient(np.linalg.norm(w)) * (W @ W)) @ p
    return np.concatenate([w, v])


def inverse_transform(T):
    """T^-1 = [[R^T, -R^T p], [0, 1]] for T = [[R, p], [0, 1]].

    T: (4, 4) homogeneous transform, e.g. T_ab (p in m).
    Returns the (4, 4) inverse transform, e.g. T_ba.
    """
    R, p = _as_transform(T, "T")
    T_inv = np.eye(4)
    T_inv[:3, :3] = R.T
    T_inv[:3, 3] = -R.T @ p
    return T_inv


def adjoint(T):
    """Ad_T = [[R, 0], [[p] R, R]] for T = [[R, p], [0, 1]] (MR Section 3.3.2).

    T: (4, 4) homogeneous transform T_ab (p in m).
    Returns the (6, 6) adjoint Ad_T, mapping twists V_b in {b} to V_a = Ad_T V_b in {a}.
    """
    R, p = _as_transform(T, "T")
    return np.block([[R, np.zeros((3, 3))], [skew(p) @ R, R]])


def ad(V):
    """ad_V = [[[w], 0], [[v], [w]]] for the twist V = (w, v) (MR Section 8.2.2).

    V: (6,) twist (rad/s, m/s) in some frame.
    Returns the (6, 6) matrix ad_V in the same frame, with ad_V V2 = [V, V2].
    """
    V = _as_twist(V, "V")
    W = skew(angular(V))
    return np.block([[W, np.zeros((3, 3))], [skew(linear(V)), W]])


def lie_bracket(V1, V2):
    """[V1, V2] = ad_{V1} V2, whose se(3) matrix is [V1][V2] - [V2][V1].

    V1, V2: (6,) twists in the same frame.
    Returns the (6,) twist ad_{V1} V2 in that frame.
    """
    return ad(_as_twist(V1, "V1")) @ _as_twist(V2, "V2")


def spatial_inertia(mass, com, I_com, R_com=None, physical=True):
    """G = [[I_c + m [c][c]^T, m [c]], [m [c]^T, m 1]], I_c = R_com I_com R_com^T, c = com.

    The spatial inertia (6, 6) of a rigid body about the origin of its frame {b}, with
    axes those of {b} and rows/columns ordered (angular, linear), so that its kinetic
    energy is 1/2 V_b^T G V_b = 1/2 m |v + w x c|^2 + 1/2 w^T I_c w for V_b = (w, v).
    mass: scalar m >= 0 (kg).
    com: (3,) centre of mass position c in {b} (m).
    I_com: (3, 3) rotational inertia about the centre of mass (kg m^2), expressed in a
        frame with orientation R_com relative to {b}; it must be symmetric, positive
        semi-definite and satisfy the triangle inequality of its principal moments.
    R_com: (3, 3) rotation of the frame of I_com relative to {b}; None means identity.
    physical: False accepts any symmetric I_com (no semi-definiteness or triangle check), for
        inertias that a URDF states and the user chose to keep as written.
    """
    mass = float(_as_array(mass, "mass", ()))
    if mass < 0.0:
        raise ValueError(f"mass must be non-negative, got {mass}")
    c = skew(_as_array(com, "com", (3,)))
    I_com = (_as_rotational_inertia if physical else _as_symmetric)(I_com, "I_com")
    R_com = np.eye(3) if R_com is None else _as_rotation(R_com, "R_com")
    I_c = R_com @ I_com @ R_com.T
    return np.block([[I_c + mass * c @ c.T, mass * c], [mass * c.T, mass * np.eye(3)]])


def transform_inertia(G_b, T_ba):
    """G_a = [Ad_{T_ba}]^T G_b [Ad_{T_ba}] (MR Section 8.2.2).

    G_b: (6, 6) spatial inertia about the origin of {b}, in {b} axes.
    T_ba: (4, 4) configuration of {a} relative to {b}.
    Returns the (6, 6) spatial inertia G_a of the same body about the origin of {a}.
    """
    G_b = _as_array(G_b, "G_b", (6, 6))
    _as_transform(T_ba, "T_ba")
    Ad_T_ba = adjoint(T_ba)
    return Ad_T_ba.T @ G_b @ Ad_T_ba


def principal_axes(I):
    """I = R_bp diag(moments) R_bp^T, the eigen-decomposition of a rotational inertia.

    I: (3, 3) symmetric rotational inertia in frame {b} (kg m^2).
    Returns (moments, R_bp): the (3,) principal moments in ascending order and the
    (3, 3) rotation matrix (det +1) whose columns are the principal axes in {b}, so
    that I_p = R_bp^T I R_bp is diagonal. The third column is flipped if needed to make
    the frame right-handed.
    """
    I = _as_symmetric(I, "I")
    moments, R_bp = np.linalg.eigh(I)
    if np.linalg.det(R_bp) < 0.0:
        R_bp[:, 2] = -R_bp[:, 2]
    return moments, R_bp


def rigid_body_wrench(G_b, V_b, dV_b):
    """F_b = G_b dV_b - [ad_{V_b}]^T G_b V_b (MR Section 8.2.2), inverse dynamics of one rigid body.

    G_b: (6, 6) spatial inertia about the origin of the body frame {b}.
    V_b: (6,) body twist (rad/s, m/s) in {b}; dV_b: (6,) its time derivative (rad/s^2, m/s^2).
    Returns the (6,) wrench F_b = (m, f) in {b} (N m, N) that produces the motion.
    """
    G_b = _as_array(G_b, "G_b", (6, 6))
    V_b = _as_twist(V_b, "V_b")
    dV_b = _as_twist(dV_b, "dV_b")
    return G_b @ dV_b - ad(V_b).T @ G_b @ V_b


def rigid_body_acceleration(G_b, V_b, F_b):
    """dV_b = G_b^-1 (F_b + [ad_{V_b}]^T G_b V_b), forward dynamics of one rigid body.

    G_b: (6, 6) non-singular spatial inertia about the origin of the body frame {b}.
    V_b: (6,) body twist (rad/s, m/s) in {b}; F_b: (6,) applied wrench (N m, N) in {b}.
    Returns the (6,) body acceleration dV_b (rad/s^2, m/s^2), solved without inverting G_b.
    """
    G_b = _as_array(G_b, "G_b", (6, 6))
    V_b = _as_twist(V_b, "V_b")
    F_b = _as_twist(F_b, "F_b")
    if np.linalg.matrix_rank(G_b) < 6:
        raise ValueError(f"G_b must be non-singular, got {G_b}")
    return np.linalg.solve(G_b, F_b + ad(V_b).T @ G_b @ V_b)


def kinetic_energy_body(G_b, V_b):
    """K = 1/2 V_b^T G_b V_b.

    G_b: (6, 6) spatial inertia about the origin of {b}; V_b: (6,) twist in {b}.
    Returns the scalar kinetic energy K (J).
    """
    G_b = _as_array(G_b, "G_b", (6, 6))
    V_b = _as_twist(V_b, "V_b")
    return 0.5 * float(V_b @ G_b @ V_b)
