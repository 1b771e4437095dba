"""Argument checks of the constraint functions: a single finite state, a configuration whose
quaternions have unit norm, a (k, nv) constraint matrix and a (k,) vector to go with it; each
raises ValueError naming the function and the argument.
"""

from __future__ import annotations

import numpy as np

from ..._runtime.status import Status
from ...multibody.joints import FREE, quaternion_status
from .. import checks


def _single(model, x, name, what, n):
    """x as a finite float64 (n,) array, or ValueError naming it."""
    try:
        x = checks.as_state(model, x, name, n)
    except (TypeError, ValueError) as e:
        raise type(e)(f"{what}: {e}") from None
    if x.ndim != 1:
        raise ValueError(f"{what}: {name} must be a single state ({n},), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{what}: {name} must be finite (it has NaN or inf)")
    return x


def _state(model, x, name, what):
    """A velocity-like argument (qd, qdd, tau): a finite (nv,) array."""
    return _single(model, x, name, what, model.nv)


def _configuration(model, q, name, what):
    """A configuration: a finite (nq,) array whose quaternions (a floating base) have unit
    norm within joints.QUATERNION_TOLERANCE."""
    q = _single(model, q, name, what, model.nq)
    free = np.any(model.jtype == FREE)
    if free and quaternion_status(model._ibuf, q) == Status.Q_NOT_UNIT_QUATERNION:
        raise ValueError(f"{what}: {checks.quaternion_problem(model, name, q)}")
    return q


def _matrix_A(model, A, what):
    A = np.array(checks.as_float_array(A, f"{what}: A"), ndmin=2)
    if A.ndim != 2 or A.shape[1] != model.nv:
        raise ValueError(
            f"{what}: A must have shape (k, nv={model.nv}) for model {model.name!r}, "
            f"got shape {A.shape}"
        )
    if not np.all(np.isfinite(A)):
        raise ValueError(f"{what}: A must be finite (it has NaN or inf)")
    return np.ascontiguousarray(A)


def _vector_k(x, k, name, what):
    x = np.array(checks.as_float_array(x, f"{what}: {name}"), ndmin=1)
    if x.shape != (k,):
        raise ValueError(
            f"{what}: {name} must have shape ({k},), one entry per row of A, got shape {x.shape}"
        )
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{what}: {name} must be finite (it has NaN or inf)")
    return np.ascontiguousarray(x)
