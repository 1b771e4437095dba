"""A Python controller that pushes a box across a table with the Panda's fingers: an
operational-space impedance (as panda_impedance.py) about a set pose that moves along a
minimum-jerk path, behind the box and then 10 cm forward through it.

    p_d(t)  = p_a + (p_b - p_a) s(u),  s(u) = 10 u^3 - 15 u^4 + 6 u^5,  u = (t - t_a) / (t_b - t_a)
    e       = log(T_sb^-1 T_sd)                        (6,) pose error in the tool frame {b}
    F_b     = K e + D (V_d - J_b qd)                   V_d = (0, R_sb^T pdot_d): the path's twist
    tau     = g(q) + J_b^T F_b + N^T (k_null (q_ready - q) - d_null qd) + tau_fingers

N = 1 - M^-1 J_b^T Lambda J_b, the dynamically consistent null-space projector (Khatib 1987):
the posture spring acts only in the motion that moves no tool coordinate. The set path:

    0   - 1.5 s   from where the tool starts (the 'ready' posture) to GAP behind the box's back
                  face, at HEIGHT (the fingertips 2.2 cm above the table)
    1.5 - 4.0 s   forward along world x by GAP + PUSH: the fingers reach the box after GAP and
                  push it PUSH = 10 cm
    4.0 s -       held

FRONT, how far the fingertips' collision boxes reach ahead of the tool frame along world x,
comes from the model's collision geometry at the ready posture (the hand keeps its
orientation), so that the fingertips' front face starts GAP behind the box: the box then moves
by PUSH (less the tool's lag behind its set point, K^-1 times the friction it pushes against,
and the contact's compliance, force / stiffness).

The controller is written for the Panda alone: it reads the robot's coordinates, the first nine
of the scene's q and qd (a scene's objects come after the robot's), and returns the nine joint
torques. Run it: opendyn simulate panda_push, or through od.Simulator (tests/test_panda_push.py).
"""

import numpy as np

import opendyn as od
from opendyn.spatial import log_se3

MODEL = od.load_urdf("panda")
TOOL = "panda_hand_tcp"
N = MODEL.nq  # the robot's coordinates, first in the scene's q (9)
Q_READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.01, 0.01])
T_READY = od.frame_pose(MODEL, Q_READY, TOOL)
BOX_BACK, BOX_TOP = 0.51, 0.28  # m: the box's back face and top (centre x 0.55, 0.08 m cube on
# a table 0.2 m high), as panda_push.toml has them
HEIGHT = 0.262  # m: the tool frame's height while pushing: the fingertips 2.2 cm above the
# table, the fingers' upper boxes clear of the box's top, so that the tips push its face
GAP, PUSH = 0.02, 0.10  # m
K = np.diag([50.0, 50.0, 50.0, 2000.0, 2000.0, 2000.0])  # N m/rad, N/m
K_NULL, D_NULL = 5.0, 1.0  # N m/rad, N m s/rad
FINGERS = np.array([7, 8])
KP_FINGERS, KD_FINGERS = 200.0, 5.0  # N/m, N s/m


def _front(model, q):
    """m: how far the fingers' collision boxes that reach below the box's top (with the tool
    frame at HEIGHT) stand ahead of the tool frame along world x, the hand posed as at q."""
    p_tool = od.frame_pose(model, q, TOOL)[:3, 3]
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) / 2.0
    front = -np.inf
    for g in model.geometries:
        if "finger" in g.link:
            T_sg = od.frame_pose(model, q, g.link) @ g.placement
            points = (T_sg[:3, :3] @ (corners * g.size).T).T + T_sg[:3, 3] - p_tool
            if points[:, 2].min() + HEIGHT < BOX_TOP:
                front = max(front, points[:, 0].max())
    return front


FRONT = _front(MODEL, Q_READY)
P_READY = T_READY[:3, 3]
P_BEHIND = np.array([BOX_BACK - FRONT - GAP, 0.0, HEIGHT])
P_PUSHED = P_BEHIND + np.array([GAP + PUSH, 0.0, 0.0])
PATH = ((0.0, 1.5, P_READY, P_BEHIND), (1.5, 4.0, P_BEHIND, P_PUSHED))


def set_point(t):
    """(p_d (3,) m, pdot_d (3,) m/s): the tool's set position and velocity at t (s), world
    frame."""
    for t_a, t_b, p_a, p_b in PATH:
        if t < t_b:
            u = max(t - t_a, 0.0) / (t_b - t_a)
            s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
            ds = 30.0 * u * u * (1.0 - u) ** 2 / (t_b - t_a)
            return p_a + (p_b - p_a) * s, (p_b - p_a) * ds
    return PATH[-1][3], np.zeros(3)


def push(t, q, qd):
    """tau (9,) N m (N at the fingers) at time t (s), from the scene's q and qd (the robot's
    first nine coordinates)."""
    q, qd = q[:N], qd[:N]
    p_d, pdot_d = set_point(t)
    T_sd = T_READY.copy()
    T_sd[:3, 3] = p_d
    T_sb = od.frame_pose(MODEL, q, TOOL)
    J_b = od.jacobian(MODEL, q, TOOL, expressed_in="body")
    e = log_se3(np.linalg.inv(T_sb) @ T_sd)
    V_d = np.concatenate([np.zeros(3), T_sb[:3, :3].T @ pdot_d])
    M = od.mass_matrix(MODEL, q)
    Lambda = od.task_space_mass_matrix(MODEL, q, TOOL)
    D = np.diag(2.0 * np.sqrt(np.diag(Lambda) * np.diag(K)))
    F_b = K @ e + D @ (V_d - J_b @ qd)
    null = np.eye(N) - np.linalg.solve(M, J_b.T @ Lambda @ J_b)
    posture = K_NULL * (Q_READY - q) - D_NULL * qd
    tau = od.gravity_forces(MODEL, q) + J_b.T @ F_b + null.T @ posture
    tau[FINGERS] = KP_FINGERS * (Q_READY[FINGERS] - q[FINGERS]) - KD_FINGERS * qd[FINGERS]
    tau[FINGERS] += od.gravity_forces(MODEL, q)[FINGERS]
    return tau
