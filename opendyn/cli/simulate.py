"""`opendyn simulate`: the scene a target names (``scene_for``), with the run settings and effects
of the arguments; every output checked, the run, its report (``summary``), the outputs written,
and the motion played in meshcat with --view."""

from __future__ import annotations

import importlib.util
import pathlib
import sys
import time

import numpy as np

from .._runtime.signals import held_interrupt
from ..errors import SceneError, URDFError
from ..io.scene.files import (
    DEFAULT_SCENE,
    default_scene,
    is_scene_file,
    load_scene,
    scene_from_dict,
    shipped_scenes,
)
from ..io.urdf import load_urdf
from ..sim import hard_settings
from ..sim.effects import registry
from ..sim.integrators import INTEGRATORS
from ..sim.scene import thaw
from .interrupts import _doing
from .outputs import (
    _check_not_inputs,
    _check_outputs,
    _contact,
    _named_outputs,
    _save_record,
    _scene_outputs,
    _write_outputs,
)

# effects that `--enable` can switch on for any robot, and the settings it gives them: their
# parameters come from the URDF (each effect's module declares its ENABLE)
ENABLE_FROM_URDF = registry.enable_settings()
WRITE_FAILED = 3  # exit status: an output could not be written after the run


def scene_for(target, floating_base=False):
    """The scene a `simulate` target names: a scene file, a shipped scene's name, a URDF file or
    a robot name (the robot's default scene: gravity only); with floating_base, its robot's
    root link a free body (robot.floating_base = true)."""
    if target is None:
        scene = load_scene(DEFAULT_SCENE)
    else:
        path = pathlib.Path(target)
        if path.is_file() and not is_scene_file(path):
            scene = None
        elif path.is_file() or path.suffix.lower() == ".toml" or target in shipped_scenes():
            scene = load_scene(target)
        else:
            scene = None
        if scene is None:  # a URDF or a robot
            if floating_base:
                return default_scene(_floating_robot(target))
            return default_scene(target)
    if not floating_base or scene.model.floating_base:
        return scene
    settings = thaw(scene.settings)
    settings["robot"]["floating_base"] = True
    source = pathlib.Path(scene.source)
    return scene_from_dict(
        settings, source=scene.source, base_dir=source.parent if source.is_file() else None
    )


def _floating_robot(target):
    """The Model of a URDF file or robot name with a free root link (SceneError if neither)."""
    try:
        return load_urdf(target, floating_base=True)
    except (URDFError, TypeError) as e:
        raise SceneError(f"<robot {target}>: robot: {e}") from None


def _with_effects(scene, enable, disable):
    """The scene with `enable` switched on from the URDF's values and `disable` switched off."""
    if enable:
        settings = thaw(scene.settings)
        effects = settings.setdefault("effects", {})
        for name in enable:
            effects.setdefault(name, ENABLE_FROM_URDF[name])
        if "robot" not in settings or scene.source.startswith("<"):
            settings["robot"] = {"urdf": scene.model.source}
        source = pathlib.Path(scene.source)
        scene = scene_from_dict(
            settings, source=scene.source, base_dir=source.parent if source.is_file() else None
        )
    return scene.without(*disable) if disable else scene


def _simulate(args) -> int:
    """opendyn simulate: check every output, load the scene, run it, report, write the outputs.
    Returns the exit status (see the module's docstring)."""
    from ..sim.profile import profile
    from ..sim.simulate import simulate
    from ..sim.step_inputs import load_controller

    named = _named_outputs(args)
    _check_outputs(named)
    _check_meshcat(args)
    if args.controller is not None and "control" in args.disable:
        raise ValueError(
            f"--controller {args.controller} and --disable control: one runs a controller, the "
            "other switches control off; give one"
        )
    both = sorted(set(args.enable) & set(args.disable))
    if both:
        raise ValueError(
            f"--enable {both[0]} and --disable {both[0]}: one switches the effect on, the "
            "other off; give one"
        )
    with _doing("loading the scene and its robot; nothing was run"):
        scene = _scene_to_run(args)
        controller = None
        if args.controller is not None:
            controller = load_controller(args.controller, "--controller")
        elif args.control_dt is not None:
            raise SceneError("--control-dt: give --controller FILE.py:FUNCTION with it")
    derived = _scene_outputs(scene, args, named)
    _check_outputs(derived, named)
    _check_not_inputs(named + derived, scene, args.controller)
    if not args.quiet:
        print(_scene_header(scene))
    with _doing("getting the compiled step ready; the run had not started"):
        try:
            traj = simulate(
                scene,
                progress=not args.quiet,
                raise_on_failure=False,
                controller=controller,
                control_dt=args.control_dt,
            )
        except SceneError as e:  # the checks before the run: of the options' values too
            raise _named_by_its_option(e, scene.source, _run_options(args)) from None
    with _doing("writing the outputs"):
        with held_interrupt():  # from the end of the run until its record is saved
            if not args.quiet or not traj.complete:
                print(summary(scene, traj))
            saved = _save_record(scene, traj, args)
        written = _write_outputs(scene, traj, args, saved)
    if not traj.complete:
        print(f"opendyn simulate: {traj.message}", file=sys.stderr)
    if args.profile:
        with _doing("timing the stages for --profile; the outputs are written"):
            print(profile(scene))
    if args.view:
        _view(scene, traj, args.collision)
    if not written:
        return WRITE_FAILED
    return 0 if traj.complete else 1


def _scene_to_run(args):
    """The scene the arguments name, with their run settings and effects."""
    scene = scene_for(args.target, args.floating_base)
    run = _run_options(args)
    if run:
        try:
            scene = scene.replace_run(**run)
        except SceneError as e:
            raise _named_by_its_option(e, scene.source, run) from None
    tolerances = [o for o, v in (("--rtol", args.rtol), ("--atol", args.atol)) if v is not None]
    if tolerances and not INTEGRATORS[scene.run.integrator].adaptive:
        raise ValueError(
            f"{' and '.join(tolerances)}: the tolerances of an adaptive step, but the run's "
            f"integrator is {scene.run.integrator} (a fixed step, dt = {scene.run.dt:g} s); "
            "give --integrator dopri5 with them, or --dt"
        )
    return _with_effects(scene, args.enable, args.disable)


def _run_options(args):
    """{run key: value} of the run settings the options give."""
    run = {
        "duration": args.duration,
        "dt": args.dt,
        "integrator": args.integrator,
        "rtol": args.rtol,
        "atol": args.atol,
        "output_dt": args.output_dt,
    }
    return {k: v for k, v in run.items() if v is not None}


def _named_by_its_option(error, source, given):
    """The SceneError of a run setting, naming the options that gave a value (`--output-dt`)
    where it named the scene file's key (`SCENE.toml: run.output_dt`), which does not hold
    that value; other errors as they are."""
    text = str(error)
    for key in given:
        prefix = f"{source}: run.{key}: "
        if text.startswith(prefix):
            text = f"run.{key}: {text[len(prefix):]}"
        text = text.replace(f"run.{key}", f"--{key.replace('_', '-')}")
    return error if text == str(error) else SceneError(text)


def _check_meshcat(args):
    """Raise ImportError naming --html or --view, and the install command, without meshcat;
    ValueError for --collision without either."""
    if args.collision and args.html is None and not args.view:
        raise ValueError("--collision draws the collision geometry in --html or --view: give one")
    if (args.html is not None or args.view) and importlib.util.find_spec("meshcat") is None:
        from ..viz import MESHCAT_HINT

        raise ImportError(f"{'--html' if args.html is not None else '--view'}: {MESHCAT_HINT}")


def _view(scene, traj, collision=False):
    from ..viz import playback as viz

    url = viz.view(
        scene.model, traj.t, traj.q, open_browser=True, contact=_contact(scene, traj),
        collision=collision,
    )
    print(f"meshcat viewer at {url} (Ctrl-C to quit)")
    _wait_for_interrupt()


def _wait_for_interrupt():
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass


def _scene_header(scene):
    run = scene.run
    step = (
        f"rtol = {run.rtol:g}, atol = {run.atol:g}"
        if run.integrator == "dopri5"
        else f"dt = {run.dt:g} s"
    )
    effects = ", ".join(scene.effects) or "none (free motion)"
    lines = [
        f"scene       {scene.name} ({scene.source})",
        f"robot       {scene.model.name}, "
        + (
            f"floating base, nq = {scene.model.nq}, nv = {scene.model.nv}"
            if scene.model.floating_base
            else f"nv = {scene.model.nv}"
        ),
        f"effects     {effects}",
    ]
    if scene.constraints:
        kinds = ", ".join(type(c).__name__ for c in scene.constraints)
        lines.append(f"constraints {kinds}")
    lines.append(f"integrator  {run.integrator}, {step}, {run.duration:g} s")
    return "\n".join(lines)


def _solver_line(scene, traj):
    """The hard model's solves: how many steps did not converge, with their worst residual, or
    that every one did, with the most iterations a sample's took."""
    stats = traj.stats
    settings = next(iter(hard_settings.sections(scene).values()))
    name = settings.solver.upper()
    unconverged = stats["unconverged_steps"]
    if unconverged:
        return (
            f"solver      {name}: {unconverged} of {stats['steps']} steps stopped at "
            f"max_iterations = {settings.max_iterations} above the tolerance "
            f"{settings.tolerance:g} m/s (worst residual {stats['worst_residual']:.3g} m/s)"
        )
    most = int(traj.solver_iterations.max(initial=0))
    return (
        f"solver      {name}: every step converged to {settings.tolerance:g} m/s (at most "
        f"{most} iterations at a sample)"
    )


def summary(scene, traj):
    """The run in a few lines: time, speed (the whole wall time's, a Python controller's calls
    included, and then the compiled step's alone), steps, integrator statistics, energy; the
    contact's extremes over every step; a warning where a pair went deeper than half its
    thinner geometry, and where the energy balance is off by more than ENERGY_WARNING; for a
    floating robot that nothing but gravity acts on from outside, how well its momentum was
    kept."""
    stats = traj.stats
    wall = stats["wall_s"]
    simulated = stats["simulated_s"]
    factor = simulated / wall if wall > 0 else float("inf")
    extremes = traj.contact_extremes
    too_deep = extremes.warning() if extremes is not None else ""
    warnings = [w for w in (too_deep, _energy_warning(scene, traj)) if w]
    status = "complete" if traj.complete else "STOPPED EARLY (partial record)"
    if warnings:
        status += ", with the warning below" if len(warnings) == 1 else ", with the warnings below"
    if stats["compile_s"] > 0:
        ready = (
            f"{stats['compile_s']:.3g} s more compiling the step, once per machine and opendyn "
            "version"
        )
    else:
        ready = f"{stats['load_s']:.2g} s more to load the compiled step"
    controller = stats.get("controller_s", 0.0)
    if controller > 0:
        step = wall - controller
        alone = simulated / step if step > 0 else float("inf")
        ready = (
            f"of it {controller:.3g} s in the Python controller, the compiled step alone "
            f"{alone:.3g}x real time; {ready}"
        )
    lines = [
        f"run         {status}",
        f"simulated   {simulated:.4g} s in {wall:.3g} s wall ({factor:.3g}x real time; {ready})",
        f"steps       {stats['steps']} accepted, {stats['rejected_steps']} rejected, "
        f"{stats['evaluations']} dynamics evaluations",
    ]
    if "unconverged_steps" in stats:
        lines.append(_solver_line(scene, traj))
    if len(traj.t):
        energy = traj.energy
        error = np.abs(traj.energy_error)
        scale = _energy_scale(traj)
        conservative = not np.any(traj.work_applied) and not np.any(traj.work_passive)
        if conservative:
            lines.append(
                f"energy      E(0) = {energy[0]:.6g} J, drift max |E - E(0)| = "
                f"{error.max():.3g} J ({error.max() / scale:.2g} of max |E|)"
            )
        else:
            lines.append(
                f"energy      E(0) = {energy[0]:.6g} J, E(end) = {energy[-1]:.6g} J; work "
                f"applied {traj.work_applied[-1]:.6g} J, passive {traj.work_passive[-1]:.6g} J"
            )
            lines.append(
                f"balance     max |E - E(0) - W| = {error.max():.3g} J "
                f"({error.max() / scale:.2g} of max |E|): the integration error"
            )
    if "quaternion_norm_error" in stats:
        from ..sim.record import QUATERNION_NORM_BOUND

        lines.append(
            f"base        max | |quat| - 1 | = {stats['quaternion_norm_error']:.2g} over the "
            f"samples (bound {QUATERNION_NORM_BOUND:g}: integrate keeps it a unit quaternion)"
        )
    if extremes is not None and len(traj.t):
        lines.append(_contact_line(traj) if traj.has_contact else _contacts_line(traj))
    lines += [f"WARNING     {warning}" for warning in warnings]
    if len(traj.com) and not (
        scene.contact or scene.wrenches or scene.constraints or scene.armature is not None
    ):
        lines.append(_momentum_line(scene, traj))
    if len(traj.violation_position):
        gains = scene.baumgarte
        how = (
            f"Baumgarte alpha = {gains[0]:g}, beta = {gains[1]:g} 1/s"
            if gains is not None
            else "no stabilisation"
        )
        lines.append(
            f"constraints {len(scene.constraints)} ({how}): max |phi| = "
            f"{traj.violation_position.max():.3g} (end {traj.violation_position[-1]:.3g}) m or "
            f"rad, max |A qd| = {traj.violation_velocity.max():.3g} m/s or rad/s"
        )
    return "\n".join(lines)


# the energy balance's error, as a fraction of max |E|, past which the summary warns: the
# integration, not the physics, made that much of the motion
ENERGY_WARNING = 0.05


def _energy_scale(traj) -> float:
    """max |E| over the samples (J; the kinetic energy where that is larger), the scale the
    summary measures the energy balance's error against."""
    return max(np.abs(traj.energy).max(), traj.kinetic.max(), 1e-300)


def _energy_warning(scene, traj) -> str:
    """A sentence when the energy balance's error max |E - E(0) - W| exceeds ENERGY_WARNING of
    max |E| (the integrator made that much energy, or lost it), naming the likely cause by the
    integrator; "" otherwise."""
    if not len(traj.t):
        return ""
    relative = np.abs(traj.energy_error).max() / _energy_scale(traj)
    if not relative > ENERGY_WARNING:
        return ""
    run = scene.run
    causes = {
        "euler": f"explicit Euler adds energy at every step, first order in run.dt = {run.dt:g} "
        "s: use rk4 or dopri5, or a smaller run.dt",
        "semi_implicit_euler": f"semi-implicit Euler's step run.dt = {run.dt:g} s is too large "
        "for the fastest motion: a smaller run.dt, or rk4 or dopri5",
        "implicit_euler": f"implicit Euler damps the motion numerically, first order in run.dt "
        f"= {run.dt:g} s, most where stiff springs (contact) act: a smaller run.dt, or dopri5",
        "dopri5": f"run.rtol = {run.rtol:g} lets the error grow: tighten it",
    }
    cause = causes.get(
        run.integrator,
        f"the step run.dt = {run.dt:g} s is too large for the fastest motion (a stiff contact, "
        "a light link): halve it and compare, or use dopri5",
    )
    return (
        f"the energy balance is off by {relative:.2g} of max |E| (more than {ENERGY_WARNING:g}):"
        f" the integration, not the physics, made or lost that energy; {cause}"
    )


def _momentum_line(scene, traj):
    """How well a floating robot kept its momentum, when nothing outside it acts but gravity:
    dh_G/dt = (0, M g), so k_G stays k_G(0) and l_G is l_G(0) + M g t (joint torques, damping
    and friction are internal)."""
    from ..sim.record import gravity_of

    h = traj.centroidal_momentum
    t = traj.t - traj.t[0]
    weight = scene.model._total_mass * gravity_of(scene)
    k_drift = np.abs(h[:, :3] - h[0, :3]).max()
    l_drift = np.abs(h[:, 3:] - h[0, 3:] - np.outer(t, weight)).max()
    return (
        f"momentum    about the centre of mass (only gravity acts from outside): max |k_G - "
        f"k_G(0)| = {k_drift:.3g} kg m^2/s (max |k_G| {np.abs(h[:, :3]).max():.3g}), max |l_G - "
        f"l_G(0) - M g t| = {l_drift:.3g} kg m/s (max |l_G| {np.abs(h[:, 3:]).max():.3g})"
    )


def _contacts_line(traj):
    """The contact between geometries in one line, from its extremes over every step: how
    many points at most, the deepest penetration and the largest force, each with its pair and
    time."""
    extremes = traj.contact_extremes
    pairs = len(extremes.pairs)
    if not extremes.touched:
        return f"contact     no pair touched at any {_kept(extremes)} ({pairs} pairs checked)"
    return (
        f"contact     up to {extremes.most_points} points of {pairs} geometry pairs: "
        f"{_extremes(extremes)}; over every {_kept(extremes)}"
    )


def _contact_line(traj):
    """The ground contact of spheres in one line, from its extremes over every step: the
    points, the largest penetration and force, where and when."""
    extremes = traj.contact_extremes
    n = len(extremes.pairs)
    where = f"{n} point{'s' if n != 1 else ''} on the ground z = {traj.ground_height:g} m"
    if not extremes.touched:
        return f"contact     {where}: none touched it at any {_kept(extremes)}"
    return f"contact     {where}: {_extremes(extremes)}; over every {_kept(extremes)}"


def _kept(extremes):
    """What the contact's extremes were taken over: every "step", or every "sample" alone."""
    return "step" if extremes.every_step else "sample"


def _extremes(extremes):
    """The deepest penetration and the largest force, each with its pair and time."""
    force = "max force 0 N"
    if extremes.largest_pair >= 0:
        force = (
            f"max force {extremes.largest_force:.4g} N "
            f"({extremes.pairs[extremes.largest_pair]} at t = {extremes.largest_t:.4g} s)"
        )
    return (
        f"max penetration {extremes.deepest * 1e3:.3g} mm "
        f"({extremes.pairs[extremes.deepest_pair]} at t = {extremes.deepest_t:.4g} s), {force}"
    )
