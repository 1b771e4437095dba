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

import os
import signal
import sys
import threading
import time

import numpy as np

from .._runtime.compile_notice import compile_seconds, compiling
from .._runtime.options import flag
from .._runtime.signals import signal_name
from .._runtime.status import Status
from ..algorithm.energy import energies
from ..errors import SceneError, SimulationError
from ..io.scene.files import load_scene
from ..io.scene.schema import Scene
from ..multibody.joints import FREE
from ..multibody.model import Model
from . import effects, integrators, step
from .diagnostics import check_contact_step, failure_message
from .effects import python_control
from .preflight import preflight
from .record import (
    Samples,
    contact_record,
    gravity_of,
    quaternion_norm_error,
    trajectory_of,
    violation,
)

_CHUNK_SECONDS = 0.1  # wall time of one compiled chunk: progress and Ctrl-C granularity
_FIRST_CHUNK = 64  # steps in the first chunk
# what compiling a scene's pieces takes on a 2-core machine, by integrator (measured by
# scripts/bench_coldstart.py; constraints add about half again)
_COMPILE_ESTIMATE = {
    integrators.EXPLICIT_RK: "about 15 s",
    integrators.SEMI_IMPLICIT: "about 20 s",
    integrators.IMPLICIT: "about 20 s",
}


class Interrupt:
    """While a run is on (in the main thread), Ctrl-C sets `requested` instead of raising; the
    loops stop after the current chunk, so that the record stays consistent. `signum` is the
    signal that asked (SIGINT, or SIGTERM when the command line hands it over).

    A process that started with Ctrl-C ignored (a background job of a script, nohup) keeps it
    ignored, as Python itself does: SIGINT changes nothing, and SIGTERM still stops the run."""

    requested = False
    signum = signal.SIGINT

    def __enter__(self):
        self._previous = None
        if threading.current_thread() is threading.main_thread():
            self._ctrl_c_ignored = signal.getsignal(signal.SIGINT) == signal.SIG_IGN
            self._previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        if signum == signal.SIGINT and self._ctrl_c_ignored:
            return
        self.requested = True
        self.signum = signum

    def __exit__(self, *exc):
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


def simulate(scene, *, progress=False, raise_on_failure=True, controller=None, control_dt=None):
    """Run `scene` and return its Trajectory.

    scene: a Scene (od.load_scene, od.default_scene, od.scene_from_dict), or a scene file or
      shipped scene's name, which load_scene reads.
    progress: show a progress bar (tqdm, on stderr) once the run has taken more than a second.
    raise_on_failure: on a failure or Ctrl-C raise SimulationError carrying the partial
      trajectory; with False, return it with complete=False and the message.
    controller: a Python controller fn(t, q, qd) -> tau (nv,) (or, on a floating base, the
      joints' (nv - 6,)), called every control_dt s (default: the scene's control_dt, else its
      run.dt) with t (s), q (nq,), qd (nv,), its torque held until the next call (a zero-order
      hold) and added to the scene's effects; a scene can name one too ([control] type =
      "python"). Such a run is driven by opendyn.sim.simulator.Simulator; a controller that
      raises or returns a wrong shape or non-finite values stops it (SimulationError naming
      the controller, the time and what it returned).
    The trajectory is sampled every scene.run.output_dt seconds and at the end; its stats give
    steps, rejected steps, dynamics evaluations, the wall time (s) and, apart from it, the time
    taken to get the compiled step ready: compile_s compiling it (once per machine and opendyn
    version; 0 when the on-disk cache had it) and load_s loading it.
    """
    progress = flag(progress, "simulate: progress")
    raise_on_failure = flag(raise_on_failure, "simulate: raise_on_failure")
    scene = as_scene(scene)
    if controller is not None or python_control.record(scene) is not None:
        from .simulator import run_controlled

        return run_controlled(scene, controller, control_dt, progress, raise_on_failure)
    run = scene.run
    model = scene.model
    integ = integrator_of(scene)
    nsteps, every, rows = preflight(scene, integ)
    table = effects.stage_table(scene)
    check_contact_step(scene, table)
    out = Samples(rows, model.nq, model.nv)
    x = integrators.State(
        np.array(scene.q0, dtype=np.float64), np.array(scene.qd0, dtype=np.float64), np.zeros(2)
    )
    counters = integrators.new_counters()
    start = time.perf_counter()
    compiled_before = compile_seconds()
    first = integrators.Stage(np.zeros((2, model.nv)), np.zeros(2), np.zeros(model.nv))
    at_start = integrators.Progress(0.0, run.dt, 1)
    load_kernels(
        scene,
        integ,
        table,
        step.scene_data(model, table),
        x,
        lambda: _adaptive_chunk(scene, integ, table, at_start, 0.0, x, first, out, counters)
        if integ.adaptive
        else _fixed_chunk(scene, integ, table, 0, 0, 1, x, out, counters),
    )
    compile_s = compile_seconds() - compiled_before
    load = time.perf_counter() - start - compile_s
    bar = progress_bar(run.duration) if progress else None
    start = time.perf_counter()
    with Interrupt() as stop:
        if integ.adaptive:
            status, t = _run_adaptive(scene, integ, table, x, out, counters, bar, stop)
        else:
            status, t = _run_fixed(scene, integ, table, nsteps, every, x, out, counters, bar, stop)
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
            record_state(scene, table, t, x, out)
    stats = {
        "integrator": integ.name,
        "steps": steps,
        "rejected_steps": int(counters.rejected[0]),
        "evaluations": int(counters.evaluations[0]),
        "wall_s": wall,
        "compile_s": compile_s,
        "load_s": load,
        "simulated_s": float(out.t[out.filled - 1]) if out.filled else 0.0,
    }
    if model.floating_base:
        stats["quaternion_norm_error"] = float(
            quaternion_norm_error(model, out.q[: out.filled]).max(initial=0.0)
        )
    traj = trajectory_of(scene, table, out.arrays(), out.filled, status == 0, message, stats)
    if status and raise_on_failure:
        raise SimulationError(message, traj)
    return traj


def integrator_of(scene):
    """The Integrator the scene's run names, checked against the scene (semi-implicit Euler
    takes no constraints: SceneError)."""
    integ = integrators.INTEGRATORS[scene.run.integrator]
    if scene.constraints and integ.kind == integrators.SEMI_IMPLICIT:
        raise SceneError(
            f"{scene.source}: run.integrator: semi_implicit_euler (symplectic, in momentum form) "
            "does not support constraints; use rk4, dopri5, euler or implicit_euler"
        )
    return integ


def load_kernels(scene, integ, table, data, x, loop):
    """Get the run's compiled pieces ready before the clock starts, one by one: forward
    dynamics, the effects, one evaluation, the loop (loop(): the run's loop called for zero
    steps) and the energies of the record. data: the run's step.SceneData; x: its State.
    numba loads each from its on-disk cache or, the first time on a machine, compiles it; then
    a notice and a bar over these pieces show on stderr."""
    model = scene.model
    nv = model.nv
    KD = data.KD
    q, qd = x.q, x.qd
    tau, qdd = np.zeros(nv), np.empty(nv)
    state = (q[None].copy(), qd[None].copy())
    pieces = [
        lambda: step.dynamics(data, q, qd, tau, qdd),
        lambda: step.generalized_forces(
            data, 0.0, q, qd, np.empty(nv), np.empty(nv), np.empty(2), KD[0], KD[1], False
        ),
        lambda: step.evaluate(data, 0.0, q, qd, qdd, tau, np.empty(2)),
        loop,
        lambda: energies(model, *state, gravity_of(scene)),
    ]
    if scene.constraints:
        pieces.append(lambda: violation(model, table, *state))
    if scene.contact is not None:
        pieces.append(lambda: contact_record(model, table.params(effects.contact), *state))
    what = f"the simulation step for {integ.name} with {', '.join(table.names) or 'no effects'}"
    with compiling(what, len(pieces), _COMPILE_ESTIMATE[integ.kind]) as done:
        for piece in pieces:
            piece()
            done()


def _fixed_chunk(scene, integ, table, step0, nsteps, every, x, out, counters):
    """integrators.run_fixed on the run's State x, record and Counters: up to nsteps steps from
    global step step0, recording every `every`-th. Returns (status, steps done)."""
    run = scene.run
    settings = integrators.FixedSettings(t0=0.0, dt=run.dt, every=every, max_speed=run.max_speed)
    data = step.scene_data(scene.model, table)
    free = free_joints(scene.model)
    return integrators.run_fixed(
        integ.switches(), data, settings, step0, nsteps, x, out.arrays(), counters, free
    )


def free_joints(model):
    """None for a fixed base (the loops then compile no Munthe-Kaas correction), else the
    first v index of each free joint (int64), for integrators.rk_stages."""
    if not model.floating_base:
        return None
    return np.array([model.iv[i] for i in range(model.nb) if model.jtype[i] == FREE], np.int64)


def _adaptive_chunk(scene, integ, table, at, t_stop, x, first, out, counters):
    """integrators.run_adaptive on the run's State x, record and Counters from the Progress
    `at` (time, first trial step, next output row) to t_stop; first: the FSAL Stage.
    Returns (status, Progress reached)."""
    run = scene.run
    settings = integrators.AdaptiveSettings(
        t0=0.0,
        t_end=run.duration,
        rtol=run.rtol,
        atol=run.atol,
        output_dt=run.output_dt,
        max_speed=run.max_speed,
        size_index=error_size_index(scene.model),
        land=False,
    )
    data = step.scene_data(scene.model, table)
    free = free_joints(scene.model)
    return integrators.run_adaptive(
        integ.tableau(), data, settings, at, t_stop, x, first, out.arrays(), counters, free
    )


def error_size_index(model):
    """(nv,) int64 for run_adaptive's error norm: for each v coordinate, the q index whose
    magnitude sets its tolerance atol + rtol |q_k| (a joint's own coordinate; a floating base's
    position for its translation rows), -1 for a floating base's rotation rows (1 rad)."""
    index = np.full(model.nv, -1, dtype=np.int64)
    index[model.v_index] = model.q_index
    for i in np.flatnonzero(model.jtype == FREE):
        index[model.iv[i] + 3 : model.iv[i] + 6] = model.iq[i] + np.arange(3)
    return index


def progress_bar(duration):
    from tqdm import tqdm

    return tqdm(
        total=duration,
        unit="s",
        unit_scale=False,
        delay=1.0,
        desc="simulating",
        file=sys.stderr,
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.2f}/{total:.2f} s simulated "
        "[{elapsed}<{remaining}]",
    )


def _chunk_steps(steps, seconds, current):
    """The next chunk's size: enough steps for about _CHUNK_SECONDS at the measured rate."""
    if seconds <= 0:
        return current * 4
    return int(min(current * 8, max(16, steps / seconds * _CHUNK_SECONDS)))


def _run_fixed(scene, integ, table, nsteps, every, x, out, counters, bar, stop):
    """Fixed steps in compiled chunks. Returns (status, time reached)."""
    run = scene.run
    done, chunk = 0, _FIRST_CHUNK
    while done < nsteps:
        n = min(chunk, nsteps - done)
        tic = time.perf_counter()
        status, steps = _fixed_chunk(scene, integ, table, done, n, every, x, out, counters)
        done += steps
        out.filled = (done - 1) // every + 1 if done else 0
        if bar is not None:
            bar.update(steps * run.dt)
        if status:
            return status, done * run.dt
        if stop.requested and done < nsteps:
            return Status.INTERRUPTED, done * run.dt
        chunk = _chunk_steps(steps, time.perf_counter() - tic, chunk)
    t_end = nsteps * run.dt
    if out.filled < len(out.t):
        record_state(scene, table, t_end, x, out)
    return 0, t_end


def _run_adaptive(scene, integ, table, x, out, counters, bar, stop):
    """Adaptive steps in compiled chunks of simulated time. Returns (status, time reached)."""
    run = scene.run
    nv = scene.model.nv
    first = integrators.Stage(np.empty((2, nv)), np.empty(2), np.empty(nv))  # the FSAL stage
    status = first_stage(scene, table, 0.0, x.q, x.qd, first.k, first.power, first.tau)
    counters.evaluations[0] += 1
    if status:
        return status, 0.0
    out.put(0, 0.0, x, first.tau)
    out.filled = 1
    at = integrators.Progress(0.0, run.dt, 1)
    span = max(run.output_dt, run.duration / 1000)
    while at.t < run.duration:
        t_stop = min(run.duration, at.t + span)
        tic = time.perf_counter()
        t_before = at.t
        status, at = _adaptive_chunk(scene, integ, table, at, t_stop, x, first, out, counters)
        out.filled = at.row
        if bar is not None:
            bar.update(at.t - t_before)
        if status:
            return status, at.t
        if stop.requested and at.t < run.duration:
            return Status.INTERRUPTED, at.t
        elapsed = time.perf_counter() - tic
        if elapsed > 0:
            span = min(
                run.duration, max(span * 0.5, min(span * 4, span * _CHUNK_SECONDS / elapsed))
            )
    return 0, at.t


def first_stage(scene, table, t, q, qd, k_first, power, tau):
    """k_first (2, nv) <- (qd, qdd), power (2,) <- (applied, passive) power and tau <- the
    control torque, at (t, q, qd). Returns the dynamics' status."""
    k_first[0] = qd
    return step.evaluate(step.scene_data(scene.model, table), t, q, qd, k_first[1], tau, power)


def record_state(scene, table, t, x, out):
    """Append (t, x) with the control torque there (NaN when the dynamics fail there)."""
    k = np.empty((2, scene.model.nv))
    tau = np.empty(scene.model.nv)
    if first_stage(scene, table, t, x.q, x.qd, k, np.empty(2), tau):
        tau[:] = np.nan
    r = out.filled
    out.grow(r + 1)
    out.put(r, t, x, tau)
    out.filled = r + 1


def as_scene(scene, what="simulate"):
    """scene itself, or the scene that a file or a shipped scene's name names; a TypeError
    naming `what` (the function called) for anything else."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    hint = ""
    if isinstance(scene, Model):
        hint = f"; od.default_scene(model) is the plainest scene of {scene.name!r}"
    elif isinstance(scene, dict):
        hint = "; od.scene_from_dict(data) makes a Scene of a dict"
    raise TypeError(
        f"{what}: scene must be an opendyn Scene (from od.load_scene or od.default_scene) or "
        f"a scene file or shipped scene's name, got {type(scene).__name__}{hint}"
    )
