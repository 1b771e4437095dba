"""What the effects' exact derivatives share (their `tangent`, for opendyn.sim.linearize): the
point of linearization, the space axes of the joints at q, and the derivative of the
generalized force of a world wrench on a body.

Every derivative in q is taken in the tangent space, as the dynamics' derivatives are (q moved
by integrate(q, dq): for a joint its coordinate, for a free joint the body twist), and moving
the axis k of a joint by dq_k moves every body below it by the space screw S_k dq_k. For a
wrench F_s (m, f) about the world origin in world axes acting on body b, the generalized force
and its derivative along an axis j on the path from the root to b are
    tau_i = S_i . F_s,
    dtau_i/dq_j = [j at or above i] (S_j x S_i) . F_s + S_i . dF_s/dq_j,
with x the Lie bracket ad (S_j moves S_i when the joint of j carries that of i). A wrench fixed
in the body turns with it, dF_s/dq_j = S_j x* F_s (= -ad_{S_j}^T F_s), and the two terms
cancel unless j is below i; a force f fixed in the world at a point x of the body has
dF_s/dq_j = ((v_j + w_j x x) x f, 0).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ...algorithm.christoffel import space_axes_and_inertias

# A point of linearization: the scene, time t (s), state q (nq,), qd (nv,), gravity (3,)
# world-frame (m/s^2; zero when the scene names none), armature (nv,) (zero where none), axes
# the joints' space axes at q (SpaceAxes), and control = [tau (nv,), dtau_dq, dtau_dqd (nv, nv)]
# the control laws' torque and derivatives so far (clip reads and changes them).
LinearAt = namedtuple(
    "LinearAt", ("scene", "t", "q", "qd", "gravity", "armature", "axes", "control")
)

# The joints at q: S_s (nb, 6, 6) rows k < nv_i: body i's joint axis k in {s} (times its
# mimic multiplier), R_s (nb, 3, 3) and p_s (nb, 3) the bodies' poses in {s}.
SpaceAxes = namedtuple("SpaceAxes", ("S_s", "R_s", "p_s"))


def space_axes(model, q) -> SpaceAxes:
    """The SpaceAxes of `model` at the configuration q (nq,)."""
    data = model.data()
    space_axes_and_inertias(model._ibuf, model._fbuf, data._work, q)
    return SpaceAxes(data.S_s.copy(), data.R_s.copy(), data.p_s.copy())


def path_axes(model, axes, body):
    """The joint axes from the root to `body`, root first: (S (n_a, 6) in {s}, coords (n_a,)
    their velocity coordinates, depth (n_a,) their bodies' places on the path)."""
    bodies = []
    while body >= 0:
        bodies.append(body)
        body = model.parent[body]
    bodies.reverse()
    S, coords, depth = [], [], []
    for place, b in enumerate(bodies):
        for k in range(model.nv_j[b]):
            S.append(axes.S_s[b, k])
            coords.append(model.iv[b] + k)
            depth.append(place)
    return np.array(S).reshape(-1, 6), np.array(coords, dtype=int), np.array(depth)


def bracket(S, W):
    """ad_S W = S x W (rows of S (n, 6) with W (6,) or rows (n, 6)): (w x w_W, v x w_W + w x
    v_W)."""
    w, v = S[..., :3], S[..., 3:]
    return np.concatenate(
        [np.cross(w, W[..., :3]), np.cross(v, W[..., :3]) + np.cross(w, W[..., 3:])], axis=-1
    )


def bracket_transpose(S, F):
    """ad_S^T F for rows S (n, 6) and a wrench F (6,) (m, f): -(w x m + v x f, w x f)."""
    w, v = S[:, :3], S[:, 3:]
    return -np.concatenate([np.cross(w, F[:3]) + np.cross(v, F[3:]), np.cross(w, F[3:])], 1)


def point_velocities(S, x):
    """(n, 3): v + w x x, the velocity of the world point x (3,) for each unit axis row of S."""
    return S[:, 3:] + np.cross(S[:, :3], x)


def wrench_tangent(model, axes, body, F_s, dF_dq):
    """(tau (nv,), dtau_dq (nv, nv)) of the world wrench F_s (6,) on `body`, with dF_dq (n_a, 6)
    its derivative along each axis of the path (path_axes order): the module docstring."""
    S, coords, depth = path_axes(model, axes, body)
    nv = model.nv
    tau, dtau_dq = np.zeros(nv), np.zeros((nv, nv))
    if not len(coords):
        return tau, dtau_dq
    np.add.at(tau, coords, S @ F_s)
    # (S_j x S_i) . F_s = S_i . ad_{S_j}^T F_s, where the joint of j is at or above that of i
    moved = (S @ bracket_transpose(S, F_s).T) * (depth[None, :] <= depth[:, None])
    np.add.at(dtau_dq, (coords[:, None], coords[None, :]), moved + S @ dF_dq.T)
    return tau, dtau_dq


def on_joints(model, values):
    """(nv,) with the joints' values (n,) at their velocity coordinates, 0 on a base."""
    out = np.zeros(model.nv)
    out[model.v_index] = values
    return out
