"""The configuration update q' = q (+) v dt: how integrators advance positions.

For the joints opendyn has now (revolute, continuous with one coordinate, prismatic) the
configuration space is a vector space and q (+) v dt = q + v dt. Integrators never add to q
themselves: they call `integrate`, so that a floating base (a quaternion in q, nq != nv) changes
this one function and no integrator.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import _args
from ._kernels import INLINE


@njit(**INLINE)
def integrate_kernel(ibuf, q, v, dt, q_next):
    """q_next (nq,) <- q (+) v dt, with v (nv,) a velocity held for dt seconds."""
    for k in range(q.shape[0]):
        q_next[k] = q[k] + v[k] * dt


def integrate(model, q, v, dt):
    """q (+) v dt: the configuration reached from q moving at velocity v for dt seconds.

    Args:
      q: (nq,) or (N, nq) joint positions (rad or m).
      v: (nv,) or (N, nv) joint velocities (rad/s or m/s).
      dt: time (s).
    Returns (nq,) or (N, nq). For the joint types opendyn models now, q + v dt.
    """
    (q, v), batch = _args.as_states(model, ("q", q), ("v", v))
    dt = float(dt)
    if not np.isfinite(dt):
        raise ValueError(f"integrate: dt must be finite, got {dt}")
    q_next = np.empty_like(q)
    for q_n, v_n, out in zip(q, v, q_next) if batch else [(q, v, q_next)]:
        integrate_kernel(model._ibuf, q_n, v_n, dt, out)
    return q_next
