"""Numbers that sum up one run: how well it kept the energy balance, its constraints and its
quaternions, how far it sank into the ground, and how well its controller tracked.

    energy_error_max = max_k |E(t_k) - E(0) - W_applied(t_k) - W_passive(t_k)|
    tracking_rms     = sqrt( mean_{k, j} (q_j(t_k) - q_r,j(t_k))^2 ),
                       q_r(t) = offset + amplitude sin(2 pi frequency t + phase)

Each metric applies to the scenes that have what it measures (a tracking error needs a
computed-torque controller, a constraint violation needs constraints); `applicable(scene)` names
them, `run_metrics(scene, traj, names)` computes them over the samples of a trajectory (complete,
or the part of a run that stopped early).
"""

from __future__ import annotations

import numpy as np

from .effects.contact import Contact


def _kind(scene):
    return scene.control.kind if scene.control is not None else None


def tracking_error(scene, traj) -> np.ndarray:
    """(K, n) q_j(t_k) - q_r,j(t_k) of the computed-torque controller at the samples."""
    c = scene.control
    q_r = c.offset + c.amplitude * np.sin(2 * np.pi * c.frequency * traj.t[:, None] + c.phase)
    return traj.q[:, scene.model.q_index] - q_r


def _setpoint_error(scene, traj):
    return np.abs(scene.control.setpoint - traj.q[-1, scene.model.q_index]).max()


# name -> (what it is, with its unit; whether a scene has it; its value from (scene, traj)),
# in the order a table shows them
METRICS = {
    "energy_error_max": (
        "largest |E(t) - E(0) - W(t)| over the samples (J): the energy drift, or with damping, "
        "friction, limits, contact, wrenches or control the residual of the energy balance",
        lambda scene: True,
        lambda scene, traj: np.abs(traj.energy_error).max(),
    ),
    "violation_position_max": (
        "largest constraint violation max_i |phi_i(q)| over the samples (m or rad)",
        lambda scene: bool(scene.constraints),
        lambda scene, traj: traj.violation_position.max(),
    ),
    "violation_velocity_max": (
        "largest velocity violation max_i |(A qd)_i| over the samples (m/s or rad/s)",
        lambda scene: bool(scene.constraints),
        lambda scene, traj: traj.violation_velocity.max(),
    ),
    "penetration_max": (
        "deepest penetration of a contact sphere into the ground over the samples (m)",
        lambda scene: isinstance(scene.contact, Contact),
        lambda scene, traj: traj.penetration.max(initial=0.0),
    ),
    "quaternion_norm_error": (
        "largest | |quat| - 1 | of the floating base over the samples",
        lambda scene: scene.model.floating_base,
        lambda scene, traj: traj.stats["quaternion_norm_error"],
    ),
    "tracking_rms": (
        "RMS over the samples and joints of q - q_r(t), the computed-torque controller's "
        "tracking error (rad or m)",
        lambda scene: _kind(scene) == "computed_torque",
        lambda scene, traj: np.sqrt(np.mean(tracking_error(scene, traj) ** 2)),
    ),
    "tracking_max": (
        "largest |q - q_r(t)| over the samples and joints (rad or m)",
        lambda scene: _kind(scene) == "computed_torque",
        lambda scene, traj: np.abs(tracking_error(scene, traj)).max(),
    ),
    "setpoint_error": (
        "largest |setpoint - q| over the joints at the last sample, for a PD controller "
        "(rad or m)",
        lambda scene: _kind(scene) == "pd",
        _setpoint_error,
    ),
}


def applicable(scene) -> tuple[str, ...]:
    """The names of METRICS that `scene` has something to measure for, in METRICS order."""
    return tuple(name for name, (_, has, _) in METRICS.items() if has(scene))


def run_metrics(scene, traj, names) -> dict[str, float]:
    """{name: value} for each of `names` that applies to `scene`, from `traj`'s samples (a
    metric that does not apply, or a record without samples, is left out)."""
    if not len(traj.t):
        return {}
    return {
        name: float(METRICS[name][2](scene, traj)) for name in applicable(scene) if name in names
    }
