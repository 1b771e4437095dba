"""Constrained dynamics with k Pfaffian constraints A(q) qd = 0 (the seed notes, "Constrained
Dynamics"; Lynch & Park, Section 8.7):

    tau = M(q) qdd + h(q, qd) + A^T lam,          A qdd + Adot qd = 0
    lam = (A M^-1 A^T)^-1 (A M^-1 (tau - h) + Adot qd),   qdd = M^-1 (tau - h - A^T lam)
    P   = I - A^T (A M^-1 A^T)^-1 A M^-1,          P tau = P (M qdd + h)   (constrained ID)
    J_b^T F_tip = A^T lam,  F_tip = J_b^-T A^T lam  where J_b is square and invertible

lam is the generalized force the robot applies TO the constraints (as f_tip is the wrench a frame
applies to the environment): for a point constraint, the force (N, world axes) the point pushes
on it with. The constraint objects and the meaning of their rows are in
opendyn.multibody.constraint_objects; for rank-deficient A, (A M^-1 A^T)^-1 is the
pseudo-inverse (solve).

The modules, each on those above it:
  frames     where the constraint points and frames are and how they move (compiled)
  terms      the constraint rows A, Adot qd and phi at a state (compiled)
  solve      the constrained solve and constrained forward dynamics (compiled)
  arguments  the argument checks of the constraint functions
  table      constraint objects bound to a model: the flat arrays the kernels read
  api        the public functions
"""

from ...multibody.constraint_objects import (
    FIXED_POSE,
    JOINT_COUPLING,
    POINT_ON_PLANE,
    POINT_TO_POINT,
    POINT_TO_WORLD,
)
from .api import (
    CONSTRAINT_TOLERANCE,
    broken_constraint,
    constrained_forward_dynamics,
    constrained_inverse_dynamics,
    constraint_drift,
    constraint_error,
    constraint_jacobian,
    constraint_projection,
    constraint_wrench,
)
from .solve import (
    NO_STABILISATION,
    RANK_RTOL,
    constrained_forward_kernel,
    constrained_on_poses,
    constrained_solve_at,
    constrained_solve_kernel,
    constrained_solve_rank_kernel,
    constraint_work,
    general_constrained_solve_at,
)
from .table import BODY_A, BODY_B, KIND, OFFSET, ROW_COUNT, ConstraintTable, constraint_table
from .terms import constraint_terms_kernel

__all__ = [
    "CONSTRAINT_TOLERANCE",
    "broken_constraint",
    "BODY_A",
    "BODY_B",
    "FIXED_POSE",
    "JOINT_COUPLING",
    "KIND",
    "NO_STABILISATION",
    "OFFSET",
    "POINT_ON_PLANE",
    "POINT_TO_POINT",
    "POINT_TO_WORLD",
    "RANK_RTOL",
    "ROW_COUNT",
    "ConstraintTable",
    "constrained_forward_dynamics",
    "constrained_forward_kernel",
    "constrained_on_poses",
    "constrained_inverse_dynamics",
    "constrained_solve_at",
    "constrained_solve_kernel",
    "constrained_solve_rank_kernel",
    "constraint_drift",
    "constraint_error",
    "constraint_jacobian",
    "constraint_projection",
    "constraint_table",
    "constraint_terms_kernel",
    "constraint_work",
    "constraint_wrench",
    "general_constrained_solve_at",
]
