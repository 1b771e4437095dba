"""Gravity: the base acceleration that produces it.

    dV_0 = (0, -g)                                    g (3,) world frame, m/s^2

RNEA and ABA start their forward pass from dV_0, so -g(q) comes out of the recursion that gives
c(q, qd), at no extra cost: gravity adds no generalized force of its own, and its potential
energy U_gravity is in E (conservative). Without gravity dV_0 stays 0.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._runtime.arrays import immutable
from ..._runtime.kernel_cache import JIT
from ..values import what_is
from .interface import CONSERVATIVE, OK, floats

NAME = "gravity"
SECTION = "effects"
KEYS = ()  # one value: gravity = true, false or [gx, gy, gz]
FIELD = "gravity"
OFF = None
DOC = "base acceleration dV_0 = (0, -g): the same recursion gives -g(q) at no extra cost"
ENABLE = True
EXAMPLE = True
STAGE = "gravity"
ENERGY = CONSERVATIVE
DERIVATIVES = ()
Params = None  # the parameters are g itself, (3,)
rates = None


def record(scene) -> np.ndarray | None:
    return scene.gravity


def read(r, value) -> np.ndarray | None:
    """true: the model's gravity; a vector [gx, gy, gz] m/s^2; false or absent: none."""
    if value is None or value is False:
        return None
    if value is True:
        return immutable(r.model.gravity)
    if not isinstance(value, list):
        r.fail(
            "effects.gravity",
            f"expected true, false or a vector [gx, gy, gz] (m/s^2), found {what_is(value)}",
        )
    return r.vector(value, "effects.gravity", 3)


def pack(g, model) -> np.ndarray:
    """g (3,), a fresh copy."""
    return floats(g)


@njit(**JIT)
def apply(g, ctx, out):
    """ctx.dV_0 (6,) <- (0, -g); g (3,), or None (no gravity: dV_0 stays 0). Returns a
    Status."""
    if g is None:
        return OK
    for k in range(3):
        ctx.dV_0[3 + k] = -g[k]
    return OK


tangent = None  # gravity acts through the dynamics' base acceleration (0, -g)
