"""The compiled loops of a rollout: runs start..stop-1 of a batch, each integrated whole by the
loops of opendyn.sim.integrators, one after another in one compiled call. The calls release the
GIL, so threads run disjoint slices of a batch at once (opendyn.sim.rollout).

Run i is what simulate does with its scene, operation for operation, so that it gives the same
numbers bit for bit:

    fixed:     run_fixed(0 -> N steps), recording every `every`-th step's start; then the last
               state (t = steps done * dt) appended with the control torque there
    adaptive:  the FSAL stage at t = 0 (recorded as row 0), run_adaptive(0 -> t_end) landing on
               the output times; after a failure the last good state appended

A failed run (a state not finite or faster than max_speed, a singular mass matrix, a step that
underflows) keeps its rows up to the failure and its last good state, and the other runs go on.
What varies between runs (the model's inertias, the effects' parameters, the armature, the
constraints and the hard model's rows and settings: a RunData each, several runs may share one)
is read per run; the step's scratch (forces, loads, K and D, the Data buffer, the contact's
running extremes, which a rollout does not read: its trajectories take their contact's extremes
from their samples) is the caller's SceneData, one per thread. So is the hard model's HardRoom,
which carries a run's warm start from step to step: each run restarts it (run_hard), so that it
starts as simulate's run does, whichever runs went before it in the room.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit
from numba.typed import List

from .._runtime.arrays import copy_into, fill
from .._runtime.kernel_cache import BATCH, JIT
from .._runtime.status import Status
from ..multibody.layout import body_count, dof_count
from .hard_step import UNCONVERGED, WORST, HardTable, restart_hard
from .integrators import Counters, Record, Stage, State, record, run_adaptive, run_fixed
from .step import SceneData, constraint_room, evaluate

# What one run of a batch may change in the step: the model's fbuf (its inertias: a payload per
# run), the stage table's effects tuple, armature and constraints (ConstraintTable or None), and
# hard, its HardTable with None for its room (the run works in its slice's: run_hard), or None.
# Every run of a batch has the same types here, so one compiled loop runs them all.
RunData = namedtuple("RunData", ("fbuf", "effects", "armature", "constraints", "hard"))
# A batch of N runs, run i's row of every array its own:
#   runs: a numba typed List of RunData; which (stop - start,) int64: the entry of each run
#      of the slice start..stop-1 in it, -1 for a run refused before it started;
#   x: a State of arrays q (N, nq), qd (N, nv), w (N, 2): the initial states, then the last
#      (the final state; after a failure, the last good one);
#   out: a Record of arrays t (N, K), q (N, K, nq), qd (N, K, nv), tau (N, K, nv), w (N, K, 2):
#      the recorded rows (K = 1 keeps only the latest);
#   counters (N, 3) int64: dynamics evaluations, steps done (a fixed-step run's too) and
#      rejected steps;
#   outcome: an Outcome of the runs.
Batch = namedtuple("Batch", ("runs", "which", "x", "out", "counters", "outcome"))
# How each run ended: status (N,) int64 (Status; 0 complete), rows (N,) int64 the rows it
# recorded, t (N,) s the time it reached, tau (N, nv) the control torque at its last state
# (NaN where the dynamics fail there), solver (N, 2) with a hard model the steps whose solve
# stopped above its tolerance and the worst residual among them (m/s; untouched without one).
Outcome = namedtuple("Outcome", ("status", "rows", "t", "tau", "solver"))


@njit(**JIT)
def run_list(first):
    """A numba typed List of RunData holding `first`: the `runs` of a Batch. Made and grown
    (push_run) by compiled functions, which the kernel cache keeps: the typed List's own
    methods called from Python compile in every process (0.6 s, a sweep worker's first task)."""
    runs = List()
    runs.append(first)
    return runs


@njit(**JIT)
def push_run(runs, run):
    """runs.append(run), compiled (see run_list)."""
    runs.append(run)


@njit(**JIT)
def run_views(base, batch, i, start):
    """(SceneData, State, Record, Counters) of run i of the Batch, which a slice from `start`
    runs: base (a SceneData: the model's ibuf, the method, the scratch, whether the world poses
    are placed, the hard model's room) with the run's RunData (fbuf, effects, armature,
    constraints; the hard model's rows and settings in base's room, restarted: run_hard) and
    its constraints' ConstraintWork (their multipliers and the solve's scratch, made once per
    run); its state and counters copied out (the loops write them at every step, and
    neighbouring runs' rows share cache lines across threads), its record a view of its rows.
    end_run copies them back."""
    run = batch.runs[batch.which[i - start]]
    scene = SceneData(
        base.ibuf, run.fbuf, run.effects, run.armature, base.method, run.constraints,
        base.forces, base.loads, base.KD,
        constraint_room(run.constraints, body_count(base.ibuf), dof_count(base.ibuf)),
        base.work, base.world, base.room, base.touch, run_hard(run.hard, base.hard),
    )
    x, out, c = batch.x, batch.out, batch.counters
    return (
        scene,
        State(x.q[i].copy(), x.qd[i].copy(), x.w[i].copy()),
        Record(out.t[i], out.q[i], out.qd[i], out.tau[i], out.w[i], None),
        Counters(c[i, 0:1].copy(), c[i, 1:2].copy(), c[i, 2:3].copy()),
    )


@njit(**JIT)
def run_hard(hard, own):
    """The HardTable a run steps with: its own rows and settings (hard: its RunData's, without
    a room) in the room of `own` (the slice's HardTable, whose room its runs use one after
    another), restarted (restart_hard: no impulses to warm-start from, the solver's counts at
    zero), as simulate's HardTable is when it is made. None for hard None (no hard model:
    numba drops the code)."""
    if hard is None:
        return None
    table = HardTable(
        hard.spheres, hard.geometry, hard.limits, hard.friction, hard.constraints, hard.settings,
        hard.solver, own.room,
    )
    restart_hard(table)
    return table


@njit(**JIT)
def keep_solve_stats(hard, solver):
    """solver (2,) <- a run's statistics of the hard model's solves (hard: its HardTable after
    the run): the steps whose solve stopped above the tolerance and the worst residual among
    them (m/s). Nothing for hard None (numba drops the code)."""
    if hard is None:
        return
    solver[0] = hard.room.stats[UNCONVERGED]
    solver[1] = hard.room.stats[WORST]


@njit(**JIT)
def end_run(scene, batch, i, status, rows, t, x, counters, tau):
    """Close run i as simulate closes a run: its last State x and Counters into the batch's
    rows, outcome <- (status, rows, t, tau, the hard model's solve statistics:
    keep_solve_stats), tau (nv,) the control torque at the last state x: the given one, or
    (tau None: numba drops the other branch) the dynamics evaluated there, NaN where they fail.
    The last state is appended to the record when a complete run's record has room for it (a
    fixed-step run's end) or a failed run's last row is earlier."""
    out = Record(
        batch.out.t[i], batch.out.q[i], batch.out.qd[i], batch.out.tau[i], batch.out.w[i],
        None,
    )
    tau_end = batch.outcome.tau[i]
    if tau is None:
        qdd, power = np.empty(x.qd.shape[0]), np.empty(2)
        if evaluate(scene, t, x.q, x.qd, qdd, tau_end, power):
            fill(tau_end, np.nan)
    else:
        copy_into(tau, tau_end)
    K = out.t.shape[0]
    if status == 0:
        append = rows < K
    else:
        append = rows == 0 or out.t[(rows - 1) % K] < t
    if append:
        record(out, rows, t, x, tau_end)
        rows += 1
    keep_solve_stats(scene.hard, batch.outcome.solver[i])
    batch.outcome.status[i] = status
    batch.outcome.rows[i] = rows
    batch.outcome.t[i] = t
    copy_into(x.q, batch.x.q[i])
    copy_into(x.qd, batch.x.qd[i])
    copy_into(x.w, batch.x.w[i])
    batch.counters[i, 0] = counters.evaluations[0]
    batch.counters[i, 1] = counters.accepted[0]
    batch.counters[i, 2] = counters.rejected[0]


@njit(**BATCH)
def rollout_fixed(switches, base, settings, nsteps, batch, free, start, stop):
    """Runs start..stop-1 of the Batch, nsteps fixed steps each from t0 by the integrator the
    Switches name (integrators.run_fixed with the FixedSettings settings). base: the SceneData
    whose scratch the runs use; free: None, or the free joints' first v indices."""
    every, dt = settings.every, settings.dt
    for i in range(start, stop):
        if batch.which[i - start] < 0:
            continue  # a run refused before it started
        scene, x, out, counters = run_views(base, batch, i, start)
        # from global step np.int64(0): a literal 0 would compile run_fixed once more, for
        # Literal[int](0), instead of reusing the one simulate compiled
        status, done = run_fixed(
            switches, scene, settings, np.int64(0), nsteps, x, out, counters, free
        )
        counters.accepted[0] += done
        rows = (done - 1) // every + 1 if done else 0
        end_run(scene, batch, i, status, rows, settings.t0 + done * dt, x, counters, None)


@njit(**BATCH)
def rollout_adaptive(tableau, base, settings, at, batch, free, start, stop):
    """Runs start..stop-1 of the Batch by the embedded pair `tableau` (integrators.run_adaptive
    with the AdaptiveSettings settings, from the Progress at: t0, the first trial step, row 1),
    each from its FSAL stage at t0, recorded as row 0. base, free: as rollout_fixed."""
    nv = batch.x.qd.shape[1]
    first = Stage(np.empty((2, nv)), np.empty(2), np.empty(nv))
    for i in range(start, stop):
        if batch.which[i - start] < 0:
            continue  # a run refused before it started
        scene, x, out, counters = run_views(base, batch, i, start)
        copy_into(x.qd, first.k[0])
        status = evaluate(scene, at.t, x.q, x.qd, first.k[1], first.tau, first.power)
        counters.evaluations[0] += 1
        t, rows = at.t, 0
        if status == Status.OK.value:
            record(out, 0, at.t, x, first.tau)
            status, reached = run_adaptive(
                tableau, scene, settings, at, settings.t_end, x, first, out, counters, free
            )
            t, rows = reached.t, reached.row
        if status == Status.OK.value:
            end_run(scene, batch, i, status, rows, t, x, counters, first.tau)
        else:
            end_run(scene, batch, i, status, rows, t, x, counters, None)
