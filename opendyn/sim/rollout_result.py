"""What od.rollout returns: N runs' samples (or final states), status and statistics, and
each run as a Trajectory on request."""

from __future__ import annotations

import functools

import numpy as np

from ..errors import SceneError
from ..multibody.joints import FREE
from . import hard_settings
from .integrators import Record
from .record import energies_of, quaternion_norm_error, trajectory_of

COMPLETE, FAILED, INTERRUPTED = "complete", "failed", "interrupted"


class RolloutResult:
    """N runs of one scene (od.rollout). Arrays are indexed by run first.

    With record="samples", K = the rows of a run (the scene's output_dt, as simulate records):
      t (N, K) s; q (N, K, nq); qd (N, K, nv); tau (N, K, nv) the control torque; kinetic,
      potential (N, K) J (computed on first use); work_applied, work_passive (N, K) J; rows
      after a run's end (rows[i] of them are filled) are NaN.
    With record="final", K = 1: each array holds the run's last state only, so memory does not
      grow with the duration.
    Every run, either way:
      rows (N,) int64 the rows filled; t_final (N,), q_final (N, nq), qd_final (N, nv),
      tau_final (N, nv): the last state (the final one; after a failure, the last good one;
      NaN for a run refused or never started);
      status (N,) "complete", "failed" (a failure, or a run that simulate would refuse: its
      initial state, its contact step) or "interrupted" (never started: Ctrl-C); complete
      (N,) bool; message [N] the cause ("" when complete); warnings [N] the scene's warnings;
      steps, rejected_steps, evaluations (N,) int64;
      with a hard model (opendyn.sim.hard), unconverged_steps (N,) int64 the steps whose solve
      stopped at max_iterations above the tolerance and worst_residual (N,) m/s the largest
      residual among them (0 when every solve converged); None without one.
    stats: the batch's integrator, runs, threads, wall_s (the runs' wall time), prepare_s (of it,
      reading and checking the runs' scenes), compile_s, load_s, steps_per_s.
    trajectory(i): run i as the Trajectory simulate gives for its scene (scene_for(i)); of a
      hard model's run, without the per-sample contact record and solver log, which a rollout
      does not keep.
    """

    def __init__(self, runs, integ, keep, arrays, outcome, counters, notes, stats):
        self._runs = runs
        self.integrator = integ.name
        self.record = keep
        x, out = arrays
        self.t, self.q, self.qd, self.tau = out.t, out.q, out.qd, out.tau
        self._w = out.w
        self.work_applied, self.work_passive = out.w[..., 0], out.w[..., 1]
        self.rows = outcome.rows
        self.t_final, self.q_final, self.qd_final = outcome.t, x.q, x.qd
        self.tau_final = outcome.tau
        self.status, self.message, self.warnings = notes
        self.complete = self.status == COMPLETE
        self.evaluations, self.steps, self.rejected_steps = counters.T
        self.unconverged_steps = self.worst_residual = None
        if hard_settings.sections(runs.scene):
            self.unconverged_steps = outcome.solver[:, 0].astype(np.int64)
            self.worst_residual = outcome.solver[:, 1]
        self.stats = stats
        wall = stats["wall_s"]
        stats["steps_per_s"] = float(self.steps.sum() / wall) if wall > 0 else 0.0

    def __len__(self):
        return len(self.rows)

    def __repr__(self):
        counts = {s: int((self.status == s).sum()) for s in (COMPLETE, FAILED, INTERRUPTED)}
        told = ", ".join(f"{n} {s}" for s, n in counts.items() if n)
        return (
            f"<RolloutResult of {self._runs.scene.name!r}: {len(self)} runs ({told}), "
            f"{self.integrator}, record={self.record!r}>"
        )

    def scene_for(self, i):
        """Run i's scene: the scene with run i's params and initial state."""
        return self._runs.scene_for(self._index(i))

    def values(self, i):
        """Run i's params {key: value}, as scene_for sets them."""
        return self._runs.values(self._index(i))

    @functools.cached_property
    def _energies(self):
        kinetic, potential = np.full(self.t.shape, np.nan), np.full(self.t.shape, np.nan)
        for i, n in enumerate(self.rows):
            if n:
                scene, table = self._runs.scene_and_table(i)
                kinetic[i, :n], potential[i, :n], _ = energies_of(
                    scene, table, self.q[i, :n], self.qd[i, :n]
                )
        return kinetic, potential

    @property
    def kinetic(self):
        """(N, K) J: T = 1/2 qd^T (M + diag(armature)) qd at each row (NaN past a run's end)."""
        return self._energies[0]

    @property
    def potential(self):
        """(N, K) J: gravity's potential plus the contact springs' energy at each row."""
        return self._energies[1]

    def trajectory(self, i):
        """Run i as a Trajectory: what simulate(scene_for(i)) returns (with
        raise_on_failure=False), its samples bit for bit; for a run refused before it started,
        the SceneError simulate raises (its message). Needs record="samples"."""
        i = self._index(i)
        if self.record != "samples":
            raise ValueError(
                "trajectory: this rollout kept only the final states (record='final'); roll "
                "out with record='samples' for each run's samples"
            )
        if not self.rows[i]:  # refused before it started, as simulate refuses it
            raise SceneError(self.message[i])
        scene, table = self._runs.scene_and_table(i)
        stats = {
            "integrator": self.integrator,
            "steps": int(self.steps[i]),
            "rejected_steps": int(self.rejected_steps[i]),
            "evaluations": int(self.evaluations[i]),
            "wall_s": self.wall_share(i),
            "compile_s": 0.0,
            "load_s": 0.0,
            "simulated_s": float(self.t[i, self.rows[i] - 1]) if self.rows[i] else 0.0,
        }
        n = int(self.rows[i])
        out = Record(self.t[i], self.q[i], self.qd[i], self.tau[i], self._w[i], None)
        if np.any(scene.model.jtype == FREE):
            stats["quaternion_norm_error"] = float(
                quaternion_norm_error(scene.model, self.q[i, :n]).max(initial=0.0)
            )
        if self.unconverged_steps is not None:  # as simulate's hard run has them (solve_stats)
            stats["unconverged_steps"] = int(self.unconverged_steps[i])
            stats["worst_residual"] = float(self.worst_residual[i])
        return trajectory_of(
            scene, table, out, n, bool(self.complete[i]), self.message[i], stats
        )

    def wall_share(self, i):
        """Run i's share of the runs' wall time (s), in proportion to its dynamics evaluations:
        the runs of a rollout are timed together, not one by one."""
        total = self.evaluations.sum()
        wall = self.stats["wall_s"] * self.stats["threads"]
        return float(wall * self.evaluations[i] / total) if total else 0.0

    def _index(self, i):
        n = len(self)
        if isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer)):
            raise TypeError(f"run index must be a whole number, got {type(i).__name__}")
        if not -n <= i < n:
            raise IndexError(f"run {i} of a rollout of {n} runs")
        return int(i) % n
