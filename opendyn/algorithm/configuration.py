"""The configuration space: q' = q (+) v dt, its inverse v = q1 (-) q0, and the special points.

    q (+) v dt:  each joint's own update (joints.joint_integrate): q_i + v_i dt for a 1-dof
                 joint, T_i exp([V_i] dt) for a free joint (the exponential map of SE(3), its
                 body twist held for dt seconds, quaternion renormalised)
    q1 (-) q0:   the v that integrates q0 to q1 in unit time: q1_i - q0_i, or log(T_0^-1 T_1)

Integrators never add to q themselves: they call `integrate`, so a floating base (a quaternion
in q, nq = nv + 1) changes these functions and no integrator.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.options import as_real
from .._runtime.kernel_cache import INLINE, JIT
from ..multibody.joints import (
    FREE,
    PRISMATIC,
    QUATERNION_TOLERANCE,
    joint_difference,
    joint_integrate,
    normalize_quaternion,
)
from ..multibody.layout import _IQ, _IV, _JTYPE, body_count, field
from . import checks


@njit(**INLINE)
def integrate_kernel(ibuf, q, v, dt, q_next):
    """q_next (nq,) <- q (+) v dt, with v (nv,) a velocity held for dt seconds."""
    nb = body_count(ibuf)
    jtype, iq, iv = field(ibuf, nb, _JTYPE), field(ibuf, nb, _IQ), field(ibuf, nb, _IV)
    for i in range(nb):
        joint_integrate(ibuf, jtype[i], q, iq[i], v, iv[i], dt, q_next)


@njit(**JIT)
def difference_kernel(ibuf, q0, q1, v):
    """v (nv,) <- q1 (-) q0."""
    nb = body_count(ibuf)
    jtype, iq, iv = field(ibuf, nb, _JTYPE), field(ibuf, nb, _IQ), field(ibuf, nb, _IV)
    for i in range(nb):
        joint_difference(ibuf, jtype[i], q0, q1, iq[i], iv[i], v)


@njit(**JIT)
def integrate_rows(ibuf, q, v, dt, q_next):
    """integrate_kernel over the rows of a batch: q (N, nq), v (N, nv)."""
    for n in range(q.shape[0]):
        integrate_kernel(ibuf, q[n], v[n], dt, q_next[n])


@njit(**JIT)
def normalize_kernel(ibuf, q):
    """Each free joint's quaternion in q (nq,) <- itself / its norm."""
    nb = body_count(ibuf)
    jtype, iq = field(ibuf, nb, _JTYPE), field(ibuf, nb, _IQ)
    for i in range(nb):
        if jtype[i] == FREE:
            normalize_quaternion(q[iq[i] + 3 : iq[i] + 7])


def _quaternions(model):
    """[(body, first q index of its quaternion)] for every free joint."""
    return [(i, int(model.iq[i]) + 3) for i in range(model.nb) if model.jtype[i] == FREE]


def _checked_q(model, q, name, what, unit=True):
    """q as a float64 (nq,) or (N, nq) array, finite, every quaternion non-zero and, with unit,
    of unit norm within QUATERNION_TOLERANCE, as every dynamics function takes it."""
    q = checks.as_q(model, q, name)
    if not np.all(np.isfinite(q)):
        raise ValueError(f"{what}: {name} must be finite (it has NaN or inf)")
    for i, k in _quaternions(model):
        norms = np.linalg.norm(q[..., k : k + 4], axis=-1)
        if np.any(norms < checks.ZERO_QUATERNION):
            raise ValueError(
                f"{what}: the quaternion {name}[{k}:{k + 4}] of {model.body_names[i]!r} is zero; "
                f"a rotation needs a unit quaternion (x, y, z, w)"
            )
    if unit:
        check_unit_quaternions(model, q, name, what)
    return q


def check_unit_quaternions(model, q, name, what):
    """ValueError naming `what`, the state (for a batch) and the slice of `name` where a free
    joint's quaternion in q (nq,) or (N, nq) is further than QUATERNION_TOLERANCE from unit
    norm."""
    for _, k in _quaternions(model):
        off = np.abs(np.linalg.norm(q[..., k : k + 4], axis=-1) - 1.0)
        if np.any(off > QUATERNION_TOLERANCE):
            bad = int(np.argmax(off > QUATERNION_TOLERANCE)) if q.ndim == 2 else None
            row = name if bad is None else f"{name}[{bad}]"
            state = q if bad is None else q[bad]
            raise ValueError(f"{what}: {checks.quaternion_problem(model, row, state)}")


def integrate(model, q, v, dt):
    """q (+) v dt: the configuration reached from q moving at velocity v for dt seconds.

    Args:
      q: (nq,) or (N, nq) configuration (a floating base's (p, quat), then joint positions).
      v: (nv,) or (N, nv) velocity (a floating base's body twist (omega_b, v_b), then joint
        velocities, rad/s or m/s).
      dt: time (s).
    Returns (nq,) or (N, nq): q + v dt for the joints; for a free joint the pose moved along
    its body twist by the exponential map of SE(3), T exp([V] dt), quaternion normalised.
    """
    checks.check_model(model, "integrate")
    q = _checked_q(model, q, "q", "integrate")
    (q, v), batch = checks.as_states(model, q, ("v", v))
    dt = as_real(dt, "integrate: dt")
    if not np.isfinite(dt):
        raise ValueError(f"integrate: dt must be finite, got {dt}")
    if not np.all(np.isfinite(v)):
        raise ValueError("integrate: v must be finite (it has NaN or inf)")
    if model.nq == model.nv:  # no free joint: q (+) v dt is q + v dt, nothing to compile
        q_next = q + v * dt
    else:
        q_next = np.empty_like(q)
        integrate_rows(model._ibuf, q if batch else q[None], v if batch else v[None], dt,
                       q_next if batch else q_next[None])
    return checks.check_result(q_next, "integrate", "q", {"q": q, "v": v, "dt": dt})


def difference(model, q0, q1):
    """q1 (-) q0: the velocity v (nv,) that integrates q0 to q1 in unit time, so that
    integrate(model, q0, difference(model, q0, q1), 1.0) = q1 (the log map of SE(3) for a free
    joint, the body twist of T_0^-1 T_1 over the shorter rotation; q1 - q0 for the joints).

    q0, q1: (nq,) or (N, nq). Returns (nv,) or (N, nv).
    """
    checks.check_model(model, "difference")
    q0 = _checked_q(model, q0, "q0", "difference")
    q1 = _checked_q(model, q1, "q1", "difference")
    if q0.ndim == 2 and q1.ndim == 2 and len(q0) != len(q1) and 1 not in (len(q0), len(q1)):
        raise ValueError(f"difference: q0 and q1 have {len(q0)} and {len(q1)} states")
    if model.nq == model.nv:  # no free joint: q1 (-) q0 is q1 - q0
        v = q1 - q0
    elif q0.ndim == q1.ndim == 1:
        v = np.empty(model.nv)
        difference_kernel(model._ibuf, q0, q1, v)
    else:
        q0, q1 = np.broadcast_arrays(np.atleast_2d(q0), np.atleast_2d(q1))
        q0, q1 = np.ascontiguousarray(q0), np.ascontiguousarray(q1)
        v = np.empty((q0.shape[0], model.nv))
        for n in range(q0.shape[0]):
            difference_kernel(model._ibuf, q0[n], q1[n], v[n])
    return checks.check_result(v, "difference", "v", {"q0": q0, "q1": q1})


def normalize(model, q):
    """q with each free joint's quaternion divided by its norm (a copy): (nq,) or (N, nq).
    A zero or non-finite quaternion is a ValueError naming its slice of q."""
    checks.check_model(model, "normalize")
    q = _checked_q(model, q, "q", "normalize", unit=False).copy()
    for row in q if q.ndim == 2 else [q]:
        normalize_kernel(model._ibuf, row)
    return q


def neutral(model):
    """The reference configuration (nq,): every joint at 0, a free joint at the origin with
    the identity rotation (quaternion (0, 0, 0, 1))."""
    checks.check_model(model, "neutral")
    q = np.zeros(model.nq)
    for _, k in _quaternions(model):
        q[k + 3] = 1.0
    return q


def random_configuration(model, rng=None):
    """A random configuration (nq,): each joint uniform between its limits, or over
    [-pi, pi] rad (revolute) or [-1, 1] m (prismatic) where a limit is infinite; a free joint
    at a uniform point of the cube [-1, 1]^3 m with a uniformly random rotation (a normalised
    4-D Gaussian quaternion). rng: a numpy Generator or a seed (default: fresh entropy)."""
    checks.check_model(model, "random_configuration")
    try:
        rng = np.random.default_rng(rng)
    except (TypeError, ValueError):
        raise TypeError(
            f"random_configuration: rng must be a numpy Generator or an integer seed, got "
            f"{type(rng).__name__} {rng!r}"
        ) from None
    q = neutral(model)
    for k, name in enumerate(model.joint_names):
        i = model.body_joints.index(name)
        span = 1.0 if model.jtype[i] == PRISMATIC else np.pi
        lo = model.lower[k] if np.isfinite(model.lower[k]) else -span
        hi = model.upper[k] if np.isfinite(model.upper[k]) else span
        q[model.q_index[k]] = rng.uniform(lo, hi)
    for i, k in _quaternions(model):
        q[k - 3 : k] = rng.uniform(-1.0, 1.0, 3)
        u = rng.normal(size=4)
        q[k : k + 4] = u / np.linalg.norm(u)
    return q
