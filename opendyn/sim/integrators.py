"""Integrators for x = (q, qd, W) with dq/dt = qd, dqd/dt = qdd(t, q, qd), dW/dt = power, kept
apart from the dynamics: they see only `evaluate` (opendyn.sim.step) and advance positions only
through `integrate_kernel(q, v, dt)` (q (+) v dt, opendyn.algorithm.configuration).

  euler                explicit Euler, the seed's: q' = q + qd dt, qd' = qd + qdd(q, qd) dt.
                       Order 1; gains energy on every oscillation.
  semi_implicit_euler  symplectic Euler in momentum form, p = (M(q) + diag(armature)) qd:
                         p' = p + dt (dK/dq(q, v) - g(q) + tau(t, q, qd)),  v = (M(q) + ..)^-1 p',
                         q' = q (+) v dt,   qd' = (M(q') + diag(armature))^-1 p'
                       (v by fixed-point iteration at fixed q; dK/dq at fixed velocity,
                       opendyn.algorithm.energy; for a floating base its rows are
                       ad_{V_b}^T p_b, the Euler-Poincare term of the base momentum p_b in
                       its own frame, d/dt p_b = ad_{V_b}^T p_b + F_b). Order 1; symplectic
                       for the conservative forces, so the energy error stays bounded (no
                       secular drift) on conservative scenes. The velocity form
                       qd' = qd + qdd dt, q' = q + qd' dt is symplectic only for a constant M:
                       on the double pendulum it lost energy steadily (max |E - E(0)| 14.6,
                       21.2, 31.3 J in successive 20 s at 1 ms, E = 79 J). Not for constrained
                       scenes.
  rk4                  classical Runge-Kutta, order 4 (the default).
  dopri5               Dormand-Prince 5(4), adaptive: the local error estimate
                       err = dt sum_i (b_i - b^_i) k_i is kept below atol + rtol |x| (RMS norm
                       over the 2 nv velocity-space components) by choosing the step; FSAL
                       (first same as last). The position part is a difference in v-space (the
                       two solutions' moves q (+) dt sum b_i kq_i differ by dt sum e_i kq_i, a
                       body twist times dt for a free joint), each row scaled by the size of
                       the coordinate it moves (size_index).
  implicit_euler       linearly implicit in velocity: the effects' stiffness K = -dtau/dq and
                       damping D = -dtau/dqd (nv, nv) are taken at the end of the step,
                         (M + diag(armature) + dt D + dt^2 K) (qd' - qd) = dt (tau - h - dt K qd),
                         q' = q (+) qd' dt,
                       which is backward Euler for the stiff linear parts (limits, damping, PD,
                       the contacts' springs, dampers and regularised friction, whose
                       J_p^T K_p J_p fill K and D beyond the diagonal) and stays stable at any
                       step on them. Order 1.

The explicit Runge-Kutta methods are data (Butcher tableaux, Hairer, Norsett & Wanner, Solving
Ordinary Differential Equations I, 2nd ed., Table 1.2 (RK4) and Table 5.2 (DOPRI5)) run by one
compiled loop. On a floating base they are Runge-Kutta-Munthe-Kaas methods (Hairer, Lubich &
Wanner, Geometric Numerical Integration, 2nd ed., Section IV.8.2): stage i sits at
q (+) Theta_i, Theta_i = dt sum_l A_il k_l, and its base velocity V_i enters the sums as
k_i = dexp^-1(V_i) = V_i + 1/2 [Theta_i, V_i] + 1/12 [Theta_i, [Theta_i, V_i]]
- 1/720 ad_Theta_i^4 V_i (the body-frame dexp, truncated past the method's order): without it
the stages' body twists, taken at different orientations, are summed as if they commuted, and
RK4 falls to order 2 in the base pose (the momentum of a tumbling tree drifted as dt^2).
All loops are compiled: a simulation pays no Python overhead per step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from .._runtime.arrays import copy_into
from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from ..algorithm.cholesky import (
    cholesky_factor,
    cholesky_solve,
    cholesky_substitute,
    largest_diagonal,
)
from ..algorithm.configuration import integrate_kernel
from ..algorithm.constraints import constrained_solve_at
from ..algorithm.crba import crba_kernel
from ..algorithm.energy import kinetic_gradient_kernel
from ..algorithm.rnea import rnea_kernel
from ..spatial.compiled import ad_twist
from .step import evaluate, generalized_forces

FIXED_POINT_RTOL = 1e-14  # the momentum update's iteration stops when v changes less than this
FIXED_POINT_MAX = 50
EXPLICIT_RK, SEMI_IMPLICIT, IMPLICIT = 0, 1, 2  # fixed-step loop kinds


@dataclass(frozen=True)
class Integrator:
    """An integrator: its name, order, loop kind and (explicit Runge-Kutta) tableau.

    A (s, s), b (s,), c (s,): Butcher tableau; e (s,): b - b^ of an embedded pair (adaptive)."""

    name: str
    order: int
    kind: int
    adaptive: bool
    description: str
    A: np.ndarray = field(default_factory=lambda: np.zeros((1, 1)))
    b: np.ndarray = field(default_factory=lambda: np.ones(1))
    c: np.ndarray = field(default_factory=lambda: np.zeros(1))
    e: np.ndarray = field(default_factory=lambda: np.zeros(1))

    def switches(self):
        """(tableau, implicit, symplectic): the compile-time switches of run_fixed, one of
        them not None, so that only this integrator's step is compiled: the tableau (A, b, c)
        of an explicit Runge-Kutta method, or True for implicit or semi-implicit Euler."""
        return (
            (self.A, self.b, self.c) if self.kind == EXPLICIT_RK else None,
            True if self.kind == IMPLICIT else None,
            True if self.kind == SEMI_IMPLICIT else None,
        )


_RK4 = dict(
    A=np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]], dtype=float),
    b=np.array([1, 2, 2, 1], dtype=float) / 6,
    c=np.array([0, 0.5, 0.5, 1]),
)
_DOPRI5_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0])
_DOPRI5_BHAT = np.array(
    [5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40]
)
_DOPRI5 = dict(
    A=np.array(
        [
            [0, 0, 0, 0, 0, 0, 0],
            [1 / 5, 0, 0, 0, 0, 0, 0],
            [3 / 40, 9 / 40, 0, 0, 0, 0, 0],
            [44 / 45, -56 / 15, 32 / 9, 0, 0, 0, 0],
            [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0, 0],
            [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0, 0],
            list(_DOPRI5_B),
        ]
    ),
    b=_DOPRI5_B,
    c=np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1]),
    e=_DOPRI5_B - _DOPRI5_BHAT,
)

INTEGRATORS = {
    "euler": Integrator("euler", 1, EXPLICIT_RK, False, "explicit Euler (the seed's)"),
    "semi_implicit_euler": Integrator(
        "semi_implicit_euler", 1, SEMI_IMPLICIT, False, "semi-implicit (symplectic) Euler"
    ),
    "rk4": Integrator("rk4", 4, EXPLICIT_RK, False, "classical Runge-Kutta 4", **_RK4),
    "dopri5": Integrator(
        "dopri5", 5, EXPLICIT_RK, True, "Dormand-Prince 5(4), adaptive", **_DOPRI5
    ),
    "implicit_euler": Integrator(
        "implicit_euler", 1, IMPLICIT, False, "Euler, linearly implicit in velocity"
    ),
}


@njit(**JIT)
def state_ok(q, qd, max_speed):
    """Status.OK.value when q and qd are finite and every |qd| <= max_speed, else Q/QD_NOT_FINITE or
    DIVERGED."""
    for k in range(q.shape[0]):
        if not np.isfinite(q[k]):
            return Status.Q_NOT_FINITE.value
    for k in range(qd.shape[0]):
        if not np.isfinite(qd[k]):
            return Status.QD_NOT_FINITE.value
        if abs(qd[k]) > max_speed:
            return Status.DIVERGED.value
    return Status.OK.value


@njit(**JIT)
def rk_work(s, nq, nv):
    """Scratch of an s-stage Runge-Kutta step: (kq (s, nv), kv (s, nv), kw (s, 2), qs (nq,),
    qds (nv,), v (nv,), stage_tau (nv,)) for rk_stages and rk_combine."""
    return (
        np.empty((s, nv)),
        np.empty((s, nv)),
        np.empty((s, 2)),
        np.empty(nq),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
    )


@njit(**JIT)
def dexp_inverse(free, theta, k):
    """k <- dexp^-1_Theta(k) = k + 1/2 ad_Theta k + 1/12 ad_Theta^2 k - 1/720 ad_Theta^4 k on
    the six rows of each free joint, whose first v index is in `free`; theta (nv,) holds the
    stage's increments Theta (a body twist times dt for a free joint). The velocity of the
    increment Theta with which q (+) Theta moves at body twist V (the right-trivialised
    derivative of exp on SE(3); Hairer, Lubich & Wanner, Lemma III.4.2 with Theta -> -Theta)."""
    ad1 = np.empty(6)
    ad2 = np.empty(6)
    ad3 = np.empty(6)
    ad4 = np.empty(6)
    for b in free:
        th, v = theta[b : b + 6], k[b : b + 6]
        ad_twist(th, v, ad1)
        ad_twist(th, ad1, ad2)
        ad_twist(th, ad2, ad3)
        ad_twist(th, ad3, ad4)
        for r in range(6):
            v[r] += 0.5 * ad1[r] + ad2[r] / 12.0 - ad4[r] / 720.0


@njit(**JIT)
def rk_stages(scene, A, c, t, dt, q, qd, work, first, tau_stage, tau, free):
    """Stages first..s-1 of an explicit Runge-Kutta step from (t, q, qd): stage i at
    q_i = q (+) dt sum_l A_il kq_l, qd_i = qd + dt sum_l A_il kv_l, kq_i = qd_i (a floating
    base's rows through dexp_inverse: the Munthe-Kaas stage),
    kv_i = qdd(t + c_i dt, q_i, qd_i), kw_i = power there, with work = rk_work(...) =
    (kq, kv, kw, qs, qds, v, stage_tau). first = 1 when stage 0 is already in kq, kv, kw (FSAL).
    free: None (a fixed base: the correction is not compiled) or the first v index of each free
    joint (int64). tau <- the control torque at stage tau_stage. Returns (status, evaluations)."""
    kq, kv, kw, qs, qds, v, stage_tau = work
    ibuf = scene[0]
    nv = qd.shape[0]
    for i in range(first, A.shape[0]):
        for j in range(nv):
            dv = 0.0
            dq = 0.0
            for m in range(i):
                dq += A[i, m] * kq[m, j]
                dv += A[i, m] * kv[m, j]
            v[j] = dq
            qds[j] = qd[j] + dt * dv
        integrate_kernel(ibuf, q, v, dt, qs)
        copy_into(qds, kq[i])
        if free is not None and i > 0:
            for j in range(nv):
                v[j] *= dt  # Theta_i
            dexp_inverse(free, v, kq[i])
        status = evaluate(scene, t + c[i] * dt, qs, qds, kv[i], stage_tau, kw[i])
        if i == tau_stage:
            copy_into(stage_tau, tau)
        if status:
            return status, i - first + 1
    return Status.OK.value, A.shape[0] - first


@njit(**JIT)
def rk_combine(ibuf, weights, dt, q, qd, w, work, q1, qd1, w1):
    """x1 = x (+) dt sum_i weights_i k_i for q (through integrate), qd and the work W."""
    kq, kv, kw, _, _, v, _ = work
    nv = qd.shape[0]
    for j in range(nv):
        dq = 0.0
        dv = 0.0
        for i in range(weights.shape[0]):
            dq += weights[i] * kq[i, j]
            dv += weights[i] * kv[i, j]
        v[j] = dq
        qd1[j] = qd[j] + dt * dv
    integrate_kernel(ibuf, q, v, dt, q1)
    for k in range(2):
        dw = 0.0
        for i in range(weights.shape[0]):
            dw += weights[i] * kw[i, k]
        w1[k] = w[k] + dt * dw


@njit(**JIT)
def velocity_solve(ibuf, fbuf, con, q, qd, M, rhs, qdd):
    """qdd <- M^-1 rhs, or with constraints con (a ConstraintTable, not None) the constrained
    solve of M qdd + A^T lambda = rhs (M overwritten). A function of its own so that the test on
    None is decided when it compiles. Returns a Status (SINGULAR + k: M singular at joint k)."""
    if con is None:
        return cholesky_solve(M, rhs, qdd)
    lam = np.empty(con.rows[:, 2].sum())
    return constrained_solve_at(ibuf, fbuf, con, q, qd, M, rhs, qdd, lam)


@njit(**JIT)
def implicit_velocity_step(scene, t, dt, q, qd, w, q1, qd1, w1, tau_ctrl):
    """One linearly implicit Euler step (module docstring). Returns a Status."""
    ibuf, fbuf, work = scene.ibuf, scene.fbuf, scene.work
    armature, con, loads = scene.armature, scene.constraints, scene.loads
    nv = qd.shape[0]
    tau, K, D = scene.forces[0], scene.KD[0], scene.KD[1]
    power = np.empty(2)
    status = generalized_forces(scene, t, q, qd, tau, tau_ctrl, power, K, D, True)
    if status:
        return status
    h = np.empty(nv)
    status = rnea_kernel(ibuf, fbuf, work, q, qd, np.zeros(nv), loads, h)
    if status:
        return status
    M = np.empty((nv, nv))
    crba_kernel(ibuf, fbuf, work, q, M)
    rhs = np.empty(nv)
    for j in range(nv):
        rhs[j] = tau[j] - h[j]
        for k in range(nv):
            M[j, k] += dt * D[j, k] + dt * dt * K[j, k]
            rhs[j] -= dt * K[j, k] * qd[k]
        if armature.shape[0]:
            M[j, j] += armature[j]
    qdd = np.empty(nv)
    status = velocity_solve(ibuf, fbuf, con, q, qd, M, rhs, qdd)
    if status:
        return status
    for j in range(nv):
        qd1[j] = qd[j] + dt * qdd[j]
    integrate_kernel(ibuf, q, qd1, dt, q1)
    w1[0] = w[0] + dt * power[0]
    w1[1] = w[1] + dt * power[1]
    return Status.OK.value


@njit(**JIT)
def symplectic_euler_step(scene, t, dt, q, qd, w, q1, qd1, w1, tau_ctrl):
    """One step of symplectic Euler in momentum form (module docstring). Returns a Status."""
    ibuf, fbuf, work = scene.ibuf, scene.fbuf, scene.work
    armature, loads, KD = scene.armature, scene.loads, scene.KD
    nv = qd.shape[0]
    tau = scene.forces[0]
    power = np.empty(2)
    status = generalized_forces(scene, t, q, qd, tau, tau_ctrl, power, KD[0], KD[1], False)
    if status:
        return status
    # g(q): RNEA at qd = qdd = 0 under the base acceleration
    zero = np.zeros(nv)
    g = np.empty(nv)
    status = rnea_kernel(ibuf, fbuf, work, q, zero, zero, loads, g)
    if status:
        return status
    # p = (M(q) + diag(armature)) qd
    M = np.empty((nv, nv))
    crba_kernel(ibuf, fbuf, work, q, M)
    p = np.zeros(nv)
    for r in range(nv):
        if armature.shape[0]:
            M[r, r] += armature[r]
        for c in range(nv):
            p[r] += M[r, c] * qd[c]
    status = cholesky_factor(M, nv, largest_diagonal(M))
    if status:
        return status
    # p' = p + dt (dK/dq(q, v) - g + tau), v = M^-1 p': fixed-point iteration from v = qd
    v = qd.copy()
    v_next = np.empty(nv)
    dK_dq = np.empty(nv)
    p1 = np.empty(nv)
    converged = False
    for _ in range(FIXED_POINT_MAX):
        status = kinetic_gradient_kernel(ibuf, fbuf, q, v, dK_dq)
        if status:
            return status
        for j in range(nv):
            p1[j] = p[j] + dt * (dK_dq[j] - g[j] + tau[j])
        cholesky_substitute(M, nv, p1, v_next)
        change = 0.0
        size = 0.0
        for j in range(nv):
            change = max(change, abs(v_next[j] - v[j]))
            size = max(size, abs(v_next[j]))
            v[j] = v_next[j]
        if change <= FIXED_POINT_RTOL * (1.0 + size):
            converged = True
            break
    if not converged:
        return Status.NO_CONVERGENCE.value
    # q' = q (+) v dt, qd' = (M(q') + diag(armature))^-1 p'
    integrate_kernel(ibuf, q, v, dt, q1)
    crba_kernel(ibuf, fbuf, work, q1, M)
    if armature.shape[0]:
        for r in range(nv):
            M[r, r] += armature[r]
    status = cholesky_solve(M, p1, qd1)
    if status:
        return status
    w1[0] = w[0] + dt * power[0]
    w1[1] = w[1] + dt * power[1]
    return Status.OK.value


@njit(**JIT)
def record(out, r, t, q, qd, tau, w):
    """Row r of the record out = (t, q, qd, tau, w) <- the state, control torque and work."""
    out_t, out_q, out_qd, out_tau, out_w = out
    out_t[r] = t
    copy_into(q, out_q[r])
    copy_into(qd, out_qd[r])
    copy_into(tau, out_tau[r])
    copy_into(w, out_w[r])


@njit(**JIT)
def rk_stage_count(tableau):
    """Stages of the tableau (A, b, c), 1 for None (a step that is no Runge-Kutta method)."""
    if tableau is None:
        return 1
    return tableau[0].shape[0]


@njit(**JIT)
def fixed_step(
    tableau, implicit, symplectic, scene, t, dt, q, qd, w, work, q1, qd1, w1, tau, free
):
    """One fixed step of dt from (t, q, qd, w) to (q1, qd1, w1), tau <- the control torque at
    its start, by the integrator the compile-time switches (tableau, implicit, symplectic)
    name (Integrator.switches): numba drops the code behind the None ones when it compiles.
    free: as in rk_stages. Returns (status, dynamics evaluations)."""
    if tableau is not None:
        A, b, c = tableau
        status, evaluations = rk_stages(scene, A, c, t, dt, q, qd, work, 0, 0, tau, free)
        if status == Status.OK.value:
            rk_combine(scene[0], b, dt, q, qd, w, work, q1, qd1, w1)
        return status, evaluations
    if implicit is not None:
        return implicit_velocity_step(scene, t, dt, q, qd, w, q1, qd1, w1, tau), 1
    if symplectic is not None:
        return symplectic_euler_step(scene, t, dt, q, qd, w, q1, qd1, w1, tau), 1
    return Status.OK.value, 0


@njit(**JIT)
def run_fixed(
    switches,
    scene,
    t0,
    dt,
    step0,
    nsteps,
    every,
    max_speed,
    q,
    qd,
    w,
    out,
    counters,
    free,
):
    """Advance (q, qd, w) in place by up to nsteps fixed steps of dt from global step step0,
    at time t0 + step0 dt (t0: the time of global step 0), by the integrator the compile-time
    switches name (fixed_step). The state at the start of every step
    whose global index is a multiple of `every` is recorded in row index // every, with the
    control torque there. Stops at the first step whose result is not finite, faster than
    max_speed, or whose dynamics fail; the state stays the last good one, the start of the
    failed step. scene: step.scene_data(model, table); out: the record (t, q, qd, tau, w).
    free: None, or the free joints' first v indices (rk_stages).
    Returns (status, steps done); counters[0] += dynamics evaluations."""
    nv = qd.shape[0]
    tableau, implicit, symplectic = switches
    work = rk_work(rk_stage_count(tableau), q.shape[0], nv)
    q1, qd1, w1 = np.empty(q.shape[0]), np.empty(nv), np.empty(2)
    tau = np.empty(nv)
    for n in range(nsteps):
        g = step0 + n
        t = t0 + g * dt
        status, evaluations = fixed_step(
            tableau, implicit, symplectic, scene, t, dt, q, qd, w, work, q1, qd1, w1, tau, free
        )
        counters[0] += evaluations
        if status == Status.OK.value:
            status = state_ok(q1, qd1, max_speed)
        if status:
            return status, n
        if g % every == 0:
            record(out, g // every, t, q, qd, tau, w)
        copy_into(q1, q)
        copy_into(qd1, qd)
        copy_into(w1, w)
    return Status.OK.value, nsteps


@njit(**JIT)
def run_adaptive(
    A,
    b,
    c,
    e,
    scene,
    t,
    t_stop,
    t_end,
    h,
    rtol,
    atol,
    size_index,
    output_dt,
    row,
    max_speed,
    q,
    qd,
    w,
    k_first,
    power_first,
    tau_first,
    out,
    counters,
    free,
):
    """Advance (q, qd, w) in place from t to t_stop with an embedded explicit Runge-Kutta pair
    (FSAL: the last stage is the first of the next step), recording row r at
    t = min(r output_dt, t_end).

    Steps are cut so that they land on the output times. size_index (nv,): the q index whose
    magnitude scales the position error of each v coordinate (the coordinate itself for a joint,
    a floating base's position for its translation), -1 for a rotation (scaled by 1 rad).
    k_first (2, nv) holds (qd, qdd),
    power_first (2,) the power and tau_first (nv,) the control torque of the first stage, at the
    current state (the FSAL stage). scene: step.scene_data(model, table); out: the record
    (t, q, qd, tau, w); free: None, or the free joints' first v indices (rk_stages).
    Returns (status, t, h, row); counters += (evaluations, accepted, rejected)."""
    nv = qd.shape[0]
    s = A.shape[0]
    work = rk_work(s, q.shape[0], nv)
    kq, kv, kw = work[0], work[1], work[2]
    q1, qd1, w1 = np.empty(q.shape[0]), np.empty(nv), np.empty(2)
    stage_tau = np.empty(nv)
    while t < t_stop:
        t_out = min(row * output_dt, t_end)
        # land on the output time when the step reaches it or would leave a sliver before it
        last_before_output = h >= 0.99 * (t_out - t)
        dt = t_out - t if last_before_output else h
        if dt <= 1e-14 * max(1.0, abs(t)):
            return Status.STEP_UNDERFLOW.value, t, h, row
        # stage 0 is the FSAL stage, evaluated at the end of the previous step
        copy_into(k_first[0], kq[0])
        copy_into(k_first[1], kv[0])
        copy_into(power_first, kw[0])
        status, evaluations = rk_stages(
            scene, A, c, t, dt, q, qd, work, 1, s - 1, stage_tau, free
        )
        counters[0] += evaluations
        if status == 0:
            rk_combine(scene[0], b, dt, q, qd, w, work, q1, qd1, w1)
            status = state_ok(q1, qd1, max_speed)
        if status >= Status.SINGULAR.value:
            return status, t, h, row  # singular mass matrix: a smaller step will not help
        if status:
            # a failed trial is a rejected step: retry smaller, give up when the step underflows
            counters[2] += 1
            h = 0.25 * dt
            continue
        # RMS of the error estimate dt sum_i e_i k_i relative to atol + rtol |x|, over v-space
        err = 0.0
        for j in range(nv):
            eq = 0.0
            ev = 0.0
            for i in range(s):
                eq += e[i] * kq[i, j]
                ev += e[i] * kv[i, j]
            k = size_index[j]
            sq = atol + rtol * (max(abs(q[k]), abs(q1[k])) if k >= 0 else 1.0)
            sv = atol + rtol * max(abs(qd[j]), abs(qd1[j]))
            err += (dt * eq / sq) ** 2 + (dt * ev / sv) ** 2
        err = np.sqrt(err / max(1, 2 * nv))
        if err > 1.0:
            counters[2] += 1
            h = dt * max(0.2, 0.9 * err**-0.2)
            continue
        counters[1] += 1
        t = t_out if last_before_output else t + dt
        copy_into(q1, q)
        copy_into(qd1, qd)
        copy_into(w1, w)
        # FSAL: the last stage was evaluated at the new state (c = 1, A's last row = b); its
        # velocity without the Munthe-Kaas correction (Theta = 0 at the next step's start)
        copy_into(qd1, k_first[0])
        copy_into(kv[s - 1], k_first[1])
        copy_into(kw[s - 1], power_first)
        copy_into(stage_tau, tau_first)
        if last_before_output:
            record(out, row, t, q, qd, tau_first, w)
            row += 1
        h = dt * min(5.0, 0.9 * err**-0.2) if err > 0 else 5.0 * dt
        if last_before_output and h < dt:
            h = dt
    return Status.OK.value, t, h, row
