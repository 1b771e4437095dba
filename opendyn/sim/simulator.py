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
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import pathlib
import sys
import time

import numpy as np

from .._runtime.options import as_real
from .._runtime.compile_notice import compile_seconds
from .._runtime.entry import entry_for
from .._runtime.signals import signal_name
from ..algorithm import checks
from ..algorithm.configuration import check_unit_quaternions
from ..errors import SceneError, SimulationError
from .run import whole_steps
from ..multibody.joints import FREE
from . import effects, integrators, step
from .diagnostics import check_contact_step, failure_message
from .effects import python_control
from .preflight import preflight
from .record import Samples, trajectory_of
from .driver import (
    Interrupt,
    error_size_index,
    free_joints,
    integrator_of,
    load_kernels,
    progress_bar,
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
        _, self._every, _ = preflight(scene, self._integ)
        self._table = effects.stage_table(scene)
        check_contact_step(scene, self._table)
        self._controller, self.control_dt = _controller_of(
            scene, self._integ, controller, control_dt
        )
        self._held = python_control.held_torque(self.model)
        self._data = step.scene_data(self.model, self._table, self._held)
        self._free = free_joints(self.model)
        # the joints' velocity coordinates and the floating base's (which no torque drives)
        if self._integ.adaptive:
            self._tableau = self._integ.tableau()
        else:
            self._switches = self._integ.switches()
        self._wall = 0.0
        self.reset()
        before = compile_seconds()
        tic = time.perf_counter()
        load_kernels(scene, self._integ, self._table, self._data, self._x, self._entries)
        self._compile_s = compile_seconds() - before
        self._load_s = time.perf_counter() - tic - self._compile_s

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
        base). The record starts again."""
        model = self.model
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
        self._x = integrators.State(q, qd, np.zeros(2))
        self._t0 = self._t = t
        self._steps = 0
        self._stopped = ""
        self._counters = integrators.new_counters()
        self._samples = Samples(16, model.nq, model.nv)
        self._record = self._samples.arrays()
        self._held[:] = 0.0
        run = self.scene.run
        if self._integ.adaptive:
            nv = model.nv
            self._first = integrators.Stage(np.zeros((2, nv)), np.zeros(2), np.zeros(nv))
            self._at = integrators.Progress(t, run.dt, 1)
            self._adaptive = integrators.AdaptiveSettings(
                t0=t, t_end=math.inf, rtol=run.rtol, atol=run.atol, output_dt=run.output_dt,
                max_speed=run.max_speed, size_index=error_size_index(model), land=True,
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
        Simulator keeps that state and refuses further steps until reset.
        """
        if self._stopped:
            raise SimulationError(
                f"the simulator stopped ({self._stopped}); reset() it to step again",
                self.trajectory(),
            )
        tau_user = checked_torque(self.model, tau, "Simulator.step: tau")
        duration = self.control_dt if duration is None else self._duration(duration)
        if self._controller is None:
            self._held[:] = tau_user
            self._advance(duration)
            return
        ticks = whole_steps(duration / self.control_dt)
        if ticks is None:
            raise ValueError(
                f"Simulator.step: duration = {duration:g} s is not a whole number of control "
                f"periods control_dt = {self.control_dt:g} s (the controller runs at each)"
            )
        for _ in range(ticks):
            self._tick(tau_user, self.control_dt)

    def _tick(self, tau_user, duration):
        """One control period: tau_held = tau_user + the controller's torque now, held over
        `duration` s."""
        self._held[:] = tau_user + self._control()
        self._advance(duration)

    def _duration(self, duration):
        duration = as_real(duration, "Simulator.step: duration")
        if not (math.isfinite(duration) and duration > 0):
            raise ValueError(f"Simulator.step: duration must be a time > 0 (s), got {duration}")
        return duration

    def _control(self):
        """The controller's torque at the current state, checked; SimulationError otherwise."""
        fn, t = self._controller, self._t
        try:
            tau = fn(t, self._x.q.copy(), self._x.qd.copy())
        except Exception as error:
            self._stop(f"controller {_name(fn)} raised {type(error).__name__}: {error} at "
                       f"t = {t:.6g} s", error)
        if tau is None:  # a controller that forgot to return: not zero torque
            self._stop(
                f"controller {_name(fn)} returned None at t = {t:.6g} s; it must return the "
                f"joint torques tau (a ({len(self.model.v_index)},) array; zeros for none)",
                TypeError("the controller returned None"),
            )
        try:
            return checked_torque(
                self.model, tau, f"controller {_name(fn)} at t = {t:.6g} s returned tau"
            )
        except (TypeError, ValueError) as error:
            self._stop(str(error), error)

    def _advance(self, duration):
        tic = time.perf_counter()
        if self._integ.adaptive:
            status = self._advance_adaptive(self._t + duration)
        else:
            n = whole_steps(duration / self.scene.run.dt)
            if n is None:
                raise ValueError(
                    f"Simulator.step: duration = {duration:g} s is not a whole number of steps "
                    f"of run.dt = {self.scene.run.dt:g} s ({duration / self.scene.run.dt:.6g} "
                    f"steps; fixed-step integrator {self._integ.name!r})"
                )
            status = self._advance_fixed(n)
        self._wall += time.perf_counter() - tic
        if status:
            steps = self._steps
            self._stop(
                failure_message(
                    self.scene, self._table, status, self._t, steps, self._x.q, self._x.qd,
                    self._held,
                )
            )

    def _advance_fixed(self, n):
        every = self._every
        self._reserve((self._steps + n - 1) // every + 1)
        status, done = self._run_fixed(
            self._switches, self._data, self._fixed, self._steps, n, self._x, self._record,
            self._counters, self._free,
        )
        self._steps += done
        self._t = self._t0 + self._steps * self.scene.run.dt
        self._samples.filled = (self._steps - 1) // every + 1 if self._steps else 0
        return status

    def _advance_adaptive(self, t_stop):
        run = self.scene.run
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
        self._reserve(int((t_stop - self._t0) / run.output_dt) + 2)
        status, self._at = self._run_adaptive(
            self._tableau, self._data, self._adaptive, self._at, t_stop, x, first,
            self._record, self._counters, self._free,
        )
        self._t = self._at.t
        self._samples.filled = self._at.row
        self._steps = int(self._counters.accepted[0])
        return status

    def _reserve(self, rows):
        """Room for `rows` records (the buffer doubles when it must grow)."""
        samples = self._samples
        if rows > len(samples.t):
            samples.grow(max(rows, 2 * len(samples.t)))
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
        if self._t > last:
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
            "wall_s": self._wall,
            "compile_s": self._compile_s,
            "load_s": self._load_s,
            "simulated_s": self._t - self._t0,
        }
        complete = not self._stopped
        return trajectory_of(
            self.scene, self._table, samples.arrays(), samples.filled, complete, self._stopped,
            stats,
        )

    # -- torques -----------------------------------------------------------------------------


def run_controlled(scene, controller, control_dt, progress, raise_on_failure):
    """simulate(scene, controller=...): a Simulator ticked one control period at a time over
    the scene's run.duration (the last period cut short where control_dt does not divide it),
    with simulate's progress bar, Ctrl-C and failure handling."""
    sim = Simulator(scene, controller=controller, control_dt=control_dt)
    duration, period = scene.run.duration, sim.control_dt
    ticks = whole_steps(duration / period) or math.ceil(duration / period)
    bar = progress_bar(duration) if progress else None
    shown, shown_at = 0.0, time.perf_counter()
    message = ""
    with Interrupt() as stop:
        try:
            for k in range(ticks):
                sim._tick(0.0, period if k + 1 < ticks else duration - k * period)
                if stop.requested and k + 1 < ticks:
                    message = sim._stopped = (
                        f"interrupted ({signal_name(stop.signum)}) at t = {sim.t:.6g} s "
                        f"(step {sim._steps})"
                    )
                    break
                if bar is not None and time.perf_counter() - shown_at > 0.1:
                    bar.update(sim.t - shown)
                    shown, shown_at = sim.t, time.perf_counter()
        except SimulationError as error:
            message = str(error)
        finally:
            if bar is not None:
                bar.update(sim.t - shown)
                bar.close()
    trajectory = sim.trajectory()
    if message and raise_on_failure:
        raise SimulationError(message, trajectory)
    return trajectory


def _controller_of(scene, integ, controller, control_dt):
    """(fn or None, control period s): the given controller or the scene's Python one, and
    its period: control_dt, else the scene's [control] control_dt, else run.control_dt, else
    run.dt; for a fixed-step integrator a whole number of steps."""
    run = scene.run
    own = python_control.record(scene)
    if controller is None and own is not None:
        controller = load_controller(own.function, f"{scene.source}: control.function")
    if controller is not None and not callable(controller):
        raise TypeError(
            f"controller must be a function fn(t, q, qd) -> tau, got "
            f"{type(controller).__name__} {controller!r}"[:200]
        )
    if own is not None and own.control_dt is not None and run.control_dt is not None:
        raise SceneError(
            f"{scene.source}: control.control_dt and run.control_dt are both given; give one"
        )
    if control_dt is None:
        control_dt = next(
            (dt for dt in (own and own.control_dt, run.control_dt) if dt is not None), run.dt
        )
    control_dt = as_real(control_dt, "control_dt")
    if not (math.isfinite(control_dt) and control_dt > 0):
        raise ValueError(f"control_dt must be a time > 0 (s), got {control_dt}")
    if not integ.adaptive and whole_steps(control_dt / run.dt) is None:
        raise ValueError(
            f"{scene.source}: control_dt = {control_dt:g} s is not a whole number of steps of "
            f"run.dt = {run.dt:g} s ({control_dt / run.dt:.6g} steps); the fixed-step "
            f"integrator {run.integrator!r} holds the torque over whole steps"
        )
    return controller, control_dt


def load_controller(spec, what):
    """The function that spec names: "FILE.py:NAME" (a file, loaded as a module of its own) or
    "MODULE:NAME" (imported). SceneError naming `what`, the file or module and the reason
    when it cannot be loaded."""
    where, name = python_control.function_parts(spec)
    if where is None:
        raise SceneError(f"{what}: {python_control.NOT_A_FUNCTION.format(spec=spec)}")
    try:
        if where.endswith(".py"):
            path = pathlib.Path(where)
            if not path.is_file():
                raise SceneError(f"{what}: no file {str(path)!r}")
            module_name = f"opendyn_controller_{abs(hash(str(path.resolve())))}"
            spec_ = importlib.util.spec_from_file_location(module_name, path)
            module = importlib.util.module_from_spec(spec_)
            sys.modules[module_name] = module
            spec_.loader.exec_module(module)
        else:
            module = importlib.import_module(where)
    except SceneError:
        raise
    except Exception as error:
        raise SceneError(
            f"{what}: loading {where!r} failed: {type(error).__name__}: {error}"
        ) from error
    fn = getattr(module, name, None)
    if not callable(fn):
        found = "nothing" if fn is None else f"a {type(fn).__name__}"
        raise SceneError(f"{what}: {where!r} has no function {name!r} ({found} by that name)")
    return fn


def checked_torque(model, tau, what):
    """tau as a (nv,) float64 generalized force: (nv,), or with free joints (a floating base,
    a scene's objects) the joints' (model.v_index,); 0.0 for None; TypeError or ValueError
    naming `what` otherwise."""
    if tau is None:
        return 0.0
    joints, base = model.v_index, model._unactuated
    a = checks.as_float_array(tau, what)
    if base.size and a.shape == joints.shape:
        full = np.zeros(model.nv)
        full[joints] = a
        a = full
    if a.shape != (model.nv,):
        also = f" or the joints' ({len(joints)},)" if base.size else ""
        raise ValueError(f"{what}: expected shape ({model.nv},){also}, got {_shown(a)}")
    if not np.isfinite(a).all():
        raise ValueError(f"{what}: not finite: {_shown(a)}")
    if base.size and np.any(a[base] != 0.0):
        raise ValueError(
            f"{what}: the free joints (a floating base, a scene's objects) are not actuated, "
            f"so tau at their coordinates "
            f"{base.tolist()} must be zero, got {a[base].tolist()} (give the joints' "
            f"({len(joints)},) alone)"
        )
    return a


def checked_configuration(model, q, what):
    """q checked as an initial configuration (nq,): finite, each quaternion within
    QUATERNION_TOLERANCE of unit norm as every dynamics function takes it (the same check), and
    normalised; errors name `what`."""
    q = checked_vector(model, q, what, model.nq)
    check_unit_quaternions(model, q, "q", what)
    for i in np.flatnonzero(model.jtype == FREE):
        k = int(model.iq[i]) + 3
        q[k : k + 4] /= np.linalg.norm(q[k : k + 4])
    return q


def checked_vector(model, x, what, n=None):
    """x as a finite float64 (n,) copy (n = nv by default); TypeError or ValueError naming
    `what`."""
    n = model.nv if n is None else n
    a = np.array(checks.as_float_array(x, what), dtype=np.float64)
    if a.shape != (n,):
        raise ValueError(f"{what}: expected shape ({n},), got {_shown(a)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: not finite: {_shown(a)}")
    return a


def _shown(a):
    text = np.array2string(np.asarray(a), precision=4, threshold=12)
    return f"shape {np.shape(a)}: {text}"


def _name(fn):
    """The controller as messages name it: its qualified name (Class.method) without the
    "outer.<locals>." of a function defined inside another."""
    name = getattr(fn, "__qualname__", None) or type(fn).__name__
    return repr(name.rpartition("<locals>.")[2])

