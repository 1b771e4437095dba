"""The `opendyn` command: its arguments, and each command run with bad input, Ctrl-C and SIGTERM
answered in one line and an exit status (the commands are the modules beside this one).

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
"""

from __future__ import annotations

import argparse
import sys
import warnings

from .._runtime.signals import SigtermAsInterrupt, signal_name
from ..errors import SceneError, SceneWarning, URDFError, URDFWarning
from ..io.scene.files import DEFAULT_SCENE, shipped_scenes
from ..sim.effects import registry
from ..sim.run import integrator_names
from .cache import _compile_ahead
from .interrupts import _Interrupted
from .robot import DEFAULT_ROBOT, _demo, _info, _verify
from .simulate import ENABLE_FROM_URDF, _simulate
from .stdout import reader_may_leave
from .sweep import _sweep


def _option_value(text: str, convert, kind: str):
    """An option's value as written, by `convert` (float or int); argparse's error for anything
    else, including the digit separators Python takes ("0_2" is not 0.2)."""
    if "_" in text:
        raise argparse.ArgumentTypeError(f"invalid {kind}: {text!r} (no digit separators)")
    try:
        return convert(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid {kind}: {text!r}") from None


def number(text: str) -> float:
    """An option's number: a decimal or scientific float."""
    return _option_value(text, float, "number")


def whole(text: str) -> int:
    """An option's whole number (no "1e3")."""
    return _option_value(text, int, "whole number")


def seed(text: str) -> int:
    """An option's random seed: a whole number >= 0, as numpy takes it."""
    value = whole(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"invalid seed: {text!r} (a whole number >= 0)")
    return value


def main(argv=None) -> int:
    args = command_line().parse_args(argv)
    with warnings.catch_warnings(), SigtermAsInterrupt() as signals, reader_may_leave():
        warnings.showwarning = _warning_printer(args.command)
        return _run(args, signals)


def command_line() -> argparse.ArgumentParser:
    """The `opendyn` command's parser: every command, its arguments and their help (the
    documentation's command-line reference is its `--help`)."""
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
    sim.add_argument(
        "--floating-base",
        action="store_true",
        help="make the robot's root link a free body (robot.floating_base = true)",
    )
    sim.add_argument("--duration", type=number, help="simulated time (s)")
    sim.add_argument("--dt", type=number, help="step (s); the first trial step of dopri5")
    sim.add_argument("--integrator", choices=integrator_names())
    sim.add_argument("--rtol", type=number, help="dopri5 relative tolerance")
    sim.add_argument("--atol", type=number, help="dopri5 absolute tolerance")
    sim.add_argument("--output-dt", type=number, help="sample interval of the record (s)")
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
        choices=registry.names(),
        help="switch off an effect the scene names (repeatable)",
    )
    sim.add_argument(
        "--controller",
        metavar="FILE.py:FUNCTION",
        help="a Python controller fn(t, q, qd) -> tau, called every control period with its "
        "torque held in between (or MODULE:FUNCTION)",
    )
    sim.add_argument(
        "--control-dt",
        type=number,
        metavar="DT",
        help="the controller's period (s); default: the scene's control_dt, else its dt",
    )
    save = sim.add_mutually_exclusive_group()
    save.add_argument(
        "-o",
        "--output",
        help="trajectory .npz (and its .json provenance record beside it); default: SCENE.npz "
        "and SCENE.json in the current folder, SCENE the scene file's or shipped scene's name "
        "(SCENE-partial.npz for a run that stopped early)",
    )
    save.add_argument("--no-save", action="store_true", help="save no trajectory file")
    sim.add_argument(
        "--csv",
        help="trajectory as CSV, with contacts between collision geometries their table beside "
        "it (run.csv: run.contacts.csv); run-partial.csv for a run that stopped early",
    )
    sim.add_argument("--plot", help="PNG of joint positions, velocities and energy")
    sim.add_argument("--html", help="self-contained meshcat playback page (extra viz)")
    sim.add_argument("--view", action="store_true", help="play in the meshcat viewer (extra viz)")
    sim.add_argument(
        "--collision",
        action="store_true",
        help="with --html or --view: draw the collision geometry instead of the visual geometry",
    )
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
    verify.add_argument("--states", type=whole, default=5, help="random states (default 5)")
    verify.add_argument("--seed", type=seed, default=0)
    verify.add_argument("--rtol", type=number, default=1e-9, help="relative tolerance")
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
        "--floating-base",
        action="store_true",
        help="make the robot's root link a free body (robot.floating_base = true)",
    )
    sw.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=SPEC",
        help="a dotted scene key (control.kp, initial.q.JOINT, run.dt, robot.payload.mass...) "
        "and its values: a,b,c | lo:hi:n | log:lo:hi:n | uniform:lo:hi | normal:mu:sigma "
        "(repeatable; lists and grids multiply)",
    )
    sw.add_argument("--samples", type=whole, help="draw N random combinations (seeded)")
    sw.add_argument("--seed", type=seed, default=0, help="seed of the draws (default 0)")
    where = sw.add_mutually_exclusive_group()
    where.add_argument("--workers", type=whole, help="local worker processes (default: the cores)")
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
    sw.add_argument("--chunk", type=whole, help="runs per task (default: chosen from the count)")
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
    comp.add_argument(
        "--export",
        metavar="FOLDER",
        help="then write the kernels these need into FOLDER, to ship as opendyn/_kernels "
        "(scripts/build_wheel.py): the functions' and the scenes' simulate, not their "
        "rollouts; refused when a shipped scene's robot is missing",
    )
    comp.set_defaults(run=_compile_ahead)
    return parser


def _warning_printer(command):
    """showwarning for the command: a scene's and a URDF's warnings as one line, "opendyn CMD:
    warning: ..." on stderr; any other warning as Python prints it."""
    default = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, (SceneWarning, URDFWarning)):
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
        elif "check_inertia=False" in str(e) and args.command in ("simulate", "sweep"):
            hint = "\n(a scene with robot.check_inertia = false loads it anyway)"
        print(f"opendyn {args.command}: {e}{hint}", file=sys.stderr)
        return 2
