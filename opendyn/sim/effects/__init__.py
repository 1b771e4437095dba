"""Physical effects as generalized forces: tau_e(t, q, qd), one module per effect.

The equation of motion a scene simulates is

    (M(q) + diag(armature)) qdd + c(q, qd) = sum over the scene's effects of tau_e(t, q, qd)

with gravity entering as the base acceleration dV_0 = (0, -g) (so that -g(q) is produced by the
same recursion that gives c, at no extra cost). Each effect is a module of this package that
declares everything about it (interface): its name and scene keys and their checks, its record
in a Scene, how its parameters are packed, its compiled generalized force, the derivatives it
adds for the implicit integrator, how its power enters the energy balance, its rates for the
stiff-effect diagnosis, its command-line switch and its line in the effects table:

  gravity          dV_0 = (0, -g)
  damping          tau = -b qd
  friction         tau = -f_c tanh(qd / v_s)
  armature         M -> M + diag(I_a)
  limits           tau = -k (q - limit) - d qd, past a limit only
  wrench           tau = J_b(frame)^T F_frame, F applied TO the robot (= -F_tip)
  contact          tau = sum_p J_p^T f_p, spheres on the ground plane
  constant, pd, computed_torque    the control laws ([control] type)
  clip             the control torque clipped to +-effort_limit

registry.EFFECTS lists them in the order the step runs them; everything else derives from it.
A scene becomes a StageTable (table.stage_table) whose effects tuple has one slot per stage:
the effect's parameters, or None when the scene does not name it. Each effect's compiled force
tests its slot against None, which numba decides when it compiles the step for that tuple
(dispatch.run_stages), so an effect the scene does not name is neither compiled nor evaluated.
"""

from . import (
    clip,
    computed_torque,
    constant,
    contact,
    damping,
    friction,
    gravity,
    limits,
    pd,
    wrench,
)
from .clip import apply as clip_effect
from .computed_torque import apply as computed_torque_effect
from .constant import apply as constant_effect
from .contact import apply as contact_effect
from .contact import contact_table
from .damping import apply as damping_effect
from .friction import apply as friction_effect
from .gravity import apply as gravity_effect
from .limits import apply as limits_effect
from .pd import apply as pd_effect
from .registry import slot, stages
from .table import StageTable, stage_table
from .wrench import apply as wrench_effect

# The built-in stages: their names in the order they run, and their slots in a StageTable's
# effects tuple; each effect's compiled force is here as NAME_effect too.
SLOT_NAMES = tuple(effect.STAGE for effect in stages())
GRAVITY = slot(gravity)
DAMPING = slot(damping)
FRICTION = slot(friction)
LIMITS = slot(limits)
WRENCH = slot(wrench)
CONTACT = slot(contact)
CONSTANT = slot(constant)
PD = slot(pd)
COMPUTED_TORQUE = slot(computed_torque)
CLIP = slot(clip)

__all__ = [
    "CLIP",
    "COMPUTED_TORQUE",
    "CONSTANT",
    "CONTACT",
    "DAMPING",
    "FRICTION",
    "GRAVITY",
    "LIMITS",
    "PD",
    "SLOT_NAMES",
    "WRENCH",
    "StageTable",
    "clip_effect",
    "computed_torque_effect",
    "constant_effect",
    "contact_effect",
    "contact_table",
    "damping_effect",
    "friction_effect",
    "gravity_effect",
    "limits_effect",
    "pd_effect",
    "stage_table",
    "wrench_effect",
]
