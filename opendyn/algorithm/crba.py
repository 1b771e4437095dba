"""Mass matrix by the composite-rigid-body algorithm (CRBA):

    M_ij = S_i^T Ad_{T_{j,i}}^T Ic_j S_j   for j a descendant of i (or i itself), else 0

(blocks nv_i x nv_j; S_i = A_i for a 1-dof joint, I_6 for a free one). Backward pass, tips to
base, composite inertias of the subtrees:
    Ic_i = G_i + sum_children Ad_{T_{c,i}}^T Ic_c Ad_{T_{c,i}}
then for each row s of S_i the wrench F = Ic_i s gives the entries with the joint's own rows,
s'^T F, and is carried up its ancestors j: F <- Ad_{T_{j',j}}^T F, M_ij = F^T S_j.
(Featherstone, Rigid Body Dynamics Algorithms, 2008, Section 6.2.)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import result_status, zero_matrix
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, JIT
from ..multibody.joints import configuration_status, place_joints
from ..multibody.layout import body_count, dof_count, rigid_inertias, tree
from ..multibody.work_views import composite_inertias, joint_poses, new_work, temp_vectors
from ..spatial.compiled import (
    add_rigid_inertia_to_parent,
    dot6,
    rigid_inertia_times,
    wrench_to_parent,
)
from . import checks
from .calls import Call, checked_call


@njit(**JIT)
def crba_kernel(ibuf, fbuf, work, q, M):
    """M (nv, nv) <- CRBA at one configuration q (nq,), working in `work` (a Data's buffer: R,
    p and the composite inertias mass_c, h_c, I_c are left as this configuration's).
    Returns a Status: OK, Q_NOT_FINITE, Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    R, p = joint_poses(work, body_count(ibuf))
    place_joints(tree(ibuf, fbuf), q, R, p)
    return crba_on_poses(ibuf, fbuf, work, M)


@njit(**JIT)
def crba_on_poses(ibuf, fbuf, work, M):
    """crba_kernel on the joint poses that `work` holds (joints.place_joints at a checked q).
    Returns OK or RESULT_NOT_FINITE."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    nb, nv = body_count(ibuf), dof_count(ibuf)
    R, p = joint_poses(work, nb)
    mass_c, h_c, I_c = composite_inertias(work, nb)
    F = temp_vectors(work, nb, nv)[0]
    for i in range(nb):
        mass_c[i] = mass[i]
        for r in range(3):
            h_c[i, r] = h[i, r]
            for c in range(3):
                I_c[i, r, c] = I_o[i, r, c]
    # backward pass: Ic_lambda += Ad^T Ic_i Ad, in rigid-body form (mass, h, I_o)
    for i in range(nb - 1, -1, -1):
        lam = parent[i]
        if lam >= 0:
            add_rigid_inertia_to_parent(
                R[i],
                p[i],
                mass_c[i],
                h_c[i],
                I_c[i],
                mass_c[lam : lam + 1],
                h_c[lam],
                I_c[lam],
            )
    # M_ab = (Ad^T ... Ic_i s_a)^T s_b along the path from i to the root, s_a a row of S_i and
    # s_b a row of S_j for each j on the path (one row for a 1-dof joint, written out)
    zero_matrix(M)
    for i in range(nb):
        for k in range(nv_j[i]):
            a = iv[i] + k
            rigid_inertia_times(mass_c[i], h_c[i], I_c[i], S[i, k], F)
            for k2 in range(nv_j[i]):
                M[a, iv[i] + k2] += mult[i] * mult[i] * dot6(F, S[i, k2])
            j = i
            while parent[j] >= 0:
                wrench_to_parent(R[j], p[j], F)
                j = parent[j]
                b = iv[j]
                if nv_j[j] == 1:
                    m_ab = mult[i] * mult[j] * dot6(F, S[j, 0])
                    M[a, b] += m_ab
                    M[b, a] += m_ab
                    continue
                for k2 in range(nv_j[j]):
                    m_ab = mult[i] * mult[j] * dot6(F, S[j, k2])
                    M[a, b + k2] += m_ab
                    M[b + k2, a] += m_ab
    return result_status(M)


@njit(**BATCH)
def crba_batch_kernel(ibuf, fbuf, q, M, status, start, stop):
    """CRBA over rows [start, stop) of a batch of configurations (N, nq) -> M (N, nv, nv),
    in a work buffer of their own."""
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = crba_kernel(ibuf, fbuf, work, q[n], M[n])


crba_exact = exact(crba_kernel)
CRBA = Call(crba_kernel, crba_exact, crba_batch_kernel, ("q",))


def mass_matrix(model, q, data=None):
    """M(q): the (nv, nv) joint-space mass matrix, symmetric positive definite, by CRBA.

    q: (nq,) configuration (joint positions in rad or m, after a floating base's (p, quat)),
    or a batch (N, nq) -> (N, nv, nv).
    data: optional Data of this model (single configurations): the call works in it and
    returns data.M, allocating nothing.
    Units: kg m^2 (rotation-rotation), kg m (mixed), kg (translation-translation); a floating
    base's block is the spatial inertia of the whole robot in the base frame.
    """
    work = checks.work_of(model, data, "mass_matrix")  # checks model and data
    # the common call: a float64 (nq,) vector goes straight to the kernel's exact twin
    M = np.empty(model._matrix_shape) if data is None else data.M
    try:
        if not crba_exact(model._ibuf, model._fbuf, work, q, M):
            return M
    except TypeError:  # arguments to convert: the checked path
        pass
    return checked_call(CRBA, model, data, (q,), M, "mass_matrix", "M")
