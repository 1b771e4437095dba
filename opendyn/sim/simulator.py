"""Simulator: a scene stepped from Python, with your own controller in the loop.

    sim = od.Simulator("ur5_falling")
    while sim.t < 1.0:
        sim.step(tau=my_controller(sim.t, sim.q, sim.qd))     # held for one control period
    trajectory = sim.trajectory()

Each `step` holds its torque tau_held (nv,) constant over the interval (a zero-order hold, as a
real robot's controller runs at its control rate) and adds it to the generalized forces of every
effect the scene names, as control torque:

    qdd = (M + diag(armature))^-1 (sum_e tau_e(t, q, qd) + tau_held - c - g)

while the scene's compiled integrator advances the state underneath at its own step (the same
loops as `simulate`: fixed steps, or DOPRI5 landing exactly on the end of the interval). A
Python controller fn(t, q, qd) -> tau (the scene's [control] type = "python", or
simulate(controller=)) is sampled at the start of every control period and its torque held
until the next; `run_controlled` is simulate's loop for it.

Ctrl-C: a step that would take more than a moment runs in compiled chunks of about a tenth of a
second under an Interrupt, and stops at the end of one, the state consistent there, raising
KeyboardInterrupt; a short one runs whole, and a Ctrl-C that lands in it puts back the state
from before it. A controller that blocks is stopped by a second Ctrl-C or a SIGTERM.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from .._runtime.entry import entry_for
from .._runtime.memory import available_memory
from .._runtime.options import as_real
from .._runtime.signals import signal_name
from ..algorithm.contact_extremes import restart
from ..errors import SceneError, SimulationError
from . import effects, integrators, step
from .diagnostics import check_contact_step, failure_message
from .driver import (
    CHUNK_SECONDS,
    FIRST_CHUNK,
    Interrupt,
    UserCodeInterrupted,
    error_size_index,
    free_joints,
    getting_ready,
    integrator_of,
    load_kernels,
    next_span,
    next_steps,
    progress_bar,
    step_name,
)
from .effects import python_control
from .hard_step import restart_hard
from .preflight import byte_size, check_start, record_every
from .record import Samples, trajectory_of, warn_too_deep
from .run import whole_steps
from .step_inputs import (
    checked_configuration,
    checked_period,
    checked_torque,
    checked_vector,
    controller_name,
    controller_of,
)


class Simulator:
    """A Scene you step: the state (t, q, qd), `step(tau, duration)`, `reset`,
    `trajectory()`. od.Simulator (opendyn.api.Simulator), which also takes a scene file or a
    shipped scene's name, documents its arguments.

    Attributes: model, scene, control_dt (s: the default duration of a step).
    """

    def __init__(self, scene, *, controller=None, control_dt=None):
        self.scene, self.model = scene, scene.model
        self._integ = integrator_of(scene)
        self._every = record_every(scene.run)
        self._table = effects.stage_table(scene)
        with getting_ready(step_name(self._integ, self._table), scene) as ready:
            check_contact_step(scene, self._table)
            self._start(controller, control_dt)
            ready.done()
            load_kernels(
                scene, self._table, self._data, self._x, self._entries, ready.done
            )
        self._compile_s, self._load_s = ready.compile_s, ready.load_s

    def _start(self, controller, control_dt):
        """The controller, the step's SceneData, the integrator's settings and the initial
        state (reset)."""
        scene = self.scene
        self._controller, self.control_dt = controller_of(
            scene, self._integ, controller, control_dt
        )
        self._controller_name = (
            None if self._controller is None else controller_name(self._controller)
        )
        self._data = step.scene_data(
            self.model, self._table, python_control.held_torque(self.model)
        )
        self._held = self._data.forces[step.HELD]  # written at every control period
        self._free = free_joints(self.model)
        # the joints' velocity coordinates and the floating base's (which no torque drives)
        if self._integ.adaptive:
            self._tableau = self._integ.tableau()
        else:
            self._switches = self._integ.switches()
        self._wall = 0.0  # wall time (s) of the compiled steps
        self._controller_wall = 0.0  # wall time (s) of the controller's calls
        self._row_bytes = Samples.row_bytes(self.model.nq, self.model.nv)
        self._rate = None  # wall seconds per simulated second of the last step
        self._interrupt = None  # the Interrupt of a long step or of run_controlled
        self._stepping = False  # within _ticks: a controller that steps again is refused
        self.reset()

    # -- the state ---------------------------------------------------------------------------

    @property
    def t(self) -> float:
        """The current time (s)."""
        return self._t

    @property
    def q(self) -> np.ndarray:
        """A copy of the current configuration (nq,)."""
        return self._x.q.copy()

    @property
    def qd(self) -> np.ndarray:
        """A copy of the current velocity (nv,)."""
        return self._x.qd.copy()

    def reset(self, q=None, qd=None, t=0.0):
        """Back to the scene's initial state, or (q (nq,), qd (nv,)) at time t (s): checked as
        a scene's initial state is (shapes, finite numbers, a unit quaternion for a floating
        base, then the start checks of simulate: speeds within run.max_speed, positions within
        enforced limits, contact points not deep in the ground or in each other, constraints
        met, a finite energy; ValueError naming the argument and the cause). The record starts
        again."""
        model = self.model
        given = q is not None or qd is not None
        q = np.array(
            self.scene.q0 if q is None else checked_configuration(model, q, "Simulator.reset: q"),
            dtype=np.float64,
        )
        qd = np.array(
            self.scene.qd0 if qd is None else checked_vector(model, qd, "Simulator.reset: qd"),
            dtype=np.float64,
        )
        t = as_real(t, "Simulator.reset: t")
        if not math.isfinite(t):
            raise ValueError(f"Simulator.reset: t must be a finite time (s), got {t}")
        if not given:
            check_start(self.scene)
        else:
            try:
                check_start(dataclasses.replace(self.scene, q0=q, qd0=qd))
            except SceneError as error:
                raise ValueError(
                    f"Simulator.reset: this state cannot start the scene: {error}"
                ) from None
        self._x = integrators.State(q, qd, np.zeros(2))
        self._t0 = self._t = t
        self._steps = 0
        self._stopped = ""
        self._counters = integrators.new_counters()
        self._samples = Samples(16, model.nq, model.nv, self._data.hard)
        self._record = self._samples.arrays()
        self._held[:] = 0.0
        restart(self._data.touch)
        restart_hard(self._data.hard)
        run = self.scene.run
        if self._integ.adaptive:
            nv = model.nv
            self._first = integrators.Stage(np.zeros((2, nv)), np.zeros(2), np.zeros(nv))
            self._at = integrators.Progress(t, run.dt, 1)
            self._adaptive = integrators.AdaptiveSettings(
                t0=t, t_end=math.inf, rtol=run.rtol, atol=run.atol, output_dt=run.output_dt,
                max_speed=run.max_speed, size_index=error_size_index(model), t_land=math.inf,
                max_steps=integrators.ALL_STEPS,
            )
        else:
            self._fixed = integrators.FixedSettings(
                t0=t, dt=run.dt, every=self._every, max_speed=run.max_speed
            )

    # -- stepping ----------------------------------------------------------------------------

    def step(self, tau=None, duration=None):
        """Advance by `duration` s (default: control_dt) with tau held constant over it.

        tau: (nv,) generalized force (N m or N) added to the scene's effects as control torque
          (None: zero); on a floating base also the joints' (nv - 6,) alone, and its base part
          (the first 6) must be zero: the base is not actuated.
        The scene's `clip = true` clips its own control law, not tau (clip a Python
        controller's torque in the controller).
        A fixed-step integrator takes whole steps (a duration that is not a whole number of
        run.dt is a ValueError naming both); DOPRI5 lands exactly on the end. With a Python
        controller, the duration must be a whole number of control periods, and the
        controller's torque is added to tau at the start of each.
        A failure (a state not finite or faster than run.max_speed, a singular mass matrix, a
        controller's error) raises SimulationError with the trajectory up to it; the
        Simulator keeps that state and refuses further steps until reset. Ctrl-C stops a long
        step at the end of a compiled chunk (KeyboardInterrupt; the Simulator steps on from
        there).
        """
        if self._stopped:
            raise SimulationError(
                f"the simulator stopped ({self._stopped}); reset() it to step again",
                self.trajectory(),
            )
        if self._stepping:
            raise RuntimeError(
                "Simulator.step: called while this Simulator steps (from its own controller?); "
                "a controller returns the torque for its period and must not step the "
                "simulator that calls it"
            )
        tau_user = checked_torque(self.model, tau, "Simulator.step: tau")
        if duration is None:
            duration = self.control_dt
        else:
            duration = checked_period(duration, "Simulator.step: duration", self._t)
        ticks, period = 1, duration
        if self._controller is not None:
            ticks, period = whole_steps(duration / self.control_dt), self.control_dt
            if ticks is None:
                raise ValueError(
                    f"Simulator.step: duration = {duration:g} s is not a whole number of "
                    f"control periods control_dt = {self.control_dt:g} s (the controller runs "
                    "at each)"
                )
        self._check_record(duration)
        t_start = self._t
        # each period's end from the step's start (no sum of rounded periods drifts)
        ends = (t_start + (duration if k == ticks else k * period) for k in range(1, ticks + 1))
        if self._interrupt is not None or not self._long(duration):
            self._ticks(tau_user, ends)
            return
        with Interrupt() as stop:
            self._interrupt = stop
            try:
                self._ticks(tau_user, ends)
            except UserCodeInterrupted:
                pass  # the controller stopped before it returned: the state is the one before
            finally:
                self._interrupt = None
        if stop.requested:
            raise KeyboardInterrupt(
                f"Simulator.step: interrupted ({signal_name(stop.signum)}) at t = {self._t:.6g} "
                "s, the end of a whole integrator step: the state is the one there, and step() "
                "goes on from it"
            )

    def _long(self, duration):
        """Whether a step of `duration` s may take longer than a chunk (the rate of the last
        step, or, before any, more than FIRST_CHUNK steps of run.dt)."""
        if self._rate is None:
            return duration > FIRST_CHUNK * self.scene.run.dt
        return duration * self._rate > 0.5 * CHUNK_SECONDS

    def _ticks(self, tau_user, ends):
        """One control period up to each time of `ends` (s) (`_tick`). Stops early once an
        Interrupt asked."""
        tic, t_before = time.perf_counter(), self._t
        self._stepping = True
        try:
            for t_end in ends:
                self._tick(tau_user, t_end)
                if self._interrupt is not None and self._interrupt.requested:
                    break
        finally:
            self._stepping = False
        if self._t > t_before:
            self._rate = (time.perf_counter() - tic) / (self._t - t_before)

    def _tick(self, tau_user, t_end):
        """One control period up to t_end (s): tau_held = tau_user + the controller's torque
        at its start (tau_user alone without a controller), held over it."""
        if self._controller is None:
            self._held[:] = tau_user
        else:
            tic = time.perf_counter()
            try:
                self._held[:] = tau_user + self._control()
            finally:
                self._controller_wall += time.perf_counter() - tic
        self._advance(t_end)

    def _control(self):
        """The controller's torque at the current state, checked; SimulationError otherwise.
        Under an Interrupt, a second Ctrl-C or a SIGTERM stops a controller that blocks
        (UserCodeInterrupted, the state untouched)."""
        fn, t, stop, name = self._controller, self._t, self._interrupt, self._controller_name
        if stop is not None:
            stop.in_user_code = True
        try:
            tau = fn(t, self._x.q.copy(), self._x.qd.copy())
        except Exception as error:
            self._stop(f"controller {name} raised {type(error).__name__}: {error} at t = "
                       f"{t:.6g} s", error)
        finally:
            if stop is not None:
                stop.in_user_code = False
        if tau is None:  # a controller that forgot to return: not zero torque
            self._stop(
                f"controller {name} returned None at t = {t:.6g} s; it must return the joint "
                f"torques tau (a ({len(self.model.v_index)},) array; zeros for none)",
                TypeError("the controller returned None"),
            )
        try:
            what = f"controller {name} at t = {t:.6g} s returned tau"
            return checked_torque(self.model, tau, what)
        except (TypeError, ValueError) as error:
            self._stop(str(error), error)

    def _advance(self, t_end):
        """Advance to t_end (s) with the held torque: in chunks under an Interrupt (stopping
        after the one during which it asked), else in one compiled call, the state before it
        put back if a Ctrl-C lands in it."""
        tic = time.perf_counter()
        saved = self._saved() if self._interrupt is None else None
        try:
            if self._integ.adaptive:
                status = self._advance_adaptive(t_end)
            else:
                status = self._advance_fixed(self._whole_steps(t_end - self._t))
        except KeyboardInterrupt:
            if saved is not None:
                self._restore(saved)
            raise
        finally:
            self._wall += time.perf_counter() - tic
        if status:
            self._stop(
                failure_message(
                    self.scene, self._table, status, self._t, self._steps, self._x.q,
                    self._x.qd, self._held,
                )
            )

    def _whole_steps(self, duration):
        run = self.scene.run
        n = whole_steps(duration / run.dt)
        if n is None:
            raise ValueError(
                f"Simulator.step: duration = {duration:g} s is not a whole number of steps "
                f"of run.dt = {run.dt:g} s ({duration / run.dt:.6g} steps; fixed-step "
                f"integrator {self._integ.name!r})"
            )
        return n

    def _saved(self):
        """What a step changes: the state, the time, the step count, the record's length, the
        adaptive loop's progress and the contact's extremes."""
        x, touch = self._x, self._data.touch
        return (x.q.copy(), x.qd.copy(), x.w.copy(), self._t, self._steps,
                self._samples.filled, getattr(self, "_at", None),
                None if touch is None else touch.copy())

    def _restore(self, saved):
        q, qd, w, self._t, self._steps, self._samples.filled, at, touch = saved
        self._x.q[:], self._x.qd[:], self._x.w[:] = q, qd, w
        if at is not None:
            self._at = at
        if touch is not None:
            self._data.touch[:] = touch

    def _advance_fixed(self, n):
        """n fixed steps, in chunks of about CHUNK_SECONDS under an Interrupt. Returns the
        status."""
        stop, run = self._interrupt, self.scene.run
        every, end = self._every, self._steps + n
        chunk = n if stop is None else FIRST_CHUNK
        self._reserve((end - 1) // every + 1)
        while self._steps < end:
            k = min(chunk, end - self._steps)
            tic = time.perf_counter() if k < end - self._steps else 0.0  # another chunk follows
            status, done = self._run_fixed(
                self._switches, self._data, self._fixed, self._steps, k, self._x, self._record,
                self._counters, self._free,
            )
            self._steps += done
            self._t = self._t0 + self._steps * run.dt
            self._samples.filled = (self._steps - 1) // every + 1 if self._steps else 0
            if status or self._steps == end or (stop is not None and stop.requested):
                return status
            chunk = next_steps(done, time.perf_counter() - tic, chunk)
        return 0

    def _advance_adaptive(self, t_land):
        """Adaptive steps landing on t_land (s), in chunks of about CHUNK_SECONDS under an
        Interrupt (a span of simulated time, cut at a budget of trial steps). Returns the
        status."""
        run, stop = self.scene.run, self._interrupt
        x, first = self._x, self._first
        # the held torque may have changed: the first (FSAL) stage is evaluated anew
        first.k[0] = x.qd
        status = self._evaluate(self._data, self._t, x.q, x.qd, first.k[1], first.tau, first.power)
        self._counters.evaluations[0] += 1
        if status:
            return status
        if self._samples.filled == 0:
            self._samples.put(0, self._t, x, first.tau)
            self._samples.filled = 1
        self._reserve(int((t_land - self._t0) / run.output_dt) + 2)
        settings = self._adaptive._replace(t_land=t_land)
        span = run.output_dt if stop is not None else math.inf
        budget = FIRST_CHUNK  # trial steps a chunk may take (under an Interrupt)
        while self._t < t_land:
            tic = time.perf_counter()
            trials = self._counters.accepted[0] + self._counters.rejected[0]
            if stop is not None:
                settings = settings._replace(max_steps=budget)
            status, self._at = self._run_adaptive(
                self._tableau, self._data, settings, self._at, min(t_land, self._t + span), x,
                first, self._record, self._counters, self._free,
            )
            self._t = self._at.t
            self._samples.filled = self._at.row
            self._steps = int(self._counters.accepted[0])
            if status or (stop is not None and stop.requested):
                return status
            seconds = time.perf_counter() - tic
            span = next_span(span, seconds, t_land - self._t0)
            trials = int(self._counters.accepted[0] + self._counters.rejected[0] - trials)
            budget = next_steps(trials, seconds, budget)
        return 0

    def _check_record(self, duration):
        """Refuse a step whose record would not fit in the memory this process may allocate
        (before anything is stepped): the samples every run.output_dt up to t + duration."""
        rows = int((self._t + duration - self._t0) / self.scene.run.output_dt) + 2
        if rows <= len(self._samples.t):  # it fits in the record as it is: no need to ask
            return
        need = rows * self._row_bytes
        room = available_memory()
        if room is not None and need > room[0]:
            have, what = room
            raise ValueError(
                f"Simulator.step: duration = {duration:g} s would make the record since the "
                f"last reset {rows:.4g} samples (one every run.output_dt = "
                f"{self.scene.run.output_dt:g} s), {byte_size(need)}, more than the "
                f"{byte_size(have)} that {what} leaves this process; step for less, keep "
                "trajectory() and reset(), or raise run.output_dt"
            )

    def _reserve(self, rows):
        """Room for `rows` records (the buffer doubles when it must grow and that fits)."""
        samples = self._samples
        if rows > len(samples.t):
            room = available_memory()
            double = 2 * len(samples.t)
            if room is None or double * self._row_bytes < 0.5 * room[0]:
                rows = max(rows, double)
            samples.grow(rows)
            self._record = samples.arrays()

    def _stop(self, message, cause=None):
        self._stopped = message
        raise SimulationError(message, self.trajectory()) from cause

    def _entries(self):
        """The compiled loop and evaluation, called without numba's type dispatch (entry_for):
        a control tick's round trip costs about 2 us instead of 9."""
        nv = self.model.nv
        self._evaluate = entry_for(
            step.evaluate, self._data, 0.0, self._x.q, self._x.qd, np.empty(nv), np.empty(nv),
            np.empty(2),
        )
        if self._integ.adaptive:
            self._run_adaptive = entry_for(
                integrators.run_adaptive, self._tableau, self._data, self._adaptive, self._at,
                0.0, self._x, self._first, self._record, self._counters, self._free,
            )
        else:
            self._run_fixed = entry_for(
                integrators.run_fixed, self._switches, self._data, self._fixed, 0, 0, self._x,
                self._record, self._counters, self._free,
            )

    # -- the record --------------------------------------------------------------------------

    def trajectory(self):
        """Everything stepped since the last reset as a Trajectory: samples every
        run.output_dt and the current state, with tau the control torque (the held torque
        included) and work_applied its work."""
        samples = self._samples.copy()
        last = samples.t[samples.filled - 1] if samples.filled else -math.inf
        if self._t - last > _sliver(self._t):
            tau = np.empty(self.model.nv)
            k, power = np.empty((2, self.model.nv)), np.empty(2)
            if self._evaluate(self._data, self._t, self._x.q, self._x.qd, k[1], tau, power):
                tau[:] = np.nan
            samples.grow(samples.filled + 1)
            samples.put(samples.filled, self._t, self._x, tau)
            samples.filled += 1
        stats = {
            "integrator": self._integ.name,
            "steps": self._steps,
            "rejected_steps": int(self._counters.rejected[0]),
            "evaluations": int(self._counters.evaluations[0]),
            "wall_s": self._wall + self._controller_wall,
            "controller_s": self._controller_wall,
            "compile_s": self._compile_s,
            "load_s": self._load_s,
            "simulated_s": self._t - self._t0,
        }
        complete = not self._stopped
        return trajectory_of(
            self.scene, self._table, samples.arrays(), samples.filled, complete, self._stopped,
            stats, self._data.touch,
        )


def run_controlled(scene, controller, control_dt, progress, raise_on_failure):
    """simulate(scene, controller=...): a Simulator ticked one control period at a time over
    the scene's run.duration (the last period cut short where control_dt does not divide it),
    with simulate's progress bar, Ctrl-C and failure handling: the run stops at the end of the
    chunk or control period during which Ctrl-C came, or at once, inside a controller that
    blocks, on a second Ctrl-C or a SIGTERM."""
    sim = Simulator(scene, controller=controller, control_dt=control_dt)
    duration, period = scene.run.duration, sim.control_dt
    ticks = whole_steps(duration / period) or math.ceil(duration / period)
    bar = progress_bar(duration) if progress else None
    shown, shown_at = 0.0, time.perf_counter()
    message = ""
    with Interrupt() as stop:
        sim._interrupt, sim._stepping = stop, True
        try:
            for k in range(1, ticks + 1):
                t_end = duration if k == ticks else k * period
                sim._tick(0.0, t_end)
                # asked during this period: the run stops at its end, or where it stopped
                if stop.requested and (k < ticks or t_end - sim.t > _sliver(t_end)):
                    message = sim._stopped = _interrupted(stop, sim)
                    break
                if bar is not None and time.perf_counter() - shown_at > 0.1:
                    bar.update(sim.t - shown)
                    shown, shown_at = sim.t, time.perf_counter()
        except UserCodeInterrupted:
            message = sim._stopped = _interrupted(stop, sim, "; the controller had not returned")
        except SimulationError as error:
            message = str(error)
        finally:
            sim._interrupt, sim._stepping = None, False
            if bar is not None:
                bar.update(sim.t - shown)
                bar.close()
    trajectory = sim.trajectory()
    warn_too_deep(trajectory, stacklevel=4)  # the caller of od.simulate
    if message and raise_on_failure:
        raise SimulationError(message, trajectory)
    return trajectory


def _sliver(t):
    """Two times closer than this (s) are one (integrators.SLIVER)."""
    return integrators.SLIVER * max(1.0, abs(t))


def _interrupted(stop, sim, where=""):
    return (
        f"interrupted ({signal_name(stop.signum)}) at t = {sim.t:.6g} s (step {sim._steps})"
        f"{where}"
    )
