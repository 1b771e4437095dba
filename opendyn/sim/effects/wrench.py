"""Wrenches applied to the robot at frames: a push, a load, a thrust.

    tau = sum over the wrenches of J_b(frame)^T F_frame

F = (m, f) (N m, N) is the wrench the environment applies TO THE ROBOT at the frame's origin,
in the frame's axes, or in world-aligned axes at the frame's origin (expressed_in = "world":
F_frame = (R_sf^T m, R_sf^T f)); constant, or linear in time between table samples, held before
the first and after the last. This is -F_tip of the dynamics functions, whose F_tip is what the
robot applies to the environment. Applied: its work is put in from outside.
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..._runtime.arrays import copy_into, immutable
from ..._runtime.kernel_cache import JIT
from ...algorithm.kinematics import frame_jacobian
from ...multibody.layout import body_count
from ...multibody.work_views import frame_pose_field, jacobian_field, scratch_rows
from ..values import what_is
from .interface import APPLIED, OK, floats
from .tangent import bracket_transpose, path_axes, point_velocities, wrench_tangent

NAME = "wrench"
SECTION = "effects"
KEYS = ("frame", "expressed_in", "value", "times", "values")  # of each [[effects.wrench]]
FIELD = "wrenches"
OFF = ()
DOC = (
    "J_b^T F: F = (m, f) the environment applies to the robot (= -F_tip of the dynamics "
    "functions)"
)
ENABLE = None
EXAMPLE = [{"frame": "tip", "expressed_in": "world", "value": [0, 0, 0, 1, 0, 2]}]
STAGE = "wrench"
ENERGY = APPLIED
WORLD_POSES = True  # its force reads the world poses the step places (frame_jacobian)
DERIVATIVES = ()
rates = None
EXPRESSED_IN = ("frame", "world")


@dataclass(frozen=True, eq=False)
class Wrench:
    """A wrench the environment applies TO THE ROBOT at a frame's origin.

    frame: a frame name of the model (a joint name finds its child link's frame).
    expressed_in: "frame" (the frame's own axes) or "world" (world-aligned axes at the frame's
    origin). times: (K,) s, strictly increasing. values: (K, 6) (m in N m, f in N); piecewise
    linear in t between the samples, held constant before the first and after the last.
    """

    frame: str
    expressed_in: str
    times: np.ndarray
    values: np.ndarray

    def at(self, t: float) -> np.ndarray:
        """(6,) the wrench (m, f) at time t (s), in the axes of ``expressed_in``."""
        if len(self.times) == 1:
            return self.values[0].copy()
        return np.array([np.interp(t, self.times, self.values[:, k]) for k in range(6)])


# per wrench w (W of them): body (W,) int64 its frame's body, world (W,) bool (F in
# world-aligned axes), T_body_frame (W, 4, 4) the frame in its body, first and count (W,) int64
# its samples' rows in times (S,) s and values (S, 6) (m, f)
Params = namedtuple(
    "Params", ("body", "world", "T_body_frame", "first", "count", "times", "values")
)


def record(scene) -> tuple[Wrench, ...] | None:
    return scene.wrenches or None


def read(r, value) -> tuple[Wrench, ...]:
    """[[effects.wrench]] tables (or one [effects.wrench] table); () when absent."""
    if value is None:
        return ()
    if isinstance(value, dict):
        return (_read_one(r, value, "effects.wrench"),)
    if not isinstance(value, list):
        r.fail(
            "effects.wrench",
            f"expected tables [[effects.wrench]] (frame, value or times/values), "
            f"found {what_is(value)}",
        )
    return tuple(_read_one(r, w, f"effects.wrench[{i}]") for i, w in enumerate(value))


def _read_one(r, table, key) -> Wrench:
    """One wrench: frame (a moving one), expressed_in, and value or times with values."""
    r.keys(table, key, KEYS)
    m = r.model
    if "frame" not in table:
        r.fail(f"{key}.frame", f"missing; frames: {', '.join(m.frame_names)}")
    frame = r.moving_frame(table["frame"], f"{key}.frame", "a wrench on it moves nothing")
    expressed_in = r.string(
        table.get("expressed_in", "frame"), f"{key}.expressed_in", EXPRESSED_IN
    )
    has_value = "value" in table
    has_table = "times" in table or "values" in table
    if has_value == has_table:
        r.fail(
            key,
            ("both value and times/values given" if has_value else "no wrench given")
            + ": give value = [m, f] (6 numbers, constant) or times = [...] with "
            "values = [[6 numbers], ...]",
        )
    if has_value:
        times = immutable([0.0])
        values = immutable(r.vector(table["value"], f"{key}.value", 6)[None, :])
    else:
        for field in ("times", "values"):
            if field not in table:
                r.fail(f"{key}.{field}", "missing: times and values go together")
        raw_t, raw_v = table["times"], table["values"]
        if not isinstance(raw_t, list) or not raw_t:
            r.fail(
                f"{key}.times", f"expected a non-empty list of times (s), found {what_is(raw_t)}"
            )
        times = r.vector(raw_t, f"{key}.times", len(raw_t))
        bad = np.flatnonzero(np.diff(times) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            r.fail(
                f"{key}.times[{k}]",
                f"times must be strictly increasing; {times[k]:g} follows {times[k - 1]:g}",
            )
        if not isinstance(raw_v, list) or len(raw_v) != len(times):
            found = f"a list of {len(raw_v)}" if isinstance(raw_v, list) else what_is(raw_v)
            r.fail(
                f"{key}.values",
                f"expected one wrench [m, f] of 6 numbers per time ({len(times)} times), "
                f"found {found}",
            )
        values = immutable(
            np.array([r.vector(v, f"{key}.values[{i}]", 6) for i, v in enumerate(raw_v)])
        )
    return Wrench(frame=frame, expressed_in=expressed_in, times=times, values=values)


def _on_moving_frames(wrenches, model):
    """[(wrench, frame)] of the wrenches on frames that move (one on a frame of the fixed world
    moves no joint)."""
    frames = [(w, model.frames[model.frame_index(w.frame)]) for w in wrenches]
    return [(w, frame) for w, frame in frames if frame.body >= 0]


def pack(wrenches, model) -> Params | None:
    """The wrenches on moving frames, or None when there is none."""
    moving = _on_moving_frames(wrenches, model)
    if not moving:
        return None
    count = np.array([len(w.times) for w, _ in moving], dtype=np.int64)
    return Params(
        body=np.array([frame.body for _, frame in moving], dtype=np.int64),
        world=np.array([w.expressed_in == "world" for w, _ in moving]),
        T_body_frame=np.array([frame.T_body_frame for _, frame in moving], dtype=np.float64),
        first=np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64),
        count=count,
        times=floats(*(w.times for w, _ in moving)),
        values=np.concatenate([np.array(w.values, dtype=np.float64) for w, _ in moving]),
    )


def label(wrenches, model) -> str:
    """ "wrench on FRAME, ...": the frames whose wrenches move the robot."""
    return "wrench on " + ", ".join(w.frame for w, _ in _on_moving_frames(wrenches, model))


@njit(**JIT)
def wrench_at(times, values, t, F):
    """F (6,) <- the wrench of the table times (n,), values (n, 6) at time t: linear between
    samples, the first value before the first time and the last after the last."""
    n = times.shape[0]
    if n == 1 or t <= times[0]:
        copy_into(values[0], F)
        return
    if t >= times[n - 1]:
        copy_into(values[n - 1], F)
        return
    k = np.searchsorted(times, t) - 1
    w = (t - times[k]) / (times[k + 1] - times[k])
    for r in range(6):
        F[r] = (1.0 - w) * values[k, r] + w * values[k + 1, r]


@njit(**JIT)
def apply(p, ctx, out):
    """out.applied += sum over the wrenches of J_b(frame)^T F_frame. p: Params, or None.
    world: F is given in world-aligned axes at the frame's origin, F_frame = (R^T m, R^T f),
    with R from the pose T_sf that the Jacobian leaves in ctx.work. Works on the world poses
    the step placed in ctx.work (WORLD_POSES), and in that Data's fields: J_b (6, nv) in J, F
    and the world-aligned F_s (6,) in scratch rows 0 and 1 (frame_jacobian uses neither).
    Returns a Status."""
    if p is None:
        return OK
    nb, nv = body_count(ctx.ibuf), ctx.qd.shape[0]
    rows = scratch_rows(ctx.work, nb, nv)
    F, F_s = rows[0], rows[1]
    J_b = jacobian_field(ctx.work, nb, nv)
    T_sf = frame_pose_field(ctx.work, nb, nv)
    for w in range(p.body.shape[0]):
        first, last = p.first[w], p.first[w] + p.count[w]
        wrench_at(p.times[first:last], p.values[first:last], ctx.t, F)
        frame_jacobian(ctx.ibuf, ctx.fbuf, ctx.work, (p.body[w], p.T_body_frame[w]), True, J_b)
        if p.world[w]:
            copy_into(F, F_s)
            for r in range(3):
                F[r] = T_sf[0, r] * F_s[0] + T_sf[1, r] * F_s[1] + T_sf[2, r] * F_s[2]
                F[3 + r] = T_sf[0, r] * F_s[3] + T_sf[1, r] * F_s[4] + T_sf[2, r] * F_s[5]
        for j in range(nv):
            s = 0.0
            for r in range(6):
                s += J_b[r, j] * F[r]
            out.applied[j] += s
    return OK


def tangent(wrenches, at):
    """(tau, dtau_dq, 0) of the wrenches at time t, exactly (opendyn.sim.effects.tangent):
    F about the world origin in world axes, F_s = (R m + p x R f, R f) for the frame's axes
    ((R, p) = T_sf), turning with the body (dF_s/dq_j = S_j x* F_s), or F_s = (m + p x f, f)
    for world-aligned axes, whose m and f stay put while the point p moves
    (dF_s/dq_j = ((v_j + w_j x p) x f, 0))."""
    model = at.scene.model
    nv = model.nv
    tau, dtau_dq = np.zeros(nv), np.zeros((nv, nv))
    for w in wrenches:
        frame = model.frames[model.frame_index(w.frame)]
        b = frame.body
        T_sf = np.eye(4)
        T_sf[:3, :3], T_sf[:3, 3] = at.axes.R_s[b], at.axes.p_s[b]
        T_sf = T_sf @ frame.T_body_frame
        R, p = T_sf[:3, :3], T_sf[:3, 3]
        m, f = w.at(at.t)[:3], w.at(at.t)[3:]
        S = path_axes(model, at.axes, b)[0]
        if w.expressed_in == "world":
            F_s = np.concatenate([m + np.cross(p, f), f])
            moved = np.cross(point_velocities(S, p), f)
            dF_dq = np.concatenate([moved, np.zeros_like(moved)], axis=1)
        else:
            F_s = np.concatenate([R @ m + np.cross(p, R @ f), R @ f])
            dF_dq = -bracket_transpose(S, F_s)
        tau_w, dtau_w = wrench_tangent(model, at.axes, b, F_s, dF_dq)
        tau += tau_w
        dtau_dq += dtau_w
    return tau, dtau_dq, np.zeros((nv, nv))
