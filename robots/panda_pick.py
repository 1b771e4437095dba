"""A Python controller with which the Panda picks a box up by friction: it closes its fingers on
the box's sides, lifts it 20 cm and holds it there.

The arm: computed torque in joint space about a set point q_d(t) that moves on a minimum-jerk
path from the start posture Q_GRASP to Q_LIFT, the posture whose tool frame stands LIFT higher
with the same orientation (found once, below, by damped least squares on the tool's pose):

    q_d(t)  = Q_GRASP + (Q_LIFT - Q_GRASP) s(u),  s(u) = 10 u^3 - 15 u^4 + 6 u^5,
              u = (t - T_LIFT) / (T_HOLD - T_LIFT) clipped to [0, 1]
    tau_arm = M(q) (K_P (q_d - q) + K_D (qd_d - qd)) + g(q)      (the robot's own M and g)

The box's weight is not modelled: the arm sags under it by M^-1 g_box / K_P, a few tenths of a
degree. The fingers: each a force-limited position servo whose set point closes from the open
hand to fully shut over CLOSE s,

    tau_f = clip(KP_FINGER (q_f,d(t) - q_f) - KD_FINGER qd_f, -2 SQUEEZE, 2 SQUEEZE)

so that a finger meets the box slowly, and once its set point lies 2 SQUEEZE / KP_FINGER past the
box's face each finger presses it with the force SQUEEZE (N) alone. The two fingers are one
coordinate q_f (the URDF's mimic joint, as the gripper's single drive moves them), on which their
forces act together: tau_f = 2 f. Friction holds the box while
2 mu SQUEEZE >= m (g + a), a the hand's upward acceleration (here 20 N against 5 N).

Times: 0 - T_LIFT the fingers close; T_LIFT - T_HOLD the lift; then the hold. The controller is
written for the Panda alone: it reads the robot's first eight coordinates of the scene's q and
qd (the box's come after them) and returns the eight joint torques. Run it: opendyn simulate
panda_pick, or through od.Simulator (tests/test_grasp.py).
"""

import numpy as np

import opendyn as od
from opendyn.spatial import log_se3

MODEL = od.load_urdf("panda", mimic=True)  # one coordinate for both fingers, as in the scene
TOOL = "panda_hand_tcp"
N = MODEL.nq  # the robot's coordinates, first in the scene's q (8)
ARM, FINGERS = np.arange(7), 7
Q_GRASP = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.04])  # fingers open
LIFT = 0.20  # m, along world z
CLOSE, T_LIFT, T_HOLD = 0.4, 0.6, 2.0  # s
K_P, K_D = 400.0, 40.0  # 1/s^2, 1/s: critically damped at 20 rad/s
KP_FINGER, KD_FINGER = 1000.0, 5.0  # N/m, N s/m
SQUEEZE = 20.0  # N, each finger


def _lifted(q, lift):
    """The arm's posture (8,) whose tool frame is the one at q raised by lift (m) along world
    z, found by damped least squares on the pose error log(T_sb^-1 T_sd) (tool frame)."""
    T_sd = od.frame_pose(MODEL, q, TOOL)
    T_sd[2, 3] += lift
    q = q.copy()
    for _ in range(100):
        e = log_se3(np.linalg.inv(od.frame_pose(MODEL, q, TOOL)) @ T_sd)
        if np.linalg.norm(e) < 1e-12:
            return q
        J_b = od.jacobian(MODEL, q, TOOL, expressed_in="body")[:, ARM]
        q[ARM] += J_b.T @ np.linalg.solve(J_b @ J_b.T + 1e-9 * np.eye(6), e)
    raise RuntimeError(f"panda_pick: no posture {lift} m above the start was found")


Q_LIFT = _lifted(Q_GRASP, LIFT)


def set_point(t):
    """(q_d (8,), qd_d (8,)): the arm's set posture (rad) and its rate (rad/s) at t (s); the
    fingers' entries are those of their servos (m, m/s)."""
    u = min(max(t - T_LIFT, 0.0) / (T_HOLD - T_LIFT), 1.0)
    s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
    ds = 30.0 * u * u * (1.0 - u) ** 2 / (T_HOLD - T_LIFT)
    q_d = Q_GRASP + (Q_LIFT - Q_GRASP) * s
    qd_d = (Q_LIFT - Q_GRASP) * ds
    # the fingers' set points close at a constant rate to shut (0) over CLOSE s, then stay
    closing = t < CLOSE
    q_d[FINGERS] = Q_GRASP[FINGERS] * max(1.0 - t / CLOSE, 0.0)
    qd_d[FINGERS] = -Q_GRASP[FINGERS] / CLOSE if closing else 0.0
    return q_d, qd_d


def pick(t, q, qd):
    """tau (8,) N m (N at the fingers) at time t (s), from the scene's q and qd (the robot's
    first eight coordinates)."""
    q, qd = q[:N], qd[:N]
    q_d, qd_d = set_point(t)
    M = od.mass_matrix(MODEL, q)
    tau = M @ (K_P * (q_d - q) + K_D * (qd_d - qd)) + od.gravity_forces(MODEL, q)
    servo = KP_FINGER * (q_d[FINGERS] - q[FINGERS]) - KD_FINGER * qd[FINGERS]
    tau[FINGERS] = np.clip(servo, -2.0 * SQUEEZE, 2.0 * SQUEEZE)
    return tau
