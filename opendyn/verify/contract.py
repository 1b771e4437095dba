"""The largest difference between each contract function of opendyn and Pinocchio's answer for
the same URDF, over random states: ``verify(robot) -> [Check]``, ``format_table(checks, model)``.

For every function f and every state k (and frame, for frame functions)

    abs error = max_entries |f_opendyn - f_Pinocchio|
    rel error = abs error / max(1, max_entries |f_Pinocchio|)

and a function passes when its largest rel error over all states is at most ``rtol``. The floor
of 1 makes answers near zero (a potential energy, a Jacobian column) compare absolutely.

The oracle, and every conversion between Pinocchio's conventions and opendyn's, is
``opendyn.verify.oracle``; ``verify`` raises its PinocchioMissingError (an ImportError) when
Pinocchio is not installed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from .._runtime.options import whole
from ..algorithm.aba_derivatives import forward_dynamics_derivatives
from ..algorithm.centroidal import (
    center_of_mass,
    center_of_mass_jacobian,
    centroidal_momentum,
    centroidal_momentum_matrix,
    centroidal_momentum_rate_bias,
)
from ..algorithm.christoffel import christoffel_symbols, coriolis_matrix
from ..algorithm.configuration import random_configuration
from ..algorithm.crba import mass_matrix
from ..algorithm.energy import kinetic_energy, potential_energy
from ..algorithm.forward import METHODS, forward_dynamics
from ..algorithm.kinematics import frame_pose, jacobian
from ..algorithm.regressor import torque_regressor
from ..algorithm.rnea import bias_forces, coriolis_forces, gravity_forces, inverse_dynamics
from ..algorithm.rnea_derivatives import inverse_dynamics_derivatives
from ..algorithm.task_space import task_space_mass_matrix
from ..errors import SingularMassMatrixError
from ..io.urdf import load_urdf
from ..multibody.model import Model
from .oracle import PinocchioMissingError, PinocchioOracle, import_pinocchio

# the public names: verify, its rows and their table, and the error it raises without Pinocchio
__all__ = ["Check", "PinocchioMissingError", "format_table", "random_states", "tip_frame", "verify"]

# gravity override used by the checks (m/s^2, world frame): not parallel to any axis
OTHER_GRAVITY = np.array([0.3, -0.2, -1.62])

# Lambda is compared only where Pinocchio's J_b M^-1 J_b^T has a condition number below this:
# inverting it multiplies rounding errors by about that much
TASK_SPACE_MAX_CONDITION = 1e6

# M is singular (forward dynamics must be refused) below this fraction of its largest entry
SINGULAR_M = 1e-12


@dataclass
class Check:
    """How far one opendyn function is from Pinocchio over the random states.

    max_abs_error: the largest |opendyn - Pinocchio| entry over every state (and frame).
    max_rel_error: the largest abs error / max(1, largest |entry| of Pinocchio's answer).
    states: number of states compared (0: none, e.g. Lambda undefined everywhere; see note).
    passed: max_rel_error <= rtol (and opendyn raised nothing it should not have).
    rtol: the tolerance used; note: what was skipped, or where the worst error was.
    """

    function: str
    max_abs_error: float
    max_rel_error: float
    states: int
    passed: bool
    rtol: float = 1e-9
    note: str = ""


@dataclass
class _Row:
    """Accumulates the comparisons of one function."""

    function: str
    abs_error: float = 0.0
    rel_error: float = 0.0
    states: set = field(default_factory=set)
    worst: str = ""
    failures: list = field(default_factory=list)
    remarks: dict = field(default_factory=dict)  # remark -> states it applies to

    def compare(self, k, ours, ref, where=""):
        """Compare ``ours()`` (called here, so that an exception is a failure of this
        function) with Pinocchio's ``ref`` at state k."""
        self.states.add(k)
        at = f"state {k}" + (f", {where}" if where else "")
        try:
            got = np.asarray(ours(), dtype=float)
        except Exception as e:  # noqa: BLE001 - any opendyn error is this function failing
            return self.fail(f"{at}: opendyn raised {type(e).__name__}: {_first_line(e)}")
        ref = np.asarray(ref, dtype=float)
        if got.shape != ref.shape:
            return self.fail(f"{at}: shape {got.shape}, Pinocchio's {ref.shape}")
        if ref.size == 0:
            return
        abs_error = float(np.max(np.abs(got - ref)))
        if not np.isfinite(abs_error):
            return self.fail(f"{at}: opendyn returned a non-finite number")
        rel_error = abs_error / max(1.0, float(np.max(np.abs(ref))))
        self.abs_error = max(self.abs_error, abs_error)
        if rel_error > self.rel_error:
            self.rel_error, self.worst = rel_error, at

    def expect_raise(self, k, ours, error, why):
        """At state k opendyn must raise ``error``: Pinocchio's answer is undefined (why)."""
        self.states.add(k)
        try:
            ours()
        except error:
            return self.remark(k, f"{why}: refused as expected")
        except Exception as e:  # noqa: BLE001
            return self.fail(f"state {k}: {why}; opendyn raised {type(e).__name__}: {e}")
        self.fail(f"state {k}: {why}, but opendyn returned an answer")

    def remark(self, k, remark):
        """Something to report about state k that is not a failure (e.g. a skipped state)."""
        self.remarks.setdefault(remark, []).append(k)

    def fail(self, message):
        self.abs_error = self.rel_error = np.inf
        self.failures.append(message)

    def check(self, rtol):
        passed = bool(self.rel_error <= rtol)
        notes = list(self.failures)
        if not passed and self.worst and np.isfinite(self.rel_error):
            notes.append(f"worst at {self.worst}")
        for remark, ks in self.remarks.items():
            ks = sorted(set(ks))
            notes.append(f"{remark} (state{'s' * (len(ks) > 1)} {', '.join(map(str, ks))})")
        return Check(
            function=self.function,
            max_abs_error=self.abs_error,
            max_rel_error=self.rel_error,
            states=len(self.states),
            passed=passed,
            rtol=rtol,
            note="; ".join(notes),
        )


def _first_line(e):
    text = str(e).strip().splitlines()
    return text[0] if text else ""


def random_states(model, n, seed):
    """n random states, fixed by seed: q from random_configuration (joints uniform within
    their limits, or +-pi rad / +-1 m where a joint has none; a free joint anywhere in the
    cube [-1, 1]^3 m with a uniformly random rotation); qd, qdd and tau standard normal; F (6,)
    a standard normal wrench. Yields (q (nq,), qd, qdd, tau (nv,), F (6,)), in opendyn's order."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = random_configuration(model, rng)
        qd, qdd, tau = rng.normal(size=(3, model.nv))
        yield q, qd, qdd, tau, rng.normal(size=6)


def tip_frame(model):
    """The frame the f_tip and task-space checks use: the last frame (URDF order) on the last
    moving body; None for a model without moving bodies."""
    on_last = [f.name for f in model.frames if model.nb and f.body == model.nb - 1]
    return on_last[-1] if on_last else None


def _load(robot, mimic, check_inertia, floating_base):
    if isinstance(robot, Model):
        if not robot.source or not os.path.isfile(robot.source):
            raise ValueError(
                f"verify: model {robot.name!r} has no URDF file to give Pinocchio "
                f"(model.source is {robot.source!r}); pass the URDF path instead"
            )
        return robot
    return load_urdf(robot, mimic=mimic, check_inertia=check_inertia, floating_base=floating_base)


def verify(
    robot, *, states=5, seed=0, rtol=1e-9, mimic=False, check_inertia=True, floating_base=False
):
    """Compare every contract function of opendyn with Pinocchio on one robot.

    Args:
      robot: a Model (compared with Pinocchio's model of ``model.source``, its URDF, with the
        mimic choice it was loaded with), a URDF path or a robot name (as ``load_urdf``).
      states: number of random states (``random_states``: q within the joint limits or +-pi,
        qd, qdd, tau standard normal), fixed by ``seed``.
      rtol: a function passes when max |opendyn - Pinocchio| / max(1, max |Pinocchio|) <= rtol
        at every state.
      mimic, check_inertia, floating_base: passed to ``load_urdf`` when robot is a path or a
        name (a floating base is compared with Pinocchio's JointModelFreeFlyer root).
    Returns one Check per function, in this order: inverse_dynamics (plain, with an f_tip
    wrench on ``tip_frame``, with gravity (0.3, -0.2, -1.62)), mass_matrix, gravity_forces,
    coriolis_forces, bias_forces, coriolis_matrix, christoffel_symbols,
    forward_dynamics[aba|crba|newton_euler] (plain and with the f_tip wrench),
    inverse_dynamics_derivatives and forward_dynamics_derivatives (plain and with the f_tip
    wrench; q-derivatives in the tangent space, as Pinocchio's), frame_pose and
    jacobian[space], jacobian[body] on every frame, kinetic_energy, potential_energy,
    task_space_mass_matrix on ``tip_frame`` (only where J_b M^-1 J_b^T has a condition number
    below 1e6), center_of_mass, center_of_mass_jacobian, centroidal_momentum_matrix,
    centroidal_momentum, centroidal_momentum_rate_bias, torque_regressor. Functions taking a
    gravity argument are checked with the default and the override.
    Raises PinocchioMissingError (an ImportError) when Pinocchio is not installed, ValueError
    when Pinocchio cannot load the URDF or for bad arguments.
    """
    import_pinocchio()
    if isinstance(states, bool) or not isinstance(states, (int, np.integer)) or states < 1:
        raise ValueError(f"verify: states must be an integer >= 1, got {states!r}")
    if not (isinstance(rtol, (int, float)) and rtol > 0 and np.isfinite(rtol)):
        raise ValueError(f"verify: rtol must be a finite number > 0, got {rtol!r}")
    whole(seed, "verify: seed", minimum=0)
    model = _load(robot, mimic, check_inertia, floating_base)
    try:
        P = PinocchioOracle(model.source, model, mimic=model.coupled)
    except (ValueError, RuntimeError) as e:
        raise ValueError(f"verify: Pinocchio cannot load {model.source}: {e}") from e

    rows = {}

    def row(name):
        return rows.setdefault(name, _Row(name))

    tip = tip_frame(model)
    frames = [f.name for f in model.frames]
    zero = np.zeros(model.nv)
    g2 = OTHER_GRAVITY
    for k, (q, qd, qdd, tau, F) in enumerate(random_states(model, states, seed)):
        f_tip = {tip: F} if tip else None
        row("inverse_dynamics").compare(
            k, lambda: inverse_dynamics(model, q, qd, qdd), P.rnea(q, qd, qdd)
        )
        if f_tip:
            row("inverse_dynamics[f_tip]").compare(
                k,
                lambda: inverse_dynamics(model, q, qd, qdd, f_tip=f_tip),
                P.rnea(q, qd, qdd, f_tip=f_tip),
                f"f_tip on {tip!r}",
            )
        row("inverse_dynamics[gravity]").compare(
            k,
            lambda: inverse_dynamics(model, q, qd, qdd, gravity=g2),
            P.rnea(q, qd, qdd, gravity=g2),
        )
        M_ref = P.mass_matrix(q)
        row("mass_matrix").compare(k, lambda: mass_matrix(model, q), M_ref)
        for g in (None, g2):
            row("gravity_forces").compare(
                k, lambda: gravity_forces(model, q, gravity=g), P.gravity_forces(q, g)
            )
        row("coriolis_forces").compare(
            k, lambda: coriolis_forces(model, q, qd), P.rnea(q, qd, zero, gravity=(0, 0, 0))
        )
        for g in (None, g2):
            row("bias_forces").compare(
                k, lambda: bias_forces(model, q, qd, gravity=g), P.rnea(q, qd, zero, gravity=g)
            )
        if model.floating_base and P.coupled:
            row("coriolis_matrix").remark(
                k, "no reference: Pinocchio has no Coriolis matrix for coupled mimic joints"
            )
        else:
            row("coriolis_matrix").compare(
                k, lambda: coriolis_matrix(model, q, qd), P.coriolis_matrix(q, qd)
            )
        row("christoffel_symbols").compare(
            k, lambda: christoffel_symbols(model, q), P.christoffel(q)
        )
        singular = model.nv and np.linalg.eigvalsh(M_ref)[0] <= SINGULAR_M * np.abs(M_ref).max()
        variants = [{}] + ([{"f_tip": f_tip}] if f_tip else [])
        for method in METHODS:
            fd = row(f"forward_dynamics[{method}]")
            for loads in variants:
                if singular:
                    fd.expect_raise(
                        k,
                        lambda: forward_dynamics(model, q, qd, tau, method=method, **loads),
                        SingularMassMatrixError,
                        "M is singular",
                    )
                else:
                    fd.compare(
                        k,
                        lambda: forward_dynamics(model, q, qd, tau, method=method, **loads),
                        P.aba(q, qd, tau, **loads),
                        "with f_tip" if loads else "",
                    )
        _derivatives(row, model, P, k, (q, qd, qdd, tau), variants, singular)
        for name in frames:
            row("frame_pose").compare(
                k, lambda: frame_pose(model, q, name), P.frame_pose(q, name), f"frame {name!r}"
            )
            for where in ("space", "body"):
                row(f"jacobian[{where}]").compare(
                    k,
                    lambda: jacobian(model, q, name, expressed_in=where),
                    P.jacobian(q, name, where),
                    f"frame {name!r}",
                )
        row("kinetic_energy").compare(
            k, lambda: kinetic_energy(model, q, qd), P.kinetic_energy(q, qd)
        )
        for g in (None, g2):
            row("potential_energy").compare(
                k, lambda: potential_energy(model, q, gravity=g), P.potential_energy(q, g)
            )
        _task_space(row("task_space_mass_matrix"), model, P, k, q, tip, singular)
        _centroidal_and_regressor(row, model, P, k, (q, qd, qdd))
    return [r.check(rtol) for r in rows.values()]


def _derivatives(row, model, P, k, state, variants, singular):
    """inverse_dynamics_derivatives and forward_dynamics_derivatives (their three matrices
    stacked) against computeRNEADerivatives and computeABADerivatives, plain and with each
    variant's loads; where M is singular the forward derivatives must be refused."""
    q, qd, qdd, tau = state
    for loads in variants:
        where = "with f_tip" if loads else ""
        row("inverse_dynamics_derivatives").compare(
            k,
            lambda: np.stack(inverse_dynamics_derivatives(model, q, qd, qdd, **loads)),
            np.stack(P.rnea_derivatives(q, qd, qdd, **loads)),
            where,
        )
        fd = row("forward_dynamics_derivatives")
        if singular:
            fd.expect_raise(
                k,
                lambda: forward_dynamics_derivatives(model, q, qd, tau, **loads),
                SingularMassMatrixError,
                "M is singular",
            )
        else:
            fd.compare(
                k,
                lambda: np.stack(forward_dynamics_derivatives(model, q, qd, tau, **loads)),
                np.stack(P.aba_derivatives(q, qd, tau, **loads)),
                where,
            )


def _centroidal_and_regressor(row, model, P, k, state):
    """The centre of mass, its Jacobian, the centroidal momentum, its matrix and Adot_G qd
    (refused where nothing that moves has mass: no centre of mass), and the torque regressor,
    at state k = (q, qd, qdd); with coupled mimic joints Pinocchio has no Adot_G qd nor
    regressor to compare with."""
    q, qd, qdd = state
    centroidal = (
        ("center_of_mass", lambda: center_of_mass(model, q), P.center_of_mass, (q,)),
        (
            "center_of_mass_jacobian",
            lambda: center_of_mass_jacobian(model, q),
            P.center_of_mass_jacobian,
            (q,),
        ),
        (
            "centroidal_momentum_matrix",
            lambda: centroidal_momentum_matrix(model, q),
            P.centroidal_momentum_matrix,
            (q,),
        ),
        (
            "centroidal_momentum",
            lambda: centroidal_momentum(model, q, qd),
            P.centroidal_momentum,
            (q, qd),
        ),
        (
            "centroidal_momentum_rate_bias",
            lambda: centroidal_momentum_rate_bias(model, q, qd),
            P.centroidal_momentum_rate_bias,
            (q, qd),
        ),
    )
    massless = not np.sum(model.mass) > 0
    # Pinocchio's dccrba and joint-torque regressor refuse coupled mimic joints
    refused = ("centroidal_momentum_rate_bias", "torque_regressor") if P.coupled else ()
    regressor = (
        "torque_regressor",
        lambda: torque_regressor(model, q, qd, qdd),
        P.torque_regressor,
        (q, qd, qdd),
    )
    for name, ours, reference, arguments in (*centroidal, regressor):
        if name in refused:
            row(name).remark(k, "no reference: Pinocchio has none for coupled mimic joints")
        elif massless and name != "torque_regressor":
            row(name).expect_raise(k, ours, ValueError, "no moving mass")
        else:
            row(name).compare(k, ours, reference(*arguments))


def _task_space(r, model, P, k, q, tip, singular):
    """Lambda on the tip frame where Pinocchio's J_b M^-1 J_b^T is well conditioned; where M
    is singular opendyn must refuse."""
    if tip is None:
        return r.remark(k, "not compared: no frame on a moving body")
    if model.nv < 6:
        return r.remark(k, f"undefined: J_b M^-1 J_b^T has rank <= nv = {model.nv} < 6")
    if singular:
        return r.expect_raise(
            k,
            lambda: task_space_mass_matrix(model, q, tip),
            SingularMassMatrixError,
            "M is singular",
        )
    Lambda, _ = P.task_space_mass_matrix(q, tip, TASK_SPACE_MAX_CONDITION)
    if Lambda is None:
        return r.remark(
            k,
            f"skipped: J_b M^-1 J_b^T of {tip!r} has a condition number above "
            f"{TASK_SPACE_MAX_CONDITION:.0e}",
        )
    r.compare(k, lambda: task_space_mass_matrix(model, q, tip), Lambda, f"frame {tip!r}")


def format_table(checks, model):
    """A plain-text table of ``verify``'s checks: a header naming the robot, nv and rtol, one
    row per function (states, max abs and rel error, PASS / FAIL, or n/a when no state could
    be compared), a summary line, then the notes."""
    rtol = checks[0].rtol if checks else float("nan")
    width = max([len("function")] + [len(c.function) for c in checks])
    lines = [
        f"opendyn verify: robot {model.name!r}, nv = {model.nv}, rtol = {rtol:g}, "
        f"against Pinocchio ({model.source})",
        "rel error = max |opendyn - Pinocchio| / max(1, max |Pinocchio|), the worst state",
        "",
        f"{'function':<{width}}  states  max abs error  max rel error  result",
        f"{'-' * width}  ------  -------------  -------------  ------",
    ]
    for c in checks:
        result = "n/a" if c.states == 0 else ("PASS" if c.passed else "FAIL")
        errors = (
            f"{'-':>13}  {'-':>13}"
            if c.states == 0
            else f"{c.max_abs_error:>13.3e}  {c.max_rel_error:>13.3e}"
        )
        lines.append(f"{c.function:<{width}}  {c.states:>6}  {errors}  {result}")
    failed = [c.function for c in checks if not c.passed]
    compared = [c for c in checks if c.states]
    lines.append("")
    if failed:
        lines.append(f"FAILED: {len(failed)} of {len(checks)} functions: {', '.join(failed)}")
    else:
        lines.append(f"all {len(compared)} compared functions agree with Pinocchio")
    notes = [c for c in checks if c.note]
    if notes:
        lines.append("notes:")
        lines.extend(f"  {c.function}: {c.note}" for c in notes)
    return "\n".join(lines)
