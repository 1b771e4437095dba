"""Physical effects as generalized forces: tau_e(t, q, qd), one compiled function per effect.

The equation of motion a scene simulates is

    (M(q) + diag(armature)) qdd + c(q, qd) = sum over the scene's effects of tau_e(t, q, qd)

with gravity entering as the base acceleration dV_0 = (0, -g) (so that -g(q) is produced by the
same recursion that gives c, at no extra cost). Each effect:

  gravity    dV_0 = (0, -g)                                  g (3,) world frame, m/s^2
  damping    tau = -b * qd                                   b (nv,) N m s/rad or N s/m
  friction   tau = -f_c * tanh(qd / v_s)                     f_c (nv,) N m or N, v_s (rad/s, m/s)
  armature   M -> M + diag(I_a)                              I_a (nv,) kg m^2 or kg
  limits     tau = -k (q - upper) - d qd   where q > upper   k (nv,) N m/rad, d (nv,) N m s/rad
             tau = -k (q - lower) - d qd   where q < lower   (a spring-damper only while past
                                                              the limit; zero inside)
  wrench     tau = J_b(frame)^T F_frame                      F (6,) = (m, f) the environment
             applies TO THE ROBOT at the frame's origin, in the frame's axes, or in world-aligned
             axes at the frame's origin (F_frame = (R_sf^T m, R_sf^T f)); constant or linear
             in time between table samples, held before the first and after the last
  control    constant  tau = tau_0
             pd        tau = kp (q_set - q) - kd qd
             computed_torque  tau = M(q) qdd_c + h(q, qd) computed by RNEA, with
                       qdd_c = qdd_r + kp (q_r - q) + kd (qd_r - qd) and the reference
                       q_r(t) = offset + amplitude sin(2 pi frequency t + phase);
                       the controller's model is the scene's rigid bodies, gravity and armature
             clip      tau_control clipped to +-effort_limit (joints with a finite limit)

Note the sign of a wrench here: an applied wrench F acts ON the robot, so it is -F_tip in the
dynamics functions' convention (F_tip is what the robot applies to the environment).

A scene becomes a tuple with one slot per effect (`stage_table`): the effect's parameters, or
None when the scene does not name it. Each effect function tests its slot against None, which
numba decides when it compiles the step for that tuple, so an effect the scene does not name is
neither compiled nor evaluated. The effect functions also add their derivatives to the diagonal
stiffness K = -d tau / d q and damping D = -d tau / d qd when asked, for the integrator that
treats them implicitly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .dynamics._kernels import JIT, copy_into
from .dynamics.constraints import constraint_table
from .dynamics.forward import NO_ARMATURE
from .dynamics.kinematics import frame_pose_kernel, jacobian_kernel
from .dynamics.rnea import rnea_kernel
from .status import Status

# the slots of a scene's effects tuple, in the order the step runs them; a slot holds the
# effect's parameters, or None when the scene does not name it
GRAVITY, DAMPING, FRICTION, LIMITS, WRENCH, CONSTANT, PD, COMPUTED_TORQUE, CLIP = range(9)
SLOT_NAMES = (
    "gravity",
    "damping",
    "friction",
    "limits",
    "wrench",
    "control (constant)",
    "control (pd)",
    "control (computed torque)",
    "clip",
)


@njit(**JIT)
def gravity_effect(g, dV_0):
    """dV_0 = (0, -g): the base acceleration that produces gravity; g (3,), or None (no
    gravity: dV_0 stays 0)."""
    if g is None:
        return
    for k in range(3):
        dV_0[3 + k] = -g[k]


@njit(**JIT)
def damping_effect(b, qd, tau, D, jac):
    """tau -= b qd; D += b. b (nv,), or None (no damping)."""
    if b is None:
        return
    for k in range(qd.shape[0]):
        tau[k] -= b[k] * qd[k]
        if jac:
            D[k] += b[k]


@njit(**JIT)
def friction_effect(p, qd, tau, D, jac):
    """tau -= f_c tanh(qd / v_s); D += f_c (1 - tanh^2) / v_s. p = (f_c (nv,), v_s), or None."""
    if p is None:
        return
    nv = qd.shape[0]
    v_s = p[nv]
    for k in range(nv):
        s = np.tanh(qd[k] / v_s)
        tau[k] -= p[k] * s
        if jac:
            D[k] += p[k] * (1.0 - s * s) / v_s


@njit(**JIT)
def limits_effect(p, q, qd, tau, K, D, jac):
    """Spring-dampers past the limits: tau -= k (q - limit) + d qd; K += k, D += d there.
    p = (k, d, lower, upper), each (nv,); or None."""
    if p is None:
        return
    nv = q.shape[0]
    for j in range(nv):
        lower, upper = p[2 * nv + j], p[3 * nv + j]
        if q[j] > upper:
            depth = q[j] - upper
        elif q[j] < lower:
            depth = q[j] - lower
        else:
            continue
        tau[j] -= p[j] * depth + p[nv + j] * qd[j]
        if jac:
            K[j] += p[j]
            D[j] += p[nv + j]


@njit(**JIT)
def wrench_at(p, n, t, F):
    """F (6,) <- the wrench table p = (times (n,), values (n, 6)) at time t: linear between
    samples, the first value before the first time and the last after the last."""
    if n == 1 or t <= p[0]:
        copy_into(p[n : n + 6], F)
        return
    if t >= p[n - 1]:
        copy_into(p[n + 6 * (n - 1) : n + 6 * n], F)
        return
    k = np.searchsorted(p[:n], t) - 1
    w = (t - p[k]) / (p[k + 1] - p[k])
    for r in range(6):
        F[r] = (1.0 - w) * p[n + 6 * k + r] + w * p[n + 6 * (k + 1) + r]


@njit(**JIT)
def wrench_effect(wrenches, ibuf, fbuf, t, q, tau):
    """tau += sum over the wrenches of J_b(frame)^T F_frame. wrenches = (rows (k, 4) int64,
    params), or None; row (offset into params, samples n, body, world); params at offset:
    T_body_frame (16,), then the table of n samples (wrench_at). world = 1: F is given in
    world-aligned axes at the frame's origin, F_frame = (R^T m, R^T f)."""
    if wrenches is None:
        return
    rows, params = wrenches
    nv = q.shape[0]
    F = np.empty(6)
    F_s = np.empty(6)
    T_sf = np.empty((4, 4))
    J_b = np.empty((6, nv))
    for w in range(rows.shape[0]):
        offset, n, body, world = rows[w, 0], rows[w, 1], rows[w, 2], rows[w, 3]
        p = params[offset:]
        T_bf = p[:16].reshape((4, 4))
        wrench_at(p[16:], n, t, F)
        if world == 1:
            frame_pose_kernel(ibuf, fbuf, q, body, T_bf, T_sf)
            copy_into(F, F_s)
            for r in range(3):
                F[r] = T_sf[0, r] * F_s[0] + T_sf[1, r] * F_s[1] + T_sf[2, r] * F_s[2]
                F[3 + r] = T_sf[0, r] * F_s[3] + T_sf[1, r] * F_s[4] + T_sf[2, r] * F_s[5]
        jacobian_kernel(ibuf, fbuf, q, body, T_bf, True, J_b)
        for j in range(nv):
            s = 0.0
            for r in range(6):
                s += J_b[r, j] * F[r]
            tau[j] += s


@njit(**JIT)
def constant_effect(tau_0, tau):
    """tau += tau_0 (nv,), or nothing for None."""
    if tau_0 is None:
        return
    for j in range(tau.shape[0]):
        tau[j] += tau_0[j]


@njit(**JIT)
def pd_effect(p, q, qd, tau, K, D, jac):
    """tau += kp (q_set - q) - kd qd; K += kp, D += kd. p = (kp, kd, q_set), each (nv,); or
    None."""
    if p is None:
        return
    nv = q.shape[0]
    for j in range(nv):
        tau[j] += p[j] * (p[2 * nv + j] - q[j]) - p[nv + j] * qd[j]
        if jac:
            K[j] += p[j]
            D[j] += p[nv + j]


@njit(**JIT)
def computed_torque_effect(p, ibuf, fbuf, t, q, qd, dV_0, armature, tau):
    """tau += M(q) qdd_c + h(q, qd) by RNEA (plus armature qdd_c), with
    qdd_c = qdd_r + kp (q_r - q) + kd (qd_r - qd) and q_r = offset + amplitude sin(w t + phase),
    w = 2 pi frequency. p = (kp, kd, offset, amplitude, frequency, phase), each (nv,); or None.
    Returns the RNEA's Status."""
    if p is None:
        return Status.OK.value
    nv = q.shape[0]
    qdd_c = np.empty(nv)
    for j in range(nv):
        w = 2.0 * np.pi * p[4 * nv + j]
        a, phase = p[3 * nv + j], p[5 * nv + j]
        s, c = np.sin(w * t + phase), np.cos(w * t + phase)
        q_r = p[2 * nv + j] + a * s
        qd_r = a * w * c
        qdd_r = -a * w * w * s
        qdd_c[j] = qdd_r + p[j] * (q_r - q[j]) + p[nv + j] * (qd_r - qd[j])
    loads = np.empty((1, 6))
    copy_into(dV_0, loads[0])
    tau_c = np.empty(nv)
    status = rnea_kernel(ibuf, fbuf, q, qd, qdd_c, loads, tau_c)
    for j in range(nv):
        tau[j] += tau_c[j]
    for j in range(armature.shape[0]):
        tau[j] += armature[j] * qdd_c[j]
    return status


@njit(**JIT)
def clip_effect(limit, tau):
    """tau <- clip(tau, -limit, limit); limit = effort limits (nv,), +inf where none; or None."""
    if limit is None:
        return
    for j in range(tau.shape[0]):
        tau[j] = min(max(tau[j], -limit[j]), limit[j])


@dataclass(frozen=True)
class StageTable:
    """A scene's step as data for the compiled loops.

    effects: a tuple with one slot per effect (GRAVITY ... CLIP): its parameters, or None when
      the scene does not name it. numba compiles the step for the tuple's types, and each effect
      function tests its slot against None when it compiles, so an effect the scene does not
      name is neither compiled nor run. Slots: gravity g (3,); damping b (nv,); friction
      (f_c (nv,), v_s); limits (k, d, lower, upper); wrench (rows (k, 4) int64, params), see
      wrench_effect; constant tau_0 (nv,); pd (kp, kd, q_set); computed torque (kp, kd,
      offset, amplitude, frequency, phase); clip the effort limits (nv,).
    names: the stages the scene names, in the order they run (for reports).
    slots: each named stage's slot in `effects`.
    method: forward dynamics by "aba", "crba" (CRBA + Cholesky: coupled mimic joints) or
      "newton_euler"; only that method is compiled.
    armature: (nv,) rotor inertias that forward dynamics adds to M's diagonal, or empty: armature
      is not a force but a change of M, so it has no slot.
    constraints: (rows (n_c, 5) int64, params float64, gains (2,)): the scene's constraints as
      opendyn.dynamics.constraints.constraint_table gives them and the Baumgarte gains
      (alpha, beta); None when the scene has none (the constrained solve is then neither
      compiled nor run).
    """

    effects: tuple
    names: tuple[str, ...]
    slots: tuple[int, ...]
    method: str
    armature: np.ndarray
    constraints: tuple | None = None


def _params(*values):
    return np.ascontiguousarray(
        np.concatenate([np.ravel(np.asarray(v, dtype=np.float64)) for v in values])
    )


def stage_table(scene) -> StageTable:
    """The compiled step's data for the effects `scene` names, in the order they run:
    gravity, damping, friction, limits, wrenches, control, clip (armature goes to M)."""
    model = scene.model
    slots = [None] * len(SLOT_NAMES)
    names = {}
    if scene.gravity is not None:
        slots[GRAVITY] = _params(scene.gravity)
    if scene.damping is not None:
        slots[DAMPING] = _params(scene.damping)
    if scene.friction is not None:
        slots[FRICTION] = _params(scene.friction.coulomb, scene.friction.smoothing)
    if scene.limits is not None:
        lim = scene.limits
        slots[LIMITS] = _params(lim.stiffness, lim.damping, lim.lower, lim.upper)
    rows, chunks, frames, offset = [], [], [], 0
    for w in scene.wrenches:
        frame = model.frames[model.frame_index(w.frame)]
        if frame.body < 0:
            continue  # a frame of the fixed world: its wrench moves no joint
        chunk = _params(frame.T_body_frame, w.times, w.values)
        rows.append((offset, len(w.times), frame.body, int(w.expressed_in == "world")))
        chunks.append(chunk)
        frames.append(w.frame)
        offset += chunk.size
    if rows:
        slots[WRENCH] = (np.array(rows, dtype=np.int64), np.concatenate(chunks))
        names[WRENCH] = "wrench on " + ", ".join(frames)
    control = scene.control
    if control is not None:
        if control.kind == "constant":
            slots[CONSTANT] = _params(control.tau)
        elif control.kind == "pd":
            slots[PD] = _params(control.kp, control.kd, control.setpoint)
        else:
            slots[COMPUTED_TORQUE] = _params(
                control.kp,
                control.kd,
                control.offset,
                control.amplitude,
                control.frequency,
                control.phase,
            )
        if control.clip:
            slots[CLIP] = _params(model.effort_limit)
    constraints = None
    if scene.constraints:
        c_rows, c_params = constraint_table(model, scene.constraints, scene.q0)
        gains = np.array(scene.baumgarte if scene.baumgarte is not None else (0.0, 0.0))
        constraints = (c_rows, c_params, gains)
    present = tuple(k for k, slot in enumerate(slots) if slot is not None)
    return StageTable(
        effects=tuple(slots),
        names=tuple(names.get(k, SLOT_NAMES[k]) for k in present),
        slots=present,
        method="crba" if model.coupled else "aba",
        armature=NO_ARMATURE if scene.armature is None else np.array(scene.armature, float),
        constraints=constraints,
    )

