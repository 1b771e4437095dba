"""Joint-limit spring-dampers, acting only past a limit of the URDF.

    tau_j = -k (q_i - upper) - d qd_j   where q_i > upper
    tau_j = -k (q_i - lower) - d qd_j   where q_i < lower        (zero inside)
    K_jj += k, D_jj += d there

at joint k's coordinates i = iq_k, j = iv_k; k (n,) N m/rad or N/m, d (n,) N m s/rad or N s/m,
both >= 0 and 0 where the joint has no finite limit. Passive (the spring's energy is not in E:
its work is counted with the passive work).
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..._runtime.arrays import immutable
from ..._runtime.kernel_cache import JIT
from ..hard_settings import SOLVER_KEYS, HardSettings, read_model
from .interface import OK, PASSIVE, floats, joint_labels, q_indices, v_indices

NAME = "limits"
SECTION = "effects"
JOINTS = True  # acts on the joint coordinates only: a robot without joints refuses it
KEYS = ("stiffness", "damping", "model", *SOLVER_KEYS)
FIELD = "limits"
OFF = None
DOC = "-k (q - limit) - d qd, only while past a URDF limit"
ENABLE = None
EXAMPLE = {"stiffness": 1e3, "damping": 5.0}
STAGE = "limits"
ENERGY = PASSIVE
DERIVATIVES = ("K", "D")


@dataclass(frozen=True, eq=False)
class Limits:
    """Joint-limit spring-dampers, acting only beyond a limit:
    -stiffness (q - upper) - damping qd where q > upper, -stiffness (q - lower) - damping qd
    where q < lower.

    stiffness: (n,) per joint, N m/rad or N/m, >= 0; damping: (n,) N m s/rad or N s/m, >= 0;
    both 0 where the joint has no finite limit. lower, upper: (n,) rad or m, the model's limits.
    hard: the hard model's settings (opendyn.sim.hard_settings: a unilateral row per limit
    within its margin), or None for the spring-dampers (then stiffness and damping are 0).
    """

    stiffness: np.ndarray
    damping: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    hard: HardSettings | None = None


# each (n,): stiffness, damping, lower and upper limits; iq, iv int64 the joints' indices
Params = namedtuple("Params", ("stiffness", "damping", "lower", "upper", "iq", "iv"))


def record(scene) -> Limits | None:
    """The scene's limit spring-dampers (a force of the step), else None."""
    limits = scene.limits
    return limits if limits is not None and limits.hard is None else None


def hard(scene) -> Limits | None:
    """The scene's hard limits (rows of the velocity-level step), else None."""
    limits = scene.limits
    return limits if limits is not None and limits.hard is not None else None


def read(r, table) -> Limits | None:
    """[effects.limits] stiffness (required) and damping: a number (every limited joint), a
    list or {joint = value}; a joint without a finite limit takes none."""
    if table is None:
        return None
    key = "effects.limits"
    r.keys(table, key, KEYS)
    m = r.model
    finite = np.isfinite(m.lower) | np.isfinite(m.upper)
    if not finite.any():
        r.fail(
            key,
            f"no joint of {m.name!r} has a finite position limit, so limit spring-dampers "
            f"would never act; remove [effects.limits]",
        )
    settings = read_model(r, table, key, ("stiffness", "damping"))
    if "stiffness" not in table and settings is None:
        r.fail(f"{key}.stiffness", "missing: give a number, a list or a table {joint = N m/rad}")
    out = {}
    for field in ("stiffness", "damping"):
        full = f"{key}.{field}"
        value = table.get(field, 0.0)
        arr = r.per_joint(value, full, np.zeros(len(m.joint_names)), minimum=0.0)
        if isinstance(value, (dict, list)):
            for j in np.flatnonzero((arr != 0) & ~finite):
                name = m.joint_names[j]
                r.fail(
                    f"{full}.{name}" if isinstance(value, dict) else f"{full}[{j}]",
                    f"joint {name!r} has no finite position limit; limited joints: "
                    f"{', '.join(n for n, f in zip(m.joint_names, finite) if f)}",
                )
        out[field] = immutable(np.where(finite, arr, 0.0))
    return Limits(
        stiffness=out["stiffness"],
        damping=out["damping"],
        lower=immutable(m.lower),
        upper=immutable(m.upper),
        hard=settings,
    )


def pack(limits, model) -> Params:
    return Params(
        floats(limits.stiffness),
        floats(limits.damping),
        floats(limits.lower),
        floats(limits.upper),
        q_indices(model),
        v_indices(model),
    )


@njit(**JIT)
def apply(p, ctx, out):
    """Past a limit: out.passive_j -= k (q_i - limit) + d qd_j; with out.jac, out.K_jj += k,
    out.D_jj += d, with i = iq_k, j = iv_k joint k's coordinates. p: Params, or None.
    Returns a Status."""
    if p is None:
        return OK
    q, qd = ctx.q, ctx.qd
    for k in range(p.iv.shape[0]):
        i, j = p.iq[k], p.iv[k]
        if q[i] > p.upper[k]:
            depth = q[i] - p.upper[k]
        elif q[i] < p.lower[k]:
            depth = q[i] - p.lower[k]
        else:
            continue
        out.passive[j] -= p.stiffness[k] * depth + p.damping[k] * qd[j]
        if out.jac:
            out.K[j, j] += p.stiffness[k]
            out.D[j, j] += p.damping[k]
    return OK


def rates(limits, at):
    """Each joint's natural frequency sqrt(k / M_jj) and damping rate d / M_jj (1/s)."""
    joints = joint_labels(at.scene.model)
    return [
        ("joint-limit stiffness", np.sqrt(limits.stiffness / at.joint_mass), joints),
        ("joint-limit damping", limits.damping / at.joint_mass, joints),
    ]


def tangent(limits, at):
    """(tau, dtau_dq, dtau_dqd): past a limit -k (q - limit) - d qd, slopes -k and -d (the
    side the joint is on; nothing within the limits)."""
    model = at.scene.model
    nv, iq, iv = model.nv, q_indices(model), v_indices(model)
    q = at.q[iq]
    depth = np.where(
        q > limits.upper, q - limits.upper, np.where(q < limits.lower, q - limits.lower, 0.0)
    )
    past = depth != 0.0
    tau, dtau_dq, dtau_dqd = np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))
    tau[iv] = np.where(past, -limits.stiffness * depth - limits.damping * at.qd[iv], 0.0)
    dtau_dq[iv, iv] = np.where(past, -limits.stiffness, 0.0)
    dtau_dqd[iv, iv] = np.where(past, -limits.damping, 0.0)
    return tau, dtau_dq, dtau_dqd
