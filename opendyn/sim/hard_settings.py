"""The settings of a scene's hard model (`model = "hard"` in [effects.contact],
[effects.limits] or [effects.friction]) and the checks of a scene that has one; opendyn.sim.hard
builds the step's data from them.

Settings (each section that is hard may give them; two that give one must agree):

    margin          m (contacts; rad or m for limits), >= 0, default 1e-3: a contact or limit
                    within it is a row of the step
    stabilization   in [0, 1], default 0.2: the share of a penetration taken out per step
    compliance      s/kg, >= 0, default 0: R on every row (G + R)
    solver          "admm" (default) or "pgs"
    tolerance       m/s, > 0, default 1e-8: on the NCP's residual (opendyn.algorithm.ncp)
    max_iterations  >= 1, default 100
"""

from __future__ import annotations

from dataclasses import dataclass

from ..algorithm.ncp import SOLVERS
from ..errors import SceneError
from .values import what_is

MODELS = ("compliant", "hard")
SOLVER_KEYS = ("margin", "stabilization", "compliance", "solver", "tolerance", "max_iterations")
SHARED = ("stabilization", "compliance", "solver", "tolerance", "max_iterations")


@dataclass(frozen=True)
class HardSettings:
    """A hard section's settings (module docstring)."""

    margin: float = 1e-3
    stabilization: float = 0.2
    compliance: float = 0.0
    solver: str = "admm"
    tolerance: float = 1e-8
    max_iterations: int = 100


def read_model(r, table, key, compliant_keys) -> HardSettings | None:
    """The section's `model`: None for "compliant" (the default), whose table may not hold the
    hard model's keys; the HardSettings for "hard", whose table may not hold the compliant
    law's `compliant_keys`."""
    model = r.string(table.get("model", "compliant"), f"{key}.model", MODELS)
    if model == "compliant":
        for field in SOLVER_KEYS:
            if field in table:
                r.fail(
                    f"{key}.{field}",
                    'is a setting of the hard model; add model = "hard" or remove it',
                )
        return None
    for field in compliant_keys:
        if field in table:
            r.fail(
                f"{key}.{field}",
                "is the compliant law's; model = \"hard\" solves the constraint exactly and "
                "has none: remove it",
            )
    stabilization = r.number(table.get("stabilization", 0.2), f"{key}.stabilization", 0.0)
    if stabilization > 1.0:
        r.fail(f"{key}.stabilization", f"expected a number in [0, 1], found {stabilization!r}")
    iterations = table.get("max_iterations", 100)
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        r.fail(f"{key}.max_iterations", f"expected an integer >= 1, found {what_is(iterations)}")
    return HardSettings(
        margin=r.number(table.get("margin", 1e-3), f"{key}.margin", 0.0),
        stabilization=stabilization,
        compliance=r.number(table.get("compliance", 0.0), f"{key}.compliance", 0.0),
        solver=r.string(table.get("solver", "admm"), f"{key}.solver", tuple(SOLVERS)),
        tolerance=r.number(table.get("tolerance", 1e-8), f"{key}.tolerance", positive=True),
        max_iterations=int(iterations),
    )


def sections(scene) -> dict:
    """{section key: HardSettings} of the scene's hard sections, contact first."""
    found = {}
    for key, record in (
        ("effects.contact", scene.contact),
        ("effects.limits", scene.limits),
        ("effects.friction", scene.friction),
    ):
        settings = getattr(record, "hard", None)
        if settings is not None:
            found[key] = settings
    return found


def check(scene):
    """SceneError unless the scene's hard sections can run: the integrator is
    "semi_implicit_euler" and the settings they share agree."""
    found = sections(scene)
    if not found:
        return
    first = next(iter(found))
    if scene.run.integrator != "semi_implicit_euler":
        raise SceneError(
            f"{scene.source}: {first}.model: \"hard\" is solved by the velocity-level step of "
            f'run.integrator = "semi_implicit_euler", and run.integrator is '
            f"{scene.run.integrator!r}: set it, or use the compliant model with this integrator"
        )
    for key, settings in found.items():
        for field in SHARED:
            if getattr(settings, field) != getattr(found[first], field):
                raise SceneError(
                    f"{scene.source}: {key}.{field}: {getattr(settings, field)!r} differs from "
                    f"{first}.{field} = {getattr(found[first], field)!r}: the hard sections "
                    "are one solve; give it once, or the same in both"
                )
