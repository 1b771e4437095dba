"""Coulomb friction at the joints, smoothed over a velocity scale v_s.

    tau_j = -f_c,k tanh(qd_j / v_s),   D_jj += f_c,k (1 - tanh^2) / v_s

at joint k's velocity j = iv_k; f_c (n,) N m or N, >= 0; v_s rad/s or m/s, > 0. Passive. Near
zero velocity it is a stiff damper f_c / v_s.
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..._runtime.kernel_cache import JIT
from ..hard_settings import SHARED, HardSettings, read_model
from .interface import OK, PASSIVE, floats, joint_labels, v_indices

NAME = "friction"
SECTION = "effects"
JOINTS = True  # acts on the joint coordinates only: a robot without joints refuses it
KEYS = ("coefficients", "smoothing", "model", *SHARED)  # no margin: a row at every joint
FIELD = "friction"
OFF = None
DOC = "-f_c tanh(qd / v_s), Coulomb smoothed over the velocity scale v_s (default 0.01)"
ENABLE = {}  # coefficients = "urdf": <dynamics friction>
EXAMPLE = {"coefficients": 0.2, "smoothing": 0.05}
STAGE = "friction"
ENERGY = PASSIVE
DERIVATIVES = ("D",)


@dataclass(frozen=True, eq=False)
class Friction:
    """Smoothed Coulomb friction: generalized force -coulomb * tanh(qd / smoothing).

    coulomb: (n,) per joint, N m or N, >= 0. smoothing: rad/s or m/s, > 0. hard: the hard
    model's settings (opendyn.sim.hard_settings: |lambda_j| <= f_c dt, static friction held
    exactly), or None for the smoothed law.
    """

    coulomb: np.ndarray
    smoothing: float = 0.01
    hard: HardSettings | None = None


# f_c (n,) the Coulomb forces; v_s (n,) the smoothing, every joint's the same; iv (n,) int64
Params = namedtuple("Params", ("f_c", "v_s", "iv"))


def record(scene) -> Friction | None:
    """The scene's smoothed friction (a force of the step), else None."""
    friction = scene.friction
    return friction if friction is not None and friction.hard is None else None


def hard(scene) -> Friction | None:
    """The scene's hard friction (rows of the velocity-level step), else None."""
    friction = scene.friction
    return friction if friction is not None and friction.hard is not None else None


def read(r, table) -> Friction | None:
    """[effects.friction] coefficients ("urdf" by default, as damping's) and smoothing."""
    if table is None:
        return None
    key = "effects.friction"
    r.keys(table, key, KEYS)
    settings = read_model(r, table, key, ("smoothing",))
    coulomb = r.coefficients(table, key, "coefficients", r.model.friction, "friction")
    smoothing = r.number(table.get("smoothing", 0.01), f"{key}.smoothing", positive=True)
    return Friction(coulomb=coulomb, smoothing=smoothing, hard=settings)


def pack(friction, model) -> Params:
    f_c = floats(friction.coulomb)
    return Params(f_c, np.full(f_c.shape, float(friction.smoothing)), v_indices(model))


@njit(**JIT)
def apply(p, ctx, out):
    """out.passive_j -= f_c tanh(qd_j / v_s); with out.jac, out.D_jj += f_c (1 - tanh^2) / v_s,
    at each joint's velocity j = iv_k. p: Params, or None (no friction). Returns a Status."""
    if p is None:
        return OK
    for k in range(p.iv.shape[0]):
        j = p.iv[k]
        s = np.tanh(ctx.qd[j] / p.v_s[k])
        out.passive[j] -= p.f_c[k] * s
        if out.jac:
            out.D[j, j] += p.f_c[k] * (1.0 - s * s) / p.v_s[k]
    return OK


def rates(friction, at):
    """The damping rate near zero velocity, f_c / (v_s M_jj), of each joint (1/s)."""
    rate = friction.coulomb / friction.smoothing / at.joint_mass
    return [("friction smoothing", rate, joint_labels(at.scene.model))]


def tangent(friction, at):
    """(tau, dtau_dq, dtau_dqd): -f_c tanh(qd_j / v_s) and its slope -f_c (1 - tanh^2) / v_s."""
    nv, iv = at.qd.shape[0], v_indices(at.scene.model)
    s = np.tanh(at.qd[iv] / friction.smoothing)
    tau, dtau_dqd = np.zeros(nv), np.zeros((nv, nv))
    tau[iv] = -friction.coulomb * s
    dtau_dqd[iv, iv] = -friction.coulomb * (1.0 - s * s) / friction.smoothing
    return tau, np.zeros((nv, nv)), dtau_dqd
