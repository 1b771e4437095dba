"""Identify an unknown payload on the UR5 from the torques that move it.

    python scripts/identify_payload.py [--seed N] [--noise 0.01]

The UR5 carries a payload at its tool flange (tool0) that the robot's model does not know:
2.5 kg, its centre of mass 5 cm out along the tool axis. A scene excites it: the computed-torque
controller makes each joint track a sine of its own amplitude and frequency (together a sum of
sines that moves the flange through many orientations, speeds and accelerations) for 20 s,
recorded every 5 ms. The recorded torques are the "measurements", with Gaussian noise of 1% of
each joint's RMS torque added; the recorded joint velocities give the accelerations through a
Savitzky-Golay differentiator (the accelerations are not measured, as on a real robot).
`od.identify_payload` then recovers the payload from the robot model without it: mass, centre of
mass and inertia, with standard deviations. Prints the truth, the estimate, its standard
deviation and the error.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.signal import savgol_filter

import opendyn as od
from opendyn.io.scene.files import scene_from_dict

FRAME = "tool0"
MASS = 2.5  # kg
COM = (0.0, 0.0, 0.05)  # m, in the tool frame
# kg m^2 about the centre of mass, in the tool frame's axes
INERTIA = ((4e-3, 0.0, 0.0), (0.0, 6e-3, 0.0), (0.0, 0.0, 9e-3))
OUTPUT_DT = 0.005  # s
# the acceleration filter: a cubic fitted over 11 samples (55 ms) at each sample
SAVGOL_WINDOW, SAVGOL_ORDER = 11, 3


def excitation_scene(duration=20.0):
    """The UR5 with the payload, tracking a sine per joint by computed torque."""
    ixx, iyy, izz = (INERTIA[k][k] for k in range(3))
    return scene_from_dict(
        {
            "name": "UR5 payload excitation",
            "robot": {
                "name": "ur5",
                "payload": {
                    "frame": FRAME,
                    "mass": MASS,
                    "com": list(COM),
                    "inertia": {"ixx": ixx, "iyy": iyy, "izz": izz},
                },
            },
            "initial": {"q": [0.0, -1.2, 1.0, -1.4, -1.57, 0.0]},
            "run": {"duration": duration, "integrator": "rk4", "dt": 0.001, "output_dt": OUTPUT_DT},
            "effects": {"gravity": True},
            "control": {
                "type": "computed_torque",
                "kp": 400.0,
                "kd": 40.0,
                "amplitude": [1.0, 0.6, 0.8, 1.2, 1.2, 1.5],
                "frequency": [0.13, 0.21, 0.29, 0.37, 0.47, 0.59],
            },
        }
    )


def measurements(seed=0, noise=0.01):
    """(q, qd, qdd, tau): the recorded states, accelerations from the filtered velocities, and
    the recorded torques with Gaussian noise of `noise` times each joint's RMS torque. The
    filter's half window at each end is dropped (its fit is one-sided there)."""
    traj = od.simulate(excitation_scene())
    assert traj.complete, traj.message
    qdd = savgol_filter(traj.qd, SAVGOL_WINDOW, SAVGOL_ORDER, deriv=1, delta=OUTPUT_DT, axis=0)
    keep = slice(SAVGOL_WINDOW, -SAVGOL_WINDOW)
    q, qd, qdd, tau = traj.q[keep], traj.qd[keep], qdd[keep], traj.tau[keep]
    rng = np.random.default_rng(seed)
    tau = tau + noise * np.sqrt(np.mean(tau**2, axis=0)) * rng.normal(size=tau.shape)
    return q, qd, qdd, tau


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="the noise's seed")
    parser.add_argument("--noise", type=float, default=0.01, help="noise / RMS torque per joint")
    args = parser.parse_args(argv)
    robot = od.load_urdf("ur5")  # the model without the payload
    q, qd, qdd, tau = measurements(args.seed, args.noise)
    est = od.identify_payload(robot, FRAME, q, qd, qdd, tau)
    print(
        f"{len(q)} samples, {args.noise:.1%} torque noise, condition number "
        f"{est.condition_number:.3g}, residual RMS {est.residual_rms:.3g} N m"
    )
    print(f"{'':12}{'true':>10}{'estimate':>12}{'std':>10}{'error':>10}")
    rows = (
        [("mass (kg)", MASS, est.mass, est.mass_std)]
        + [
            (f"com_{axis} (mm)", 1e3 * COM[k], 1e3 * est.com[k], 1e3 * est.com_std[k])
            for k, axis in enumerate("xyz")
        ]
        + [
            (
                f"I_{axis}{axis} (g m^2)",
                1e3 * INERTIA[k][k],
                1e3 * est.inertia[k, k],
                1e3 * est.inertia_std[k, k],
            )
            for k, axis in enumerate("xyz")
        ]
    )
    for name, true, value, std in rows:
        print(f"{name:12}{true:10.4g}{value:12.4g}{std:10.2g}{value - true:10.2g}")
    return est


if __name__ == "__main__":
    main()
