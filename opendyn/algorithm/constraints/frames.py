"""Where the constraint points and frames are and how they move, compiled for the constraint
rows (opendyn.algorithm.constraints.terms): world poses from the parent-relative ones, a body
point's position, classical acceleration and Jacobian, a frame's pose and twist, the relative
pose of two frames, the twist Jacobian in another frame's axes, and the SE(3) logarithm.

Twists are (w, v), angular first; R_s, p_s are the bodies' world poses T_{s,i}; a body index of
-1 is the fixed world.
"""

from __future__ import annotations

from numba import njit

from ..._runtime.kernel_cache import INLINE
from ...spatial.compiled import twist_to_child
from ..kinematics import space_axis


@njit(**INLINE)
def world_poses(parent, R, p, R_s, p_s):
    """R_s[i], p_s[i] <- T_{s,i} from the parent-relative poses (R[i], p[i]) = T_{lambda,i}."""
    for i in range(parent.shape[0]):
        lam = parent[i]
        if lam < 0:
            R_s[i] = R[i]
            p_s[i] = p[i]
            continue
        for r in range(3):
            for c in range(3):
                R_s[i, r, c] = (
                    R_s[lam, r, 0] * R[i, 0, c]
                    + R_s[lam, r, 1] * R[i, 1, c]
                    + R_s[lam, r, 2] * R[i, 2, c]
                )
            p_s[i, r] = (
                p_s[lam, r]
                + R_s[lam, r, 0] * p[i, 0]
                + R_s[lam, r, 1] * p[i, 1]
                + R_s[lam, r, 2] * p[i, 2]
            )


@njit(**INLINE)
def point_motion(R_s, p_s, V, dV, body, r, p_w, a_w):
    """p_w <- the world position of the point r (body coordinates) of `body`, and a_w <- its
    classical acceleration in world axes from the body twist V = (w, v) and its rate dV:
        a = R (dv + dw x r + w x (v + w x r));   body -1: r is a world point at rest."""
    if body < 0:
        for k in range(3):
            p_w[k] = r[k]
            a_w[k] = 0.0
        return
    w0, w1, w2 = V[body, 0], V[body, 1], V[body, 2]
    u0 = V[body, 3] + w1 * r[2] - w2 * r[1]
    u1 = V[body, 4] + w2 * r[0] - w0 * r[2]
    u2 = V[body, 5] + w0 * r[1] - w1 * r[0]
    b0 = dV[body, 3] + dV[body, 1] * r[2] - dV[body, 2] * r[1] + w1 * u2 - w2 * u1
    b1 = dV[body, 4] + dV[body, 2] * r[0] - dV[body, 0] * r[2] + w2 * u0 - w0 * u2
    b2 = dV[body, 5] + dV[body, 0] * r[1] - dV[body, 1] * r[0] + w0 * u1 - w1 * u0
    for k in range(3):
        R = R_s[body, k]
        p_w[k] = p_s[body, k] + R[0] * r[0] + R[1] * r[1] + R[2] * r[2]
        a_w[k] = R[0] * b0 + R[1] * b1 + R[2] * b2


@njit(**INLINE)
def relative_pose(R_s1, p_s1, R_s2, p_s2, R_12, p_12):
    """(R_12, p_12) <- T_12 = T_s1^-1 T_s2 = (R_s1^T R_s2, R_s1^T (p_s2 - p_s1))."""
    for i in range(3):
        for j in range(3):
            R_12[i, j] = R_s1[0, i] * R_s2[0, j] + R_s1[1, i] * R_s2[1, j] + R_s1[2, i] * R_s2[2, j]
        p_12[i] = (
            R_s1[0, i] * (p_s2[0] - p_s1[0])
            + R_s1[1, i] * (p_s2[1] - p_s1[1])
            + R_s1[2, i] * (p_s2[2] - p_s1[2])
        )


@njit(**INLINE)
def frame_in_world(R_s, p_s, body, R_bf, p_bf, R_sf, p_sf):
    """(R_sf, p_sf) <- T_{s,body} T_{body,frame}; body -1: T_{body,frame} is already T_sf."""
    for r in range(3):
        if body < 0:
            for c in range(3):
                R_sf[r, c] = R_bf[r, c]
            p_sf[r] = p_bf[r]
            continue
        for c in range(3):
            R_sf[r, c] = (
                R_s[body, r, 0] * R_bf[0, c]
                + R_s[body, r, 1] * R_bf[1, c]
                + R_s[body, r, 2] * R_bf[2, c]
            )
        p_sf[r] = (
            p_s[body, r]
            + R_s[body, r, 0] * p_bf[0]
            + R_s[body, r, 1] * p_bf[1]
            + R_s[body, r, 2] * p_bf[2]
        )


@njit(**INLINE)
def frame_twist(V, body, R_bf, p_bf, out):
    """out <- Ad_{T_{frame,body}} V[body], a frame's body twist (or its rate); 0 in the world."""
    if body < 0:
        for k in range(6):
            out[k] = 0.0
        return
    twist_to_child(R_bf, p_bf, V[body], out)


@njit(**INLINE)
def add_relative_twist_jacobian(body_tree, R_s, p_s, body, R_sb, p_sb, sign, J, S_s, S_b):
    """J (6, nv) += sign * Ad_{T_{b,s}} J_s(body): the space twist of `body` per unit v, in the
    axes of frame b at (R_sb, p_sb) (body_tree: the model's BodyTree). S_s, S_b: (6,) scratch."""
    i = body
    while i >= 0:
        f = sign * body_tree.mult[i]
        for k in range(body_tree.nv_j[i]):
            space_axis(R_s[i], p_s[i], body_tree.S[i, k], S_s)
            twist_to_child(R_sb, p_sb, S_s, S_b)
            c = body_tree.iv[i] + k
            for r in range(6):
                J[r, c] += f * S_b[r]
        i = body_tree.parent[i]
