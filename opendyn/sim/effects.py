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
  contact    tau = sum_p J_p^T f_p                            spheres on the ground plane: a
             spring-damper normal force f_n = max(0, k delta + d delta_dot) and regularised
             Coulomb friction f_t = -mu f_n v_t / sqrt(|v_t|^2 + v_s^2) at each sphere's lowest
             point (opendyn.algorithm.contact)
  control    constant  tau = tau_0
             pd        tau = kp (q_set - q) - kd qd
             computed_torque  tau = M(q) qdd_c + h(q, qd) computed by RNEA, with
                       qdd_c = qdd_r + kp (q_r - q) + kd (qd_r - qd) and the reference
                       q_r(t) = offset + amplitude sin(2 pi frequency t + phase);
                       the controller's model is the scene's rigid bodies, gravity and armature
             clip      tau_control clipped to +-effort_limit (joints with a finite limit)

Note the sign of a wrench here: an applied wrench F acts ON the robot, so it is -F_tip in the
dynamics functions' convention (F_tip is what the robot applies to the environment).

Per-joint values act on the joint coordinates: joint k's position is q[iq_k] and its velocity
qd[iv_k] (model.q_index, model.v_index), so a floating base (q = (p, quat, q_joints), v =
(omega_b, v_b, qd_joints)) is neither damped, limited nor actuated by them: the base is driven
only by gravity, applied wrenches and the reaction of the joints. Computed torque on a floating
base solves for the base acceleration the joint torques produce (see computed_torque_effect).

A scene becomes a tuple with one slot per effect (`stage_table`): the effect's parameters, or
None when the scene does not name it. Each effect function tests its slot against None, which
numba decides when it compiles the step for that tuple, so an effect the scene does not name is
neither compiled nor evaluated. The effect functions also add their derivatives to the
stiffness K = -d tau / d q and damping D = -d tau / d qd (nv, nv) when asked, for the integrator
that treats them implicitly: the per-joint effects on the diagonal, contact as J_p^T K_p J_p.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .._runtime.arrays import copy_into
from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from ..algorithm.cholesky import cholesky_solve
from ..algorithm.constraints import ConstraintTable, constraint_table
from ..algorithm.contact import contact_kernel
from ..algorithm.crba import crba_kernel
from ..algorithm.forward import NO_ARMATURE
from ..algorithm.kinematics import jacobian_kernel
from ..algorithm.rnea import rnea_kernel
from ..multibody.data import frame_pose_field
from ..multibody.layout import body_count

# the slots of a scene's effects tuple, in the order the step runs them; a slot holds the
# effect's parameters, or None when the scene does not name it
GRAVITY, DAMPING, FRICTION, LIMITS, WRENCH, CONTACT, CONSTANT, PD, COMPUTED_TORQUE, CLIP = range(10)
SLOT_NAMES = (
    "gravity",
    "damping",
    "friction",
    "limits",
    "wrench",
    "contact",
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
def damping_effect(p, qd, tau, D, jac):
    """tau_j -= b_k qd_j; D_jj += b_k at each joint's velocity j = iv_k. p = (b (n,), iq, iv),
    or None (no damping)."""
    if p is None:
        return
    b, _, iv = p
    for k in range(b.shape[0]):
        j = iv[k]
        tau[j] -= b[k] * qd[j]
        if jac:
            D[j, j] += b[k]


@njit(**JIT)
def friction_effect(p, qd, tau, D, jac):
    """tau_j -= f_c tanh(qd_j / v_s); D_jj += f_c (1 - tanh^2) / v_s at each joint's velocity
    j = iv_k. p = ((f_c (n,), v_s), iq, iv), or None."""
    if p is None:
        return
    f, _, iv = p
    n = iv.shape[0]
    v_s = f[n]
    for k in range(n):
        j = iv[k]
        s = np.tanh(qd[j] / v_s)
        tau[j] -= f[k] * s
        if jac:
            D[j, j] += f[k] * (1.0 - s * s) / v_s


@njit(**JIT)
def limits_effect(p, q, qd, tau, K, D, jac):
    """Spring-dampers past the limits: tau_j -= k (q_i - limit) + d qd_j; K_jj += k, D_jj += d
    there, with i = iq_k, j = iv_k joint k's coordinates. p = ((k, d, lower, upper), each
    (n,), iq, iv); or None."""
    if p is None:
        return
    params, iq, iv = p
    n = iv.shape[0]
    for k in range(n):
        i, j = iq[k], iv[k]
        lower, upper = params[2 * n + k], params[3 * n + k]
        if q[i] > upper:
            depth = q[i] - upper
        elif q[i] < lower:
            depth = q[i] - lower
        else:
            continue
        tau[j] -= params[k] * depth + params[n + k] * qd[j]
        if jac:
            K[j, j] += params[k]
            D[j, j] += params[n + k]


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
def wrench_effect(wrenches, ibuf, fbuf, work, t, q, tau):
    """tau += sum over the wrenches of J_b(frame)^T F_frame. wrenches = (rows (k, 4) int64,
    params), or None; row (offset into params, samples n, body, world); params at offset:
    T_body_frame (16,), then the table of n samples (wrench_at). world = 1: F is given in
    world-aligned axes at the frame's origin, F_frame = (R^T m, R^T f), with R from the pose
    T_sf that the Jacobian's kinematics leave in `work` (one pass of kinematics a wrench)."""
    if wrenches is None:
        return
    rows, params = wrenches
    nv = tau.shape[0]
    F = np.empty(6)
    F_s = np.empty(6)
    J_b = np.empty((6, nv))
    T_sf = frame_pose_field(work, body_count(ibuf), nv)
    for w in range(rows.shape[0]):
        offset, n, body, world = rows[w, 0], rows[w, 1], rows[w, 2], rows[w, 3]
        p = params[offset:]
        T_bf = p[:16].reshape((4, 4))
        wrench_at(p[16:], n, t, F)
        jacobian_kernel(ibuf, fbuf, work, q, (body, T_bf), True, J_b)
        if world == 1:
            copy_into(F, F_s)
            for r in range(3):
                F[r] = T_sf[0, r] * F_s[0] + T_sf[1, r] * F_s[1] + T_sf[2, r] * F_s[2]
                F[3 + r] = T_sf[0, r] * F_s[3] + T_sf[1, r] * F_s[4] + T_sf[2, r] * F_s[5]
        for j in range(nv):
            s = 0.0
            for r in range(6):
                s += J_b[r, j] * F[r]
            tau[j] += s


@njit(**JIT)
def contact_effect(p, ibuf, fbuf, work, q, qd, tau, linear, power):
    """tau += sum_p J_p^T f_p, the ground's forces on the contact spheres; power[1] += their
    spring's share sum_p k delta_p delta_dot_p (with qd . tau it makes the contacts'
    non-conservative power); with linear = (K, D, jac) and jac, K, D (nv, nv) += their
    linearisation (opendyn.algorithm.contact). p = (bodies (P,) int64, params), or None.
    Works in `work`, the step's Data buffer."""
    if p is None:
        return
    K, D, jac = linear
    n = p[0].shape[0]
    record = (np.empty((n, 3)), np.empty((n, 3)), np.empty(n))
    # np.bool_(jac): a run-time flag, so that the kernel compiles once for both values
    power[1] += contact_kernel(ibuf, fbuf, work, p, q, qd, tau, (K, D, np.bool_(jac)), record)


@njit(**JIT)
def constant_effect(p, tau):
    """tau_j += tau_0k at each joint's velocity j = iv_k. p = (tau_0 (n,), iq, iv), or None."""
    if p is None:
        return
    tau_0, _, iv = p
    for k in range(iv.shape[0]):
        tau[iv[k]] += tau_0[k]


@njit(**JIT)
def pd_effect(p, q, qd, tau, K, D, jac):
    """tau_j += kp (q_set - q_i) - kd qd_j; K_jj += kp, D_jj += kd, with i = iq_k, j = iv_k
    joint k's coordinates. p = ((kp, kd, q_set), each (n,), iq, iv); or None."""
    if p is None:
        return
    gains, iq, iv = p
    n = iv.shape[0]
    for k in range(n):
        i, j = iq[k], iv[k]
        tau[j] += gains[k] * (gains[2 * n + k] - q[i]) - gains[n + k] * qd[j]
        if jac:
            K[j, j] += gains[k]
            D[j, j] += gains[n + k]


@njit(**JIT)
def base_reaction(ibuf, fbuf, work, q, tau_c):
    """A floating base is unactuated: given tau_c (nv,) = RNEA(q, qd, (0, qdd_c)) = M_{:,j} qdd_c
    + h, the base accelerates with a_b = -M_bb^-1 tau_c[:6] (its rows of M a + h vanish), and
    the joints need tau_j = tau_c[j] + M_jb a_b. tau_c <- (0, tau_j). Returns a Status
    (SINGULAR when the whole body has no inertia)."""
    nv = tau_c.shape[0]
    M = np.empty((nv, nv))
    crba_kernel(ibuf, fbuf, work, q, M)
    M_bb = np.empty((6, 6))
    minus_h_b = np.empty(6)
    for r in range(6):
        minus_h_b[r] = -tau_c[r]
        for c in range(6):
            M_bb[r, c] = M[r, c]
    a_b = np.empty(6)
    status = cholesky_solve(M_bb, minus_h_b, a_b)
    if status:
        return status
    for r in range(6):
        tau_c[r] = 0.0
    for j in range(6, nv):
        for c in range(6):
            tau_c[j] += M[j, c] * a_b[c]
    return Status.OK.value


@njit(**JIT)
def computed_torque_effect(p, ibuf, fbuf, work, t, q, qd, dV_0, armature, tau):
    """tau += the joint torques that give the joints the acceleration
    qdd_c = qdd_r + kp (q_r - q) + kd (qd_r - qd), q_r = offset + amplitude sin(w t + phase),
    w = 2 pi frequency (joint k's position q[iq_k], velocity qd[iv_k]):

      fixed base      tau = M(q) qdd_c + h(q, qd) + armature qdd_c          (RNEA)
      floating base   tau_j = M_jb a_b + M_jj qdd_c + h_j + armature qdd_c,
                      a_b = -M_bb^-1 (M_bj qdd_c + h_b): the acceleration of the unactuated
                      base under those torques (base_reaction)

    p = ((kp, kd, offset, amplitude, frequency, phase) each (n,), iq, iv, base) with base None
    for a fixed base and True for a floating one (a compile-time switch: a fixed-base scene
    does not compile base_reaction); or None. Returns a Status."""
    if p is None:
        return Status.OK.value
    params, iq, iv, base = p
    n = iv.shape[0]
    qdd_c = np.zeros(qd.shape[0])  # the base's rows stay 0 in the RNEA call
    for k in range(n):
        i, j = iq[k], iv[k]
        w = 2.0 * np.pi * params[4 * n + k]
        a, phase = params[3 * n + k], params[5 * n + k]
        s, c = np.sin(w * t + phase), np.cos(w * t + phase)
        q_r = params[2 * n + k] + a * s
        qd_r = a * w * c
        qdd_r = -a * w * w * s
        qdd_c[j] = qdd_r + params[k] * (q_r - q[i]) + params[n + k] * (qd_r - qd[j])
    loads = np.empty((1, 6))
    copy_into(dV_0, loads[0])
    tau_c = np.empty(qd.shape[0])
    status = rnea_kernel(ibuf, fbuf, work, q, qd, qdd_c, loads, tau_c)
    if status:
        return status
    if base is not None:
        status = base_reaction(ibuf, fbuf, work, q, tau_c)
        if status:
            return status
    for k in range(n):
        j = iv[k]
        tau[j] += tau_c[j]
        if armature.shape[0]:
            tau[j] += armature[j] * qdd_c[j]
    return Status.OK.value


@njit(**JIT)
def clip_effect(p, tau):
    """tau_j <- clip(tau_j, -limit_k, limit_k) at each joint's velocity j = iv_k; p = (effort
    limits (n,), +inf where none, iq, iv); or None."""
    if p is None:
        return
    limit, _, iv = p
    for k in range(iv.shape[0]):
        j = iv[k]
        tau[j] = min(max(tau[j], -limit[k]), limit[k])


@dataclass(frozen=True)
class StageTable:
    """A scene's step as data for the compiled loops.

    effects: a tuple with one slot per effect (GRAVITY ... CLIP): its parameters, or None when
      the scene does not name it. numba compiles the step for the tuple's types, and each effect
      function tests its slot against None when it compiles, so an effect the scene does not
      name is neither compiled nor run. Slots: gravity g (3,); wrench (rows (k, 4) int64,
      params), see wrench_effect; contact (bodies (P,) int64, params), see contact_table; the
      per-joint effects (values, iq, iv) with iq, iv (n,) the joints' indices into q and v
      (model.q_index, model.v_index) and values: damping b (n,); friction (f_c (n,), v_s); limits
      (k, d, lower, upper); constant tau_0 (n,); pd (kp, kd, q_set); clip the effort limits (n,);
      computed torque (kp, kd, offset, amplitude, frequency, phase), iq, iv and a fourth item, True
      for a floating base, None for a fixed one.
    names: the stages the scene names, in the order they run (for reports).
    slots: each named stage's slot in `effects`.
    method: forward dynamics by "aba", "crba" (CRBA + Cholesky: coupled mimic joints) or
      "newton_euler"; only that method is compiled.
    armature: (nv,) rotor inertias that forward dynamics adds to M's diagonal, or empty: armature
      is not a force but a change of M, so it has no slot.
    constraints: (rows (n_c, 5) int64, params float64, gains (2,)): the scene's constraints as
      opendyn.algorithm.constraints.constraint_table gives them and the Baumgarte gains
      (alpha, beta); None when the scene has none (the constrained solve is then neither
      compiled nor run).
    """

    effects: tuple
    names: tuple[str, ...]
    slots: tuple[int, ...]
    method: str
    armature: np.ndarray
    constraints: tuple | None = None


def _in_v(model, per_joint):
    """A per-joint array (n,) as a velocity-space array (nv,): zero on a floating base."""
    out = np.zeros(model.nv)
    out[model.v_index] = per_joint
    return out


def _params(*values):
    return np.ascontiguousarray(
        np.concatenate([np.ravel(np.asarray(v, dtype=np.float64)) for v in values])
    )


def contact_table(model, contact):
    """(bodies (P,) int64, params) of opendyn.algorithm.contact for a scene's contact
    (scene.Contact): the shared values (ground height, k, d, mu, v_s), then each point's sphere
    centre c_b = T_body_frame (position, 1) in its body's frame (m) and radius (m)."""
    bodies, chunks = [], []
    for point in contact.points:
        frame = model.frames[model.frame_index(point.frame)]
        bodies.append(frame.body)
        chunks += [(frame.T_body_frame @ np.append(point.position, 1.0))[:3], point.radius]
    shared = (
        contact.ground_height,
        contact.stiffness,
        contact.damping,
        contact.friction,
        contact.slip_velocity,
    )
    return np.array(bodies, dtype=np.int64), _params(shared, *chunks)


def stage_table(scene) -> StageTable:
    """The compiled step's data for the effects `scene` names, in the order they run:
    gravity, damping, friction, limits, wrenches, contact, control, clip (armature goes to
    M)."""
    model = scene.model
    slots = [None] * len(SLOT_NAMES)
    names = {}
    # where each per-joint value acts: joint k's position q[iq_k] and velocity qd[iv_k]
    iq = np.array(model.q_index, dtype=np.int64)
    iv = np.array(model.v_index, dtype=np.int64)
    if scene.gravity is not None:
        slots[GRAVITY] = _params(scene.gravity)
    if scene.damping is not None:
        slots[DAMPING] = (_params(scene.damping), iq, iv)
    if scene.friction is not None:
        slots[FRICTION] = (_params(scene.friction.coulomb, scene.friction.smoothing), iq, iv)
    if scene.limits is not None:
        lim = scene.limits
        slots[LIMITS] = (_params(lim.stiffness, lim.damping, lim.lower, lim.upper), iq, iv)
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
    if scene.contact is not None:
        slots[CONTACT] = contact_table(model, scene.contact)
        names[CONTACT] = f"contact ({len(scene.contact.points)} points)"
    control = scene.control
    if control is not None:
        if control.kind == "constant":
            slots[CONSTANT] = (_params(control.tau), iq, iv)
        elif control.kind == "pd":
            slots[PD] = (_params(control.kp, control.kd, control.setpoint), iq, iv)
        else:
            gains = _params(
                control.kp,
                control.kd,
                control.offset,
                control.amplitude,
                control.frequency,
                control.phase,
            )
            slots[COMPUTED_TORQUE] = (gains, iq, iv, True if model.floating_base else None)
        if control.clip:
            slots[CLIP] = (_params(model.effort_limit), iq, iv)
    constraints = None
    if scene.constraints:
        c_rows, c_params = constraint_table(model, scene.constraints, scene.q0)
        gains = np.array(scene.baumgarte if scene.baumgarte is not None else (0.0, 0.0))
        constraints = ConstraintTable(c_rows, c_params, gains)
    present = tuple(k for k, slot in enumerate(slots) if slot is not None)
    return StageTable(
        effects=tuple(slots),
        names=tuple(names.get(k, SLOT_NAMES[k]) for k in present),
        slots=present,
        method="crba" if model.coupled else "aba",
        armature=NO_ARMATURE if scene.armature is None else _in_v(model, scene.armature),
        constraints=constraints,
    )

