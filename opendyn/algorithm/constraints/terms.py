"""The constraint rows at a state: A (k, nv), Adot qd (k,) and phi (k,) of a constraint table
(opendyn.algorithm.constraints.table), compiled for the simulation step:

    d/dt phi = A qd,   d/dt (A qd) = A qdd + Adot qd

Floating base: q is (nq,), qd and the columns of A are (nv,)
(opendyn.multibody.constraint_objects): the kernel walks each joint through its rows of S and its
index iv into v, so a free joint's six columns are its body-twist coordinates (angular first) and
nothing here assumes one coordinate per body.

Compiled interface:
  constraint_terms_kernel(ibuf, fbuf, rows, params, q (nq,), qd (nv,), A, Adot_qd, phi)
      -> status
  constraint_terms_in(..., work)   the same in a TermsWork made once (terms_work(nb, nv)):
                                   the simulation step's, which allocates nothing
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..._runtime.arrays import zero_matrix
from ..._runtime.kernel_cache import JIT
from ..._runtime.status import Status
from ...multibody.constraint_objects import (
    FIXED_POSE,
    POINT_ON_PLANE,
    POINT_TO_POINT,
    POINT_TO_WORLD,
)
from ...multibody.joints import state_status
from ...multibody.layout import body_count, tree
from ...spatial.compiled import ad_twist, log_se3
from ..configuration import difference_kernel
from ..kinematics import add_point_jacobian, space_axis
from ..rnea import forward_pass
from .frames import (
    add_relative_twist_jacobian,
    frame_in_world,
    frame_twist,
    point_motion,
    relative_pose,
    world_poses,
)
from .table import BODY_A, BODY_B, KIND, OFFSET, ROW_COUNT


# The rows' scratch at nb bodies and nv coordinates (terms_work): per body the joint and
# world rotations R, R_s (2, nb, 3, 3), positions p, p_s (2, nb, 3) (m) and the twists V and
# their velocity-product rates dV (2, nb, 6) in {i}; six 6-vectors S, c6, Va, Vb, X, Y (6, 6),
# four 3-vectors p_a, a_a, p_b, a_b (4, 3), three frames' rotations R_sa, R_sb, R_ab (3, 3, 3)
# and positions p_sa, p_sb, p_ab (3, 3), a point's Jacobian J_p (3, nv), a configuration
# difference dq (nv,), and zeros qdd_0 (nv,) and dV_0 (6,) (kept zero: qdd = 0, no gravity).
TermsWork = namedtuple(
    "TermsWork",
    ("poses", "points", "twists", "s6", "v3", "frames", "t3", "J_p", "dq", "qdd_0", "dV_0"),
)


@njit(**JIT)
def terms_work(nb, nv):
    """The TermsWork of a model with nb bodies and nv velocity coordinates."""
    return TermsWork(
        np.empty((2, nb, 3, 3)),
        np.empty((2, nb, 3)),
        np.empty((2, nb, 6)),
        np.empty((6, 6)),
        np.empty((4, 3)),
        np.empty((3, 3, 3)),
        np.empty((3, 3)),
        np.empty((3, nv)),
        np.empty(nv),
        np.zeros(nv),
        np.zeros(6),
    )


@njit(**JIT)
def constraint_terms_kernel(ibuf, fbuf, rows, params, q, qd, A, Adot_qd, phi):
    """A (k, nv), Adot_qd (k,), phi (k,) <- every constraint's rows at (q (nq,), qd (nv,)),
    k = rows[:, ROW_COUNT].sum(), in table order. Adot qd is d/dt (A qd) at qdd = 0 (no gravity).
    Point rows: world axes; FIXED_POSE: frame b axes, angular first (see
    opendyn.multibody.constraint_objects). Returns a Status: OK, Q_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION or QD_NOT_FINITE."""
    work = terms_work(body_count(ibuf), qd.shape[0])
    return constraint_terms_in(ibuf, fbuf, rows, params, q, qd, A, Adot_qd, phi, work)


@njit(**JIT)
def constraint_terms_in(ibuf, fbuf, rows, params, q, qd, A, Adot_qd, phi, work):
    """constraint_terms_kernel in work, a TermsWork of the model (terms_work): allocates
    nothing."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent = body_tree.parent
    nv = qd.shape[0]
    R, R_s = work.poses[0], work.poses[1]
    p, p_s = work.points[0], work.points[1]
    V, dV = work.twists[0], work.twists[1]
    s6 = work.s6
    S, c6, Va, Vb, X, Y = s6[0], s6[1], s6[2], s6[3], s6[4], s6[5]
    v3 = work.v3
    p_a, a_a, p_b, a_b = v3[0], v3[1], v3[2], v3[3]
    R_sa, R_sb, R_ab = work.frames[0], work.frames[1], work.frames[2]
    p_sa, p_sb, p_ab = work.t3[0], work.t3[1], work.t3[2]
    J3, dq = work.J_p, work.dq
    # forward pass at qdd = 0, no gravity: V_i and dV_i = the velocity-product part of the rate
    forward_pass(body_tree, q, qd, work.qdd_0, work.dV_0, R, p, V, dV, s6[:2])
    world_poses(parent, R, p, R_s, p_s)

    zero_matrix(A)
    r0 = 0
    for n in range(rows.shape[0]):
        kind, o, m = rows[n, KIND], rows[n, OFFSET], rows[n, ROW_COUNT]
        body_a, body_b = rows[n, BODY_A], rows[n, BODY_B]
        if kind == POINT_TO_WORLD or kind == POINT_TO_POINT:
            # world velocity of point a (minus that of point b): 3 rows
            point_motion(R_s, p_s, V, dV, body_a, params[o : o + 3], p_a, a_a)
            add_point_jacobian(body_tree, R_s, p_s, body_a, p_a, 1.0, A[r0 : r0 + 3], S)
            if kind == POINT_TO_WORLD:
                for k in range(3):
                    p_b[k] = params[o + 3 + k]  # the target
                    a_b[k] = 0.0
            else:
                point_motion(R_s, p_s, V, dV, body_b, params[o + 3 : o + 6], p_b, a_b)
                add_point_jacobian(body_tree, R_s, p_s, body_b, p_b, -1.0, A[r0 : r0 + 3], S)
            for k in range(3):
                Adot_qd[r0 + k] = a_a[k] - a_b[k]
                phi[r0 + k] = p_a[k] - p_b[k]
        elif kind == POINT_ON_PLANE:
            # n . (world velocity of the point): 1 row
            point_motion(R_s, p_s, V, dV, body_a, params[o : o + 3], p_a, a_a)
            zero_matrix(J3)
            add_point_jacobian(body_tree, R_s, p_s, body_a, p_a, 1.0, J3, S)
            nrm = params[o + 3 : o + 6]
            for c in range(nv):
                A[r0, c] = nrm[0] * J3[0, c] + nrm[1] * J3[1, c] + nrm[2] * J3[2, c]
            Adot_qd[r0] = nrm[0] * a_a[0] + nrm[1] * a_a[1] + nrm[2] * a_a[2]
            phi[r0] = nrm[0] * p_a[0] + nrm[1] * p_a[1] + nrm[2] * p_a[2] - params[o + 6]
        elif kind == FIXED_POSE:
            # V_rel = V_b - Ad_{T_ba} V_a in frame b axes: 6 rows
            R_af = params[o : o + 9].reshape((3, 3))
            p_af = params[o + 9 : o + 12]
            R_bf = params[o + 12 : o + 21].reshape((3, 3))
            p_bf = params[o + 21 : o + 24]
            R_ab_ref = params[o + 24 : o + 33].reshape((3, 3))
            p_ab_ref = params[o + 33 : o + 36]
            frame_in_world(R_s, p_s, body_a, R_af, p_af, R_sa, p_sa)
            frame_in_world(R_s, p_s, body_b, R_bf, p_bf, R_sb, p_sb)
            Arows = A[r0 : r0 + 6]
            add_relative_twist_jacobian(
                body_tree, R_s, p_s, body_b, R_sb, p_sb, 1.0, Arows, S, c6
            )
            add_relative_twist_jacobian(
                body_tree, R_s, p_s, body_a, R_sb, p_sb, -1.0, Arows, S, c6
            )
            # T_ba = T_bs T_sa: R_ab holds R_ba here, p_ab holds p_ba
            relative_pose(R_sb, p_sb, R_sa, p_sa, R_ab, p_ab)
            # d/dt V_rel at qdd = 0: dV_b - Ad_{T_ba} dV_a + ad_{V_b} (Ad_{T_ba} V_a)
            frame_twist(V, body_a, R_af, p_af, Va)
            space_axis(R_ab, p_ab, Va, X)  # X = Ad_{T_ba} V_a
            frame_twist(V, body_b, R_bf, p_bf, Vb)
            ad_twist(Vb, X, Y)
            frame_twist(dV, body_a, R_af, p_af, Va)
            space_axis(R_ab, p_ab, Va, X)  # X = Ad_{T_ba} dV_a
            frame_twist(dV, body_b, R_bf, p_bf, Vb)
            for k in range(6):
                Adot_qd[r0 + k] = Vb[k] - X[k] + Y[k]
            # phi = log(T_ab*^-1 T_ab), T_ab = T_sa^-1 T_sb
            relative_pose(R_sa, p_sa, R_sb, p_sb, R_ab, p_ab)
            for i in range(3):
                for j in range(3):
                    R_sa[i, j] = (
                        R_ab_ref[0, i] * R_ab[0, j]
                        + R_ab_ref[1, i] * R_ab[1, j]
                        + R_ab_ref[2, i] * R_ab[2, j]
                    )
                p_sa[i] = (
                    R_ab_ref[0, i] * (p_ab[0] - p_ab_ref[0])
                    + R_ab_ref[1, i] * (p_ab[1] - p_ab_ref[1])
                    + R_ab_ref[2, i] * (p_ab[2] - p_ab_ref[2])
                )
            log_se3(R_sa, p_sa, phi[r0 : r0 + 6])
        else:
            # JOINT_COUPLING: a constant C (m, nv); phi = C (q (-) q_ref)
            difference_kernel(ibuf, params[o + m * nv : o + m * nv + q.shape[0]], q, dq)
            for i in range(m):
                e = 0.0
                for c in range(nv):
                    C_ic = params[o + i * nv + c]
                    A[r0 + i, c] = C_ic
                    e += C_ic * dq[c]
                Adot_qd[r0 + i] = 0.0
                phi[r0 + i] = e
        r0 += m
    return Status.OK.value
