"""What the drivers share (simulate, Simulator, rollout): Ctrl-C during a run, the scene's
integrator, getting the compiled pieces ready, the free joints and the error's size index, the
progress bar, and a Stepper: one run's step, its SceneData built once, advanced in compiled
chunks (opendyn.sim.integrators) and evaluated at a state."""

from __future__ import annotations

import math
import signal
import sys
import threading
import time
from contextlib import contextmanager

import numpy as np

from .._runtime.compile_notice import compile_seconds, compiling
from ..errors import SceneError
from ..multibody.joints import FREE
from . import effects, hard_settings, integrators, step
from .record import Samples, records_of

# what compiling a run's pieces takes on a 2-core machine, in seconds: everything that
# getting_ready's block compiles, its start checks and record included (scripts/
# bench_coldstart.py, docs/performance/startup.md): the step of any integrator with
# joint-space effects 20-30 s, and what contact (48-55 s in all) and constraints (38-42 s in
# all, after the scene's reader compiled their terms: opendyn.io.scene.sections_constraints)
# add to it. A Python controller runs the plain step; what its own calls compile is its own.
STEP_SECONDS = 25
CONTACT_SECONDS = 25
CONSTRAINT_SECONDS = 15


def compile_estimate(scene) -> str:
    """The compile notice's words on how long `scene`'s pieces take to compile (the numbers
    above), within a factor of 1.5 of the measured time."""
    seconds = STEP_SECONDS
    contact = effects.contact.record(scene), effects.geometry_contact.record(scene)
    if any(record is not None for record in contact):
        seconds += CONTACT_SECONDS
    if scene.constraints:
        seconds += CONSTRAINT_SECONDS
    return f"about {seconds} s"


CHUNK_SECONDS = 0.1  # wall time of one compiled chunk: progress and Ctrl-C granularity
# steps (fixed, or adaptive trials) in the first chunk, before the rate is known: few, since a
# step of a scene of many bodies in contact may take 0.1 s (64 made a 200-box scene answer
# Ctrl-C after 7 s); the next chunks grow by up to 8 times (next_steps)
FIRST_CHUNK = 4


def next_steps(steps, seconds, current):
    """The next chunk's fixed steps: enough for about CHUNK_SECONDS at the rate of the last
    (`steps` in `seconds`), at most 8 times `current`."""
    if seconds <= 0:
        return current * 4
    return int(min(current * 8, max(16, steps / seconds * CHUNK_SECONDS)))


def next_span(span, seconds, longest):
    """The next chunk's simulated time (s) of adaptive steps: about CHUNK_SECONDS of wall time
    at the rate of the last (`span` in `seconds`), between half and four times it, at most
    `longest`."""
    if seconds <= 0:
        return min(longest, span * 4)
    return min(longest, max(span * 0.5, min(span * 4, span * CHUNK_SECONDS / seconds)))


class Interrupt:
    """While a run is on (in the main thread), Ctrl-C sets `requested` instead of raising; the
    loops stop after the current chunk, so that the record stays consistent. `signum` is the
    signal that asked (SIGINT, or SIGTERM when the command line hands it over).

    Python code of the user's that the run calls (a controller) may block or spin and never let
    the run reach its next chunk: while it runs (`in_user_code`), a second Ctrl-C, or a SIGTERM,
    raises UserCodeInterrupted in it at once; the run's state is the one before the call.

    A process that started with Ctrl-C ignored (a background job of a script, nohup) keeps it
    ignored, as Python itself does: SIGINT changes nothing, and SIGTERM still stops the run."""

    requested = False
    signum = signal.SIGINT
    in_user_code = False

    def __enter__(self):
        self._previous = None
        if threading.current_thread() is threading.main_thread():
            self._ctrl_c_ignored = signal.getsignal(signal.SIGINT) == signal.SIG_IGN
            self._previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        if signum == signal.SIGINT and self._ctrl_c_ignored:
            return
        again = self.requested or signum != signal.SIGINT
        self.requested = True
        self.signum = signum
        if self.in_user_code and again:
            self.in_user_code = False
            raise UserCodeInterrupted(signum)

    def __exit__(self, *exc):
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


class UserCodeInterrupted(KeyboardInterrupt):
    """A second Ctrl-C, or a SIGTERM, while the user's Python code ran within a run: raised in
    that code (args: the signal's number)."""


def integrator_of(scene):
    """The Integrator the scene's run names, checked against the scene (semi-implicit Euler
    in momentum form takes no constraints: SceneError; with a hard model it is the
    velocity-level step, whose solve takes them as equality rows)."""
    integ = integrators.INTEGRATORS[scene.run.integrator]
    hard = hard_settings.sections(scene)
    if scene.constraints and integ.kind == integrators.SEMI_IMPLICIT and not hard:
        raise SceneError(
            f"{scene.source}: run.integrator: semi_implicit_euler (symplectic, in momentum form) "
            "does not support constraints; use rk4, dopri5, euler or implicit_euler, or a hard "
            'model (model = "hard" in [effects.contact], [effects.limits] or '
            "[effects.friction]), whose velocity-level step solves them as equality rows"
        )
    return integ


# what a run gets ready before its clock starts, each a piece of the compile notice's bar: the
# start checks (preflight, the contact step), the step's dynamics, its generalized forces, one
# evaluation, the loop and the record (load_kernels)
READY_PIECES = 6


class Ready:
    """What getting a run ready took, once getting_ready's block has ended: compile_s (seconds
    compiling kernels, once per machine and opendyn version) and load_s (the rest: the checks,
    the kernels loaded from the cache, the arrays). done(): the bar's next piece. estimate: the
    notice's words on how long, read when the first compile shows it (a block whose first
    pieces may all load from the cache says what the rest takes once they have)."""

    def __init__(self, estimate):
        self.estimate = estimate
        self.done = None  # set by getting_ready
        self.compile_s = self.load_s = 0.0


@contextmanager
def getting_ready(what, scene, pieces=READY_PIECES):
    """One compile notice and bar, naming `what` with `scene`'s compile_estimate, over all
    that the block compiles: a run's start checks, its step and its record, so that the time
    the run then reports compiling is the time the notice estimated. Yields a Ready."""
    ready = Ready(compile_estimate(scene))
    before, tic = compile_seconds(), time.perf_counter()
    with compiling(what, pieces, lambda: ready.estimate) as ready.done:
        yield ready
    ready.compile_s = compile_seconds() - before
    ready.load_s = time.perf_counter() - tic - ready.compile_s


def step_name(integ, table, loop="simulation step"):
    """The notice's words for a run's step: its loop, its integrator and its effects."""
    return f"the {loop} for {integ.name} with {', '.join(table.names) or 'no effects'}"


def load_kernels(scene, table, data, x, loop, done):
    """Get the run's compiled pieces ready before the clock starts, one by one, calling done()
    after each: forward dynamics, the effects, one evaluation, the loop (loop(): the run's
    loop called for zero steps) and the record's kernels (record.records_of). data: the run's
    step.SceneData; x: its State. numba loads each from its on-disk cache or, the first time on
    a machine, compiles it (within getting_ready's notice)."""
    nv = scene.model.nv
    KD = data.KD
    q, qd = x.q, x.qd
    tau, qdd = np.zeros(nv), np.empty(nv)
    pieces = (
        lambda: step.dynamics(data, q, qd, tau, qdd),
        lambda: step.generalized_forces(
            data, 0.0, q, qd, np.empty(nv), np.empty(nv), np.empty(2), KD[0], KD[1], False
        ),
        lambda: step.evaluate(data, 0.0, q, qd, qdd, tau, np.empty(2)),
        loop,
        lambda: records_of(scene, table, q[None].copy(), qd[None].copy()),
    )
    for piece in pieces:
        piece()
        done()


def free_joints(model):
    """None without a free joint (the loops then compile no Munthe-Kaas correction), else the
    first v index of each free joint (int64: a floating base's, a scene's objects'), for
    integrators.rk_stages."""
    if not np.any(model.jtype == FREE):
        return None
    return np.array([model.iv[i] for i in range(model.nb) if model.jtype[i] == FREE], np.int64)


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
    """A tqdm bar over `duration` s of simulated time, on stderr, shown after a second."""
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


class Stepper:
    """One run of `scene` with its stage table: the integrator, the step's SceneData (built
    once, here), the free joints; chunks of fixed or adaptive steps on a State, and the
    evaluation at a state."""

    def __init__(self, scene, table, integ=None):
        self.scene, self.table = scene, table
        self.integ = integrator_of(scene) if integ is None else integ
        self.data = step.scene_data(scene.model, table)
        self.free = free_joints(scene.model)

    def load(self, x, done):
        """load_kernels for this run at the State x, its loop called for zero steps on a
        scratch record (the types of a run's own)."""
        model = self.scene.model
        out = Samples(1, model.nq, model.nv, self.data.hard)
        counters = integrators.new_counters()
        if self.integ.adaptive:
            first = integrators.Stage(np.zeros((2, model.nv)), np.zeros(2), np.zeros(model.nv))
            at_start = integrators.Progress(0.0, self.scene.run.dt, 1)

            def loop():
                self.adaptive_chunk(at_start, 0.0, x, first, out, counters, FIRST_CHUNK)
        else:

            def loop():
                self.fixed_chunk(0, 0, 1, x, out, counters)

        load_kernels(self.scene, self.table, self.data, x, loop, done)

    def fixed_chunk(self, step0, nsteps, every, x, out, counters):
        """integrators.run_fixed on the State x, the record `out` (record.Samples) and
        Counters: up to nsteps steps from global step step0, recording every `every`-th.
        Returns (status, steps done)."""
        run = self.scene.run
        settings = integrators.FixedSettings(
            t0=0.0, dt=run.dt, every=every, max_speed=run.max_speed
        )
        return integrators.run_fixed(
            self.integ.switches(), self.data, settings, step0, nsteps, x, out.arrays(),
            counters, self.free,
        )

    def adaptive_chunk(self, at, t_stop, x, first, out, counters, max_steps):
        """integrators.run_adaptive on the State x, record and Counters from the Progress
        `at` (time, first trial step, next output row) to t_stop, or for max_steps trial steps
        if it gets no further; first: the FSAL Stage. Returns (status, Progress reached)."""
        run = self.scene.run
        settings = integrators.AdaptiveSettings(
            t0=0.0,
            t_end=run.duration,
            rtol=run.rtol,
            atol=run.atol,
            output_dt=run.output_dt,
            max_speed=run.max_speed,
            size_index=error_size_index(self.scene.model),
            t_land=math.inf,
            max_steps=max_steps,
        )
        return integrators.run_adaptive(
            self.integ.tableau(), self.data, settings, at, t_stop, x, first, out.arrays(),
            counters, self.free,
        )

    def first_stage(self, t, q, qd, k_first, power, tau):
        """k_first (2, nv) <- (qd, qdd), power (2,) <- (applied, passive) power and tau <- the
        control torque, at (t, q, qd). Returns the dynamics' status."""
        k_first[0] = qd
        return step.evaluate(self.data, t, q, qd, k_first[1], tau, power)

    def record_state(self, t, x, out):
        """Append (t, x) to `out` with the control torque there (NaN when the dynamics fail
        there)."""
        nv = self.scene.model.nv
        k, tau = np.empty((2, nv)), np.empty(nv)
        if self.first_stage(t, x.q, x.qd, k, np.empty(2), tau):
            tau[:] = np.nan
        r = out.filled
        out.grow(r + 1)
        out.put(r, t, x, tau)
        out.filled = r + 1
