"""Data: the work arrays of one model's evaluations (Pinocchio's Data, MuJoCo's mjData).

A Model is what the robot is and never changes; a Data is where the algorithms work on it. Every
public dynamics function takes an optional ``data=``: with it, the call allocates nothing, works
in the Data's arrays and returns an array the Data holds (overwritten by the next call that
computes the same quantity); without it, the call returns a fresh array as it always did. (The
constraint functions return the Data's arrays but still allocate temporaries: their module,
opendyn.algorithm.constraints.api, says which.)

All of a Data's numbers live in one flat float64 buffer, laid out once by WORK_FIELDS; the
compiled kernels receive that buffer as one argument and take named views of it (`joint_poses`,
`body_motion`, ...: opendyn.multibody.work_views), and the fields below are numpy views of the
same memory. nb is the number of moving bodies, nv the number of velocity coordinates; {i} is
body i's frame, {s} the world.

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
