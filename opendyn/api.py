"""The public drivers, taking a scene as a Scene, a scene file or a shipped scene's name:
simulate, Simulator, rollout and linearize. The simulation (opendyn.sim) runs Scenes; this is
where a file or a name is read into one (opendyn.io.scene), and where a rollout's params become
each run's scene (opendyn.io.scene.variants)."""

from __future__ import annotations

import os

from .errors import SceneError
from .io.scene.files import load_scene
from .io.scene.variants import Variants
from .multibody.model import Model
from .sim import effects, hard, hard_settings, step, step_inputs
from .sim import linearize as _linearize
from .sim import rollout as _rollout
from .sim import simulate as _simulate
from .sim import simulator as _simulator
from .sim.scene import Scene


def as_scene(scene, what="simulate") -> Scene:
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
    return _simulate.simulate(
        as_scene(scene),
        progress=progress,
        raise_on_failure=raise_on_failure,
        controller=controller,
        control_dt=control_dt,
    )


class Simulator(_simulator.Simulator):
    """A scene you step: the state (t, q, qd), `step(tau, duration)`, `reset`, `trajectory()`.

    scene: a Scene, a shipped scene's name or a scene file (as simulate takes). controller,
    control_dt: a Python controller fn(t, q, qd) -> tau and its period (s), which `step` calls
    at the start of every control period and adds to its own tau; by default the scene's own
    ([control] type = "python", its control_dt or the run's, else run.dt). The scene's
    run.duration does not bound a Simulator: it steps as far as it is asked, each step's record
    checked against the memory the process may allocate. A long step stops at Ctrl-C with a
    KeyboardInterrupt, the state consistent at the end of a whole integrator step; a second
    Ctrl-C or a SIGTERM stops a controller that blocks.
    Attributes: model, scene, control_dt (s: the default duration of a step).
    """

    def __init__(self, scene, *, controller=None, control_dt=None):
        super().__init__(as_scene(scene), controller=controller, control_dt=control_dt)


def rollout(scene, q0=None, qd0=None, params=None, threads=None, record="samples", *,
            progress=False):
    """N runs of `scene` in compiled loops over the cores; returns a RolloutResult.

    scene: a Scene, or a scene file or shipped scene's name.
    q0 (N, nq), qd0 (N, nv): the initial states (rad or m, rad/s or m/s; a floating base's
      q as simulate takes it, its quaternion of unit norm); default: the scene's, repeated.
    params: {dotted scene key: values (N,) or (N, k)}: run i sets the key to values[i] (a
      number, or a list of k) as a scene file would, e.g. "control.kp", "effects.damping.
      coefficients", "effects.contact.stiffness", "robot.payload.mass",
      "robot.payload.com", "initial.q.shoulder_lift_joint". run.* keys and words or true/false
      are refused (od.sweep varies them), and so is a key that sets part of what q0 or qd0
      gives (initial.q.*, initial.base_position, an object's position with q0; initial.qd.*,
      an object's velocity with qd0); a run whose step would compile differently from run 0's
      fails, saying so.
    threads: threads to run on (default: one per core).
    record: "samples" keeps every run's rows at the scene's output_dt, (N, K, ...) arrays;
      "final" only each run's last state, (N, 1, ...): memory does not grow with duration.
    progress: a progress bar over the runs (tqdm, on stderr) after a second.
    A scene with a hard model (model = "hard") runs each run from no warm start, as simulate
    does; the result keeps each run's unconverged_steps and worst_residual, not the per-sample
    contact record and solver log of simulate's trajectory.
    N is the length of q0, qd0 and params (which must agree), 1 when none is given. Values that
    are not finite numbers are refused before anything runs (ValueError or TypeError naming the
    argument and the run); a value the scene refuses (a negative mass) or a start simulate
    refuses (off a constraint, deep in the ground, beyond max_speed) fails its run only. A run
    that fails keeps its rows up to the failure (status "failed", message the cause, as
    simulate states it) and the others go on. Ctrl-C stops after the runs under way and raises
    RolloutInterrupted carrying the result so far.
    """
    scene = as_scene(scene, "rollout")
    return _rollout.rollout(
        scene, q0, qd0, params, threads, record, progress=progress,
        vary=Variants.of(scene).scene_for,
    )


def linearize(scene, t=0.0, q=None, qd=None, tau=None, discrete=False):
    """The scene's dynamics, every effect it names included, linearized at (t, q, qd) under the
    joint torques tau (opendyn.sim.linearize's docstring gives the equations).

    Args:
      scene: a Scene, a scene file or a shipped scene's name (constraints are refused).
      t: time (s), for effects that change with it (a wrench table, a reference trajectory).
      q: (nq,) configuration, default the scene's initial q0; qd: (nv,) velocity, default qd0.
      tau: the joint torques u held at the point, (nv,), or the joints' (nv - 6,) on a
        floating base (whose base is not actuated); default zero.
      discrete: False for the continuous-time (A, B); True for the zero-order-hold
        discretisation over the scene's step run.dt.
    Returns (A, B): A (2 nv, 2 nv) on the state error dx = (dq, dqd), dq in the tangent space
      (q = integrate(q_0, dq)); B (2 nv, n) on the n joint torques (model.v_index), n = nv for
      a fixed base. Units: per s (continuous), none (discrete).
    Raises ValueError for a scene with constraints, a Python controller (no derivatives), bad
    arguments (named), or a singular mass matrix (SingularMassMatrixError).
    """
    return _linearize.linearize(as_scene(scene, "linearize"), t, q, qd, tau, discrete)


def contact_problem(scene, q=None, qd=None, t=0.0):
    """One step of a scene's hard model (model = "hard" in [effects.contact], [effects.limits]
    or [effects.friction]) from (t, q, qd), laid open: the contacts found at q, the free
    velocity, the constraint rows, the Delassus matrix, the impulses and the velocity after the
    step (opendyn.sim.hard_step's docstring gives the equations).

    Args:
      scene: a Scene, a scene file or a shipped scene's name, with a hard section.
      q: (nq,) configuration, default the scene's q0; qd: (nv,) velocity, default qd0; t: s.
    Returns a ContactProblem (opendyn.sim.hard): contacts (a ContactList: pair, feature,
      bodies (C, 2), point (C, 3) m, frame (C, 3, 3) rows t1, t2, n, depth (C,) m, mu (C,);
      world frame), v_free (nv,), J (m, nv), G (m, m) = J M^-1 J^T + compliance, g (m,) m/s,
      blocks (B, 3) int (kind, first row, rows; opendyn.algorithm.ncp), param (B,), lam (m,)
      the impulses (N s or N m s), v_next (nv,), q_next (nq,), iterations, residual (m/s).
    Raises SceneError for a scene without a hard section, ValueError for a bad q or qd.
    """
    scene = as_scene(scene, "contact_problem")
    if not hard_settings.sections(scene):
        raise SceneError(
            f"{scene.source}: contact_problem: the scene has no hard section (model = \"hard\" "
            "in [effects.contact], [effects.limits] or [effects.friction])"
        )
    model = scene.model
    q = scene.q0.copy() if q is None else step_inputs.checked_configuration(
        model, q, "contact_problem: q"
    )
    qd = scene.qd0.copy() if qd is None else step_inputs.checked_vector(
        model, qd, "contact_problem: qd"
    )
    table = effects.stage_table(scene)
    data = step.scene_data(model, table)
    return hard.contact_problem(scene, table, data, (float(t), q, qd))
