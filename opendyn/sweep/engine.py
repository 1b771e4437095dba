"""Sweeps and Monte Carlo runs of a scene on a Dask cluster: one table row per run.

    runs = the specs' combinations or draws (opendyn.sweep.specs)
    row(run) = the run's values + simulate(scene with those values): status, stats, final
               state, metrics (opendyn.sim.metrics)

A key is a dotted scene key (`control.kp`, `initial.q.shoulder_pan_joint`, `run.dt`,
`robot.payload.mass`), set in the base scene as opendyn.io.scene.variants describes.

Every run's scene is read (and so checked) before anything runs: a bad key or value is a
SweepError naming the run, its values and the key, with the valid keys. What simulate itself
refuses or stops on (a step too large for contact, an initial state outside enforced limits, a
state that blows up) is a failed row, and the other runs go on.

The runs go to the workers of a Dask cluster in chunks (tasks of at least TASK_MIN_S of work,
not one tiny task per short run): a local cluster of worker processes by default, or any cluster
through its Client. On a worker, a chunk's runs of one compiled step go as one rollout
(opendyn.sim.rollout: one compiled loop, each run what simulate gives it, bit for bit), so that
the worker spends its time integrating. A worker that dies has its chunk rerun elsewhere (Dask's retries); a chunk that keeps
killing workers is split and each of its runs retried alone, and a run that still kills its
worker is a failed row. The workers rebuild each run's scene from the base scene's settings and
the run's values (each worker loads a robot's URDF once), and load the compiled kernels from
the cache, which the client fills before the first task (`opendyn compile` prepares the workers
of a cluster that does not share the client's disk).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import math
import os
import pathlib
import pickle
import re
import sys
import time

import numpy as np

from .._runtime.files import atomic_write, name_too_long, unwritable
from .._runtime.options import flag
from .._runtime.signals import unswallowed_interrupt
from .._runtime.version import __version__
from ..api import as_scene
from ..errors import SceneError, SweepError, SweepInterrupted, SweepWriteError
from ..io.scene.variants import Variants
from ..sim.driver import integrator_of
from ..sim.effects import python_control, registry
from ..sim.metrics import METRICS, applicable
from ..sim.scene import Scene
from .cluster import LocalOrGiven
from .results import Unwritten, written
from .specs import check_whole, combinations, parse_axis, spans_decades
from .worker import failed_row, run_chunk

READ_QUIETLY = 10_000  # runs whose scenes are read without a progress bar (about 2 s)
# A task is a chunk of runs rolled out together on a worker. Chunks are cut into about
# CHUNKS_PER_WORKER per worker, each of at least TASK_MIN_S of work (estimated from a short run
# on the client), so that the scheduler is never what limits a large cluster (64 workers need
# at most 640 tasks a second), and at most TASK_MAX_S and MAX_CHUNK runs, so that progress,
# Ctrl-C, a lost worker and the last task's wait cost little.
MAX_CHUNK = 1000
CHUNKS_PER_WORKER = 8
TASK_MIN_S = 0.1
TASK_MAX_S = 0.5
EXTRA_HINT = "pip install 'opendyn[sweep]' (dask[distributed] and pyarrow)"


def check_installed():
    """Raise ImportError, saying what to install, without dask.distributed or pyarrow."""
    missing = [m for m in ("distributed", "pyarrow") if importlib.util.find_spec(m) is None]
    if missing:
        raise ImportError(f"sweeps need {' and '.join(missing)}: {EXTRA_HINT}")


def check_runs(base: Variants, runs, progress=False) -> list[Scene]:
    """Read every run's scene (SceneError -> SweepError naming the run and its values), the
    first scene of each distinct step (integrator, effects, constraints, base) returned, in
    order, for compiling ahead; and the union of the metrics that apply, in METRICS order.
    With progress, a bar (on stderr) over the runs when there are more than READ_QUIETLY."""
    from tqdm import tqdm

    firsts, metrics = {}, set()
    shown = progress and len(runs) > READ_QUIETLY
    bar = tqdm(runs, desc="reading the runs' scenes", unit="run", file=sys.stderr,
               disable=not shown or None, leave=False)
    for run, values in enumerate(bar):
        try:
            scene = base.scene_for(values)
        except SceneError as e:
            raise SweepError(f"run {run} ({_describe(values)}): {e}") from None
        step = (scene.run.integrator, scene.effects, bool(scene.constraints), scene.model.nq)
        firsts.setdefault(step, scene)
        metrics.update(applicable(scene))
    return list(firsts.values()), tuple(m for m in METRICS if m in metrics)


def _describe(values) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in values.items())


# --- the sweep ----------------------------------------------------------------------------------


def sweep(
    scene,
    vary,
    samples=None,
    seed=0,
    client=None,
    outputs=None,
    *,
    parquet=None,
    trajectories=None,
    workers=None,
    chunk_size=None,
    progress=False,
):
    """Run `scene` once per combination of the varied keys, on a Dask cluster; returns the
    results, one row per run, as a pyarrow Table sorted by run (needs the extra `sweep`:
    dask[distributed] and pyarrow).

    scene: a Scene, or a scene file or shipped scene's name.
    vary: {dotted key: spec}, spec a list of values or a string: 'a,b,c', a grid 'lo:hi:n' or
      'log:lo:hi:n', or a distribution 'uniform:lo:hi' or 'normal:mu:sigma' (needs samples).
    samples: None for every combination of the lists and grids; N for N random runs, each key
      drawn on its own (seeded by `seed`).
    client: a dask.distributed Client of the cluster to run on, or its scheduler's address
      ('tcp://HOST:PORT', connected for the sweep, as `opendyn sweep --scheduler`); None
      starts a local cluster of `workers` worker processes (default: one per core) for it.
    outputs: names of opendyn.sim.metrics.METRICS to compute for every run; None: every metric
      that applies to some run's scene.
    parquet: a Parquet file the rows are written to as they arrive (parts in the folder
      PARQUET.parts until the sweep ends, then one file); if it holds rows of the same sweep,
      those runs are skipped (a sweep stopped by Ctrl-C or a lost client resumes), and if it
      holds another sweep's rows, SweepError. None: rows only in the returned table.
    trajectories: a folder to save each run's trajectory in (run-NNNNNN.npz and .json).
    chunk_size: runs per task; default: about CHUNKS_PER_WORKER tasks a worker, each of
      TASK_MIN_S to TASK_MAX_S of work as a short run on this machine estimates it, at most
      MAX_CHUNK runs.
    progress: show a progress bar (on stderr) with the complete and failed counts.

    Columns: run (its index), one per varied key (named by the key), status ('complete' or
    'failed'), message (the failure's cause as simulate states it), warnings (the scene's
    warnings), simulated_s and wall_s (s; the run's share of its chunk's rollout, by its
    dynamics evaluations), steps, rejected_steps, evaluations, one column per
    metric, q_final (nq,) and qd_final (nv,), the last sample. A Ctrl-C stops the sweep after
    saving the rows that arrived, raising SweepInterrupted (a KeyboardInterrupt) with the
    table of every row saved.
    """
    check_installed()
    from .results import Results

    progress = flag(progress, "sweep: progress")
    scene = as_scene(scene)
    if not isinstance(vary, dict) or not vary:
        raise SweepError("vary: expected a dict {dotted scene key: spec} with at least one key")
    check_whole(seed, "seed", 0)
    if chunk_size is not None:
        check_whole(chunk_size, "chunk_size (--chunk)", 1)
    _check_outputs(parquet, trajectories)
    cluster = LocalOrGiven(client, workers)
    axes = [parse_axis(key, spec) for key, spec in vary.items()]
    runs = combinations(axes, samples, seed)
    base = Variants.of(scene)
    firsts, metrics = check_runs(base, runs, progress)
    outputs = _outputs(outputs, metrics)
    record = {
        "scene": base.settings,
        "source": base.source,
        "vary": {a.key: a.spec for a in axes},
        "log": [a.key for a in axes if a.log or spans_decades(a.values)],
        "samples": samples,
        "seed": seed,
        "outputs": list(outputs),
        # the robot itself: a URDF edited between a stopped sweep and its resume is another
        # sweep, not rows of two robots in one table
        "robot": hashlib.sha1(
            scene.model._ibuf.tobytes() + scene.model._fbuf.tobytes()
        ).hexdigest()[:16],
        # and what the scene read from it: coefficients = "urdf" takes the URDF's damping
        "effects": _effects_digest(scene),
        # and the Python controller's code: a gain edited in its file is another sweep too
        "controller": _controller_digest(scene),
    }
    record["fingerprint"] = hashlib.sha1(
        json.dumps(record, sort_keys=True, default=str).encode()
    ).hexdigest()[:16]
    record["name"], record["opendyn"] = scene.name, __version__
    results = Results(parquet, record, axes, runs, outputs)
    todo = [(run, values) for run, values in enumerate(runs) if run not in results.finished]
    try:
        try:
            if todo:
                runnable = _runnable(firsts)
                with unswallowed_interrupt():
                    _compile(runnable, progress)
                    run_s = _run_seconds(runnable)
                if trajectories is not None:
                    _claim(trajectories, record)
                with cluster as dask_client:
                    workers = max(1, len(dask_client.scheduler_info(n_workers=-1)["workers"]))
                    size = chunk_size or chunk_runs(len(todo), workers, run_s)
                    _execute(
                        dask_client, base, todo, outputs, trajectories, results, size, progress
                    )
        except KeyboardInterrupt:
            raise SweepInterrupted(results.close()) from None
        return results.close()
    except Unwritten as e:
        raise _stopped_writing(e, results) from None
    finally:
        results.release()


def _stopped_writing(unwritten, results):
    """The SweepWriteError of a sweep that could not write `unwritten.path`: the file, why,
    and where the rows that arrived before are kept."""
    table = results.table()
    rows = f"{table.num_rows} row{'s' if table.num_rows != 1 else ''}"
    if results.path is None:
        kept = f"the {rows} so far are in this error's table (no results file was named)"
    else:
        where = " and ".join(str(f) for f in (results.path, results.parts) if f.exists())
        kept = (
            f"the {rows} so far are kept in {where or 'no file'}, and the same sweep resumes "
            "from them once the file can be written"
        )
    e = unwritten.error
    return SweepWriteError(
        f"{unwritten.path}: {e.strerror or e}; the sweep stopped there: {kept}",
        e.errno, e.strerror, str(unwritten.path), table,
    )


def _controller_digest(scene) -> str | None:
    """A digest of the source of the scene's Python controller ([control] type = "python": the
    file of "FILE.py:NAME", the module file of "MODULE:NAME"), or None without one."""
    control = python_control.record(scene)
    if control is None:
        return None
    where, _ = python_control.function_parts(control.function)
    path = where
    if not where.endswith(".py"):
        try:
            spec = importlib.util.find_spec(where)
        except (ImportError, ValueError):
            spec = None
        path = getattr(spec, "origin", None)
    try:
        source = pathlib.Path(path).read_bytes()
    except (OSError, TypeError):  # a built-in module, or one that is not a file
        source = control.function.encode()
    return hashlib.sha1(source).hexdigest()[:16]


def _effects_digest(scene) -> str:
    """A digest of the values of every effect the scene names, as it resolved them (its
    records: the URDF's damping or limits where the scene says "urdf"), so that a URDF edited
    between a stopped sweep and its resume is another sweep."""
    digest = hashlib.sha1()
    for effect in registry.EFFECTS:
        record = effect.record(scene)
        try:
            digest.update(pickle.dumps(record))
        except (pickle.PicklingError, TypeError, AttributeError):  # a lambda controller
            digest.update(re.sub(r" at 0x[0-9a-f]+", "", repr(record)).encode())
    return digest.hexdigest()[:16]


def _check_outputs(parquet, trajectories):
    """SweepError naming the argument when the results file or the trajectories' folder cannot
    be written, before anything runs."""
    for name, value in (("parquet", parquet), ("trajectories", trajectories)):
        if value is not None and not isinstance(value, (str, os.PathLike)):
            raise TypeError(
                f"{name} must be a path (a str or pathlib.Path), got {type(value).__name__} "
                f"{value!r}"
            )
    if parquet is not None:
        path = pathlib.Path(parquet)
        if path.suffix.lower() not in ("", ".parquet", ".pq"):
            raise SweepError(
                f"parquet (-o) {str(parquet)!r}: a sweep's results are a Parquet table; name "
                f"a .parquet file (not {path.suffix})"
            )
        problem = unwritable(str(parquet), path)
        parts = path.with_name(path.name + ".parts")  # opendyn.sweep.results
        if problem is None and name_too_long(parts) is not None:
            problem = f"its folder of parts {parts.name}: {name_too_long(parts)}"
        if problem is not None:
            raise SweepError(f"parquet {str(parquet)!r}: {problem}")
    if trajectories is not None:
        folder = pathlib.Path(trajectories)
        if folder.exists() and not folder.is_dir():
            raise SweepError(f"trajectories {str(trajectories)!r}: is a file, not a folder")
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise SweepError(
                f"trajectories {str(trajectories)!r}: the folder cannot be made ({e.strerror})"
            ) from None
        probe = folder / "run-000000.npz"
        problem = unwritable(str(probe), probe)
        if problem is not None:
            raise SweepError(f"trajectories {str(trajectories)!r}: {problem}")


def _claim(trajectories, record):
    """Mark the trajectories' folder as this sweep's (its sweep.json: name, source and
    fingerprint); SweepError when it holds another sweep's runs, whose files would be
    overwritten and mixed with these."""
    folder = pathlib.Path(trajectories)
    mark = folder / "sweep.json"
    ours = {k: record[k] for k in ("name", "source", "fingerprint")}
    if mark.is_file():
        try:
            theirs = json.loads(mark.read_text())
        except (OSError, ValueError):
            theirs = {}
        if theirs.get("fingerprint") == record["fingerprint"]:
            return  # the same sweep, resumed
        raise SweepError(
            f"trajectories {str(trajectories)!r}: the folder holds the runs of another sweep "
            f"({theirs.get('name', 'unnamed')!r}, see its sweep.json); choose another folder, "
            "or empty it"
        )
    if any(folder.glob("run-*.npz")):
        raise SweepError(
            f"trajectories {str(trajectories)!r}: the folder holds run files of a sweep that "
            "did not mark it; choose another folder, or empty it"
        )
    with written(mark), atomic_write(mark) as f:
        f.write(json.dumps(ours, indent=1).encode())


def _outputs(outputs, metrics) -> tuple[str, ...]:
    if outputs is None:
        return metrics
    names = (outputs,) if isinstance(outputs, str) else tuple(outputs)
    for name in names:
        if name not in METRICS:
            raise SweepError(f"outputs: unknown metric {name!r}; metrics: {', '.join(METRICS)}")
        if name not in metrics:
            raise SweepError(
                f"outputs: {name!r} applies to no run of this sweep ({METRICS[name][0]}); "
                f"those that apply: {', '.join(metrics)}"
            )
    return names


def _runnable(scenes):
    """The scenes whose step simulate takes: a step it refuses (semi-implicit Euler with
    constraints) compiles nothing, and its runs are failed rows."""
    runnable = []
    for scene in scenes:
        try:
            integrator_of(scene)
        except SceneError:
            continue
        runnable.append(scene)
    return runnable


def _compile(scenes, progress):
    """Compile (or load from the cache) each distinct step before the workers start, so that
    they load it rather than each compile it: one step of each scene, rolled out (a scene with
    a Python controller, which only simulate runs, simulated). The compile notice says so only
    when something compiles."""
    from .._runtime.compile_notice import compiling, quiet
    from ..sim.rollout import rollout
    from ..sim.simulate import simulate

    with contextlib.nullcontext() if progress else quiet():
        with compiling(f"{len(scenes)} steps ahead of time", len(scenes), "20-80 s each") as done:
            for scene in scenes:
                run = scene.run
                one_step = scene.replace_run(duration=run.dt, output_dt=run.dt)
                if python_control.record(scene) is None:
                    rollout(one_step, threads=1)
                else:
                    simulate(one_step)
                done()


def _run_seconds(scenes):
    """The estimated wall time (s) of one run on one core: each distinct step's wall time per
    simulated second, the difference of two short rollouts on this machine (100 and 500 steps,
    or at most the run), times its duration; their mean."""
    from ..sim.rollout import rollout

    estimates = []
    for scene in scenes:
        run = scene.run
        if python_control.record(scene) is not None:
            continue
        spans = sorted({min(run.duration, 100 * run.dt), min(run.duration, 500 * run.dt)})
        walls = []
        for span in spans:
            result = rollout(scene.replace_run(duration=span, output_dt=span), threads=1,
                             record="final")
            walls.append(result.stats["wall_s"] if result.complete[0] else 0.0)
        if len(spans) == 2 and walls[1] > walls[0]:
            estimates.append((walls[1] - walls[0]) / (spans[1] - spans[0]) * run.duration)
        elif walls[-1] > 0:
            estimates.append(walls[-1] / spans[-1] * run.duration)
    return float(np.mean(estimates)) if estimates else 0.0


def chunk_runs(n, workers, run_s):
    """Runs per task for n runs on `workers` workers, each run about run_s seconds: about
    CHUNKS_PER_WORKER tasks a worker, each of TASK_MIN_S to TASK_MAX_S of work, at most
    MAX_CHUNK runs."""
    balanced = -(-n // (workers * CHUNKS_PER_WORKER))
    if run_s <= 0:
        return max(1, min(MAX_CHUNK, balanced))
    least, most = math.ceil(TASK_MIN_S / run_s), max(1, math.floor(TASK_MAX_S / run_s))
    return max(1, min(MAX_CHUNK, max(least, min(balanced, most))))


def _execute(client, base, todo, outputs, folder, results, size, progress):
    """Send `todo` [(run, values)] to the cluster in chunks of `size` runs and hand each
    chunk's rows to `results` as it arrives; a chunk lost with its workers is split and its
    runs retried alone."""
    from dask.distributed import as_completed
    from tqdm import tqdm

    keep = folder is not None

    def submit(chunk):
        future = client.submit(run_chunk, base, chunk, outputs, keep, __version__, pure=False)
        pending[future] = chunk
        return future

    pending = {}
    done = as_completed([submit(todo[i : i + size]) for i in range(0, len(todo), size)])
    bar = tqdm(
        total=len(results.finished) + len(todo),
        initial=len(results.finished),
        unit="run",
        desc="sweep",
        file=sys.stderr,
        disable=not progress or None,
        smoothing=0.1,
    )
    start = time.perf_counter()
    try:
        for future in done:
            chunk = pending.pop(future)
            try:
                pairs = future.result()
            except Exception as e:  # the chunk's workers died: retry its runs one by one
                if len(chunk) > 1:
                    for item in chunk:
                        done.add(submit([item]))
                    continue
                run, values = chunk[0]
                pairs = [(failed_row(run, values, f"its worker was lost: {e}"), None)]
            for row, traj in pairs:
                if traj is not None:
                    path = os.path.join(folder, f"run-{row['run']:06d}.npz")
                    with written(path):
                        traj.save(path)
            results.add([row for row, _ in pairs])
            bar.update(len(pairs))
            bar.set_postfix_str(f"{results.complete} complete, {results.failed} failed")
    except BaseException:
        client.cancel(list(pending))
        raise
    finally:
        bar.close()
        results.wall_s = time.perf_counter() - start
