"""The output files of `opendyn simulate`: each checked before the run (a file that cannot be
written, or that two options name, stops the command before anything is loaded), each written
after it with what failed said, and a fallback file for a trajectory that would otherwise be lost.

`opendyn simulate` saves the trajectory by default: SCENE.npz and SCENE.json (its provenance
record) in the current folder (SCENE the scene file's name without .toml, which is a shipped
scene's name; SCENE-partial.npz for a run that stopped early, so that it never replaces a
complete record), `-o` elsewhere, `--no-save` not at all. `--csv NAME.csv` writes NAME.csv, with
contacts between collision geometries NAME.contacts.csv beside it. A run that stopped early
writes every output under its partial name, NAME-partial.SUFFIX (-o run.npz: run-partial.npz
and .json; --csv, --plot, --html likewise), never over a complete run's.
"""

from __future__ import annotations

import contextlib
import os
import pathlib
import sys
import tempfile

from .._runtime.files import unwritable
from .._runtime.signals import held_interrupt
from ..io.meshes import mesh_files
from ..sim.effects import geometry_contact
from ..sim.effects.geometry_contact import GROUND
from ..sim.effects.python_control import function_parts
from ..sim.trajectory import contacts_csv_path, saved_paths
from .interrupts import _doing

# the options of `simulate` that name an output file, and their attributes in args
OUTPUT_OPTIONS = {"-o": "output", "--csv": "csv", "--plot": "plot", "--html": "html"}
DEFAULT_SAVE = "the trajectory"  # how messages name the file saved without -o
DEFAULT_SAVE_HINT = "-o names another file, --no-save skips saving"


def _default_record(scene, complete):
    """The trajectory's file without -o: SCENE.npz in the current folder, SCENE-partial.npz for
    a run that stopped early (`_for_run`)."""
    return _for_run(f"{scene_stem(scene)}.npz", complete)


def _for_run(name, complete):
    """The file of the output `name` for a run: `name` for a complete run; for a run that
    stopped early NAME-partial.SUFFIX beside it (run.csv -> run-partial.csv), so that it never
    replaces a complete run's."""
    if complete:
        return name
    folder, base = os.path.split(name)
    stem, suffix = os.path.splitext(base)
    return os.path.join(folder, f"{stem}-partial{suffix}")


def scene_stem(scene):
    """What a scene's default outputs are named after: its file's name without .toml (for a
    shipped scene, the name it is run by), else (a URDF, a dict) its name made file-safe."""
    source = pathlib.Path(scene.source)
    return _slug(source.stem) if source.suffix == ".toml" else _slug(scene.name)


def _named_outputs(args):
    """(option, name, path) for each file the options name, for a complete run and for one
    that stopped early (`_for_run`): -o's .npz and its .json record, --csv, --plot, --html.
    Raises ValueError for an empty name."""
    named = []
    for option, attr in OUTPUT_OPTIONS.items():
        name = getattr(args, attr)
        if name is None:
            continue
        if not name.strip():
            raise ValueError(f"{option}: the file name is empty")
        if option == "-o" and os.path.isdir(name):
            raise ValueError(f"{option} {name}: is a folder, not a file; name the .npz to write")
        for complete in (True, False):
            path = _for_run(name, complete)
            paths = saved_paths(path) if option == "-o" else [pathlib.Path(path)]
            named += [(option, name, path) for path in paths]
    return named


def _scene_outputs(scene, args, named):
    """(option, name, path) for each file that `scene` adds to the outputs the options name
    (`named`): without -o and --no-save the default record, complete and partial, with its
    .json (`_default_record`); with contacts between collision geometries, the contact table
    beside each of --csv's files (run.csv -> run.contacts.csv, contacts_csv_path)."""
    found = []
    if args.output is None and not args.no_save:
        names = [_default_record(scene, complete) for complete in (True, False)]
        found += [(DEFAULT_SAVE, name, path) for name in names for path in saved_paths(name)]
    if geometry_contact.record(scene) is not None:
        found += [(o, name, contacts_csv_path(path)) for o, name, path in named if o == "--csv"]
    return found


def _check_outputs(outputs, others=()):
    """Raise ValueError naming the option and the file for the first of `outputs` (option,
    name, path) that cannot be written (`unwritable`), that is also the file of another
    output (of `outputs` or `others`), or, for --plot, whose format matplotlib does not write.
    Quick: nothing is loaded or run."""
    seen = {}  # real path: the first output (option, name, path) that writes it
    for option, name, path in (*others, *outputs):
        seen.setdefault(os.path.realpath(path), (option, name, path))
    for option, name, path in outputs:
        problem = unwritable(name, path)
        other, other_name, other_path = seen[os.path.realpath(path)]
        if problem is None and (other, other_name) != (option, name):
            which = f" {other_path}" if other_path != pathlib.Path(other_name) else ""
            problem = f"is also the file{which} of {other} {other_name!r}"
        if problem is None and option == "--plot":
            problem = _unplottable(path)
        if problem is not None:
            hint = f" ({DEFAULT_SAVE_HINT})" if option == DEFAULT_SAVE else ""
            raise _refused(option, name, path, problem + hint)


def _check_not_inputs(outputs, scene, controller=None):
    """Raise ValueError naming the option and the file for the first of `outputs` (option,
    name, path) that is one of the run's inputs (`_inputs`): writing it would replace the
    scene, the robot or the controller with a record."""
    inputs = _inputs(scene, controller)
    for option, name, path in outputs:
        what = inputs.get(os.path.realpath(path))
        if what is not None:
            raise _refused(
                option, name, path, f"is {what}, an input of this run; writing the output "
                "there would replace it: name another file"
            )


def _refused(option, name, path, problem):
    """The ValueError that refuses an output before the run: its option, the name given, the
    file where it is another (-o's .json, --csv's contact table or partial file), and why."""
    which = f" {path}:" if path != pathlib.Path(name) else ""
    return ValueError(f"{option} {name!r}:{which} {problem}")


def _inputs(scene, controller):
    """{real path: what it is} of every file the run reads: the scene file, the robot's URDF,
    the files the scene names (SRDF, objects' URDFs, world meshes, its controller's file), the
    meshes those URDFs name, and the file of --controller FILE.py:NAME."""
    inputs = {}
    named = list(scene.inputs())
    urdfs = [path for path, _ in named if str(path).endswith(".urdf")]
    named += [(mesh, "a mesh of the robot or an object") for u in urdfs for mesh in mesh_files(u)]
    where, _ = function_parts(controller) if controller else (None, None)
    if where is not None and where.endswith(".py"):
        named.append((where, "the controller's file"))
    for path, what in named:
        if path and os.path.isfile(path):
            inputs.setdefault(os.path.realpath(path), what)
    return inputs


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
        name = _for_run(args.output, traj.complete)
        return _write("-o", name, lambda: saved_paths(traj.save(name)))
    name = _default_record(scene, traj.complete)
    return _write(DEFAULT_SAVE, name, lambda: saved_paths(traj.save(name)))


def _write_outputs(scene, traj, args, saved) -> bool:
    """Write the other outputs asked for: --csv, --plot, --html. One that fails does not stop
    the others; and when one failed and the trajectory has no file (`saved`: False, or None
    with --no-save), it goes to a fallback file (`_save_fallback`), so that the run is never
    lost. Returns whether everything asked for was written, the trajectory's file included."""
    csv, plot, html = (
        None if name is None else _for_run(name, traj.complete)
        for name in (args.csv, args.plot, args.html)
    )
    writes = []
    if csv is not None:
        writes.append(("--csv", csv, lambda: _write_csv(traj, csv)))
    if plot is not None:
        writes.append(("--plot", plot, lambda: [traj.plot(plot)]))
    if html is not None:
        writes.append(("--html", html, lambda: [_write_html(scene, traj, html, args.collision)]))
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
        if isinstance(e, MemoryError):
            reason = f"out of memory ({e})" if str(e) else "out of memory"
        where = getattr(e, "filename", None)
        if where and os.path.basename(where) != os.path.basename(name):
            reason = f"{where}: {reason}"  # another of the output's files than the one named
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


def _contact(scene, traj):
    """The contact argument of viz.write_html and viz.view: None without contact; between
    collision geometries, the contact table's slots (the force on each pair's moving body)."""
    geometry = geometry_contact.record(scene)
    if geometry is not None and traj.contacts is not None:
        body = scene.model.geometry_table.body
        static = {GROUND} | {
            g.name for k, g in enumerate(scene.model.geometries) if body[k] < 0
        }
        points, forces = traj.contacts.slots(len(traj.t), static)
        return geometry.ground_height, points, forces
    if not traj.has_contact:
        return None
    return traj.ground_height, traj.contact_point, traj.contact_force


def _write_html(scene, traj, path, collision=False):
    from ..viz import playback as viz

    return viz.write_html(
        scene.model, traj.t, traj.q, path, contact=_contact(scene, traj), collision=collision
    )


def _slug(name):
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name).strip("_") or "scene"


def _write_csv(traj, name) -> list:
    """The trajectory's CSV at `name` (a stopped run's partial name already, `_for_run`), and
    its contact table's beside it when it has one: the paths written."""
    path = traj.to_csv(name)
    return [path] if traj.contacts is None else [path, contacts_csv_path(path)]
