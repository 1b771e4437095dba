"""Physical effects as generalized forces: tau_e(t, q, qd), one module per effect.

The equation of motion a scene simulates is

    (M(q) + diag(armature)) qdd + c(q, qd) = sum over the scene's effects of tau_e(t, q, qd)

with gravity entering as the base acceleration dV_0 = (0, -g) (so that -g(q) is produced by the
same recursion that gives c, at no extra cost). Each effect is a module of this package that
declares everything about it (interface): its name and scene keys and their checks, its record
in a Scene, how its parameters are packed, its compiled generalized force, the derivatives it
adds for the implicit integrator, how its power enters the energy balance, its rates for the
stiff-effect diagnosis, its command-line switch, its line in the effects table
(``registry.effects_table()``, the scenes guide's table) and an example of its settings.

registry.EFFECTS lists them in the order the step runs them; everything else derives from it.
A scene becomes a StageTable (table.stage_table) whose effects tuple has one slot per stage
(``registry.slot(module)``): the effect's parameters, or None when the scene does not name it.
Each effect's compiled force tests its slot against None, which numba decides when it compiles
the step for that tuple (dispatch.run_stages), so an effect the scene does not name is neither
compiled nor evaluated.
"""

from . import registry
from .table import StageTable, stage_table

__all__ = ["StageTable", "registry", "stage_table"]
