"""od.rollout: N runs of one scene in compiled loops spread over the cores, no Python per run or
per step.

    rollout(scene, q0 (N, nq), qd0 (N, nv), params {key: (N,) or (N, k)}) -> RolloutResult

Run i is simulate(scene_i), bit for bit, where scene_i is the scene with run i's params set (as
a scene file with those values would be read: opendyn.io.scene.variants, which od.rollout passes
as `vary`) and its initial state
replaced by q0[i], qd0[i]. Only the state: a PD setpoint that the scene takes from its
initial.q stays the scene's.

How it runs:
  - each run's scene is read and checked in Python, as simulate checks one before it starts
    (its initial state, its contact step: a run simulate would refuse is a failed run); what it
    changes in the compiled step (the model's inertias, the effects' parameters, armature,
    constraints) is packed into a RunData, one shared by all runs when nothing but the initial
    states varies;
  - the runs go in blocks to `threads` threads, each calling one compiled loop
    (opendyn.sim.rollout_loops) on a slice of the block; the loops release the GIL, and the
    next block is read while one runs;
  - every run has the same compiled step (the same integrator, run settings and kinds of
    effects: params may not change them; a sweep groups runs that do) and its own steps;
  - a scene with a hard model (opendyn.sim.hard) keeps its solve's warm start from step to
    step in a HardRoom: each call of the loop has its own, and each run restarts it, so that
    a run gives what simulate gives whichever thread ran it and whatever ran before it. A run
    keeps its solve's statistics (RolloutResult.unconverged_steps, worst_residual), not the
    per-sample log of contacts, forces and iterations that simulate's trajectory holds.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import os
import sys
import time
import warnings
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._runtime.arrays import immutable
from .._runtime.memory import available_memory
from .._runtime.options import flag, whole
from .._runtime.signals import signal_name
from ..algorithm.checks import as_float_array
from ..algorithm.configuration import check_unit_quaternions
from ..errors import RolloutInterrupted, SceneError, SceneWarning
from . import effects, integrators
from .diagnostics import check_contact_step, failure_message
from .driver import (
    READY_PIECES,
    Interrupt,
    Stepper,
    error_size_index,
    free_joints,
    getting_ready,
    integrator_of,
    step_name,
)
from .effects import python_control
from .preflight import byte_size, check_start, run_size, sample_numbers
from .rollout_loops import (
    Batch,
    Outcome,
    RunData,
    push_run,
    rollout_adaptive,
    rollout_fixed,
    run_list,
)
from .rollout_result import COMPLETE, FAILED, INTERRUPTED, RolloutResult
from .step import scene_data

RECORDS = ("samples", "final")
_BLOCK_SECONDS = 0.5  # wall time of a block of runs: progress and Ctrl-C granularity
_MAX_BLOCK = 4096  # runs read ahead at most (their RunData stay in memory while they run)
# what a rollout's batch loop (rollout_loops) compiles once the step it calls has: 3.4-4.4 s on
# a 2-core machine (docs/performance/startup.md, a rollout after a plain run of its scene)
BATCH_LOOP_SECONDS = 5
_SLICES_PER_THREAD = 4  # a block's slices per thread, so that a thread that ends early helps


def rollout(scene, q0=None, qd0=None, params=None, threads=None, record="samples", *,
            progress=False, vary=None):
    """N runs of `scene`, a Scene, in compiled loops over the cores; returns a
    RolloutResult: the driver of od.rollout (opendyn.api.rollout), which documents the
    arguments and also takes a scene file or a shipped scene's name. vary: run i's values
    {dotted key: value} -> its Scene, read as a scene file with those values would be
    (opendyn.io.scene.variants.Variants.scene_for); needed when params is given."""
    progress = flag(progress, "rollout: progress")
    if python_control.record(scene) is not None:
        raise SceneError(
            f"{scene.source}: control.type: a Python controller runs in Python at every control "
            "period; rollout runs compiled scenes only (use od.simulate or od.Simulator)"
        )
    if record not in RECORDS:
        raise ValueError(f"rollout: record must be 'samples' or 'final', got {record!r}")
    return run_batch(Runs.of(scene, q0, qd0, params, vary), _threads(threads), record, progress)


class Runs:
    """The runs of a batch: how many, run i's values, its scene and stage table, and whether
    they share one RunData (only their initial states differ)."""

    def __init__(self, scene, n, values, scene_and_table, shared):
        self.scene, self.n, self.shared = scene, n, shared
        self._values, self._scene_and_table = values, scene_and_table

    @classmethod
    def of(cls, scene, q0=None, qd0=None, params=None, vary=None):
        """The runs od.rollout describes (arguments checked: TypeError or ValueError naming the
        argument, SceneError naming a key that does not fit the scene); vary(values) -> run
        i's Scene with its params set (rollout's `vary`)."""
        model = scene.model
        params = _params(params)
        _check_state_keys(params, q0, qd0)
        bad = {}  # {run: why its q0 or qd0 row cannot start it}: a failed run
        q0 = None if q0 is None else _states(model, q0, "q0", model.nq, bad)
        qd0 = None if qd0 is None else _states(model, qd0, "qd0", model.nv, bad)
        n = _count(q0, qd0, params)
        shared = not params and not scene.constraints
        table = effects.stage_table(scene) if shared else None

        def values(i):
            return {key: _plain(v[i]) for key, v in params.items()}

        def scene_of(i):
            if i in bad:
                raise SceneError(bad[i])
            run_scene = vary(values(i)) if params else scene
            changes = {}
            if q0 is not None:
                changes["q0"] = immutable(q0[i])
            if qd0 is not None:
                changes["qd0"] = immutable(qd0[i])
            return dataclasses.replace(run_scene, **changes) if changes else run_scene

        def scene_and_table(i):
            run_scene = scene_of(i)
            return run_scene, table if shared else effects.stage_table(run_scene)

        # with params, run 0's scene (with the scene's initial state) stands for the batch's
        # step, and a key that does not fit the scene is a SceneError now, not N times
        first = vary(values(0)) if params else scene
        return cls(first, n, values, scene_and_table, shared)

    @classmethod
    def of_scenes(cls, scenes, tables, values):
        """Runs of given scenes with their stage tables (one compiled step) and their values
        [{key: value}]."""
        return cls(
            scenes[0], len(scenes), values.__getitem__, lambda i: (scenes[i], tables[i]), False
        )

    def values(self, i):
        """Run i's values {key: value}."""
        return self._values(i)

    def scene_for(self, i):
        """Run i's scene."""
        return self._scene_and_table(i)[0]

    def scene_and_table(self, i):
        """(scene, stage table) of run i."""
        return self._scene_and_table(i)


def run_batch(runs, threads, keep, progress=False):
    """Run every run of `runs` (Runs) on `threads` threads, keeping "samples" or "final";
    returns the RolloutResult (RolloutInterrupted on Ctrl-C)."""
    scene = runs.scene
    model = scene.model
    integ = integrator_of(scene)
    nsteps, every, rows = run_size(scene, integ)
    n, K = runs.n, rows if keep == "samples" else 1
    _check_memory(scene, n, K)
    # NaN until a run starts: a run refused or never started has no last state
    x = integrators.State(
        np.full((n, model.nq), np.nan), np.full((n, model.nv), np.nan), np.full((n, 2), np.nan)
    )
    # the record is written by the runs and its rows past each run's end set to NaN when its
    # block closes (_close): filling it with NaN first cost 1.0 s of 10 for 1,000 UR5 runs
    # every step (336 MB, one thread), where the runs' threads write it anyway
    out = integrators.Record(
        np.empty((n, K)), np.empty((n, K, model.nq)), np.empty((n, K, model.nv)),
        np.empty((n, K, model.nv)), np.empty((n, K, 2)), None,
    )
    counters = np.zeros((n, 3), dtype=np.int64)
    outcome = Outcome(
        np.zeros(n, np.int64), np.zeros(n, np.int64), np.full(n, np.nan),
        np.full((n, model.nv), np.nan), np.zeros((n, 2)),
    )
    notes = (np.full(n, INTERRUPTED, dtype="<U11"), [""] * n, [""] * n)
    which = np.full(n, -1, dtype=np.int64)
    arrays = (x, out, counters, outcome)
    loop = _Loop(runs, integ, every if keep == "samples" else max(1, nsteps), nsteps, arrays)
    kind = signature(loop.first)
    size = min(n, threads * _SLICES_PER_THREAD)
    # one compile notice for the first block's start checks, the step and record that
    # simulate compiles for the scene (loaded, after a plain run of it), and the batch loop
    with getting_ready(loop.name(), runs.scene, pieces=READY_PIECES + 1) as ready:
        block = _prepare(runs, range(size), which, x, notes, kind)
        ready.done()
        loop.load_step(ready.done)
        ready.estimate = f"about {BATCH_LOOP_SECONDS} s"  # what is left to compile
        loop.load(block)
        ready.done()
    bar = _bar(n) if progress else None
    prepare_s, start = 0.0, time.perf_counter()
    with Interrupt() as stop, ThreadPoolExecutor(threads, "opendyn-rollout") as pool:
        # two blocks in flight: the next block's slices queue behind this one's, so that no
        # thread waits at a block's end; a block is read while the one before it runs
        pending, last_done = collections.deque(), start
        while block is not None or pending:
            if block is not None:
                step = max(1, len(block.range) // (threads * _SLICES_PER_THREAD))
                futures = [
                    pool.submit(loop, block, a, min(a + step, block.range.stop))
                    for a in range(block.range.start, block.range.stop, step)
                ]
                pending.append((block, futures, time.perf_counter()))
                end, block = block.range.stop, None
                if end < n and not stop.requested:
                    tic = time.perf_counter()
                    block = _prepare(
                        runs, range(end, min(n, end + size)), which, x, notes, kind
                    )
                    prepare_s += time.perf_counter() - tic
            if block is None or len(pending) > 1:
                done, futures, submitted = pending.popleft()
                for f in futures:
                    f.result()
                _close(done, keep, x, out, outcome, counters, notes)
                if bar is not None:
                    bar.update(len(done.range))
                now = time.perf_counter()
                size = _next_size(size, len(done.range), now - max(submitted, last_done), threads)
                last_done = now
            if stop.requested:
                block = None
    wall = time.perf_counter() - start
    if bar is not None:
        bar.close()
    result = RolloutResult(
        runs, integ, keep, (x, out), outcome, counters, notes,
        _stats(integ, n, threads, wall, prepare_s, ready.compile_s, ready.load_s),
    )
    if stop.requested:
        reason = f"interrupted ({signal_name(stop.signum)}) before it started"
        never = np.flatnonzero(notes[0] == INTERRUPTED)
        for i in never:
            notes[1][i] = reason
        x.q[never], x.qd[never], x.w[never] = np.nan, np.nan, np.nan  # read, but not run
        _nan_past_rows(out, outcome.rows, never)
        raise RolloutInterrupted(result)
    return result


class _Loop:
    """The compiled loop of a batch's integrator, called on slices of a block's runs:
    loop(block, start, stop), each call with its own scratch (a SceneData of the scene, with
    its own copy of the hard model's HardTable, whose room the slice's runs use in turn)."""

    def __init__(self, runs, integ, every, nsteps, arrays):
        scene = runs.scene
        run = scene.run
        self.scene, self.integ, self.arrays = scene, integ, arrays
        self.table = table = effects.stage_table(scene)
        self.first = run_data(scene, table)
        free = free_joints(scene.model)
        if integ.adaptive:
            settings = integrators.AdaptiveSettings(
                t0=0.0, t_end=run.duration, rtol=run.rtol, atol=run.atol,
                output_dt=run.output_dt, max_speed=run.max_speed,
                size_index=error_size_index(scene.model), t_land=math.inf,
                max_steps=integrators.ALL_STEPS,  # a run is whole: the batch's chunks are runs
            )
            at = integrators.Progress(0.0, run.dt, 1)
            self.kernel, self.head = rollout_adaptive, (integ.tableau(), settings, at)
        else:
            settings = integrators.FixedSettings(0.0, run.dt, every, run.max_speed)
            self.kernel, self.head = rollout_fixed, (integ.switches(), settings, nsteps)
        self.free = free

    def __call__(self, block, start, stop):
        """Runs start..stop-1 of the block. Every array the runs read is the call's own copy:
        threads that share an array contend for its reference count at every compiled call
        (measured on the UR5, 2 threads ran 1.4x one thread's runs per second sharing them,
        1.8x with copies)."""
        which, index = np.full(stop - start, -1, np.int64), {}
        for k, e in enumerate(block.which[start:stop]):
            if e >= 0:
                index.setdefault(e, len(index))
                which[k] = index[e]
        # no run to do: numba still wants the List's type
        items = [_private(block.data[e]) for e in index] or [_private(self.first)]
        entries = run_list(items[0])
        for item in items[1:]:
            push_run(entries, item)
        switch, settings, last = _private(self.head)
        base = scene_data(self.scene.model, self.table)
        base = base._replace(ibuf=base.ibuf.copy(), hard=_private(base.hard))
        batch = Batch(entries, which, *self.arrays)
        self.kernel(switch, base, settings, last, batch, _private(self.free), start, stop)

    def name(self):
        """The compile notice's words for this loop."""
        return step_name(self.integ, self.table, "rollout loop")

    def load_step(self, done):
        """What simulate compiles for the run's scene (driver.Stepper.load), so that a rollout
        after a plain run of it compiles its batch loop alone."""
        scene = self.scene
        x = integrators.State(
            np.array(scene.q0, dtype=np.float64), np.array(scene.qd0, dtype=np.float64),
            np.zeros(2),
        )
        Stepper(scene, self.table, self.integ).load(x, done)

    def load(self, block):
        """Compile or load the loop for the block's RunData type before the clock starts."""
        self(block, 0, 0)


@dataclasses.dataclass
class _Block:
    """A block of runs read ahead: their range, the RunData of its runs (data) and each run's
    index in it (which (N,) int64, the batch's; -1 for a run refused), and each run's (scene,
    table) while it runs (for a failure's message)."""

    range: range
    data: list
    which: np.ndarray
    scenes: dict


def _prepare(runs, block, which, x, notes, kind):
    """Read and check the runs of `block` (a range): each run's initial state into x, its
    RunData into the block's data (which[i] its index), or, for a run simulate would refuse,
    status failed with the reason (which[i] = -1). kind: the batch's RunData signature, which
    every run's must match."""
    data, scenes = [], {}
    for i in block:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", SceneWarning)
                scene, table = runs.scene_and_table(i)
                check_start(scene)
                check_contact_step(scene, table)
            notes[2][i] = "; ".join(str(w.message) for w in caught)
            if not runs.shared or not data:
                data.append(_checked_run_data(runs.scene, scene, table, kind))
        except SceneError as e:
            notes[0][i], notes[1][i] = FAILED, str(e)
            continue
        which[i] = len(data) - 1
        x.q[i], x.qd[i], x.w[i] = scene.q0, scene.qd0, 0.0
        scenes[i] = (scene, table)
    return _Block(block, data, which, scenes)


def run_data(scene, table):
    """The RunData of a run's scene and its stage table: its hard model's HardTable without
    its room (the loop's call lends it one: rollout_loops.run_hard)."""
    hard = None if table.hard is None else table.hard._replace(room=None)
    return RunData(scene.model._fbuf, table.effects, table.armature, table.constraints, hard)


def _checked_run_data(first, scene, table, kind):
    """The RunData of a run's scene; SceneError when its compiled step differs from the
    batch's (the first run's scene, whose RunData has the signature `kind`)."""
    entry = run_data(scene, table)
    if not np.array_equal(scene.model._ibuf, first.model._ibuf) or signature(entry) != kind:
        raise SceneError(
            f"{scene.source}: its step compiles differently from the batch's first run (its "
            "robot's structure or the kinds of its effects differ); vary such keys with "
            "od.sweep"
        )
    return entry


def signature(x):
    """What numba compiles for x, in brief: each array's dtype, dimensions and flags, the
    structure of the tuples, None and the other values' types."""
    if isinstance(x, np.ndarray):
        return (x.dtype.str, x.ndim, x.flags.c_contiguous, x.flags.writeable)
    if isinstance(x, tuple):
        return (type(x).__name__, tuple(signature(v) for v in x))
    return None if x is None else type(x).__name__


def _private(x):
    """x with every array in it (through tuples and namedtuples) copied."""
    if isinstance(x, np.ndarray):
        return x.copy()
    if isinstance(x, tuple):
        items = [_private(v) for v in x]
        return type(x)(*items) if hasattr(x, "_fields") else tuple(items)
    return x


def _close(block, keep, x, out, outcome, counters, notes):
    """The block's runs done: their status and message (failure_message for a failed run); with
    keep "final" their last state as their one row; NaN in the rows a run did not record."""
    for i, (scene, table) in block.scenes.items():
        status = int(outcome.status[i])
        notes[0][i] = COMPLETE if status == 0 else FAILED
        if status:
            t, steps = float(outcome.t[i]), int(counters[i, 1])
            notes[1][i] = failure_message(scene, table, status, t, steps, x.q[i], x.qd[i])
    if keep == "final":
        ran = np.array(sorted(block.scenes), dtype=np.int64)
        out.t[ran, 0], out.q[ran, 0], out.qd[ran, 0] = outcome.t[ran], x.q[ran], x.qd[ran]
        out.tau[ran, 0], out.w[ran, 0] = outcome.tau[ran], x.w[ran]
        outcome.rows[ran] = 1
    _nan_past_rows(out, outcome.rows, block.range)


def _nan_past_rows(out, rows, runs):
    """NaN in the rows of the Record out that runs (indices) did not record: row rows[i] on of
    run i (every row of a run refused or never started, rows[i] = 0)."""
    for i in runs:
        r = int(rows[i])
        if r < out.t.shape[1]:
            for array in out:
                if array is not None:  # a rollout keeps no hard log (Record.hard)
                    array[i, r:] = np.nan


def _next_size(size, done, seconds, threads):
    """Runs in the next block: about _BLOCK_SECONDS of work at the rate just measured."""
    rate = done / seconds if seconds > 0 else math.inf
    target = rate * _BLOCK_SECONDS
    return int(min(_MAX_BLOCK, max(threads * _SLICES_PER_THREAD, min(size * 8, target))))


def _stats(integ, n, threads, wall, prepare_s, compile_s, load_s):
    return {
        "integrator": integ.name,
        "runs": n,
        "threads": threads,
        "wall_s": wall,
        "prepare_s": prepare_s,
        "compile_s": compile_s,
        "load_s": load_s,
    }


def _check_memory(scene, n, rows):
    """Refuse a batch whose arrays would not fit in the memory available now."""
    model = scene.model
    per_row = sample_numbers(scene)
    need = 8.0 * n * (rows * per_row + 2 * model.nq + 3 * model.nv + 8)
    room = available_memory()
    if room is not None and need > room[0]:
        have, what = room
        raise ValueError(
            f"rollout: {n} runs of {rows} rows of {per_row} numbers need about {byte_size(need)}, "
            f"more than the {byte_size(have)} that {what} leaves; record='final' keeps only "
            "each run's last state, or raise run.output_dt, or roll out fewer runs at a time"
        )


def _bar(n):
    from tqdm import tqdm

    return tqdm(total=n, unit="run", delay=1.0, desc="rolling out", file=sys.stderr)


def _threads(threads):
    if threads is None:
        return os.cpu_count() or 1
    return whole(threads, "rollout: threads")


def _params(params):
    """params as {key: float64 array (N,) or (N, k)}, checked."""
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        raise TypeError(
            f"rollout: params must be a mapping {{dotted scene key: values}}, got "
            f"{type(params).__name__}"
        )
    checked = {}
    for key, values in params.items():
        if not isinstance(key, str):
            raise TypeError(f"rollout: params keys must be dotted scene keys, got {key!r}")
        if key.split(".")[0] == "run":
            raise ValueError(
                f"rollout: params[{key!r}]: the run settings are one for the whole batch (the "
                "steps and records of its runs); od.sweep varies them"
            )
        a = as_float_array(
            values,
            f"rollout: params[{key!r}]",
            "numbers (rollout varies numbers only, the keys that leave what is compiled as it "
            "is; od.sweep varies words and true/false)",
        )
        if a.ndim not in (1, 2) or not len(a):
            raise ValueError(
                f"rollout: params[{key!r}] must have shape (N,) or (N, k), got {a.shape}"
            )
        if not np.isfinite(a).all():
            run = int(np.flatnonzero(~np.isfinite(a.reshape(len(a), -1)).all(axis=1))[0])
            raise ValueError(f"rollout: params[{key!r}] of run {run} is not finite: {a[run]}")
        checked[key] = a
    return checked


# the scene keys that set part of the initial configuration, and of the initial velocity, which
# q0 and qd0 replace whole: [initial] and each object's pose and speed (objects.N.KEY)
_STATE_KEYS = {
    "q0": (("initial.q", "initial.base_position", "initial.base_orientation",
            "initial.base_rpy"), ("position", "orientation", "rpy")),
    "qd0": (("initial.qd", "initial.base_velocity", "initial.base_angular_velocity"),
            ("velocity", "angular_velocity")),
}


def _check_state_keys(params, q0, qd0):
    """Refuse a params key that sets part of the initial state q0 or qd0 replaces: one of the
    two would be dropped without a word."""
    for name, given in (("q0", q0), ("qd0", qd0)):
        if given is None:
            continue
        initial, of_object = _STATE_KEYS[name]
        for key in params:
            parts = key.split(".")
            if (
                any(key == k or key.startswith(k + ".") for k in initial)
                or (parts[0] == "objects" and len(parts) > 2 and parts[2] in of_object)
            ):
                raise ValueError(
                    f"rollout: params[{key!r}] sets part of the initial state that {name}= "
                    f"replaces whole; give the runs' states in {name} alone, or vary {key!r} "
                    f"without {name}="
                )


def _count(q0, qd0, params):
    """N from the checked arguments' lengths (ValueError when they disagree), 1 when none is
    given."""
    lengths = {name: len(a) for name, a in [("q0", q0), ("qd0", qd0)] if a is not None}
    lengths.update({f"params[{key!r}]": len(a) for key, a in params.items()})
    if len(set(lengths.values())) > 1:
        told = ", ".join(f"{name} has {k}" for name, k in lengths.items())
        raise ValueError(f"rollout: the runs' arguments disagree on N: {told}")
    n = next(iter(lengths.values()), 1)
    if n < 1:
        raise ValueError(f"rollout: no runs: {next(iter(lengths))} has no rows")
    return n


def _states(model, states, name, width, bad):
    """(N, width) float64 initial states; a row that is not finite or, in q0, whose floating
    base's quaternion is not a unit one, is put in bad {row: why} (its run fails)."""
    a = np.ascontiguousarray(as_float_array(states, f"rollout: {name}"))
    if a.ndim != 2 or a.shape[1] != width:
        raise ValueError(
            f"rollout: {name} must have shape (N, {width}) for {model.name!r}, got {a.shape}"
        )
    for i in np.flatnonzero(~np.isfinite(a).all(axis=1)):
        bad.setdefault(int(i), f"rollout: {name}[{i}] is not finite: {a[i]}")
    if name == "q0":
        try:
            check_unit_quaternions(model, a[np.isfinite(a).all(axis=1)], "q0", "rollout")
        except ValueError:  # which rows, and why each
            for i in range(len(a)):
                try:
                    if i not in bad:
                        check_unit_quaternions(model, a[i], f"q0[{i}]", "rollout")
                except ValueError as e:
                    bad[i] = str(e)
    return a


def _plain(v):
    """A run's value as a scene file holds it: a float, or a list of floats."""
    return float(v) if np.ndim(v) == 0 else [float(x) for x in v]
