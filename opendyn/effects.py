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

A scene becomes a short table of stages, one row per effect it names (`stage_table`); the
compiled step (opendyn.step) runs exactly those rows, so an effect the scene does not name has
no row and is never evaluated. The effect functions also add their derivatives to the diagonal
stiffness K = -d tau / d q and damping D = -d tau / d qd when asked, for the integrator that
treats them implicitly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .dynamics._kernels import INLINE
from .dynamics.constraints import constraint_table
from .dynamics.forward import NO_ARMATURE
from .dynamics.kinematics import frame_pose_kernel, jacobian_kernel
from .dynamics.rnea import rnea_kernel

# stage codes: the rows of a stage table, in the order the step runs them
GRAVITY, DAMPING, FRICTION, LIMITS, WRENCH, CONSTANT, PD, COMPUTED_TORQUE, CLIP = range(9)
STAGE_NAMES = (
    "gravity",
    "damping",
    "friction",
    "limits",
    "wrench",
    "control",
    "control",
    "control",
    "clip",
)


@njit(**INLINE)
def gravity_effect(p, dV_0):
    """dV_0 = (0, -g): the base acceleration that produces gravity; p = g (3,)."""
    for k in range(3):
        dV_0[3 + k] = -p[k]


@njit(**INLINE)
def damping_effect(p, qd, tau, D, jac):
    """tau -= b qd; D += b. p = b (nv,)."""
    for k in range(qd.shape[0]):
        tau[k] -= p[k] * qd[k]
        if jac:
            D[k] += p[k]


@njit(**INLINE)
def friction_effect(p, qd, tau, D, jac):
    """tau -= f_c tanh(qd / v_s); D += f_c (1 - tanh^2) / v_s. p = (f_c (nv,), v_s)."""
    nv = qd.shape[0]
    v_s = p[nv]
    for k in range(nv):
        s = np.tanh(qd[k] / v_s)
        tau[k] -= p[k] * s
        if jac:
            D[k] += p[k] * (1.0 - s * s) / v_s


@njit(**INLINE)
def limits_effect(p, q, qd, tau, K, D, jac):
    """Spring-dampers past the limits: tau -= k (q - limit) + d qd; K += k, D += d there.
    p = (k, d, lower, upper), each (nv,)."""
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


@njit(**INLINE)
def wrench_at(p, n, t, F):
    """F (6,) <- the wrench table p = (times (n,), values (n, 6)) at time t: linear between
    samples, the first value before the first time and the last after the last."""
    if n == 1 or t <= p[0]:
        F[:] = p[n : n + 6]
        return
    if t >= p[n - 1]:
        F[:] = p[n + 6 * (n - 1) : n + 6 * n]
        return
    k = np.searchsorted(p[:n], t) - 1
    w = (t - p[k]) / (p[k + 1] - p[k])
    for r in range(6):
        F[r] = (1.0 - w) * p[n + 6 * k + r] + w * p[n + 6 * (k + 1) + r]


@njit(**INLINE)
def wrench_effect(ibuf, fbuf, p, n, body, world, t, q, tau):
    """tau += J_b(frame)^T F_frame. p = (T_body_frame (16,), table of n samples).
    world: F is given in world-aligned axes at the frame's origin, F_frame = (R^T m, R^T f)."""
    nv = q.shape[0]
    T_bf = p[:16].reshape((4, 4))
    F = np.empty(6)
    wrench_at(p[16:], n, t, F)
    if world:
        T_sf = np.empty((4, 4))
        frame_pose_kernel(ibuf, fbuf, q, body, T_bf, T_sf)
        F_s = F.copy()
        for r in range(3):
            F[r] = T_sf[0, r] * F_s[0] + T_sf[1, r] * F_s[1] + T_sf[2, r] * F_s[2]
            F[3 + r] = T_sf[0, r] * F_s[3] + T_sf[1, r] * F_s[4] + T_sf[2, r] * F_s[5]
    J_b = np.empty((6, nv))
    jacobian_kernel(ibuf, fbuf, q, body, T_bf, True, J_b)
    for j in range(nv):
        s = 0.0
        for r in range(6):
            s += J_b[r, j] * F[r]
        tau[j] += s


@njit(**INLINE)
def pd_effect(p, q, qd, tau, K, D, jac):
    """tau += kp (q_set - q) - kd qd; K += kp, D += kd. p = (kp, kd, q_set), each (nv,)."""
    nv = q.shape[0]
    for j in range(nv):
        tau[j] += p[j] * (p[2 * nv + j] - q[j]) - p[nv + j] * qd[j]
        if jac:
            K[j] += p[j]
            D[j] += p[nv + j]


@njit(**INLINE)
def computed_torque_effect(ibuf, fbuf, p, t, q, qd, dV_0, armature, tau):
    """tau += M(q) qdd_c + h(q, qd) by RNEA (plus armature qdd_c), with
    qdd_c = qdd_r + kp (q_r - q) + kd (qd_r - qd) and q_r = offset + amplitude sin(w t + phase),
    w = 2 pi frequency. p = (kp, kd, offset, amplitude, frequency, phase), each (nv,).
    Returns the RNEA status."""
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
    loads[0] = dV_0
    tau_c = np.empty(nv)
    status = rnea_kernel(ibuf, fbuf, q, qd, qdd_c, loads, tau_c)
    for j in range(nv):
        tau[j] += tau_c[j]
    for j in range(armature.shape[0]):
        tau[j] += armature[j] * qdd_c[j]
    return status


@njit(**INLINE)
def clip_effect(p, tau):
    """tau <- clip(tau, -limit, limit); p = effort limits (nv,), +inf where none."""
    for j in range(tau.shape[0]):
        tau[j] = min(max(tau[j], -p[j]), p[j])


@dataclass(frozen=True)
class StageTable:
    """A scene's step as data for the compiled loops.

    rows: (S, 5) int64, one row per stage: (code, offset into params, count, body, flag); for a
      wrench: count its table samples, body the body its frame is welded to, flag 1 when the
      wrench is given in world-aligned axes.
    params: flat float64 parameters of every stage.
    names: (S,) the stage names, for reports.
    method: forward dynamics by 0 = ABA, 1 = CRBA + Cholesky (coupled mimic joints).
    armature: (nv,) rotor inertias that forward dynamics adds to M's diagonal, or empty: armature
      is not a force but a change of M, so it has no row.
    constraints: (rows (n_c, 5) int64, params float64, gains (2,)): the scene's constraints as
      opendyn.dynamics.constraints.constraint_table gives them and the Baumgarte gains
      (alpha, beta); None when the scene has none. The compiled loops then drop the constrained
      solve at compile time (a None argument prunes its branch), so that a scene without
      constraints neither compiles nor runs it.
    """

    rows: np.ndarray
    params: np.ndarray
    names: tuple[str, ...]
    method: int
    armature: np.ndarray
    constraints: tuple | None = None


def stage_table(scene) -> StageTable:
    """The rows of the compiled step for the effects `scene` names, in the order they run:
    gravity, damping, friction, limits, wrenches, control, clip (armature goes to M)."""
    model = scene.model
    rows, chunks, names = [], [], []
    offset = 0

    def add(code, values, count=0, body=-1, flag=0, name=None):
        nonlocal offset
        values = np.ascontiguousarray(np.asarray(values, dtype=np.float64).ravel())
        rows.append((code, offset, count, body, flag))
        chunks.append(values)
        names.append(name or STAGE_NAMES[code])
        offset += values.size

    if scene.gravity is not None:
        add(GRAVITY, scene.gravity)
    if scene.damping is not None:
        add(DAMPING, scene.damping)
    if scene.friction is not None:
        add(FRICTION, np.append(scene.friction.coulomb, scene.friction.smoothing))
    if scene.limits is not None:
        lim = scene.limits
        add(LIMITS, np.concatenate([lim.stiffness, lim.damping, lim.lower, lim.upper]))
    for w in scene.wrenches:
        frame = model.frames[model.frame_index(w.frame)]
        if frame.body < 0:
            continue  # a frame of the fixed world: its wrench moves no joint
        table = np.concatenate([frame.T_body_frame.ravel(), w.times, np.ravel(w.values)])
        world = int(w.expressed_in == "world")
        add(WRENCH, table, len(w.times), frame.body, world, f"wrench on {w.frame}")
    control = scene.control
    if control is not None:
        if control.kind == "constant":
            add(CONSTANT, control.tau, name="control (constant)")
        elif control.kind == "pd":
            add(PD, np.concatenate([control.kp, control.kd, control.setpoint]), name="control (pd)")
        else:
            gains = [control.kp, control.kd, control.offset, control.amplitude]
            params = np.concatenate([*gains, control.frequency, control.phase])
            add(COMPUTED_TORQUE, params, name="control (computed torque)")
        if control.clip:
            add(CLIP, model.effort_limit)
    constraints = None
    if scene.constraints:
        c_rows, c_params = constraint_table(model, scene.constraints, scene.q0)
        gains = np.array(scene.baumgarte if scene.baumgarte is not None else (0.0, 0.0))
        constraints = (c_rows, c_params, gains)
    return StageTable(
        rows=np.array(rows, dtype=np.int64).reshape(-1, 5),
        params=np.concatenate(chunks) if chunks else np.zeros(0),
        names=tuple(names),
        method=0 if model.nb == model.nv else 1,
        armature=NO_ARMATURE if scene.armature is None else np.array(scene.armature, float),
        constraints=constraints,
    )
