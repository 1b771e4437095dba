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
All loops are compiled: a simulation pays no Python overhead per step. They take and fill named
records (State, Record, Counters, ...; below), and the two Euler steps that solve with the mass
matrix (implicit and semi-implicit Euler) are in opendyn.sim.euler_steps.
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from .._runtime.arrays import copy_into
from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from ..algorithm.configuration import integrate_kernel
from ..algorithm.contact_extremes import fold_step, keep_step
from ..multibody.layout import body_count
from ..multibody.work_views import scratch_rows
from ..spatial.compiled import ad_twist
from .euler_steps import implicit_velocity_step, symplectic_euler_step
from .hard_step import hard_velocity_step, log_sample
from .step import evaluate

EXPLICIT_RK, SEMI_IMPLICIT, IMPLICIT = 0, 1, 2  # fixed-step loop kinds

# The records the compiled loops take and fill, read by name (defined here, at module level, so
# that numba caches the loops that take them). Arrays are float64 unless said otherwise.
# An explicit Runge-Kutta method: Butcher tableau A (s, s), b (s,), c (s,) and e = b - b^ (s,),
# the weights of an embedded pair's error estimate (zeros: none).
Tableau = namedtuple("Tableau", ("A", "b", "c", "e"))
# run_fixed's compile-time switches, one of them not None (Integrator.switches): the Tableau of
# an explicit Runge-Kutta method, or True for implicit or semi-implicit Euler.
Switches = namedtuple("Switches", ("tableau", "implicit", "symplectic"))
# The state x: q (nq,), qd (nv,) (rad or m, rad/s or m/s) and the work w (2,) (applied,
# passive; J) done on the robot so far.
State = namedtuple("State", ("q", "qd", "w"))
# A step's scratch (rk_work): the stages' rates kq, kv (s, nv) and power kw (s, 2), the stage's
# state qs (nq,), qds (nv,), the increment v (nv,) and control torque stage_tau (nv,);
# tau (nv,) <- the control torque that the step reports (at its start; adaptive: at its end);
# and for the Euler steps that solve with the mass matrix (opendyn.sim.euler_steps) their
# matrix M (nv, nv), its row swaps piv (nv,) int64 and their joint-space vectors (6, nv).
StepWork = namedtuple(
    "StepWork", ("kq", "kv", "kw", "qs", "qds", "v", "stage_tau", "tau", "M", "piv", "vectors")
)
# run_adaptive's FSAL stage at the current state: k (2, nv) = (qd, qdd), power (2,) (applied,
# passive; W) and tau (nv,) the control torque.
Stage = namedtuple("Stage", ("k", "power", "tau"))
# The recorded rows: t (K,), q (K, nq), qd (K, nv), tau (K, nv) the control torque, w (K, 2),
# and hard: the hard model's HardLog of the same rows (opendyn.sim.hard_step), or None.
Record = namedtuple("Record", ("t", "q", "qd", "tau", "w", "hard"))
# (1,) int64 each: dynamics evaluations, accepted and rejected steps (the last two adaptive).
Counters = namedtuple("Counters", ("evaluations", "accepted", "rejected"))
# run_fixed's settings: t0 (s) the time of global step 0, the step dt (s), every (the record
# takes every `every`-th step), max_speed (rad/s or m/s; a faster |qd| stops the run).
FixedSettings = namedtuple("FixedSettings", ("t0", "dt", "every", "max_speed"))
# run_adaptive's settings: t0 (s) the time of output row 0, t_end (s) the end of the run, rtol,
# atol, output_dt (s), max_speed
# and size_index (nv,) int64, the q index whose magnitude scales each v coordinate's position
# error (-1: 1 rad); t_land (s): a time the steps land on besides the output times (the end of
# a control period, where the held torque changes; inf for none: a chunk of a run merely stops
# once past its t_stop); max_steps: the trial steps (accepted and rejected) one call may take
# before it returns where it stands, short of t_stop: a chunk's budget, so that a run whose
# steps become tiny (a stiff contact) still comes back to its caller, who checks for Ctrl-C
# (ALL_STEPS: no budget, the call runs to t_stop).
AdaptiveSettings = namedtuple(
    "AdaptiveSettings",
    ("t0", "t_end", "rtol", "atol", "output_dt", "max_speed", "size_index", "t_land",
     "max_steps"),
)
ALL_STEPS = 2**62
# Two times closer than SLIVER max(1, |t|) s are one: the sums that give an output time
# (t0 + r output_dt) and the end of a control period (t + duration) round differently, and the
# rounding (a few 1e-17 s at t = 0.06 s) is no step to take.
SLIVER = 1e-13
# Where run_adaptive stands: the time t (s), the next trial step h (s), the next output row.
Progress = namedtuple("Progress", ("t", "h", "row"))


def new_counters():
    """Counters at zero."""
    return Counters(*(np.zeros(1, dtype=np.int64) for _ in Counters._fields))


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

    def tableau(self):
        """The Tableau (A, b, c, e) of an explicit Runge-Kutta method."""
        return Tableau(self.A, self.b, self.c, self.e)

    def switches(self):
        """The Switches (tableau, implicit, symplectic) of run_fixed, one of them not None, so
        that only this integrator's step is compiled: the Tableau of an explicit Runge-Kutta
        method, or True for implicit or semi-implicit Euler."""
        return Switches(
            self.tableau() if self.kind == EXPLICIT_RK else None,
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
    """The StepWork of an s-stage Runge-Kutta step (1 stage for the other methods)."""
    return StepWork(
        np.empty((s, nv)),
        np.empty((s, nv)),
        np.empty((s, 2)),
        np.empty(nq),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty((nv, nv)),
        np.empty(nv, dtype=np.int64),
        np.empty((6, nv)),
    )


@njit(**JIT)
def dexp_inverse(free, theta, k, ad):
    """k <- dexp^-1_Theta(k) = k + 1/2 ad_Theta k + 1/12 ad_Theta^2 k - 1/720 ad_Theta^4 k on
    the six rows of each free joint, whose first v index is in `free`; theta (nv,) holds the
    stage's increments Theta (a body twist times dt for a free joint); ad (4, 6) scratch
    <- ad_Theta^m k, m = 1..4. The velocity of the increment Theta with which q (+) Theta moves
    at body twist V (the right-trivialised derivative of exp on SE(3); Hairer, Lubich & Wanner,
    Lemma III.4.2 with Theta -> -Theta)."""
    ad1, ad2, ad3, ad4 = ad[0], ad[1], ad[2], ad[3]
    for b in free:
        th, v = theta[b : b + 6], k[b : b + 6]
        ad_twist(th, v, ad1)
        ad_twist(th, ad1, ad2)
        ad_twist(th, ad2, ad3)
        ad_twist(th, ad3, ad4)
        for r in range(6):
            v[r] += 0.5 * ad1[r] + ad2[r] / 12.0 - ad4[r] / 720.0


@njit(**JIT)
def rk_stages(scene, tableau, t, dt, x, work, first, tau_stage, free):
    """Stages first..s-1 of an explicit Runge-Kutta step (tableau: a Tableau) from x = (q, qd, w)
    at t: stage i at q_i = q (+) dt sum_l A_il kq_l, qd_i = qd + dt sum_l A_il kv_l, kq_i = qd_i
    (a floating base's rows through dexp_inverse: the Munthe-Kaas stage),
    kv_i = qdd(t + c_i dt, q_i, qd_i), kw_i = power there, in work (a StepWork). first = 1 when
    stage 0 is already in kq, kv, kw (FSAL). free: None (a fixed base: the correction is not
    compiled) or the first v index of each free joint (int64). work.tau <- the control torque at
    stage tau_stage, and the contact's extremes there are kept as the step's
    (contact_extremes.keep_step: the state the step reports). Returns (status, evaluations)."""
    A, c = tableau.A, tableau.c
    kq, kv, v = work.kq, work.kv, work.v
    nv = x.qd.shape[0]
    for i in range(first, A.shape[0]):
        for j in range(nv):
            dv = 0.0
            dq = 0.0
            for m in range(i):
                dq += A[i, m] * kq[m, j]
                dv += A[i, m] * kv[m, j]
            v[j] = dq
            work.qds[j] = x.qd[j] + dt * dv
        integrate_kernel(scene.ibuf, x.q, v, dt, work.qs)
        copy_into(work.qds, kq[i])
        if free is not None and i > 0:
            for j in range(nv):
                v[j] *= dt  # Theta_i
            # between evaluations the Data's scratch rows are free
            nb = body_count(scene.ibuf)
            dexp_inverse(free, v, kq[i], scratch_rows(scene.work, nb, nv)[:4])
        status = evaluate(
            scene, t + c[i] * dt, work.qs, work.qds, kv[i], work.stage_tau, work.kw[i]
        )
        if i == tau_stage:
            copy_into(work.stage_tau, work.tau)
            keep_step(scene.touch)
        if status:
            return status, i - first + 1
    return Status.OK.value, A.shape[0] - first


@njit(**JIT)
def rk_combine(ibuf, weights, dt, x, work, x1):
    """x1 = x (+) dt sum_i weights_i k_i for q (through integrate), qd and the work w, with the
    stages' rates in work (a StepWork)."""
    kq, kv, kw = work.kq, work.kv, work.kw
    v = work.v
    nv = x.qd.shape[0]
    for j in range(nv):
        dq = 0.0
        dv = 0.0
        for i in range(weights.shape[0]):
            dq += weights[i] * kq[i, j]
            dv += weights[i] * kv[i, j]
        v[j] = dq
        x1.qd[j] = x.qd[j] + dt * dv
    integrate_kernel(ibuf, x.q, v, dt, x1.q)
    for k in range(2):
        dw = 0.0
        for i in range(weights.shape[0]):
            dw += weights[i] * kw[i, k]
        x1.w[k] = x.w[k] + dt * dw


@njit(**JIT)
def record(out, r, t, x, tau):
    """Row r of the Record out <- the time t, the State x and the control torque tau there. A
    Record of K rows takes row r in row r mod K: one of a single row keeps the latest (a
    rollout that keeps only final states)."""
    r = r % out.t.shape[0]
    out.t[r] = t
    copy_into(x.q, out.q[r])
    copy_into(x.qd, out.qd[r])
    copy_into(tau, out.tau[r])
    copy_into(x.w, out.w[r])


@njit(**JIT)
def rk_stage_count(tableau):
    """Stages of the Tableau, 1 for None (a step that is no Runge-Kutta method)."""
    if tableau is None:
        return 1
    return tableau.A.shape[0]


@njit(**JIT)
def fixed_step(tableau, implicit, symplectic, scene, t, dt, x, x1, work, free):
    """One fixed step of dt from the State x at t to x1, work.tau <- the control torque at its
    start (work: a StepWork), by the integrator the compile-time switches (tableau, implicit,
    symplectic) name (Integrator.switches): numba drops the code behind the None ones when it
    compiles. free: as in rk_stages. Returns (status, dynamics evaluations)."""
    if tableau is not None:
        status, evaluations = rk_stages(scene, tableau, t, dt, x, work, 0, 0, free)
        if status == Status.OK.value:
            rk_combine(scene.ibuf, tableau.b, dt, x, work, x1)
        return status, evaluations
    if implicit is not None:
        return implicit_velocity_step(scene, t, dt, x, x1, work), 1
    if symplectic is not None:
        return velocity_step(scene.hard, scene, t, dt, x, x1, work), 1
    return Status.OK.value, 0


@njit(**JIT)
def velocity_step(hard, scene, t, dt, x, x1, work):
    """semi_implicit_euler's step: the hard model's velocity-level step (hard: its HardTable,
    opendyn.sim.hard_step) or, without one (hard None: numba drops that branch when it
    compiles), symplectic Euler in momentum form. Returns a Status."""
    if hard is not None:
        return hard_velocity_step(hard, scene, t, dt, x, x1, work)
    return symplectic_euler_step(scene, t, dt, x, x1, work)


@njit(**JIT)
def run_fixed(switches, scene, settings, step0, nsteps, x, out, counters, free):
    """Advance the State x in place by up to nsteps fixed steps of settings.dt from global step
    step0, at time t0 + step0 dt (settings: a FixedSettings), by the integrator the Switches
    name (fixed_step). The state at the start of every step whose global index is a multiple of
    settings.every is recorded in row index // every of the Record out, with the control torque
    there. Stops at the first step whose result is not finite, faster than settings.max_speed,
    or whose dynamics fail; x stays the last good state, the start of the failed step. The
    contact's extremes at the start of every step done are folded into the run's
    (scene.touch: contact_extremes.fold_step). scene: step.scene_data(model, table); free:
    None, or the free joints' first v indices (rk_stages). Returns (status, steps done);
    counters.evaluations += dynamics evaluations."""
    nq, nv = x.q.shape[0], x.qd.shape[0]
    tableau = switches.tableau
    work = rk_work(rk_stage_count(tableau), nq, nv)
    x1 = State(np.empty(nq), np.empty(nv), np.empty(2))
    dt, every = settings.dt, settings.every
    for n in range(nsteps):
        g = step0 + n
        t = settings.t0 + g * dt
        status, evaluations = fixed_step(
            tableau, switches.implicit, switches.symplectic, scene, t, dt, x, x1, work, free
        )
        counters.evaluations[0] += evaluations
        if status == Status.OK.value:
            status = state_ok(x1.q, x1.qd, settings.max_speed)
        if status:
            return status, n
        fold_step(scene.touch)
        if g % every == 0:
            record(out, g // every, t, x, work.tau)
            log_sample(out.hard, scene.hard, g // every, dt)
        copy_into(x1.q, x.q)
        copy_into(x1.qd, x.qd)
        copy_into(x1.w, x.w)
    return Status.OK.value, nsteps


@njit(**JIT)
def run_adaptive(tableau, scene, settings, at, t_stop, x, first, out, counters, free):
    """Advance the State x in place from at.t to t_stop with an embedded explicit Runge-Kutta
    pair (tableau: a Tableau; FSAL: the last stage is the first of the next step), first trial
    step at.h, recording row r of the Record out, from r = at.row on, at
    t = min(t0 + r output_dt, t_end) (settings: an AdaptiveSettings).

    Steps are cut so that they land on the output times and on settings.t_land (no row is
    recorded there unless it is an output time); the loop stops once t >= t_stop (t_stop <=
    t_land), or after settings.max_steps trial steps, short of t_stop (the caller goes on
    from the Progress returned). A time within SLIVER of t counts as reached: an output time is
    recorded at once, and t_land ends the loop with t = t_land. The error of each v coordinate's
    position is scaled by the magnitude of q[settings.size_index[j]] (the coordinate itself for
    a joint, a floating base's position for its translation), by 1 rad where that is -1 (a
    rotation). first: the Stage at the current state (the FSAL stage), kept up to date.
    The contact's extremes at the end of every accepted step are folded into the run's
    (scene.touch: contact_extremes.fold_step). scene: step.scene_data(model, table); free:
    None, or the free joints' first v indices (rk_stages). Returns (status, Progress(t, h,
    row)); counters += (evaluations, accepted, rejected)."""
    A, b, e = tableau.A, tableau.b, tableau.e
    rtol, atol, size_index = settings.rtol, settings.atol, settings.size_index
    q, qd, nv = x.q, x.qd, x.qd.shape[0]
    s = A.shape[0]
    work = rk_work(s, q.shape[0], nv)
    kq, kv, kw = work.kq, work.kv, work.kw
    x1 = State(np.empty(q.shape[0]), np.empty(nv), np.empty(2))
    t, h, row = at.t, at.h, at.row
    trials = 0
    while t < t_stop:
        t_out = min(settings.t0 + row * settings.output_dt, settings.t_end)
        sliver = SLIVER * max(1.0, abs(t))
        if t_out - t <= sliver:  # on an output time but for rounding: record it
            record(out, row, t, x, first.tau)
            row += 1
            continue
        if settings.t_land - t <= sliver:  # at the end of the control period but for rounding
            t = max(t, settings.t_land)
            break
        if trials == settings.max_steps:  # the chunk's budget spent: back to the caller
            break
        trials += 1
        t_land = min(t_out, settings.t_land)
        # land on the output time (or t_land) when the step reaches it or would leave a sliver
        # before it
        last_before_output = h >= 0.99 * (t_land - t)
        dt = t_land - t if last_before_output else h
        if dt <= 1e-14 * max(1.0, abs(t)):
            return Status.STEP_UNDERFLOW.value, Progress(t, h, row)
        # stage 0 is the FSAL stage, evaluated at the end of the previous step
        copy_into(first.k[0], kq[0])
        copy_into(first.k[1], kv[0])
        copy_into(first.power, kw[0])
        status, evaluations = rk_stages(scene, tableau, t, dt, x, work, 1, s - 1, free)
        counters.evaluations[0] += evaluations
        if status == 0:
            rk_combine(scene.ibuf, b, dt, x, work, x1)
            status = state_ok(x1.q, x1.qd, settings.max_speed)
        if status >= Status.SINGULAR.value:
            # singular mass matrix: a smaller step will not help
            return status, Progress(t, h, row)
        if status:
            # a failed trial is a rejected step: retry smaller, give up when the step underflows
            counters.rejected[0] += 1
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
            sq = atol + rtol * (max(abs(q[k]), abs(x1.q[k])) if k >= 0 else 1.0)
            sv = atol + rtol * max(abs(qd[j]), abs(x1.qd[j]))
            err += (dt * eq / sq) ** 2 + (dt * ev / sv) ** 2
        err = np.sqrt(err / max(1, 2 * nv))
        if err > 1.0:
            counters.rejected[0] += 1
            h = dt * max(0.2, 0.9 * err**-0.2)
            continue
        counters.accepted[0] += 1
        fold_step(scene.touch)
        t = t_land if last_before_output else t + dt
        copy_into(x1.q, q)
        copy_into(x1.qd, qd)
        copy_into(x1.w, x.w)
        # FSAL: the last stage was evaluated at the new state (c = 1, A's last row = b); its
        # velocity without the Munthe-Kaas correction (Theta = 0 at the next step's start)
        copy_into(x1.qd, first.k[0])
        copy_into(kv[s - 1], first.k[1])
        copy_into(kw[s - 1], first.power)
        copy_into(work.tau, first.tau)
        if last_before_output and t_land == t_out:
            record(out, row, t, x, first.tau)
            row += 1
        h = dt * min(5.0, 0.9 * err**-0.2) if err > 0 else 5.0 * dt
        if last_before_output and h < dt:
            h = dt
    return Status.OK.value, Progress(t, h, row)
