"""[robot] and [initial]: the robot a scene loads (a URDF path or a robot name, with the options
of load_urdf), a payload welded to one of its frames, and its initial state.

A floating base's initial motion is given in world axes (as one thinks of it) and stored as the
body twist of the convention, v = (omega_b, v_b, qd_joints) with omega_b = R^T omega_s and
v_b = R^T p_dot (R the base's orientation in the world); q0 = (p, quat, q_joints).
"""

from __future__ import annotations

import os

import numpy as np

from ..._runtime.arrays import immutable
from ...errors import URDFError
from ...multibody.joints import FREE, QUATERNION_TOLERANCE
from ...multibody.model import Model
from ..urdf import load_urdf
from ...sim.values import ValueReader, what_is

ROBOT_KEYS = ("urdf", "name", "mimic", "check_inertia", "floating_base", "srdf", "payload")
PAYLOAD_KEYS = ("frame", "mass", "com", "inertia")
# a URDF <inertia>'s attributes, each the entry (row, column) of the symmetric matrix
_INERTIA_ENTRIES = {
    "ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2), "ixy": (0, 1), "ixz": (0, 2), "iyz": (1, 2)
}
_BASE_KEYS = (
    "base_position",
    "base_orientation",
    "base_rpy",
    "base_velocity",
    "base_angular_velocity",
)
INITIAL_KEYS = ("q", "qd") + _BASE_KEYS


class RobotSection(ValueReader):
    """Reads [robot] into a Model (with its payload) and [initial] into (q0, qd0)."""

    def robot(self, table, base_dir) -> Model:
        if table is None:
            self.fail("robot", "missing: a scene needs [robot] with urdf = PATH or name = NAME")
        self.keys(table, "robot", ROBOT_KEYS)
        given = [k for k in ("urdf", "name") if k in table]
        if len(given) != 1:
            what = "both" if given else "neither"
            self.fail(
                "robot",
                f"{what} of robot.urdf and robot.name given; give exactly one: urdf = a URDF "
                f"path (relative to the scene file) or name = a robot name (e.g. 'ur5')",
            )
        key = f"robot.{given[0]}"
        target = self.string(table[given[0]], key)
        options = {
            "mimic": self.boolean(table.get("mimic", False), "robot.mimic"),
            "check_inertia": self.boolean(table.get("check_inertia", True), "robot.check_inertia"),
            "floating_base": self.boolean(
                table.get("floating_base", False), "robot.floating_base"
            ),
        }
        if given[0] == "urdf":
            target = str(self.existing_file(target, key, "URDF", base_dir))
        elif "/" in target or os.sep in target or target.endswith(".urdf"):
            self.fail(key, f"{target!r} is a path, not a robot name; use robot.urdf for a file")
        if "srdf" in table:
            options["srdf"] = str(
                self.existing_file(table["srdf"], "robot.srdf", "SRDF", base_dir)
            )
        try:
            return load_urdf(target, **options)
        except URDFError as e:
            self.fail("robot.srdf" if "SRDF" in str(e) else key, str(e))

    def payload(self, table) -> Model:
        """[robot.payload] -> self.model.with_payload(frame, mass, com, inertia); self.model
        itself when there is none. inertia: a table of a URDF <inertia>'s entries (kg m^2,
        about the centre of mass in the frame's axes), missing entries 0."""
        m = self.model
        if table is None:
            return m
        key = "robot.payload"
        self.keys(table, key, PAYLOAD_KEYS)
        for field in ("frame", "mass"):
            if field not in table:
                self.fail(
                    f"{key}.{field}",
                    "missing: [robot.payload] needs frame (a frame that moves) and mass (kg)",
                )
        frame = self.moving_frame(table["frame"], f"{key}.frame", "a payload on it would not move")
        mass = self.number(table["mass"], f"{key}.mass", minimum=0.0)
        com = self.vector(table.get("com", [0.0] * 3), f"{key}.com", 3)
        inertia = None
        if "inertia" in table:
            entries = table["inertia"]
            if not isinstance(entries, dict):
                self.fail(
                    f"{key}.inertia",
                    f"expected a table {{{', '.join(_INERTIA_ENTRIES)}}} (kg m^2, about the "
                    f"centre of mass in the frame's axes), found {what_is(entries)}",
                )
            self.keys(entries, f"{key}.inertia", tuple(_INERTIA_ENTRIES))
            inertia = np.zeros((3, 3))
            for name, (row, column) in _INERTIA_ENTRIES.items():
                value = self.number(entries.get(name, 0.0), f"{key}.inertia.{name}")
                inertia[row, column] = inertia[column, row] = value
        try:
            return m.with_payload(frame, mass, com, inertia)
        except ValueError as e:  # frame, mass and com are checked above: the inertia is wrong
            self.fail(f"{key}.inertia", str(e))

    def initial(self, table) -> tuple[np.ndarray, np.ndarray]:
        """[initial] -> (q0 (nq,), qd0 (nv,)): the joints from q and qd, a floating base from
        the base_* keys (world-frame motion turned into the body twist)."""
        m = self.model
        self.keys(table, "initial", INITIAL_KEYS)
        given = [k for k in _BASE_KEYS if k in table]
        if given and not m.floating_base:
            self.fail(
                f"initial.{given[0]}",
                f"{m.name!r} is loaded with a fixed base (welded to the world), so it has no base "
                f"state; set floating_base = true under [robot] to make its root link free",
            )
        zeros = np.zeros(len(m.joint_names))
        q0, qd0 = np.zeros(m.nq), np.zeros(m.nv)
        q0[m.q_index] = self.per_joint(table.get("q"), "initial.q", zeros, scalar=False)
        qd0[m.v_index] = self.per_joint(table.get("qd"), "initial.qd", zeros, scalar=False)
        if m.floating_base:
            self.base_state(table, q0, qd0)
        self.object_states(q0, qd0)
        return immutable(q0), immutable(qd0)

    def base_state(self, table, q0, qd0):
        """q0's (p, quat) and qd0's (omega_b, v_b) of the robot's free joint from the base_*
        keys (free_state)."""
        m = self.model
        free = next(i for i in np.flatnonzero(m.jtype == FREE) if m.body_names[i] not in m.objects)
        self.free_state(table, "initial", "base_", int(free), q0, qd0)

    def free_state(self, table, where, prefix, body, q0, qd0):
        """q0's (p, quat) and qd0's (omega_b, v_b) of the free joint of `body` from the keys
        PREFIX position, orientation (a unit quaternion x, y, z, w) or rpy, velocity and
        angular_velocity of `table` (world frame; each optional: at the origin, upright, at
        rest): omega_b = R^T omega_s, v_b = R^T p_dot. `where` names the table in errors."""
        from scipy.spatial.transform import Rotation  # (its import costs 0.15 s: when needed)

        m = self.model
        a, b = int(m.iq[body]), int(m.iv[body])

        def vec3(key):
            value = table.get(prefix + key)
            return np.zeros(3) if value is None else self.vector(value, f"{where}.{prefix}{key}", 3)

        if prefix + "orientation" in table and prefix + "rpy" in table:
            self.fail(
                f"{where}.{prefix}rpy",
                f"both {prefix}orientation and {prefix}rpy given; give the orientation once: "
                "a quaternion [x, y, z, w] or roll, pitch, yaw in rad",
            )
        if prefix + "orientation" in table:
            key = f"{where}.{prefix}orientation"
            quat = self.vector(table[prefix + "orientation"], key, 4)
            norm = float(np.linalg.norm(quat))
            if not abs(norm - 1.0) <= QUATERNION_TOLERANCE:
                self.fail(
                    key,
                    f"expected a unit quaternion [x, y, z, w] (norm within "
                    f"{QUATERNION_TOLERANCE:g} of 1), found norm {norm:.6g}",
                )
            R_sb = Rotation.from_quat(quat)
        else:
            R_sb = Rotation.from_euler("xyz", vec3("rpy"))
        q0[a : a + 3] = vec3("position")
        q0[a + 3 : a + 7] = R_sb.as_quat()
        R = R_sb.as_matrix()
        qd0[b : b + 3] = R.T @ vec3("angular_velocity")
        qd0[b + 3 : b + 6] = R.T @ vec3("velocity")
