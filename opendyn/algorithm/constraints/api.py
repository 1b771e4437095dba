"""The public constraint functions: the rows A, their drift Adot qd and their error phi at a
state; constrained forward and inverse dynamics; the projection P; the wrench a frame applies to
the constraints:

    tau = M(q) qdd + h(q, qd) + A^T lam,          A qdd + Adot qd = 0
    P   = I - A^T (A M^-1 A^T)^-1 A M^-1,          P tau = P (M qdd + h)   (constrained ID)
    J_b^T F_tip = A^T lam,  F_tip = J_b^-T A^T lam  where J_b is square and invertible

For rank-deficient A, (A M^-1 A^T)^-1 is the pseudo-inverse (opendyn.algorithm.constraints.solve).

Each takes an optional data= (a Data of the model, single states): the result is then an array
the Data holds, overwritten by the next call that computes it: data.constraint_rows(k) for the
k-row results A, Adot qd, phi and lam (made on the first call with k rows), data.qdd, data.tau,
data.P and data.F_tip. What still allocates with data=: the constraint table, built from the
constraint objects on every call (small arrays, freed when the call returns), the compiled
kernels' k-sized temporaries (the constraint rows' kinematics and the eigendecomposition of
A M^-1 A^T; the simulation step runs the same kernels in a ConstraintWork it makes once, and
allocates nothing), and the numpy factorisations of constraint_projection,
constrained_inverse_dynamics and constraint_wrench, whose results are copied into the Data.
"""

from __future__ import annotations

import numpy as np

from .. import checks
from ..crba import crba_kernel, mass_matrix
from ..eigen import symmetric_eigen
from ..kinematics import jacobian
from ..rnea import rnea_kernel
from ..singular import singular_mass_matrix
from .arguments import _configuration, _matrix_A, _state, _vector_k
from .solve import (
    NO_STABILISATION,
    RANK_RTOL,
    constrained_forward_kernel,
    constrained_solve_kernel,
)
from .table import ROW_COUNT, ConstraintTable, _table
from .terms import constraint_terms_kernel

_TERMS = ("A", "Adot_qd", "phi")  # what constraint_terms_kernel computes, in its order


def _data_for(model, data, what, *states):
    """Check data (None, or a Data of this model) and, with data, that no state is a batch:
    the errors of every data= call (checks.work_of, checks.single_state_only)."""
    if data is None:
        return
    checks.work_of(model, data, what)
    if any(not isinstance(x, str) and np.ndim(x) > 1 for x in states):
        checks.single_state_only(data, what)


def _term(model, q, qd, constraints, q_bound, what, term, data):
    """One of the constraints' terms at (q, qd): "A", "Adot_qd" or "phi", checked finite; in
    data.constraint_rows(k) with data."""
    _data_for(model, data, what, q, qd, q_bound)
    q = _configuration(model, q, "q", what)
    qd = model._zero_v if qd is None else _state(model, qd, "qd", what)
    # A and Adot qd do not depend on targets: those two bind None defaults at q
    q0 = q if isinstance(q_bound, str) else q_bound
    rows, params = _table(model, constraints, q0, "q_bound")
    k = int(rows[:, ROW_COUNT].sum())
    if data is None:
        terms = np.empty((k, model.nv)), np.empty(k), np.empty(k)
    else:
        terms = data.constraint_rows(k)[: len(_TERMS)]
    status = constraint_terms_kernel(model._ibuf, model._fbuf, rows, params, q, qd, *terms)
    arguments = {"q": q, "qd": qd, "q_bound": q0}
    if status:
        checks.raise_status(status, model, what, term, arguments)
    return checks.check_result(terms[_TERMS.index(term)], what, term, arguments)


def constraint_jacobian(model, q, constraints, data=None):
    """A(q): (k, nv) the constraints' rows stacked in order, A qd = 0 on the motion.

    q: (nq,) configuration; constraints: one constraint object or a sequence
    (opendyn.multibody.constraint_objects). Row units and frames: a point's rows are its world
    velocity per unit qd (world axes, m/s), a plane's the normal velocity, a FixedPose's the twist
    of frame b relative to frame a in frame b's axes (angular first), a JointCoupling's its
    matrix. On a floating base the first 6 columns are per unit base body twist (omega_b, v_b).
    Targets do not enter A, so None targets are simply bound at q.
    data: optional Data of this model: returns data.constraint_rows(k).A.
    """
    checks.check_model(model, "constraint_jacobian")
    return _term(model, q, None, constraints, "q", "constraint_jacobian", "A", data)


def constraint_drift(model, q, qd, constraints, data=None):
    """Adot(q, qd) qd: (k,) the time derivative of A qd at qdd = 0, without gravity, so that
    d/dt (A qd) = A qdd + Adot qd. For a point: its classical acceleration in world axes
    (m/s^2); for a FixedPose: the rate of the relative twist (frame b axes, angular first);
    0 for a JointCoupling.

    q: (nq,) configuration, qd: (nv,) velocity (on a floating base qdd is the rate of the base
    body twist); constraints: one constraint object or a sequence. Targets do not enter, so
    None targets are bound at q.
    data: optional Data of this model: returns data.constraint_rows(k).Adot_qd.
    """
    checks.check_model(model, "constraint_drift")
    return _term(model, q, qd, constraints, "q", "constraint_drift", "Adot_qd", data)


def constraint_error(model, q, constraints, q_bound=None, data=None):
    """phi(q): (k,) the constraints' position errors, d/dt phi = A qd (for a FixedPose where
    phi = 0): p - target, n . p - offset, p_a - p_b (m, world axes), log(T_ab*^-1 T_ab) (rad, m;
    frame b axes, angular first), C (q (-) q_ref) = C difference(model, q_ref, q).

    q: (nq,) configuration; constraints: one constraint object or a sequence;
    q_bound: (nq,) the configuration at which a None target / offset / T_ab / q_ref is bound.
    A None default without q_bound raises ValueError naming the constraint and the field.
    data: optional Data of this model: returns data.constraint_rows(k).phi.
    """
    checks.check_model(model, "constraint_error")
    return _term(model, q, None, constraints, q_bound, "constraint_error", "phi", data)


# a state farther than this from its constraints (m or rad; m/s or rad/s) cannot start a run
CONSTRAINT_TOLERANCE = 1e-6


def broken_constraint(model, q, qd, constraints):
    """The first of `constraints` (a sequence) that the state (q (nq,), qd (nv,)) breaks by
    more than CONSTRAINT_TOLERANCE: (its index, "position" (|phi|, with the None targets bound
    at q) or "velocity" (|A qd|), the largest error), or None when it meets them all."""
    phi = constraint_error(model, q, constraints, q_bound=q)
    velocity = constraint_jacobian(model, q, constraints) @ qd
    row = 0
    for i, c in enumerate(constraints):
        k = c.n_rows(model.nv)
        for what, values in (("position", phi), ("velocity", velocity)):
            worst = float(np.max(np.abs(values[row : row + k])))
            if not worst <= CONSTRAINT_TOLERANCE:
                return i, what, worst
        row += k
    return None


def constrained_forward_dynamics(
    model,
    q,
    qd,
    tau,
    constraints=None,
    *,
    A=None,
    Adot_qd=None,
    gravity=None,
    f_tip=None,
    data=None,
):
    """(qdd, lam): forward dynamics under A(q) qd = 0,
        M qdd + h + A^T lam = tau,   A qdd + Adot qd = 0,
        lam = (A M^-1 A^T)^+ (A M^-1 (tau - h) + Adot qd),  qdd = M^-1 (tau - h - A^T lam).

    Args:
      q: (nq,) configuration; qd, tau: (nv,) single state (rad or m, rad/s or m/s, N m or N;
        a floating base's body twist and the wrench on it in its frame, angular first).
      constraints: constraint objects (opendyn.multibody.constraint_objects), OR
      A, Adot_qd: a general (k, nv) constraint matrix and its (k,) drift Adot qd; exactly one of
        `constraints` and `A` (with `Adot_qd`).
      gravity: optional (3,) world-frame gravity (m/s^2); f_tip: optional {frame: (6,) wrench
        (m, f) the frame applies to the environment, in its own coordinates}, as in
        forward_dynamics.
    Returns qdd (nv,) and lam (k,), the generalized constraint force the robot applies to the
    constraints (for a point constraint: the force in N, world axes, that the point pushes with;
    for a FixedPose: the wrench (m, f) frame b applies, in frame b's coordinates). For
    rank-deficient A, lam is the minimum-norm solution (constraints.solve).
    data: optional Data of this model: returns data.qdd and data.constraint_rows(k).lam; with
      A, data.h holds the right-hand side tau - h - J^T F_tip and data.M's lower triangle the
      Cholesky factor of M.
    Raises SingularMassMatrixError when M is singular.
    """
    what = "constrained_forward_dynamics"
    checks.check_model(model, what)
    _data_for(model, data, what, q, qd, tau)
    if (constraints is None) == (A is None):
        raise ValueError(
            f"{what}: give exactly one of `constraints` (constraint objects) and `A` (a (k, nv) "
            f"matrix, with its Adot_qd), got {'both' if A is not None else 'neither'}"
        )
    if A is None and Adot_qd is not None:
        raise ValueError(f"{what}: Adot_qd goes with A; with `constraints` it is computed")
    if A is not None and Adot_qd is None:
        raise ValueError(f"{what}: A needs its drift Adot_qd ((k,) = d/dt (A) qd)")
    q = _configuration(model, q, "q", what)
    qd = _state(model, qd, "qd", what)
    tau = _state(model, tau, "tau", what)
    loads = checks.loads(model, gravity, f_tip)
    if constraints is not None:
        rows, params = _table(model, constraints, q, "q")
        qdd, lam = _solution(model, int(rows[:, ROW_COUNT].sum()), data)
        status = constrained_forward_kernel(
            model._ibuf,
            model._fbuf,
            ConstraintTable(rows, params, NO_STABILISATION),
            q,
            qd,
            tau,
            loads,
            np.zeros(0),
            qdd,
            lam,
        )
    else:
        A = _matrix_A(model, A, what)
        gamma = _vector_k(Adot_qd, A.shape[0], "Adot_qd", what)
        work = checks.work_of(model, data, what)
        if data is None:
            rhs, M = np.empty(model.nv), np.empty((model.nv, model.nv))
        else:
            rhs, M = data.h, data.M
        # rhs = tau - h - J^T F_tip, M by CRBA
        status = rnea_kernel(model._ibuf, model._fbuf, work, q, qd, model._zero_v, loads, rhs)
        if not status:
            np.subtract(tau, rhs, out=rhs)
            status = crba_kernel(model._ibuf, model._fbuf, work, q, M)
        qdd, lam = _solution(model, A.shape[0], data)
        if not status:
            status = constrained_solve_kernel(M, rhs, A, gamma, qdd, lam)
    arguments = {
        "q": q,
        "qd": qd,
        "tau": tau,
        "A": A,
        "Adot_qd": Adot_qd,
        "gravity": gravity,
        "f_tip": f_tip,
    }
    if status:
        checks.raise_status(status, model, what, "qdd", arguments, singular_mass_matrix)
    return (
        checks.check_result(qdd, what, "qdd", arguments),
        checks.check_result(lam, what, "lam", arguments),
    )


def _solution(model, k, data):
    """(qdd (nv,), lam (k,)) to solve into: fresh, or data.qdd and data.constraint_rows(k).lam."""
    if data is None:
        return np.empty(model.nv), np.empty(k)
    return data.qdd, data.constraint_rows(k).lam


def _held(x, data, field):
    """x, or with data its copy in the Data's field of that name (which is returned)."""
    if data is None:
        return x
    out = getattr(data, field)
    out[...] = x
    return out


def _pseudo_inverse(G):
    """G^+ of a symmetric positive semi-definite G, with the cutoff of pseudo_solve."""
    k = G.shape[0]
    E, e = np.empty((k, k)), np.empty(k)
    symmetric_eigen(np.array(0.5 * (G + G.T), dtype=np.float64), E, e)
    if k == 0 or not e.max() > 0.0:
        return np.zeros((k, k))
    keep = e > RANK_RTOL * e.max()
    return (E[:, keep] / e[keep]) @ E[:, keep].T


def _projection(model, q, A, what):
    """P, G^+ and M^-1 for the checked (q, A)."""
    M = mass_matrix(model, q)
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise singular_mass_matrix(model, q, what) from None
    M_inv = np.linalg.solve(L.T, np.linalg.solve(L, np.eye(model.nv)))
    M_inv = 0.5 * (M_inv + M_inv.T)
    G_pinv = _pseudo_inverse(A @ M_inv @ A.T)
    P = np.eye(model.nv) - A.T @ G_pinv @ A @ M_inv
    return P, G_pinv, M_inv


def constraint_projection(model, q, A, data=None):
    """P(q) = I - A^T (A M^-1 A^T)^+ A M^-1: (nv, nv), so that P tau = P (M qdd + h) on the
    constrained motion (constrained inverse dynamics). P A^T = 0 (P removes the torques the
    constraints absorb), P^2 = P, A M^-1 P = 0, and P M = M - A^T G^+ A is symmetric.

    q: (nq,) configuration; A: (k, nv) constraint matrix (e.g. constraint_jacobian). For
    rank-deficient A, (A M^-1 A^T)^+ is the pseudo-inverse (constraints.solve).
    data: optional Data of this model: returns data.P (computed by numpy, then copied in).
    """
    what = "constraint_projection"
    checks.check_model(model, what)
    _data_for(model, data, what, q)
    q = _configuration(model, q, "q", what)
    A = _matrix_A(model, A, what)
    P = checks.check_result(_projection(model, q, A, what)[0], what, "P", {"q": q, "A": A})
    return _held(P, data, "P")


def constrained_inverse_dynamics(model, q, qd, qdd, A, lam=None, gravity=None, data=None):
    """tau (nv,): the joint torques that produce qdd under the constraints A qd = 0.

    lam None: tau = P (M qdd + h), the torque with no part that the constraints absorb
      (A M^-1 tau = 0); the constraints then carry lam_P = -(A M^-1 A^T)^+ A M^-1 (M qdd + h).
    lam (k,) given: tau = P (M qdd + h) + A^T (lam - lam_P) = M qdd + h + A^T lam, the torque
      that produces qdd while the constraints carry exactly lam.
    Either way constrained_forward_dynamics(tau) gives back qdd (and lam_P or lam) when qdd is
    consistent: A qdd + Adot qd = 0.

    q: (nq,) configuration; qd, qdd: (nv,); A: (k, nv); lam: (k,) constraint force as returned by
    constrained_forward_dynamics; gravity: optional (3,) world-frame gravity (m/s^2).
    data: optional Data of this model: returns data.tau (computed by numpy, then copied in).
    """
    what = "constrained_inverse_dynamics"
    checks.check_model(model, what)
    _data_for(model, data, what, q, qd, qdd)
    q = _configuration(model, q, "q", what)
    qd = _state(model, qd, "qd", what)
    qdd = _state(model, qdd, "qdd", what)
    A = _matrix_A(model, A, what)
    if lam is not None:
        lam = _vector_k(lam, A.shape[0], "lam", what)
    arguments = {"q": q, "qd": qd, "qdd": qdd, "A": A, "lam": lam, "gravity": gravity}
    tau_free = np.empty(model.nv)
    status = rnea_kernel(
        model._ibuf,
        model._fbuf,
        model._work,
        q,
        qd,
        qdd,
        checks.loads(model, gravity, None),
        tau_free,
    )
    if status:
        checks.raise_status(status, model, what, "tau", arguments, singular_mass_matrix)
    P, G_pinv, M_inv = _projection(model, q, A, what)
    tau = P @ tau_free
    if lam is not None:
        lam_P = -G_pinv @ (A @ (M_inv @ tau_free))
        tau = tau + A.T @ (lam - lam_P)
    return _held(checks.check_result(tau, what, "tau", arguments), data, "tau")


def constraint_wrench(model, q, frame, A, lam, data=None):
    """F_tip = J_b^-T A^T lam: (6,) the wrench (m, f) the frame applies to the constraint, in
    the frame's coordinates (N m, N), so that J_b^T F_tip = A^T lam (the seed's J^T F_tip =
    A^T lam); J_b is the frame's body Jacobian.

    q: (nq,) configuration; frame: a frame name; A: (k, nv); lam: (k,) (as from
    constrained_forward_dynamics). Raises ValueError when J_b is not square (nv != 6) or not
    invertible at q (a singular configuration), saying so.
    data: optional Data of this model: returns data.F_tip (computed by numpy, then copied in).
    """
    what = "constraint_wrench"
    checks.check_model(model, what)
    _data_for(model, data, what, q)
    q = _configuration(model, q, "q", what)
    A = _matrix_A(model, A, what)
    lam = _vector_k(lam, A.shape[0], "lam", what)
    J_b = jacobian(model, q, frame, expressed_in="body")
    if model.nv != 6:
        raise ValueError(
            f"{what}: J_b of frame {frame!r} is 6 x {model.nv}, not square: F_tip = J_b^-T A^T "
            f"lam needs exactly 6 velocity coordinates (model {model.name!r} has nv={model.nv})"
        )
    sv = np.linalg.svd(J_b, compute_uv=False)
    if not sv[-1] > 1e-10 * sv[0]:
        raise ValueError(
            f"{what}: J_b of frame {frame!r} is not invertible at this q (singular values "
            f"{sv}): the frame cannot move in every direction, so F_tip is not determined"
        )
    F_tip = np.linalg.solve(J_b.T, A.T @ lam)
    F_tip = checks.check_result(F_tip, what, "F_tip", {"q": q, "A": A, "lam": lam})
    return _held(F_tip, data, "F_tip")
