"""An operational-space impedance controller for the Panda: the tool frame held at a set pose
T_sd like a spring-damper of stiffness K, whatever pushes it.

    e     = log(T_sb^-1 T_sd)                    (6,) the pose error in the tool frame {b}
                                                 (rad, m; angular first), MR eq. 6.9 (log map)
    V_b   = J_b(q) qd                            (6,) the tool's twist in {b}
    F_b   = K e - D V_b                          (6,) the wrench (N m, N) the controller asks
    tau   = g(q) + J_b^T F_b - d_null qd + tau_fingers

K = diag(k_rot, k_rot, k_rot, k_lin, k_lin, k_lin); D from the task-space inertia
Lambda(q) = (J_b M^-1 J_b^T)^-1 for critical damping, D_ii = 2 sqrt(Lambda_ii K_ii). At rest
under an external wrench F_ext at the tool, J_b^T (K e + F_ext) = 0 and J_b has full row rank,
so K e = -F_ext: the stiffness seen at the tool is K (to first order in e). The arm's seventh
joint leaves one motion that moves no tool coordinate; joint damping d_null settles it. The
fingers are held open by a PD of their own.

Run it: opendyn simulate panda_impedance (the scene pushes the tool 10 N along world x from
0.5 s to 2 s), or od.simulate(scene, controller=impedance).
"""

import numpy as np

import opendyn as od
from opendyn.spatial import log_se3

MODEL = od.load_urdf("panda")
TOOL = "panda_hand_tcp"
Q_READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.02, 0.02])
T_SD = od.frame_pose(MODEL, Q_READY, TOOL)  # the set pose: the tool where the ready posture has it
K = np.diag([20.0, 20.0, 20.0, 500.0, 500.0, 500.0])  # N m/rad, N/m
D_NULL = 0.5  # N m s/rad
FINGERS = np.array([7, 8])  # the fingers' velocity indices
KP_FINGERS, KD_FINGERS = 200.0, 5.0  # N/m, N s/m


def impedance(t, q, qd):
    """tau (9,) N m (N at the fingers) at time t (s), configuration q (9,), velocity qd (9,)."""
    T_sb = od.frame_pose(MODEL, q, TOOL)
    J_b = od.jacobian(MODEL, q, TOOL, expressed_in="body")
    e = log_se3(np.linalg.inv(T_sb) @ T_SD)
    Lambda = od.task_space_mass_matrix(MODEL, q, TOOL)
    D = np.diag(2.0 * np.sqrt(np.diag(Lambda) * np.diag(K)))
    F_b = K @ e - D @ (J_b @ qd)
    tau = od.gravity_forces(MODEL, q) + J_b.T @ F_b - D_NULL * qd
    tau[FINGERS] += KP_FINGERS * (Q_READY[FINGERS] - q[FINGERS]) - KD_FINGERS * qd[FINGERS]
    return tau
