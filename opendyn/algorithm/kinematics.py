"""Forward kinematics and Jacobians on the tree, product of exponentials in body frames:

    T_{s,i}(q) = T_{s,lambda(i)} M_{lambda(i), i} X_J(q_i)
    T_{s,frame} = T_{s,body} T_{body,frame}
    J_s(q)[:, k] = sum over the frame's path of mult_i Ad_{T_{s,i}} s_i (rows s_i of S_i with
                   velocity coordinate k)
    J_b(q) = Ad_{T_{frame,s}} J_s(q)

so that V_s = J_s v and V_b = J_b v are the frame's twists in the space and the frame's own
coordinates (angular first; Lynch & Park, Sections 4.1 and 5.1). For a floating base v starts
with the base twist in its own frame, so its columns of J are the base's body-frame axes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import copy_into, fill, result_status, zero_matrix
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from ..multibody.joints import (
    FREE,
    configuration_status,
    joint_transform,
    place_joints,
    prepare_joint_transforms,
)
from ..multibody.layout import body_count, dof_count, tree
from ..multibody.work_views import (
    body_flags,
    frame_pose_field,
    joint_poses,
    new_work,
    temp_vectors,
    world_poses,
)
from ..spatial.compiled import twist_to_child
from . import checks
from .calls import Call, checked_call


@njit(**INLINE)
def world_pose(R_s, p_s, lam, R, p, i):
    """R_s[i], p_s[i] <- T_{s,i} = T_{s,lambda} T_{lambda,i} with (R, p) = T_{lambda,i};
    lam -1 is the world (T_{s,i} = T_{lambda,i})."""
    if lam < 0:
        for r in range(3):
            p_s[i, r] = p[r]
            for c in range(3):
                R_s[i, r, c] = R[r, c]
        return
    for r in range(3):
        for c in range(3):
            R_s[i, r, c] = (
                R_s[lam, r, 0] * R[0, c] + R_s[lam, r, 1] * R[1, c] + R_s[lam, r, 2] * R[2, c]
            )
        p_s[i, r] = (
            p_s[lam, r] + R_s[lam, r, 0] * p[0] + R_s[lam, r, 1] * p[1] + R_s[lam, r, 2] * p[2]
        )


@njit(**JIT)
def forward_kinematics(ibuf, fbuf, work, q):
    """The work buffer's R[i], p[i] <- T_{lambda(i), i}(q) and R_s[i], p_s[i] <- T_{s,i}(q)
    (world frame = the root link) for every body of the model of buffers ibuf, fbuf.
    Compiled once and called by the kernels that need world poses: it takes the two buffers,
    not their BodyTree of ten views, as a compiled call updates the reference count of each
    array it takes, twice (measured on a UR5: 0.05 us a call)."""
    body_tree = tree(ibuf, fbuf)
    R, p = joint_poses(work, body_count(ibuf))
    place_joints(body_tree, q, R, p)
    place_bodies(body_tree, work)


@njit(**JIT)
def path_kinematics(body_tree, work, q, last):
    """forward_kinematics for the bodies on the path from the root to body `last` >= 0 alone
    (a frame's pose and Jacobian need no other)."""
    parent, jtype, iq = body_tree.parent, body_tree.jtype, body_tree.iq
    mult, offset, S = body_tree.mult, body_tree.offset, body_tree.S
    R_home, p_home = body_tree.R_home, body_tree.p_home
    nb = parent.shape[0]
    R, p = joint_poses(work, nb)
    R_s, p_s = world_poses(work, nb)
    prepare_joint_transforms(body_tree, q, R, p)
    wanted = body_flags(work, nb)  # 1.0 for a body on the path
    fill(wanted, 0.0)
    i = last
    while i >= 0:
        wanted[i] = 1.0
        i = parent[i]
    for i in range(last + 1):
        if wanted[i] == 0.0:
            continue
        if jtype[i] != FREE:
            theta = mult[i] * q[iq[i]] + offset[i]
            joint_transform(S[i], R_home[i], p_home[i], theta, R[i], p[i])
        world_pose(R_s, p_s, parent[i], R[i], p[i], i)


@njit(**INLINE)
def place_bodies(body_tree, work):
    """The work buffer's R_s[i], p_s[i] <- T_{s,i} = T_{s,lambda(i)} T_{lambda(i), i} for every
    body, from the joint poses R, p it holds (joints.place_joints)."""
    parent = body_tree.parent
    nb = parent.shape[0]
    R, p = joint_poses(work, nb)
    R_s, p_s = world_poses(work, nb)
    for i in range(nb):
        world_pose(R_s, p_s, parent[i], R[i], p[i], i)


@njit(**INLINE)
def space_axis(R_s, p_s, A_i, S):
    """S <- Ad_{T_{s,i}} A_i = (R w, p x (R w) + R v), a motion axis of joint i (a row of
    S_i) in {s}, with (R, p) = (R_s, p_s) = T_{s,i} and A_i = (w, v)."""
    for r in range(3):
        S[r] = R_s[r, 0] * A_i[0] + R_s[r, 1] * A_i[1] + R_s[r, 2] * A_i[2]
        S[3 + r] = R_s[r, 0] * A_i[3] + R_s[r, 1] * A_i[4] + R_s[r, 2] * A_i[5]
    S[3] += p_s[1] * S[2] - p_s[2] * S[1]
    S[4] += p_s[2] * S[0] - p_s[0] * S[2]
    S[5] += p_s[0] * S[1] - p_s[1] * S[0]


@njit(**INLINE)
def place_space_axes(body_tree, R_s, p_s, S_s):
    """S_s[i, k] <- mult_i Ad_{T_{s,i}} S_i[k] for every body i and row k < nv_i of its joint's
    S_i: the joints' motion axes in {s} at the world poses R_s, p_s, each coordinate's share
    (mult) included."""
    nv_j, mult, S = body_tree.nv_j, body_tree.mult, body_tree.S
    for i in range(nv_j.shape[0]):
        for k in range(nv_j[i]):
            space_axis(R_s[i], p_s[i], S[i, k], S_s[i, k])
            for r in range(6):
                S_s[i, k, r] *= mult[i]


@njit(**INLINE)
def add_point_jacobian(body_tree, R_s, p_s, body, p_w, sign, J, S_s):
    """J (3, nv) += sign * d(world velocity of the world point p_w fixed to `body`)/d v:
    column iv[i] + k gets mult[i] (v_i + w_i x p_w) with (w_i, v_i) = Ad_{T_{s,i}} S[i, k]
    (row k of S_i), for every body i from `body` to the root (body_tree: the model's BodyTree).
    S_s is (6,) scratch."""
    i = body
    while i >= 0:
        f = sign * body_tree.mult[i]
        for k in range(body_tree.nv_j[i]):
            space_axis(R_s[i], p_s[i], body_tree.S[i, k], S_s)
            c = body_tree.iv[i] + k
            J[0, c] += f * (S_s[3] + S_s[1] * p_w[2] - S_s[2] * p_w[1])
            J[1, c] += f * (S_s[4] + S_s[2] * p_w[0] - S_s[0] * p_w[2])
            J[2, c] += f * (S_s[5] + S_s[0] * p_w[1] - S_s[1] * p_w[0])
        i = body_tree.parent[i]


@njit(**JIT)
def compose_frame(R_s, p_s, body, T_bf, T_sf):
    """T_sf (4, 4) <- T_{s,body} T_{body,frame}; body -1 is the world."""
    zero_matrix(T_sf)
    T_sf[3, 3] = 1.0
    for r in range(3):
        for c in range(4):
            T_sf[r, c] = (
                T_bf[r, c]
                if body < 0
                else (
                    R_s[body, r, 0] * T_bf[0, c]
                    + R_s[body, r, 1] * T_bf[1, c]
                    + R_s[body, r, 2] * T_bf[2, c]
                )
            )
        if body >= 0:
            T_sf[r, 3] += p_s[body, r]


@njit(**JIT)
def frame_pose_kernel(ibuf, fbuf, work, q, body, T_bf, T_sf):
    """T_sf (4, 4) <- T_{s,body}(q) T_{body,frame}, in `work` (a Data's buffer: R_s, p_s hold
    the poses of the bodies from the root to `body`). Returns a Status: OK, Q_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    nb = body_count(ibuf)
    R_s, p_s = world_poses(work, nb)
    if body >= 0:
        path_kinematics(tree(ibuf, fbuf), work, q, body)
    compose_frame(R_s, p_s, body, T_bf, T_sf)
    return result_status(T_sf)


@njit(**JIT)
def jacobian_kernel(ibuf, fbuf, work, q, frame, body_frame, J):
    """J (6, nv) <- J_s, or J_b of the frame when body_frame, in `work` (a Data's buffer: R_s,
    p_s as frame_pose_kernel leaves them, T_sf the frame's pose). frame = (body, T_bf): the
    frame's body and its pose in the body. Returns a Status: OK, Q_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    body = frame[0]
    if body >= 0:
        path_kinematics(tree(ibuf, fbuf), work, q, body)
    frame_jacobian(ibuf, fbuf, work, frame, body_frame, J)
    return result_status(J)


@njit(**JIT)
def frame_jacobian(ibuf, fbuf, work, frame, body_frame, J):
    """jacobian_kernel on the world poses R_s, p_s that `work` holds for the bodies from the
    root to the frame's (path_kinematics at a checked q): J (6, nv) <- J_s, or J_b when
    body_frame; work's T_sf <- the frame's pose."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S_rows = body_tree.mult, body_tree.S
    nb, nv = parent.shape[0], J.shape[1]
    body, T_bf = frame
    R_s, p_s = world_poses(work, nb)
    T_sf = frame_pose_field(work, nb, nv)
    compose_frame(R_s, p_s, body, T_bf, T_sf)
    temp = temp_vectors(work, nb, nv)
    S, col = temp[0], temp[1]
    zero_matrix(J)
    i = body
    while i >= 0:
        for k in range(nv_j[i]):
            space_axis(R_s[i], p_s[i], S_rows[i, k], S)
            if body_frame:
                # Ad_{T_{frame,s}} S = (R^T w, R^T (v + w x p)) with (R, p) = T_sf
                twist_to_child(T_sf[:3, :3], T_sf[:3, 3], S, col)
            else:
                copy_into(S, col)
            for r in range(6):
                J[r, iv[i] + k] += mult[i] * col[r]
        i = parent[i]


@njit(**BATCH)
def jacobian_batch_kernel(ibuf, fbuf, q, frame, body_frame, J, status, start, stop):
    """Jacobians over rows [start, stop) of a batch of configurations (N, nq) -> (N, 6, nv),
    in a work buffer of their own."""
    work = new_work(body_count(ibuf), J.shape[2])
    for n in range(start, stop):
        status[n] = jacobian_kernel(ibuf, fbuf, work, q[n], frame, body_frame, J[n])


@njit(**BATCH)
def frame_pose_batch_kernel(ibuf, fbuf, q, body, T_bf, T_sf, status, start, stop):
    """Frame poses over rows [start, stop) of a batch of configurations (N, nq) -> (N, 4, 4),
    in a work buffer of their own."""
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = frame_pose_kernel(ibuf, fbuf, work, q[n], body, T_bf, T_sf[n])


frame_pose_exact = exact(frame_pose_kernel)
jacobian_exact = exact(jacobian_kernel)
FRAME_POSE = Call(frame_pose_kernel, frame_pose_exact, frame_pose_batch_kernel, ("q",))
JACOBIAN = Call(jacobian_kernel, jacobian_exact, jacobian_batch_kernel, ("q",))


def _at_configurations(call, model, q, data, a, b, what, result):
    """The result of a frame function at q (nq,), or at each row of a batch (N, nq): call's
    kernels take (ibuf, fbuf, [work,] q, a, b, out); result "T_sf" (4, 4) or "J" (6, nv), the
    Data field that data= returns. A float64 (nq,) q goes straight to the twin; anything else
    through checked_call."""
    work = checks.work_of(model, data, what)
    if data is not None:
        out = getattr(data, result)
    else:
        out = np.empty((4, 4) if result == "T_sf" else (6, model.nv))
    try:
        if not call.twin(model._ibuf, model._fbuf, work, q, a, b, out):
            return out
    except TypeError:  # arguments to convert: the checked path
        pass
    return checked_call(call, model, data, (q,), out, what, result, (a, b))


def _frame(model, frame):
    """(body, T_bf) of a frame, the pair the kernels take; KeyError naming an unknown frame."""
    try:
        return model._frame_targets[frame]
    except (KeyError, TypeError):
        model.frame_index(frame)  # raises the KeyError that names it and the valid frames
        raise


def frame_pose(model, q, frame, data=None):
    """T_sf(q): (4, 4) pose of a frame (any URDF link) in the world frame (the root link).

    q: (nq,) or (N, nq) -> (4, 4) or (N, 4, 4); translation in metres.
    data: optional Data of this model (single configurations): returns data.T_sf, allocating
    nothing; data.R_s, data.p_s hold the world poses of the bodies from the root to the
    frame's.
    Raises KeyError naming the frame if it is not a frame of the model.
    """
    checks.check_model(model, "frame_pose")
    body, T_bf = _frame(model, frame)
    return _at_configurations(FRAME_POSE, model, q, data, body, T_bf, "frame_pose", "T_sf")


def jacobian(model, q, frame, expressed_in="space", data=None):
    """The (6, nv) Jacobian of a frame: V = J(q) v, twist (omega, v) angular first.

    expressed_in="space": J_s, the frame's twist in the world frame (MR eq. 5.11);
    expressed_in="body":  J_b, the twist in the frame's own coordinates (MR eq. 5.18);
    J_s = Ad_{T_sf} J_b. q: (nq,) or (N, nq) -> (6, nv) or (N, 6, nv).
    data: optional Data of this model (single configurations): returns data.J, allocating
    nothing; data.T_sf holds the frame's pose.
    """
    checks.check_model(model, "jacobian")
    if expressed_in not in ("space", "body"):
        raise ValueError(f"jacobian: expressed_in must be 'space' or 'body', got {expressed_in!r}")
    frame_at, body_frame = _frame(model, frame), expressed_in == "body"
    return _at_configurations(JACOBIAN, model, q, data, frame_at, body_frame, "jacobian", "J")
