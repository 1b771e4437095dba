"""How a scene is advanced in time: the ``Run`` record, reading it from a scene's [run] settings
(the scene reader and ``Scene.replace_run`` read with it), and the check that a fixed-step run
records every k-th step and ends on a step (``check_fixed_steps``, which opendyn.sim.preflight
repeats for a Run built directly). The integrators a run may name are the rows of
opendyn.sim.integrators.INTEGRATORS, read when a run is read (``integrator_names``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import integrators
from .values import ValueReader

RUN_KEYS = (
    "duration", "integrator", "dt", "output_dt", "rtol", "atol", "max_speed", "control_dt"
)
# a ratio of times counts as a whole number of steps within this relative tolerance
_WHOLE_STEPS_RTOL = 1e-9
# float64 counts steps exactly up to 2^53; a run of more steps could not say which step failed
MAX_STEPS = 2**53


@dataclass(frozen=True)
class Run:
    """How to advance a scene in time.

    duration: s, > 0. integrator: one of integrator_names(). dt: s, the step of fixed-step integrators,
    the first trial step of "dopri5". rtol, atol: "dopri5"'s tolerances. output_dt: s, the
    sample interval of the recorded trajectory (a whole multiple of dt for fixed-step
    integrators). max_speed: rad/s or m/s; any |qd| above it stops the run as diverging.
    control_dt: s or None, the period of a Python controller (opendyn.sim.simulator: the
    default step of a Simulator and the tick of simulate's controller=); None: dt.
    """

    duration: float = 5.0
    integrator: str = "rk4"
    dt: float = 1e-3
    rtol: float = 1e-6
    atol: float = 1e-9
    output_dt: float = 0.01
    max_speed: float = 1e4
    control_dt: float | None = None


def integrator_names() -> tuple[str, ...]:
    """The integrators a run may name: the rows of opendyn.sim.integrators.INTEGRATORS."""
    return tuple(integrators.INTEGRATORS)


class RunSection(ValueReader):
    """Reads [run] into a Run."""

    def run(self, table) -> Run:
        table = self.table(table, "run")
        self.keys(table, "run", RUN_KEYS)
        d = Run()
        duration = self.number(table.get("duration", d.duration), "run.duration", positive=True)
        integrator = self.string(
            table.get("integrator", d.integrator), "run.integrator", integrator_names()
        )
        dt = self.number(table.get("dt", d.dt), "run.dt", positive=True)
        rtol = self.number(table.get("rtol", d.rtol), "run.rtol", positive=True)
        atol = self.number(table.get("atol", d.atol), "run.atol", positive=True)
        output_dt = self.number(
            table.get("output_dt", max(0.01, dt)), "run.output_dt", positive=True
        )
        max_speed = self.number(table.get("max_speed", d.max_speed), "run.max_speed", positive=True)
        control_dt = None
        if "control_dt" in table:
            control_dt = self.number(table["control_dt"], "run.control_dt", positive=True)
        if dt > duration:
            self.fail("run.dt", f"the step {dt:g} s is longer than run.duration = {duration:g} s")
        run = Run(
            duration=duration,
            integrator=integrator,
            dt=dt,
            rtol=rtol,
            atol=atol,
            output_dt=output_dt,
            max_speed=max_speed,
            control_dt=control_dt,
        )
        check_fixed_steps(run, self.source)
        return run


def check_fixed_steps(run: Run, source: str) -> None:
    """A fixed-step run records every k-th step and ends on a step: run.output_dt and
    run.duration must be whole numbers of steps run.dt, and the steps countable (at most
    MAX_STEPS). Raises SceneError naming `source` and the key; adaptive runs pass."""
    if integrators.INTEGRATORS[run.integrator].adaptive:
        return
    r = ValueReader(source)
    duration, dt, output_dt = run.duration, run.dt, run.output_dt
    ratio = output_dt / dt
    if not np.isfinite(ratio):
        r.fail("run.dt", f"{dt:g} s is too small a step to count in float64")
    if whole_steps(ratio) is None:
        r.fail(
            "run.output_dt",
            f"{output_dt:g} s is not a whole multiple of run.dt = {dt:g} s (it is "
            f"{ratio:.6g} steps); the fixed-step integrator {run.integrator!r} records "
            f"every k-th step: choose output_dt = k * dt",
        )
    ratio = duration / dt
    if not ratio <= MAX_STEPS:
        r.fail(
            "run.dt",
            f"run.duration / run.dt = {duration:g} s / {dt:g} s = {ratio:.3g} steps, more "
            f"than a run can count (2^53 = {MAX_STEPS:.3g}); shorten run.duration or raise "
            "run.dt",
        )
    if whole_steps(ratio) is None:
        below, above = int(np.floor(ratio)) or 1, int(np.ceil(ratio))
        r.fail(
            "run.duration",
            f"{duration:g} s is not a whole number of steps of run.dt = {dt:g} s (it is "
            f"{ratio:.6g} steps), so a fixed-step run cannot end at it; choose duration = "
            f"n * dt (e.g. {below * dt:.10g} or {above * dt:.10g} s) or a dt that divides it",
        )


def whole_steps(ratio: float) -> int | None:
    """round(ratio) when a ratio of times is a whole number (at least 1) of steps, to rounding;
    else None."""
    steps = round(ratio)
    return steps if steps >= 1 and abs(ratio - steps) <= _WHOLE_STEPS_RTOL * ratio else None
