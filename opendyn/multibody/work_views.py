"""Views of a Data's work buffer inside the compiled kernels: each field of the layout in
opendyn.multibody.data (WORK_FIELDS), by name, as a slice or shaped view of the one flat float64
buffer a kernel receives (`joint_poses`, `body_motion`, ...). Where each field starts and how
big it is are compile-time constants (WORK_AT); the shapes, frames and units of every field are
in data.py's docstring.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .._runtime.arrays import shaped
from .._runtime.kernel_cache import INLINE, JIT
from .data import WORK_AT, WORK_SIZE


def _where(name):
    """(start, size) Extents of a field: compile-time constants in a kernel."""
    return WORK_AT[name]


_R, _P, _R_S, _P_S = (_where(n) for n in ("R", "p", "R_s", "p_s"))
_V, _DV, _F = (_where(n) for n in ("V", "dV", "F"))
_A_VP, _PA, _U_VEC = (_where(n) for n in ("a_vp", "pA", "u"))
_IA, _U, _L = (_where(n) for n in ("IA", "U", "L"))
_MASS_C, _H_C, _I_C = (_where(n) for n in ("mass_c", "h_c", "I_c"))
_BODY_FLAG, _ZERO_V, _E_K = (_where(n) for n in ("body_flag", "zero_v", "e_k"))
_TAU, _G, _C, _H, _QDD = (_where(n) for n in ("tau", "g", "c", "h", "qdd"))
_J, _M, _C_MATRIX, _T_SF, _COM = (_where(n) for n in ("J", "M", "C", "T_sf", "com"))
_S_S, _G_S, _GC, _DS = (_where(n) for n in ("S_s", "G_s", "Gc", "dS"))
_BC, _V_S, _IDLE, _STILL = (_where(n) for n in ("Bc", "V_s", "idle", "still"))
_NO_LOADS, _SCRATCH, _TEMP = _where("no_loads"), _where("scratch"), _where("temp")
_JMINV, _LAMBDA, _DV_F = _where("JMinv"), _where("Lambda"), _where("dV_f")
_EFFECT_ROWS, _CONTACT_AXES = _where("effect_rows"), _where("contact_axes")


@njit(**INLINE)
def work_field(work, nb, nv, where):
    """The flat slice of one field of a work buffer (where: its start and size Extents)."""
    start, size = where
    a = start.per_nb * nb + start.per_nv * nv + start.per_nv2 * nv * nv + start.fixed
    n = size.per_nb * nb + size.per_nv * nv + size.per_nv2 * nv * nv + size.fixed
    return work[a : a + n]


@njit(**INLINE)
def body_field(work, nb, where):
    """The flat slice of one per-body field of a work buffer: per-body fields come first, so
    where each starts and ends depends on nb alone."""
    return work_field(work, nb, 0, where)


@njit(**JIT)
def joint_poses(work, nb):
    """R (nb, 3, 3), p (nb, 3): T_{lambda(i), i} of every body."""
    return (
        shaped(body_field(work, nb, _R), (nb, 3, 3)),
        shaped(body_field(work, nb, _P), (nb, 3)),
    )


@njit(**JIT)
def world_poses(work, nb):
    """R_s (nb, 3, 3), p_s (nb, 3): T_{s,i} of every body."""
    return (
        shaped(body_field(work, nb, _R_S), (nb, 3, 3)),
        shaped(body_field(work, nb, _P_S), (nb, 3)),
    )


@njit(**JIT)
def body_motion(work, nb):
    """V, dV, F (nb, 6): body twists, accelerations and transmitted wrenches, each in {i}."""
    return (
        shaped(body_field(work, nb, _V), (nb, 6)),
        shaped(body_field(work, nb, _DV), (nb, 6)),
        shaped(body_field(work, nb, _F), (nb, 6)),
    )


@njit(**JIT)
def articulated_inertias(work, nb):
    """IA, U, L (nb, 6, 6): ABA's articulated inertias and per-joint U_i, D_i (or its factor)."""
    return (
        shaped(body_field(work, nb, _IA), (nb, 6, 6)),
        shaped(body_field(work, nb, _U), (nb, 6, 6)),
        shaped(body_field(work, nb, _L), (nb, 6, 6)),
    )


@njit(**JIT)
def articulated_biases(work, nb):
    """a_vp, pA, u (nb, 6): ABA's velocity-product accelerations, bias wrenches and u_i."""
    return (
        shaped(body_field(work, nb, _A_VP), (nb, 6)),
        shaped(body_field(work, nb, _PA), (nb, 6)),
        shaped(body_field(work, nb, _U_VEC), (nb, 6)),
    )


@njit(**JIT)
def composite_inertias(work, nb):
    """mass_c (nb,), h_c (nb, 3), I_c (nb, 3, 3): CRBA's composite inertias in rigid-body form."""
    return (
        body_field(work, nb, _MASS_C),
        shaped(body_field(work, nb, _H_C), (nb, 3)),
        shaped(body_field(work, nb, _I_C), (nb, 3, 3)),
    )


# The Coriolis terms' per-body arrays (opendyn.algorithm.christoffel), views of a work buffer:
# S_s, G_s, Gc, dS (nb, 6, 6), Bc (nb, 6, 3), V_s (nb, 6), idle and still (nb,) flags (0 or 1).
CoriolisTerms = namedtuple(
    "CoriolisTerms", ("S_s", "G_s", "Gc", "dS", "Bc", "V_s", "idle", "still")
)


@njit(**JIT)
def space_axes(work, nb):
    """S_s (nb, 6, 6): rows k < nv_i, joint i's motion axes mult_i Ad_{T_si} S_i[k] in {s} (the
    Coriolis terms' first field, which the regressor fills too)."""
    return shaped(body_field(work, nb, _S_S), (nb, 6, 6))


@njit(**JIT)
def coriolis_terms(work, nb):
    """The CoriolisTerms views of a work buffer."""
    return CoriolisTerms(
        space_axes(work, nb),
        shaped(body_field(work, nb, _G_S), (nb, 6, 6)),
        shaped(body_field(work, nb, _GC), (nb, 6, 6)),
        shaped(body_field(work, nb, _DS), (nb, 6, 6)),
        shaped(body_field(work, nb, _BC), (nb, 6, 3)),
        shaped(body_field(work, nb, _V_S), (nb, 6)),
        body_field(work, nb, _IDLE),
        body_field(work, nb, _STILL),
    )


@njit(**JIT)
def body_flags(work, nb):
    """(nb,) one number per body for a kernel's own marks (0.0 or 1.0)."""
    return body_field(work, nb, _BODY_FLAG)


@njit(**JIT)
def scratch_rows(work, nb, nv):
    """(9, 6) scratch for one kernel's small temporaries."""
    return shaped(work_field(work, nb, nv, _SCRATCH), (9, 6))


@njit(**JIT)
def temp_vectors(work, nb, nv):
    """(3, 6) three 6-vectors of scratch, one row each, for one kernel's temporaries."""
    return shaped(work_field(work, nb, nv, _TEMP), (3, 6))


@njit(**JIT)
def skew_scratch(work, nb, nv):
    """(4, 3, 3): four 3 x 3 matrices of scratch (the first 36 numbers of the scratch rows)."""
    return shaped(work_field(work, nb, nv, _SCRATCH)[:36], (4, 3, 3))


@njit(**JIT)
def effect_rows(work, nb, nv):
    """(3, nv) scratch for a simulation effect's compiled force, one effect at a time (the
    step runs them in turn): a contact point's Jacobian J_p, computed torque's qdd_c and
    tau_c."""
    return shaped(work_field(work, nb, nv, _EFFECT_ROWS), (3, nv))


# The contact's derivatives per velocity coordinate j on the path from a touching point's body
# to the root (opendyn.algorithm.contact_tangent.add_sphere_tangent), row j of each, in {s}: the joint
# axis S_j and ad_{S_j}^T F_s, dF_s/dq_j (nv, 6) of the point's wrench F_s = (x x f, f), and
# J_j(x) = v_j + w_j x x, df/dqd_j (nv, 3) of its force f. Views of a work buffer.
ContactAxes = namedtuple("ContactAxes", ("S", "moved", "dF_dq", "J_x", "df_dqd"))


@njit(**JIT)
def contact_axes(work, nb, nv):
    """The ContactAxes views of a work buffer (its contact_axes field, 24 numbers a velocity
    coordinate)."""
    rows = work_field(work, nb, nv, _CONTACT_AXES)
    return ContactAxes(
        shaped(rows[: 6 * nv], (nv, 6)),
        shaped(rows[6 * nv : 12 * nv], (nv, 6)),
        shaped(rows[12 * nv : 18 * nv], (nv, 6)),
        shaped(rows[18 * nv : 21 * nv], (nv, 3)),
        shaped(rows[21 * nv :], (nv, 3)),
    )


@njit(**JIT)
def joint_vectors(work, nb, nv):
    """h (nv,), zero_v (nv,) (kept zero), e_k (nv,) (kept zero between uses): a kernel's
    joint-space vectors."""
    return (
        work_field(work, nb, nv, _H),
        work_field(work, nb, nv, _ZERO_V),
        work_field(work, nb, nv, _E_K),
    )


@njit(**JIT)
def no_loads(work, nb, nv):
    """(1, 6) external loads of zero (kept zero): no gravity, no wrenches."""
    return shaped(work_field(work, nb, nv, _NO_LOADS), (1, 6))


@njit(**JIT)
def new_work(nb, nv):
    """A fresh, zeroed work buffer: each thread of a batch kernel works in its own."""
    return np.zeros(
        WORK_SIZE.per_nb * nb + WORK_SIZE.per_nv * nv + WORK_SIZE.per_nv2 * nv * nv
        + WORK_SIZE.fixed
    )


@njit(**JIT)
def frame_pose_field(work, nb, nv):
    """T_sf (4, 4): a frame's pose in the world."""
    return shaped(work_field(work, nb, nv, _T_SF), (4, 4))


@njit(**JIT)
def com_field(work, nb, nv):
    """com (3,): the centre of mass c (m, world frame)."""
    return work_field(work, nb, nv, _COM)


@njit(**JIT)
def coriolis_matrix_field(work, nb, nv):
    """C (nv, nv)."""
    return shaped(work_field(work, nb, nv, _C_MATRIX), (nv, nv))


@njit(**JIT)
def jacobian_field(work, nb, nv):
    """J (6, nv): a frame's Jacobian, J_s or J_b."""
    return shaped(work_field(work, nb, nv, _J), (6, nv))


@njit(**JIT)
def mass_matrix_field(work, nb, nv):
    """M (nv, nv)."""
    return shaped(work_field(work, nb, nv, _M), (nv, nv))


# A frame's task-space arrays (opendyn.algorithm.task_space), views of a work buffer, in the
# frame's coordinates: J_b (6, nv), M (nv, nv) (or its Cholesky factor), JMinv = J_b M^-1
# (6, nv), Lambda (6, 6), dV_f (6,).
TaskSpace = namedtuple("TaskSpace", ("J_b", "M", "JMinv", "Lambda", "dV_f"))


@njit(**JIT)
def task_space_fields(work, nb, nv):
    """The TaskSpace views of a work buffer."""
    return TaskSpace(
        jacobian_field(work, nb, nv),
        mass_matrix_field(work, nb, nv),
        shaped(work_field(work, nb, nv, _JMINV), (6, nv)),
        shaped(work_field(work, nb, nv, _LAMBDA), (6, 6)),
        work_field(work, nb, nv, _DV_F),
    )


_A_S, _FC_S, _PSI, _ALPHA, _BETA = (_where(n) for n in ("A_s", "Fc_s", "psi", "alpha", "beta"))
_IA_S, _U_S, _DINV, _SUBTREE_END = (_where(n) for n in ("IA_s", "U_s", "Dinv", "subtree_end"))
_DTAU_DQ, _DTAU_DQD = _where("dtau_dq"), _where("dtau_dqd")
_DDQ_DQ, _DDQ_DQD, _MINV, _UNIT_RESPONSES = (
    _where(n) for n in ("ddq_dq", "ddq_dqd", "Minv", "unit_responses")
)

# The derivatives' per-body arrays (opendyn.algorithm.rnea_derivatives), views of a work
# buffer, in {s}: A_s, Fc_s (nb, 6), and per joint axis psi, alpha, beta (nb, 6, 6).
AxisRates = namedtuple("AxisRates", ("A_s", "Fc_s", "psi", "alpha", "beta"))


@njit(**JIT)
def axis_rates(work, nb):
    """The AxisRates views of a work buffer."""
    return AxisRates(
        shaped(body_field(work, nb, _A_S), (nb, 6)),
        shaped(body_field(work, nb, _FC_S), (nb, 6)),
        shaped(body_field(work, nb, _PSI), (nb, 6, 6)),
        shaped(body_field(work, nb, _ALPHA), (nb, 6, 6)),
        shaped(body_field(work, nb, _BETA), (nb, 6, 6)),
    )


# The recursive M^-1's arrays (opendyn.algorithm.minverse), views of a work buffer, in {s}:
# IA_s, U_s, Dinv (nb, 6, 6), subtree_end (nb,) (one past the last coordinate of the subtree of
# body i, as a float) and responses (nb, nv, 6), the bias wrenches, then the accelerations, of
# unit torques, one 6-vector per torque (it needs nb <= nv: one coordinate or more per body).
InverseTerms = namedtuple("InverseTerms", ("IA_s", "U_s", "Dinv", "subtree_end", "responses"))


@njit(**JIT)
def inverse_terms(work, nb, nv):
    """The InverseTerms views of a work buffer."""
    return InverseTerms(
        shaped(body_field(work, nb, _IA_S), (nb, 6, 6)),
        shaped(body_field(work, nb, _U_S), (nb, 6, 6)),
        shaped(body_field(work, nb, _DINV), (nb, 6, 6)),
        body_field(work, nb, _SUBTREE_END),
        shaped(work_field(work, nb, nv, _UNIT_RESPONSES)[: nb * nv * 6], (nb, nv, 6)),
    )


# The derivatives' joint-space results, views of a work buffer: dtau_dq, dtau_dqd, ddq_dq,
# ddq_dqd, Minv (nv, nv).
Derivatives = namedtuple("Derivatives", ("dtau_dq", "dtau_dqd", "ddq_dq", "ddq_dqd", "Minv"))


@njit(**JIT)
def derivative_fields(work, nb, nv):
    """The Derivatives views of a work buffer."""
    return Derivatives(
        shaped(work_field(work, nb, nv, _DTAU_DQ), (nv, nv)),
        shaped(work_field(work, nb, nv, _DTAU_DQD), (nv, nv)),
        shaped(work_field(work, nb, nv, _DDQ_DQ), (nv, nv)),
        shaped(work_field(work, nb, nv, _DDQ_DQD), (nv, nv)),
        shaped(work_field(work, nb, nv, _MINV), (nv, nv)),
    )


@njit(**JIT)
def joint_accelerations(work, nb, nv):
    """qdd (nv,): forward dynamics' result."""
    return work_field(work, nb, nv, _QDD)
