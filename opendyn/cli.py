"""The `opendyn` command: `opendyn demo [ROBOT]` and `opendyn info ROBOT`."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from . import forward_dynamics, gravity_forces, inverse_dynamics, load_urdf, mass_matrix
from .urdf import URDFError

DEFAULT_ROBOT = "double_pendulum"


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
    model = load_urdf(args.robot, mimic=args.mimic, check_inertia=not args.keep_inertia)
    print(model.summary())
    print()
    print(model.report)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="opendyn", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="print M(q), g(q) and forward dynamics for a robot")
    demo.add_argument(
        "robot",
        nargs="?",
        default=DEFAULT_ROBOT,
        help=f"URDF file or robot name (default: {DEFAULT_ROBOT})",
    )
    demo.set_defaults(run=_demo)
    info = sub.add_parser("info", help="model summary and URDF fidelity report")
    info.add_argument("robot", help="URDF file or robot name")
    info.add_argument("--mimic", action="store_true", help="couple mimic joints")
    info.add_argument(
        "--keep-inertia", action="store_true", help="keep physically invalid inertias as written"
    )
    info.set_defaults(run=_info)
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (URDFError, ValueError, KeyError) as e:
        hint = ""
        if "check_inertia=False" in str(e) and args.command == "info":
            hint = "\n(opendyn info --keep-inertia ROBOT loads it anyway)"
        print(f"opendyn {args.command}: {e}{hint}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
