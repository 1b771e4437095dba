"""Data: the work arrays of one model's evaluations (Pinocchio's Data, MuJoCo's mjData).

A Model is what the robot is and never changes; a Data is where the algorithms work on it. Every
public dynamics function takes an optional ``data=``: with it, the call allocates nothing, works
in the Data's arrays and returns an array the Data holds (overwritten by the next call that
computes the same quantity); without it, the call returns a fresh array as it always did. (The
constraint functions return the Data's arrays but still allocate temporaries: their module,
opendyn.algorithm.constraints.api, says which.)

All of a Data's numbers live in one flat float64 buffer, laid out once by WORK_FIELDS; the
compiled kernels receive that buffer as one argument and take named views of it (`joint_poses`,
`body_motion`, ...), and the fields below are numpy views of the same memory. nb is the number
of moving bodies, nv the number of velocity coordinates; {i} is body i's frame, {s} the world.

Per body, as the last evaluation that computes them left them:
  R, p          (nb, 3, 3), (nb, 3)  T_{lambda(i), i} = (R[i], p[i]): body i's pose in its parent
                                     (metres), after the joint's motion
  R_s, p_s      (nb, 3, 3), (nb, 3)  T_{s,i}: body i's pose in the world (kinematics, Jacobians)
  V             (nb, 6)   body twists V_i = (omega, v) in {i} (rad/s, m/s)
  dV            (nb, 6)   body accelerations in {i}, with gravity as the base's acceleration
                          (0, -g) (rad/s^2, m/s^2)
  F             (nb, 6)   wrench (m, f) that joint i transmits to body i, in {i} (N m, N) (RNEA)
  a_vp          (nb, 6)   velocity-product acceleration c_i = ad_{V_i} S_i qd_i in {i} (ABA)
  pA            (nb, 6)   articulated-body bias wrenches in {i} (N m, N) (ABA)
  IA            (nb, 6, 6) articulated-body inertias in {i} (kg, kg m, kg m^2) (ABA)
  U, L          (nb, 6, 6) ABA's U_i = IA_i S_i (rows) and D_i = S_i^T U_i or its Cholesky factor
  u             (nb, 6)   ABA's u_i = tau_i - S_i^T pA_i (first nv_i entries)
  mass_c, h_c, I_c (nb,), (nb, 3), (nb, 3, 3) composite rigid-body inertia of the subtree of
                          body i, in {i}: mass (kg), first moment m c (kg m), rotational inertia
                          about {i}'s origin (kg m^2) (CRBA)
  S_s           (nb, 6, 6) rows k < nv_i: joint i's motion axes mult_i Ad_{T_si} S_i[k] in {s}
                          (Coriolis matrix, Christoffel symbols, torque_regressor)
  G_s, Gc       (nb, 6, 6) body i's spatial inertia in {s}, and the sum over its subtree
  dS            (nb, 6, 6) rows k < nv_i: the axes' rates ad_{V_s[i]} S_s[i, k] in {s}
  Bc            (nb, 6, 3) the angular columns of the subtree's sum of
                          Bs = -1/2 (G ad_V + ad_V^T G) - 1/2 X(G V), in {s}
  V_s           (nb, 6)   body twists in {s} (the spatial velocities)
The dynamics' derivatives (opendyn.algorithm.rnea_derivatives, minverse), in {s}:
  A_s           (nb, 6)   body accelerations dV_s/dt in {s}, with gravity as the base's
                          acceleration (0, -g) (rad/s^2, m/s^2)
  Fc_s          (nb, 6)   the sum over the subtree of body i of the wrenches G A + V x* G V and
                          the wrenches the bodies apply to the environment, in {s} (N m, N)
  psi, alpha, beta (nb, 6, 6) rows k < nv_i: the rates of V and A that moving joint i's axis
                          S = S_s[i, k] adds beyond carrying the subtree along: psi = V_lambda x S,
                          alpha = A_lambda x S + V_lambda x psi (per rad or m); beta = dS + psi,
                          the rate of A per unit of its velocity (per s)
  IA_s, U_s, Dinv (nb, 6, 6) the recursive M^-1's articulated inertias in {s}, U_i = IA_i S_i
                          (rows) and D_i^-1 = (S_i^T U_i)^-1
Joint space, the results (the function that returns each):
  tau           (nv,)     inverse_dynamics
  g             (nv,)     gravity_forces
  c             (nv,)     coriolis_forces
  h             (nv,)     bias_forces; forward dynamics by CRBA leaves in it the right-hand
                          side tau - h - J^T F_tip, task_space_bias h(q, qd)
  qdd           (nv,)     forward_dynamics
  M             (nv, nv)  mass_matrix; forward dynamics by CRBA and the task-space functions
                          leave in its lower triangle the Cholesky factor L of M = L L^T
  C             (nv, nv)  coriolis_matrix
  dtau_dq, dtau_dqd (nv, nv) inverse_dynamics_derivatives (with data.M = dtau/dqdd)
  ddq_dq, ddq_dqd, Minv (nv, nv) forward_dynamics_derivatives (Minv = dqdd/dtau = M^-1)
  Gamma         (nv, nv, nv) christoffel_symbols (an array of its own beside the buffer)
  J             (6, nv)   jacobian; the task-space functions and the step's applied wrenches
                          leave a frame's J_b in it
  T_sf          (4, 4)    frame_pose (jacobian and the task-space functions leave the frame's
                          pose in it too)
  energy        (2,)      (K, U) (J): kinetic_energy and potential_energy leave both (with
                          qd = 0 for potential_energy)
Centroidal (opendyn.algorithm.centroidal), in the world frame or world-aligned axes at the
centre of mass G, angular first:
  com           (3,)      center_of_mass: c (m); centroidal_momentum and
                          centroidal_momentum_rate_bias leave it too
  J_c           (3, nv)   center_of_mass_jacobian: c_dot = J_c qd
  A_G           (6, nv)   centroidal_momentum_matrix: h_G = A_G qd
  h_G           (6,)      centroidal_momentum: (k_G, l_G) (kg m^2/s, kg m/s);
                          centroidal_momentum_rate_bias leaves it too
  Adot_G_qd     (6,)      centroidal_momentum_rate_bias (N m, N); centroidal_momentum leaves
                          zero in it
Task space, in the frame's coordinates {f}, angular first (opendyn.algorithm.task_space):
  JMinv         (6, nv)   J_b M^-1 (task_space_mass_matrix, task_space_bias)
  Lambda        (6, 6)    task_space_mass_matrix: (J_b M^-1 J_b^T + damping I)^-1 (kg m^2,
                          kg m, kg); task_space_bias leaves the undamped one
  eta           (6,)      task_space_bias: the wrench (m, f) (N m, N)
  dV_f          (6,)      frame_acceleration: dV_b = J_b qdd + Jdot_b qd (rad/s^2, m/s^2);
                          task_space_bias leaves Jdot_b qd in it
Constraints (opendyn.algorithm.constraints; the row units and frames are constraint_jacobian's):
  P             (nv, nv)  constraint_projection: I - A^T (A M^-1 A^T)^+ A M^-1
  F_tip         (6,)      constraint_wrench: the wrench (m, f) a frame applies to the
                          constraint, in the frame's coordinates (N m, N)
  tau, qdd                constrained_inverse_dynamics and constrained_forward_dynamics return
                          them, as inverse_dynamics and forward_dynamics do
  constraint_rows(k)      the arrays of k constraint rows, made on the first call with k rows
                          and kept for the next: A (k, nv) constraint_jacobian, Adot_qd (k,)
                          constraint_drift, phi (k,) constraint_error (the three fill all
                          three), lam (k,) constrained_forward_dynamics
(N m or N for forces, rad/s^2 or m/s^2 for accelerations, as the functions' docstrings say.)
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .._runtime.arrays import shaped
from .._runtime.kernel_cache import INLINE, JIT

# The arrays of k constraint rows (Data.constraint_rows): A (k, nv), Adot_qd, phi, lam (k,).
ConstraintRows = namedtuple("ConstraintRows", ("A", "Adot_qd", "phi", "lam"))

# Where a field starts and how many numbers it holds: start = nb * per_nb + nv * per_nv +
# nv^2 * per_nv2 + fixed, and likewise its size. A namedtuple of ints, which numba freezes as a
# compile-time constant.
Extent = namedtuple("Extent", ("per_nb", "per_nv", "per_nv2", "fixed"))

# (field, shape per unit, unit): unit "nb" for per-body fields, "nv" and "nv2" for joint-space
# ones, "fixed" for a fixed shape. Scratch rows used inside one kernel come last.
WORK_FIELDS = (
    ("R", (3, 3), "nb"),
    ("p", (3,), "nb"),
    ("R_s", (3, 3), "nb"),
    ("p_s", (3,), "nb"),
    ("V", (6,), "nb"),
    ("dV", (6,), "nb"),
    ("F", (6,), "nb"),
    ("a_vp", (6,), "nb"),
    ("pA", (6,), "nb"),
    ("u", (6,), "nb"),
    ("IA", (6, 6), "nb"),
    ("U", (6, 6), "nb"),
    ("L", (6, 6), "nb"),
    ("mass_c", (), "nb"),
    ("h_c", (3,), "nb"),
    ("I_c", (3, 3), "nb"),
    ("body_flag", (), "nb"),
    ("S_s", (6, 6), "nb"),
    ("G_s", (6, 6), "nb"),
    ("Gc", (6, 6), "nb"),
    ("dS", (6, 6), "nb"),
    ("Bc", (6, 3), "nb"),
    ("V_s", (6,), "nb"),
    ("A_s", (6,), "nb"),
    ("Fc_s", (6,), "nb"),
    ("psi", (6, 6), "nb"),
    ("alpha", (6, 6), "nb"),
    ("beta", (6, 6), "nb"),
    ("IA_s", (6, 6), "nb"),
    ("U_s", (6, 6), "nb"),
    ("Dinv", (6, 6), "nb"),
    ("subtree_end", (), "nb"),
    ("idle", (), "nb"),
    ("still", (), "nb"),
    ("tau", (), "nv"),
    ("g", (), "nv"),
    ("c", (), "nv"),
    ("h", (), "nv"),
    ("qdd", (), "nv"),
    ("zero_v", (), "nv"),
    ("e_k", (), "nv"),
    ("J", (6,), "nv"),
    ("JMinv", (6,), "nv"),
    ("J_c", (3,), "nv"),
    ("A_G", (6,), "nv"),
    ("effect_rows", (3,), "nv"),
    ("contact_axes", (24,), "nv"),
    ("M", (), "nv2"),
    ("C", (), "nv2"),
    ("P", (), "nv2"),
    ("dtau_dq", (), "nv2"),
    ("dtau_dqd", (), "nv2"),
    ("ddq_dq", (), "nv2"),
    ("ddq_dqd", (), "nv2"),
    ("Minv", (), "nv2"),
    ("unit_responses", (6,), "nv2"),
    ("T_sf", (4, 4), "fixed"),
    ("com", (3,), "fixed"),
    ("h_G", (6,), "fixed"),
    ("Adot_G_qd", (6,), "fixed"),  # right after h_G: the momentum kernel writes both
    ("energy", (2,), "fixed"),
    ("Lambda", (6, 6), "fixed"),
    ("eta", (6,), "fixed"),
    ("dV_f", (6,), "fixed"),
    ("F_tip", (6,), "fixed"),
    ("no_loads", (1, 6), "fixed"),
    ("scratch", (9, 6), "fixed"),
    ("temp", (3, 6), "fixed"),
)
# the kernels' scratch; every other field is one a user reads
SCRATCH_FIELDS = (
    "body_flag",
    "idle",
    "still",
    "subtree_end",
    "zero_v",
    "e_k",
    "unit_responses",
    "effect_rows",
    "contact_axes",
    "no_loads",
    "scratch",
    "temp",
)
PUBLIC_FIELDS = tuple(name for name, _, _ in WORK_FIELDS if name not in SCRATCH_FIELDS)
_UNITS = ("nb", "nv", "nv2", "fixed")


def _extents(fields):
    """{field: (start Extent, size Extent)}: fields of each unit in turn, in table order."""
    out, start = {}, [0, 0, 0, 0]
    for unit_index, unit in enumerate(_UNITS):
        for name, shape, field_unit in fields:
            if field_unit != unit:
                continue
            size = [0, 0, 0, 0]
            size[unit_index] = int(np.prod(shape))
            out[name] = (Extent(*start), Extent(*size))
            start[unit_index] += size[unit_index]
    return out, Extent(*start)


WORK_AT, WORK_SIZE = _extents(WORK_FIELDS)


def _count(extent, nb, nv):
    return extent.per_nb * nb + extent.per_nv * nv + extent.per_nv2 * nv * nv + extent.fixed


def work_size(nb: int, nv: int) -> int:
    """Numbers in the work buffer of a model with nb bodies and nv velocity coordinates."""
    return _count(WORK_SIZE, nb, nv)


def _shape(name, shape, unit, nb, nv):
    if unit == "nb":
        return (nb, *shape)
    if unit == "nv":
        return (*shape, nv)
    return (*shape, nv, nv) if unit == "nv2" else shape


class Data:
    """The work arrays of one Model (see the module docstring for every field: its shape, frame
    and unit). Make one with ``od.Data(model)`` or ``model.data()``, and pass it as ``data=`` to
    the dynamics functions: they then allocate nothing and return arrays this Data holds, which
    the next call computing the same quantity overwrites (copy what you keep).

    A Data belongs to the model it was made for: passing it with another model is a ValueError.
    It is not shared between threads: give each thread its own.
    """

    def __init__(self, model):
        # a Model by what it holds (model.py imports this module, for Model.data())
        if not all(hasattr(model, name) for name in ("nb", "nv", "_ibuf", "_fbuf", "_work")):
            raise TypeError(
                f"Data: model must be an opendyn Model (from od.load_urdf), got "
                f"{type(model).__name__}"
            )
        self.model = model
        nb, nv = model.nb, model.nv
        self._work = np.zeros(work_size(nb, nv))
        for name, shape, unit in WORK_FIELDS:
            start, size = WORK_AT[name]
            a = _count(start, nb, nv)
            view = self._work[a : a + _count(size, nb, nv)]
            setattr(self, name, view.reshape(_shape(name, shape, unit, nb, nv)))
        # nv^3 numbers each: beside the buffer, which every Model keeps one of
        # (h_G, Adot_G qd) as the one (2, 6) array the momentum kernel writes
        a = _count(WORK_AT["h_G"][0], nb, nv)
        self._momentum = self._work[a : a + 12].reshape(2, 6)
        self.Gamma = np.zeros((nv, nv, nv))
        self._C_e = np.zeros((nv, nv, nv))
        self._kept = {}

    def kept(self, key, make, *args):
        """The arrays make(*args) returns, made on the first call with this key and the same on
        every later one: the work of a call whose sizes depend on its arguments (k constraint
        rows, P collision pairs), which so allocates nothing after its first."""
        if key not in self._kept:
            self._kept[key] = make(*args)
        return self._kept[key]

    def constraint_rows(self, k: int) -> ConstraintRows:
        """The ConstraintRows of k constraint rows: A (k, nv), Adot_qd (k,), phi (k,), lam (k,)
        (kept: the same arrays for every call with k rows)."""
        return self.kept(("constraint rows", k), _constraint_rows, k, self.model.nv)

    def __repr__(self) -> str:
        return f"Data({self.model.name!r}, nb={self.model.nb}, nv={self.model.nv})"


def _constraint_rows(k, nv):
    return ConstraintRows(np.zeros((k, nv)), np.zeros(k), np.zeros(k), np.zeros(k))


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
# to the root (opendyn.algorithm.contact.add_contact_tangent), row j of each, in {s}: the joint
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
