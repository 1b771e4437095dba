"""`opendyn info`, `opendyn verify` and `opendyn demo`: a robot's summary and URDF fidelity report,
every contract function against Pinocchio, and M(q), g(q) and forward dynamics at one state."""

from __future__ import annotations

import sys
import time

import numpy as np

from ..algorithm.crba import mass_matrix
from ..algorithm.forward import forward_dynamics
from ..algorithm.rnea import gravity_forces, inverse_dynamics
from ..io.urdf import load_urdf, welded_mobile_warning
from .cache import _cache_info

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
        warning = welded_mobile_warning(
            model, "load it with --floating-base (load_urdf(..., floating_base=True))"
        )
        if warning:
            print(f"warning: {warning}", file=sys.stderr)
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
