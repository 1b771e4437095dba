"""simulate(scene) -> Trajectory: the scene's step, a short list of named stages, advanced by its
integrator in compiled loops.

    step = [effect stages the scene names] -> forward dynamics -> integrate(q, v, dt)

The loops run in chunks of about a tenth of a second of wall time, so that a progress bar moves,
Ctrl-C is answered, and a failure keeps everything computed before it. A failure (a state that is
not finite or faster than the run's max_speed, a singular mass matrix, an adaptive step that
underflows) stops the run with a message naming the time, the step and the likely cause
(opendyn.sim.diagnostics).

A floating base changes nothing here: positions advance through integrate (the exponential map
for the base, which keeps its quaternion a unit one), and the record carries q (nq) and v (nv)
with the model's coordinate names. The largest deviation of a recorded quaternion's norm from 1
is the run's `quaternion_norm_error` (bound QUATERNION_NORM_BOUND).
"""

from __future__ import annotations

import time

import numpy as np

from .._runtime.options import flag
from .._runtime.signals import signal_name
from .._runtime.status import Status
from ..errors import SimulationError
from . import effects, integrators
from .diagnostics import check_contact_step, failure_message
from .driver import (
    FIRST_CHUNK,
    Interrupt,
    Stepper,
    getting_ready,
    integrator_of,
    next_span,
    next_steps,
    progress_bar,
    step_name,
)
from .effects import python_control
from .preflight import preflight
from .record import Samples, quaternion_norm_error, trajectory_of, warn_too_deep
from .simulator import run_controlled


def simulate(scene, *, progress=False, raise_on_failure=True, controller=None, control_dt=None):
    """Run `scene`, a Scene, and return its Trajectory: the driver of od.simulate
    (opendyn.api.simulate), which documents the arguments and also takes a scene file or a
    shipped scene's name."""
    progress = flag(progress, "simulate: progress")
    raise_on_failure = flag(raise_on_failure, "simulate: raise_on_failure")
    if controller is not None or python_control.record(scene) is not None:
        return run_controlled(scene, controller, control_dt, progress, raise_on_failure)
    run = scene.run
    model = scene.model
    integ = integrator_of(scene)
    table = effects.stage_table(scene)
    with getting_ready(step_name(integ, table), scene) as ready:
        nsteps, every, rows = preflight(scene, integ)
        check_contact_step(scene, table)
        ready.done()
        out = Samples(rows, model.nq, model.nv, table.hard)
        x = integrators.State(
            np.array(scene.q0, dtype=np.float64),
            np.array(scene.qd0, dtype=np.float64),
            np.zeros(2),
        )
        counters = integrators.new_counters()
        stepper = Stepper(scene, table, integ)
        stepper.load(x, ready.done)
    bar = progress_bar(run.duration) if progress else None
    start = time.perf_counter()
    with Interrupt() as stop:
        if integ.adaptive:
            status, t = _run_adaptive(stepper, x, out, counters, bar, stop)
        else:
            status, t = _run_fixed(stepper, nsteps, every, x, out, counters, bar, stop)
    wall = time.perf_counter() - start
    if bar is not None:
        bar.close()
    steps = int(counters.accepted[0]) if integ.adaptive else int(round(t / run.dt))
    message = ""
    if status == Status.INTERRUPTED:
        message = f"interrupted ({signal_name(stop.signum)}) at t = {t:.6g} s (step {steps})"
    elif status:
        message = failure_message(scene, table, status, t, steps, x.q, x.qd)
    if status:
        # the last good state ends the partial record, unless it is already its last row
        if not out.filled or out.t[out.filled - 1] < t:
            stepper.record_state(t, x, out)
    stats = {
        "integrator": integ.name,
        "steps": steps,
        "rejected_steps": int(counters.rejected[0]),
        "evaluations": int(counters.evaluations[0]),
        "wall_s": wall,
        "compile_s": ready.compile_s,
        "load_s": ready.load_s,
        "simulated_s": float(out.t[out.filled - 1]) if out.filled else 0.0,
    }
    if model.floating_base:
        stats["quaternion_norm_error"] = float(
            quaternion_norm_error(model, out.q[: out.filled]).max(initial=0.0)
        )
    traj = trajectory_of(
        scene, table, out.arrays(), out.filled, status == 0, message, stats, stepper.data.touch
    )
    warn_too_deep(traj, stacklevel=3)  # the caller of od.simulate
    if status and raise_on_failure:
        raise SimulationError(message, traj)
    return traj


def _run_fixed(stepper, nsteps, every, x, out, counters, bar, stop):
    """Fixed steps in compiled chunks. Returns (status, time reached)."""
    run = stepper.scene.run
    done, chunk = 0, FIRST_CHUNK
    while done < nsteps:
        n = min(chunk, nsteps - done)
        tic = time.perf_counter()
        status, steps = stepper.fixed_chunk(done, n, every, x, out, counters)
        done += steps
        out.filled = (done - 1) // every + 1 if done else 0
        if bar is not None:
            bar.update(steps * run.dt)
        if status:
            return status, done * run.dt
        if stop.requested and done < nsteps:
            return Status.INTERRUPTED, done * run.dt
        chunk = next_steps(steps, time.perf_counter() - tic, chunk)
    t_end = nsteps * run.dt
    if out.filled < len(out.t):
        stepper.record_state(t_end, x, out)
    return 0, t_end


def _run_adaptive(stepper, x, out, counters, bar, stop):
    """Adaptive steps in compiled chunks of simulated time, each also cut at a budget of trial
    steps sized to about CHUNK_SECONDS of wall time (next_steps), so that Ctrl-C is answered
    however small the steps become. Returns (status, time reached)."""
    run = stepper.scene.run
    nv = stepper.scene.model.nv
    first = integrators.Stage(np.empty((2, nv)), np.empty(2), np.empty(nv))  # the FSAL stage
    status = stepper.first_stage(0.0, x.q, x.qd, first.k, first.power, first.tau)
    counters.evaluations[0] += 1
    if status:
        return status, 0.0
    out.put(0, 0.0, x, first.tau)
    out.filled = 1
    at = integrators.Progress(0.0, run.dt, 1)
    span = max(run.output_dt, run.duration / 1000)
    budget = FIRST_CHUNK
    while at.t < run.duration:
        t_stop = min(run.duration, at.t + span)
        tic = time.perf_counter()
        t_before, trials = at.t, counters.accepted[0] + counters.rejected[0]
        status, at = stepper.adaptive_chunk(at, t_stop, x, first, out, counters, budget)
        out.filled = at.row
        if bar is not None:
            bar.update(at.t - t_before)
        if status:
            return status, at.t
        if stop.requested and at.t < run.duration:
            return Status.INTERRUPTED, at.t
        seconds = time.perf_counter() - tic
        span = next_span(span, seconds, run.duration)
        trials = int(counters.accepted[0] + counters.rejected[0] - trials)
        budget = next_steps(trials, seconds, budget)
    return 0, at.t


