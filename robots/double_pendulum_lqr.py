"""LQR that balances the double pendulum upright, both joints actuated, from the linearization
opendyn computes of its own dynamics.

    plant:   the double pendulum under gravity, RK4 at dt = 1 ms, as the scene
             double_pendulum_lqr.toml runs it (built here: that scene names this module)
    A_d, B_d = od.linearize(plant, q=UPRIGHT, qd=0, discrete=True)    zero-order hold over dt
    P        = the solution of the discrete algebraic Riccati equation (scipy.linalg)
    K        = (R + B_d^T P B_d)^-1 B_d^T P A_d
    tau      = -K (q - q_up, qd)          sampled every dt and held (the hold A_d, B_d assume)

Upright is q_up = (pi, 0) (angles from the downward vertical, robots/double_pendulum.urdf),
where gravity's torque vanishes, so the equilibrium torque is zero. The scene starts 0.1 rad
off in each joint; the closed loop's slowest pole decays with a time constant of about 0.18 s
(|eigenvalue| 0.9946 per 1 ms step), so the error falls below 1e-6 rad within 3 s, and the
torques stay within the URDF's effort limits (50 and 20 N m).

Run it: opendyn simulate double_pendulum_lqr, or od.simulate(scene, controller=lqr).
"""

import numpy as np
import scipy.linalg

import opendyn as od

UPRIGHT = np.array([np.pi, 0.0])  # rad
PLANT = od.scene_from_dict(
    {
        "name": "double pendulum plant",
        "robot": {"name": "double_pendulum"},
        "initial": {"q": UPRIGHT.tolist()},
        "run": {"duration": 1.0, "integrator": "rk4", "dt": 0.001},
        "effects": {"gravity": True},
    }
)
MODEL = PLANT.model
Q_WEIGHT = np.diag([1000.0, 1000.0, 1.0, 1.0])  # on (rad, rad, rad/s, rad/s)
R_WEIGHT = np.diag([0.01, 0.03])  # on (N m, N m)


def lqr_gain(plant=PLANT, Q=Q_WEIGHT, R=R_WEIGHT):
    """K (2, 4): the discrete-time LQR gain of the plant linearized upright at rest."""
    A, B = od.linearize(plant, q=UPRIGHT, qd=np.zeros(2), discrete=True)
    P = scipy.linalg.solve_discrete_are(A, B, Q, R)
    return np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)


K = lqr_gain()


def lqr(t, q, qd):
    """tau (2,) N m at time t (s), configuration q (2,) rad, velocity qd (2,) rad/s."""
    return -K @ np.concatenate([od.difference(MODEL, UPRIGHT, q), qd])
