"""The `opendyn` command.

  opendyn simulate [SCENE | URDF | ROBOT]   run a scene (default: the bundled double pendulum)
  opendyn info ROBOT                        model summary and URDF fidelity report
  opendyn verify ROBOT [--floating-base]    every contract function against Pinocchio
  opendyn demo [ROBOT]                      M(q), g(q) and forward dynamics at one state
  opendyn sweep SCENE --vary KEY=SPEC ...   many runs on a Dask cluster, one Parquet row each
  opendyn compile [--all | SCENE...]        compile the kernels ahead of time (images, workers)
  opendyn info --cache                      where the compiled kernels are cached

Exit status: 0 success; 1 a simulation that stopped early (a failure, or Ctrl-C or SIGTERM
during the run: its partial record is written) or a failed verification; 2 bad input, the
message naming the file, key or argument (`simulate` checks every output file before the run);
3 an output that could not be written after the run (the message names it and, when the
trajectory had no file of its own, the fallback file it went to); 130 Ctrl-C or 143 SIGTERM
while loading, compiling or writing (the message says which).

`opendyn simulate` saves the trajectory by default: SCENE.npz and SCENE.json in the current
folder (SCENE the scene's name; SCENE-partial.npz for a run that stopped early, so that it
never replaces a complete record), `-o` elsewhere, `--no-save` not at all.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import os
import pathlib
import sys
import tempfile
import time
import warnings

import numpy as np

from .. import forward_dynamics, gravity_forces, inverse_dynamics, load_urdf, mass_matrix
from .._runtime.signals import SigtermAsInterrupt, held_interrupt, signal_name
from ..errors import SceneError, SceneWarning, URDFError
from ..io.scene import (
    DEFAULT_SCENE,
    EFFECTS,
    INTEGRATORS,
    default_scene,
    is_scene_file,
    load_scene,
    scene_from_dict,
    shipped_scenes,
    thaw,
)
from ..io.urdf import looks_mobile
from ..sim.trajectory import saved_paths

DEFAULT_ROBOT = "double_pendulum"
# effects that `--enable` can switch on for any robot: their parameters come from the URDF
ENABLE_FROM_URDF = {"gravity": True, "damping": {}, "friction": {}}
# the options of `simulate` that name an output file, and their attributes in args
OUTPUT_OPTIONS = {"-o": "output", "--csv": "csv", "--plot": "plot", "--html": "html"}
DEFAULT_SAVE = "the trajectory"  # how messages name the file saved without -o
DEFAULT_SAVE_HINT = "-o names another file, --no-save skips saving"
WRITE_FAILED = 3  # exit status: an output could not be written after the run


class _Interrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM, with what the command was doing (the message's "while ...")."""


@contextlib.contextmanager
def _doing(what):
    """Name what the block does in the message of a Ctrl-C or SIGTERM that stops it."""
    try:
        yield
    except _Interrupted:
        raise
    except KeyboardInterrupt:
        raise _Interrupted(what) from None


def _compile_ahead(args) -> int:
    """opendyn compile: the scenes named (or, with --all or nothing named, every core function
    and every shipped scene whose robot is installed), compiled into the kernel cache."""
    from .._runtime.compile_notice import compile_ahead

    names = args.scenes or []
    everything = args.all or not names
    scenes, skipped = [], []
    for name in list(shipped_scenes()) if everything else names:
        try:
            scenes.append(load_scene(name))
        except SceneError as e:
            if not everything:
                raise
            skipped.append(f"{name} ({e})")
    t0 = time.perf_counter()
    done = compile_ahead(scenes, functions=everything)
    for name in skipped:
        print(f"skipped scene {name}", file=sys.stderr)
    print(f"compiled {len(done)} items in {time.perf_counter() - t0:.1f} s")
    return 0


def _cache_info() -> int:
    """opendyn info --cache: the kernel cache folder, why it is there, and its size."""
    import os

    from .._runtime.kernel_cache import CACHE_DIR, CACHE_WHERE

    print(f"kernel cache  {CACHE_DIR or 'none: kernels are compiled in every process'}")
    print(f"chosen as     {CACHE_WHERE} (first writable of NUMBA_CACHE_DIR, the package folder, "
          "the per-user cache)")
    if CACHE_DIR and os.path.isdir(CACHE_DIR):
        files = [os.path.join(d, f) for d, _, fs in os.walk(CACHE_DIR) for f in fs]
        size = sum(os.path.getsize(f) for f in files)
        print(f"holds         {len(files)} files, {size / 1e6:.1f} MB")
    return 0


def _demo(args) -> int:
    """Load a robot, print its summary and fidelity report, M(q), g(q) and a forward-dynamics
    result at a fixed state, and check the result by inverse dynamics."""
    model = load_urdf(args.robot)
    print(model.summary())
    print()
    print(model.report)
    rng = np.random.default_rng(0)
    q = rng.uniform(-1.0, 1.0, model.nv)
    qd = rng.uniform(-1.0, 1.0, model.nv)
    tau = np.zeros(model.nv)
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    t0 = time.perf_counter()
    M = mass_matrix(model, q)
    first_call = time.perf_counter() - t0
    print(f"\nstate (SI units: rad or m, N m or N): q = {q}, qd = {qd}, tau = 0")
    print(f"M(q) =\n{M}")
    print(f"g(q) = {gravity_forces(model, q)}")
    qdd = forward_dynamics(model, q, qd, tau)
    print(f"qdd = forward_dynamics(q, qd, tau=0) = {qdd}")
    residual = np.abs(inverse_dynamics(model, q, qd, qdd) - tau).max()
    print(f"check: max |inverse_dynamics(q, qd, qdd) - tau| = {residual:.2e}")
    print(f"(first call, including loading or compiling the kernels: {first_call:.2f} s)")
    return 0


def _info(args) -> int:
    if args.cache:
        return _cache_info()
    if args.robot is None:
        raise ValueError("name a robot (a URDF file or robot name), or ask for --cache")
    model = load_urdf(
        args.robot,
        mimic=args.mimic,
        check_inertia=not args.keep_inertia,
        floating_base=args.floating_base,
    )
    print(model.summary())
    if model.floating_base:
        print(
            f"base: floating (a free joint: q = (p, quat (x, y, z, w), joints), nq = "
            f"{model.nq}; v = (omega_b, v_b, joints), nv = {model.nv})"
        )
    else:
        print("base: fixed (the root link is welded to the world)")
        if looks_mobile(model):
            print(
                f"warning: {model.name!r} looks like a mobile robot (its root link carries "
                f"{model.report.welded_mass:.4g} kg and nothing attaches it to a world link), "
                f"but its base is welded to the world; load it with --floating-base "
                f"(load_urdf(..., floating_base=True)) to let it move",
                file=sys.stderr,
            )
    print()
    print(model.report)
    return 0


def _verify(args) -> int:
    from ..verify.contract import PinocchioMissingError, format_table, verify

    try:
        model = load_urdf(
            args.robot,
            mimic=args.mimic,
            check_inertia=not args.keep_inertia,
            floating_base=args.floating_base,
        )
        checks = verify(model, states=args.states, seed=args.seed, rtol=args.rtol)
    except PinocchioMissingError as e:
        print(e, file=sys.stderr)
        return 2
    print(format_table(checks, model))
    return 0 if all(c.passed for c in checks) else 1


def scene_for(target):
    """The scene a `simulate` target names: a scene file, a shipped scene's name, a URDF file or
    a robot name (the robot's default scene: gravity only)."""
    if target is None:
        return load_scene(DEFAULT_SCENE)
    path = pathlib.Path(target)
    if path.is_file():
        return load_scene(path) if is_scene_file(path) else default_scene(target)
    if path.suffix.lower() == ".toml" or target in shipped_scenes():
        return load_scene(target)
    return default_scene(target)


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

    named = _named_outputs(args)
    _check_outputs(named)
    _check_meshcat(args)
    with _doing("loading the scene and its robot; nothing was run"):
        scene = _scene_to_run(args)
    if args.output is None and not args.no_save:
        defaults = [_default_record(scene, complete) for complete in (True, False)]
        _check_outputs(
            [(DEFAULT_SAVE, name, path) for name in defaults for path in saved_paths(name)], named
        )
    if not args.quiet:
        print(_scene_header(scene))
    with _doing("getting the compiled step ready; the run had not started"):
        traj = simulate(scene, progress=not args.quiet, raise_on_failure=False)
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
        _view(scene, traj)
    if not written:
        return WRITE_FAILED
    return 0 if traj.complete else 1


def _sweep(args) -> int:
    """opendyn sweep: check the outputs, read every run's scene, run them on the cluster,
    report. Returns 0 when every run has a row (complete or failed)."""
    from ..errors import SweepInterrupted
    from ..sweep.engine import check_installed, sweep

    check_installed()
    vary = {}
    for item in args.vary:
        key, eq, spec = item.partition("=")
        if not eq or not key.strip():
            raise ValueError(f"--vary {item!r}: expected KEY=SPEC, e.g. control.kp=100:400:4")
        if key.strip() in vary:
            raise ValueError(f"--vary {key.strip()}: given twice")
        vary[key.strip()] = spec.strip()
    with _doing("loading the scene and its robot; nothing was run"):
        scene = scene_for(args.target)
    output = args.output or f"{_slug(scene.name)}-sweep.parquet"
    named = [("-o", output, pathlib.Path(output))]
    if args.plot is not None:
        named.append(("--plot", args.plot, pathlib.Path(args.plot)))
    _check_outputs(named)
    if args.plot is not None:
        from ..sweep.engine import parse_axis
        from ..sweep.plot import check_plan

        check_plan([parse_axis(key, spec) for key, spec in vary.items()], args.metric)
    if args.trajectories is not None and os.path.exists(args.trajectories):
        if not os.path.isdir(args.trajectories):
            raise ValueError(f"--trajectories {args.trajectories}: is a file, not a folder")
    client = None
    if args.scheduler is not None:
        from dask.distributed import Client

        try:
            client = Client(args.scheduler, timeout="10s")
        except (OSError, TimeoutError) as e:
            raise ValueError(f"--scheduler {args.scheduler}: cannot connect ({e})") from None
    outputs = [m.strip() for m in args.outputs.split(",")] if args.outputs else None
    tic = time.perf_counter()
    try:
        table = sweep(
            scene, vary, samples=args.samples, seed=args.seed, client=client, outputs=outputs,
            parquet=output, trajectories=args.trajectories, workers=args.workers,
            chunk_size=args.chunk, progress=not args.quiet,
        )
    except SweepInterrupted as e:
        print(f"opendyn sweep: interrupted; {_counts(e.table)} are saved in {output}: the same "
              f"command resumes", file=sys.stderr)
        return 130
    finally:
        if client is not None:
            client.close()
    if args.plot is not None:
        from ..sweep.plot import plot_sweep

        with _doing("drawing the plot; the results are saved"):
            plot_sweep(table, args.plot, args.metric)
    if not args.quiet:
        print(f"{_counts(table)} in {time.perf_counter() - tic:.1f} s; wrote {output}"
              + (f", {args.plot}" if args.plot else ""))
        failed = [r for r in table.select(["run", "message"]).to_pylist()
                  if r["message"]]
        if failed:
            print(f"first failure, run {failed[0]['run']}: {failed[0]['message']}")
    return 0


def _counts(table) -> str:
    """'N runs (C complete, F failed)' of a sweep's results table."""
    from ..sweep.results import status_counts

    complete, failed = status_counts(table)
    return f"{table.num_rows} runs ({complete} complete, {failed} failed)"


def _scene_to_run(args):
    """The scene the arguments name, with their run settings and effects."""
    scene = scene_for(args.target)
    run = {
        "duration": args.duration,
        "dt": args.dt,
        "integrator": args.integrator,
        "rtol": args.rtol,
        "atol": args.atol,
        "output_dt": args.output_dt,
    }
    run = {k: v for k, v in run.items() if v is not None}
    if run:
        scene = scene.replace_run(**run)
    return _with_effects(scene, args.enable, args.disable)


def _default_record(scene, complete):
    """The trajectory's file without -o: SCENE.npz in the current folder, SCENE-partial.npz for
    a run that stopped early (so that it never replaces a complete record)."""
    return f"{_slug(scene.name)}{'' if complete else '-partial'}.npz"


def _named_outputs(args):
    """(option, name, path) for each file the options name: -o's .npz and its .json record,
    --csv, --plot, --html. Raises ValueError for an empty name."""
    named = []
    for option, attr in OUTPUT_OPTIONS.items():
        name = getattr(args, attr)
        if name is None:
            continue
        if not name.strip():
            raise ValueError(f"{option}: the file name is empty")
        if option == "-o" and os.path.isdir(name):
            raise ValueError(f"{option} {name}: is a folder, not a file; name the .npz to write")
        paths = saved_paths(name) if option == "-o" else [pathlib.Path(name)]
        named += [(option, name, path) for path in paths]
    return named


def _check_outputs(outputs, others=()):
    """Raise ValueError naming the option and the file for the first of `outputs` (option,
    name, path) that cannot be written (`_unwritable`), that is also the file of another
    output (of `outputs` or `others`), or, for --plot, whose format matplotlib does not write.
    Quick: nothing is loaded or run."""
    seen = {os.path.realpath(path): (option, name) for option, name, path in others}
    for option, name, path in outputs:
        real = os.path.realpath(path)
        problem = _unwritable(name, path)
        if problem is None and seen.get(real, (option, name)) != (option, name):
            problem = "is also the file of {} {!r}".format(*seen[real])
        if problem is None and option == "--plot":
            problem = _unplottable(path)
        if problem is not None:
            which = f" {path}:" if path != pathlib.Path(name) else ""
            hint = f" ({DEFAULT_SAVE_HINT})" if option == DEFAULT_SAVE else ""
            raise ValueError(f"{option} {name!r}:{which} {problem}{hint}")
        seen.setdefault(real, (option, name))


def _check_meshcat(args):
    """Raise ImportError naming --html or --view, and the install command, without meshcat."""
    if (args.html is not None or args.view) and importlib.util.find_spec("meshcat") is None:
        from ..viz.playback import MESHCAT_HINT

        raise ImportError(f"{'--html' if args.html is not None else '--view'}: {MESHCAT_HINT}")


def _unwritable(name, path):
    """Why a file cannot be written at `path` (`name` as the user wrote it), or None: a name
    that ends like a folder's, a folder in its place, a folder that is missing or is a file, a
    read-only file, a folder where no file can be created (tried: a temporary file is created
    there and removed)."""
    if name.endswith(tuple(sep for sep in (os.sep, os.altsep) if sep)):
        return "names a folder, not a file"
    if path.is_dir():
        return "is a folder, not a file"
    if path.exists() and not path.is_file():  # a device or a pipe: written in place
        return None if os.access(path, os.W_OK) else "cannot be written (permission denied)"
    folder = path.parent
    if not folder.is_dir():
        blocking = next((p for p in (folder, *folder.parents) if p.exists()), None)
        if blocking is not None and not blocking.is_dir():
            return f"{blocking} is a file, not a folder"
        return f"the folder {folder} does not exist"
    if path.exists() and not os.access(path, os.W_OK):
        return "the file is read-only"
    real_folder = os.path.dirname(os.path.realpath(path))  # where atomic_write writes
    try:
        with tempfile.NamedTemporaryFile(dir=real_folder, prefix=".opendyn-check-"):
            pass
    except OSError as e:
        return f"no file can be written in the folder {folder} ({e.strerror})"
    return None


def _unplottable(path):
    """Why matplotlib cannot write a plot to `path` (its format, by the suffix), or None."""
    from matplotlib.backend_bases import FigureCanvasBase

    formats = FigureCanvasBase.get_supported_filetypes()
    suffix = path.suffix[1:].lower()
    if suffix and suffix not in formats:
        return f"matplotlib writes no .{suffix} files (it writes {', '.join(sorted(formats))})"
    return None


def _save_record(scene, traj, args) -> bool | None:
    """Save the trajectory: to -o, or by default to SCENE.npz (`_default_record`). Returns
    whether it was saved; None with --no-save."""
    if args.no_save:
        return None
    if args.output is not None:
        return _write("-o", args.output, lambda: saved_paths(traj.save(args.output)))
    name = _default_record(scene, traj.complete)
    return _write(DEFAULT_SAVE, name, lambda: saved_paths(traj.save(name)))


def _write_outputs(scene, traj, args, saved) -> bool:
    """Write the other outputs asked for: --csv, --plot, --html. One that fails does not stop
    the others; and when one failed and the trajectory has no file (`saved`: False, or None
    with --no-save), it goes to a fallback file (`_save_fallback`), so that the run is never
    lost. Returns whether everything asked for was written, the trajectory's file included."""
    writes = []
    if args.csv is not None:
        writes.append(("--csv", args.csv, lambda: [traj.to_csv(args.csv)]))
    if args.plot is not None:
        writes.append(("--plot", args.plot, lambda: [traj.plot(args.plot)]))
    if args.html is not None:
        writes.append(("--html", args.html, lambda: [_write_html(scene, traj, args.html)]))
    failed = saved is False
    for option, name, write in writes:
        failed = not _write(option, name, write) or failed
    if failed and not saved:
        with held_interrupt():
            _save_fallback(scene, traj)
    return not failed


def _write(option, name, write) -> bool:
    """Run `write()` (it returns the paths written) and print each path written, or say that
    the output `option` `name` could not be written, and why. Returns whether it was."""
    try:
        with _doing(f"writing {option} {name!r}"):
            paths = write()
    except Exception as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else e
        print(f"opendyn simulate: could not write {option} {name!r}: {reason}", file=sys.stderr)
        return False
    for path in paths:
        print(f"wrote {path}")
    return True


def _save_fallback(scene, traj):
    """Save the trajectory under a new name (SCENE-XXXXXXXX.npz and its .json) in the current
    folder or, failing that, the system's temporary folder, and say where; or say that neither
    could take it."""
    stem = pathlib.Path(_default_record(scene, traj.complete)).stem
    tried = []
    try:
        folders = [os.getcwd()]
    except OSError as e:  # the current folder was removed
        folders = []
        tried.append(f"the current folder ({e.strerror})")
    folders.append(tempfile.gettempdir())
    for folder in folders:
        try:
            fd, name = tempfile.mkstemp(prefix=f"{stem}-", suffix=".npz", dir=folder)
        except OSError as e:
            tried.append(f"{folder} ({e.strerror})")
            continue
        os.close(fd)  # the name is now reserved; the save replaces the empty file
        if _write("the fallback", name, lambda: saved_paths(traj.save(name))):
            print(f"opendyn simulate: the trajectory was saved to {name} instead", file=sys.stderr)
            return
        with contextlib.suppress(OSError):
            os.unlink(name)
        tried.append(folder)
    print(
        f"opendyn simulate: the trajectory could not be saved anywhere (tried {'; '.join(tried)})",
        file=sys.stderr,
    )


def _contact(traj):
    """The contact argument of viz.write_html and viz.view: None without contact."""
    if not traj.has_contact:
        return None
    return traj.ground_height, traj.contact_point, traj.contact_force


def _write_html(scene, traj, path):
    from ..viz import playback as viz

    return viz.write_html(scene.model, traj.t, traj.q, path, contact=_contact(traj))


def _view(scene, traj):
    from ..viz import playback as viz

    url = viz.view(scene.model, traj.t, traj.q, open_browser=True, contact=_contact(traj))
    print(f"meshcat viewer at {url} (Ctrl-C to quit)")
    _wait_for_interrupt()


def _wait_for_interrupt():
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass


def _slug(name):
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name).strip("_") or "scene"


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


def summary(scene, traj):
    """The run in a few lines: time, speed, steps, integrator statistics, energy."""
    stats = traj.stats
    wall = stats["wall_s"]
    simulated = stats["simulated_s"]
    factor = simulated / wall if wall > 0 else float("inf")
    status = "complete" if traj.complete else "STOPPED EARLY (partial record)"
    if stats["compile_s"] > 0:
        ready = (
            f"{stats['compile_s']:.3g} s more compiling the step, once per machine and opendyn "
            "version"
        )
    else:
        ready = f"{stats['load_s']:.2g} s more to load the compiled step"
    lines = [
        f"run         {status}",
        f"simulated   {simulated:.4g} s in {wall:.3g} s wall ({factor:.3g}x real time; {ready})",
        f"steps       {stats['steps']} accepted, {stats['rejected_steps']} rejected, "
        f"{stats['evaluations']} dynamics evaluations",
    ]
    if len(traj.t):
        energy = traj.energy
        error = np.abs(traj.energy_error)
        scale = max(np.abs(energy).max(), traj.kinetic.max(), 1e-300)
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
        from ..sim.simulate import QUATERNION_NORM_BOUND

        lines.append(
            f"base        max | |quat| - 1 | = {stats['quaternion_norm_error']:.2g} over the "
            f"samples (bound {QUATERNION_NORM_BOUND:g}: integrate keeps it a unit quaternion)"
        )
    if traj.has_contact and len(traj.t):
        lines.append(_contact_line(traj))
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


def _contact_line(traj):
    """The contact in one line: the points, the largest penetration and force, where and when."""
    names = traj.contact_names
    depth = traj.penetration
    force = np.linalg.norm(traj.contact_force, axis=2)
    k, p = np.unravel_index(np.argmax(depth), depth.shape)
    kf, pf = np.unravel_index(np.argmax(force), force.shape)
    return (
        f"contact     {len(names)} points on the ground z = {traj.ground_height:g} m: max "
        f"penetration {depth[k, p] * 1e3:.3g} mm ({names[p]} at t = {traj.t[k]:.4g} s), max "
        f"force {force[kf, pf]:.4g} N ({names[pf]} at t = {traj.t[kf]:.4g} s)"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="opendyn",
        description=__doc__.split("\n\n")[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("simulate", help="run a scene, a URDF or a robot and report")
    sim.add_argument(
        "target",
        nargs="?",
        help=f"scene file (.toml), shipped scene ({', '.join(shipped_scenes())}), URDF file or "
        f"robot name; default: {DEFAULT_SCENE}",
    )
    sim.add_argument("--duration", type=float, help="simulated time (s)")
    sim.add_argument("--dt", type=float, help="step (s); the first trial step of dopri5")
    sim.add_argument("--integrator", choices=INTEGRATORS)
    sim.add_argument("--rtol", type=float, help="dopri5 relative tolerance")
    sim.add_argument("--atol", type=float, help="dopri5 absolute tolerance")
    sim.add_argument("--output-dt", type=float, help="sample interval of the record (s)")
    sim.add_argument(
        "--enable",
        action="append",
        default=[],
        choices=sorted(ENABLE_FROM_URDF),
        help="switch an effect on, with the URDF's values (repeatable)",
    )
    sim.add_argument(
        "--disable",
        action="append",
        default=[],
        choices=EFFECTS,
        help="switch off an effect the scene names (repeatable)",
    )
    save = sim.add_mutually_exclusive_group()
    save.add_argument(
        "-o",
        "--output",
        help="trajectory .npz (and its .json provenance record); default: SCENE.npz in the "
        "current folder (SCENE-partial.npz for a run that stopped early)",
    )
    save.add_argument("--no-save", action="store_true", help="save no trajectory file")
    sim.add_argument("--csv", help="trajectory as CSV")
    sim.add_argument("--plot", help="PNG of joint positions, velocities and energy")
    sim.add_argument("--html", help="self-contained meshcat playback page (extra viz)")
    sim.add_argument("--view", action="store_true", help="play in the meshcat viewer (extra viz)")
    sim.add_argument("--profile", action="store_true", help="time each stage of the step")
    sim.add_argument("-q", "--quiet", action="store_true", help="print only failures")
    sim.set_defaults(run=_simulate)

    info = sub.add_parser("info", help="model summary and URDF fidelity report")
    info.add_argument("robot", nargs="?", help="URDF file or robot name")
    info.add_argument(
        "--cache", action="store_true", help="where the compiled kernels are cached, and how much"
    )
    info.add_argument("--mimic", action="store_true", help="couple mimic joints")
    info.add_argument(
        "--floating-base", action="store_true", help="make the root link a free body"
    )
    info.add_argument(
        "--keep-inertia", action="store_true", help="keep physically invalid inertias as written"
    )
    info.set_defaults(run=_info)

    verify = sub.add_parser("verify", help="compare every dynamics function with Pinocchio")
    verify.add_argument("robot", help="URDF file or robot name")
    verify.add_argument("--states", type=int, default=5, help="random states (default 5)")
    verify.add_argument("--seed", type=int, default=0)
    verify.add_argument("--rtol", type=float, default=1e-9, help="relative tolerance")
    verify.add_argument("--mimic", action="store_true", help="couple mimic joints")
    verify.add_argument(
        "--floating-base", action="store_true", help="make the root link a free body"
    )
    verify.add_argument(
        "--keep-inertia", action="store_true", help="keep physically invalid inertias as written"
    )
    verify.set_defaults(run=_verify)

    demo = sub.add_parser("demo", help="print M(q), g(q) and forward dynamics for a robot")
    demo.add_argument(
        "robot",
        nargs="?",
        default=DEFAULT_ROBOT,
        help=f"URDF file or robot name (default: {DEFAULT_ROBOT})",
    )
    demo.set_defaults(run=_demo)

    sw = sub.add_parser(
        "sweep",
        help="run a scene once per combination of varied keys, on a Dask cluster",
        description="Run a scene once per combination of the varied keys (or --samples random "
        "ones) on a local Dask cluster or an existing one; one Parquet row per run, written as "
        "runs finish; the same command resumes a stopped sweep.",
    )
    sw.add_argument("target", help="scene file, shipped scene, URDF file or robot name")
    sw.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=SPEC",
        help="a dotted scene key (control.kp, initial.q.JOINT, run.dt, robot.payload.mass...) "
        "and its values: a,b,c | lo:hi:n | log:lo:hi:n | uniform:lo:hi | normal:mu:sigma "
        "(repeatable; lists and grids multiply)",
    )
    sw.add_argument("--samples", type=int, help="draw N random combinations (seeded)")
    sw.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    where = sw.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="local worker processes (default: the cores)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler")
    sw.add_argument(
        "-o", "--output", help="results table (.parquet); default: SCENE-sweep.parquet"
    )
    sw.add_argument("--trajectories", metavar="DIR", help="save every run's trajectory here")
    sw.add_argument(
        "--outputs",
        help="metrics to compute, comma-separated (default: every one that applies)",
    )
    sw.add_argument("--plot", help="PNG of a metric against the varied keys")
    sw.add_argument("--metric", help="the metric --plot draws (default: the scene's main one)")
    sw.add_argument("--chunk", type=int, help="runs per task (default: chosen from the count)")
    sw.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    sw.set_defaults(run=_sweep)

    comp = sub.add_parser(
        "compile",
        help="compile the kernels ahead of time (Docker images, CI images, cluster workers)",
    )
    comp.add_argument(
        "scenes",
        nargs="*",
        help="scene files or shipped scene names: compile what they need (default: --all)",
    )
    comp.add_argument(
        "--all",
        action="store_true",
        help="every core function and every shipped scene whose robot is installed",
    )
    comp.set_defaults(run=_compile_ahead)

    args = parser.parse_args(argv)
    with warnings.catch_warnings(), SigtermAsInterrupt() as signals:
        warnings.showwarning = _warning_printer(args.command)
        return _run(args, signals)


def _warning_printer(command):
    """showwarning for the command: a scene's warnings as one line, "opendyn CMD: warning: ..."
    on stderr; any other warning as Python prints it."""
    default = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, SceneWarning):
            print(f"opendyn {command}: warning: {message}", file=sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)

    return show


def _run(args, signals) -> int:
    """Run the command; bad input (2) and Ctrl-C or SIGTERM (`signals`: 130 or 143) become one
    line on stderr and the exit status."""
    try:
        return args.run(args)
    except KeyboardInterrupt as e:
        doing = f" while {e}" if isinstance(e, _Interrupted) else ""
        print(
            f"opendyn {args.command}: interrupted ({signal_name(signals.signum)}){doing}",
            file=sys.stderr,
        )
        return signals.exit_status
    except (URDFError, SceneError, ValueError, KeyError, ImportError, OSError) as e:
        hint = ""
        if "check_inertia=False" in str(e) and args.command in ("info", "verify"):
            hint = f"\n(opendyn {args.command} --keep-inertia ROBOT loads it anyway)"
        print(f"opendyn {args.command}: {e}{hint}", file=sys.stderr)
        return 2

