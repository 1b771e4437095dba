"""A sweep's task on a worker: a chunk of runs, each row what simulate() gives for the run.

The runs of a chunk whose compiled step is the same (step_key) go together as one rollout
(opendyn.sim.rollout: one compiled loop, each run bit for bit what simulate gives it), so that
the worker spends its time integrating; a scene with a Python controller runs with simulate().
Anything a run raises is its failed row, and the other runs go on.
"""

from __future__ import annotations

import warnings

from .._runtime.version import __version__
from ..errors import SceneWarning
from ..io.scene.variants import Variants
from ..sim import effects
from ..sim.effects import python_control
from ..sim.metrics import run_metrics
from ..sim.rollout import Runs, run_batch, run_data, signature
from ..sim.simulate import simulate


def run_chunk(base: Variants, runs, outputs, keep_trajectories, version):
    """[(row, trajectory or None)] of the runs [(run, values)]: a worker's task. The runs whose
    compiled step is the same go together as one rollout (opendyn.sim.rollout), which gives
    each run what simulate() gives it; a scene with a Python controller runs with simulate().
    Anything a run raises is its failed row."""
    if version != __version__:
        message = f"the worker has opendyn {__version__}, the client {version}"
        return [(failed_row(run, values, message), None) for run, values in runs]
    pairs, groups = {}, {}
    for run, values in runs:
        try:
            scene = base.scene_for(values)
            if python_control.record(scene) is not None:
                pairs[run] = _simulated(run, values, scene, outputs, keep_trajectories)
                continue
            table = effects.stage_table(scene)
        except Exception as e:  # a run's failure is its row; the sweep goes on
            pairs[run] = failed_row(run, values, str(e) or type(e).__name__), None
            continue
        groups.setdefault(step_key(scene, table), []).append((run, values, scene, table))
    for group in groups.values():
        pairs.update(_rolled_out(group, outputs, keep_trajectories))
    return [pairs[run] for run, _ in runs]


def step_key(scene, table):
    """What must be the same for runs to go in one rollout: the run settings, the robot's
    structure and what the compiled step is made of."""
    return scene.run, scene.model._ibuf.tobytes(), signature(run_data(scene, table))


def _rolled_out(group, outputs, keep):
    """{run: (row, trajectory or None)} of a group [(run, values, scene, table)] of one step,
    in one rollout on this worker's thread."""
    scenes = [scene for _, _, scene, _ in group]
    tables = [table for _, _, _, table in group]
    values = [v for _, v, _, _ in group]
    try:
        result = run_batch(Runs.of_scenes(scenes, tables, values), 1, "samples")
    except Exception as e:  # what simulate refuses for every run of the group
        return {run: (failed_row(run, v, str(e) or type(e).__name__), None) for run, v, *_ in group}
    pairs = {}
    for k, (run, v, scene, _) in enumerate(group):
        if not result.rows[k]:  # refused before it started, as simulate refuses it
            pairs[run] = failed_row(run, v, result.message[k]), None
            continue
        traj = result.trajectory(k)
        row = _row(run, v, scene, traj, result.warnings[k], outputs)
        pairs[run] = row, (traj if keep else None)
    return pairs


def _simulated(run, values, scene, outputs, keep):
    """(row, trajectory or None) of a run done by simulate()."""
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SceneWarning)
            traj = simulate(scene, raise_on_failure=False)
    except Exception as e:  # a run's failure is its row; the sweep goes on
        return failed_row(run, values, str(e) or type(e).__name__), None
    row = _row(run, values, scene, traj, "; ".join(str(w.message) for w in caught), outputs)
    return row, (traj if keep else None)


def _row(run, values, scene, traj, warned, outputs) -> dict:
    """The table row of a run that produced a trajectory."""
    stats = traj.stats
    return {
        "run": run,
        **values,
        "status": "complete" if traj.complete else "failed",
        "message": traj.message,
        "warnings": warned,
        "simulated_s": stats["simulated_s"],
        "wall_s": stats["wall_s"],
        "steps": stats["steps"],
        "rejected_steps": stats["rejected_steps"],
        "evaluations": stats["evaluations"],
        **run_metrics(scene, traj, outputs),
        "q_final": traj.q[-1].tolist() if len(traj.t) else None,
        "qd_final": traj.qd[-1].tolist() if len(traj.t) else None,
    }


def failed_row(run, values, message) -> dict:
    """The row of a run that produced no trajectory: its values, status 'failed', the cause."""
    return {"run": run, **values, "status": "failed", "message": message}
