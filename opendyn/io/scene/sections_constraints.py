"""[[constraints]] and [baumgarte]: the constraint objects a scene names, checked at its initial
state, and the stabilisation of their drift.

Constraints (the seed's Pfaffian constraints A(q) qd = 0) add the forces A^T lambda that keep
them, lambda solved with the accelerations at every evaluation (opendyn.algorithm.constraints).
The initial state must satisfy them (position and velocity within CONSTRAINT_TOLERANCE).
Integrating A qdd + Adot qd = 0 lets the position error phi drift; [baumgarte] pulls it back
(alpha = beta = w: a critically damped error at rate w). The trajectory records the largest
|phi| and |A qd| of every sample.
"""

from __future__ import annotations

import numpy as np

from ..._runtime.compile_notice import compiling
from ...algorithm.constraints import broken_constraint
from ...errors import SceneError
from ...multibody.constraint_objects import (
    FixedPose,
    JointCoupling,
    PointOnPlane,
    PointToPoint,
    PointToWorld,
)
from ...sim.preflight import broken_message
from ...spatial.algebra import rpy_matrix
from ...sim.values import ValueReader, what_is

# what the initial state's check compiles the first time on a machine, the constraints' terms
# (phi, A, Adot qd), which the run's start check and record then load: 18 s on 2 cores
# (a cold `opendyn simulate four_bar`; docs/performance/startup.md, constraint_jacobian's first
# call, 20 s)
CHECK_COMPILE_SECONDS = 20

CONSTRAINT_TYPES = (
    "point_to_world",
    "point_on_plane",
    "point_to_point",
    "fixed_pose",
    "joint_coupling",
)
CONSTRAINT_KEYS = {
    "point_to_world": ("type", "frame", "point", "target"),
    "point_on_plane": ("type", "frame", "normal", "point", "offset"),
    "point_to_point": ("type", "frame_a", "frame_b", "point_a", "point_b"),
    "fixed_pose": ("type", "frame_a", "frame_b", "xyz", "rpy"),
    "joint_coupling": ("type", "coefficients", "matrix"),
}
BAUMGARTE_KEYS = ("alpha", "beta")


class ConstraintsSection(ValueReader):
    """Reads [[constraints]] into constraint objects and [baumgarte] into (alpha, beta)."""

    def constraints(self, value, q0, qd0) -> tuple:
        """[[constraints]] -> constraint objects (opendyn.multibody.constraint_objects), checked at
        (q0, qd0)."""
        if value is None:
            return ()
        if isinstance(value, dict):
            value = [value]
        if not isinstance(value, list) or not value:
            self.fail(
                "constraints",
                f"expected tables [[constraints]] with type = one of "
                f"{', '.join(CONSTRAINT_TYPES)}, found {what_is(value)}",
            )
        out = tuple(self.constraint(c, f"constraints[{i}]") for i, c in enumerate(value))
        self._check_initial_state(out, q0, qd0)
        return out

    def constraint(self, table, key):
        table = self.table(table, key)
        if "type" not in table:
            self.fail(f"{key}.type", f"missing: one of {', '.join(CONSTRAINT_TYPES)}")
        kind = self.string(table["type"], f"{key}.type", CONSTRAINT_TYPES)
        self.keys(table, key, CONSTRAINT_KEYS[kind])

        def frame(field):
            if field not in table:
                self.fail(f"{key}.{field}", f"missing; frames: {', '.join(self.model.frame_names)}")
            return self.frame(table[field], f"{key}.{field}")

        def point(field):
            if field not in table:
                return (0.0, 0.0, 0.0)
            return tuple(self.vector(table[field], f"{key}.{field}", 3))

        try:
            if kind == "point_to_world":
                target = table.get("target")
                return PointToWorld(
                    frame("frame"),
                    point("point"),
                    None if target is None else tuple(self.vector(target, f"{key}.target", 3)),
                )
            if kind == "point_on_plane":
                if "normal" not in table:
                    self.fail(f"{key}.normal", "missing: the plane's normal, 3 numbers (world)")
                normal = self.vector(table["normal"], f"{key}.normal", 3)
                offset = table.get("offset")
                return PointOnPlane(
                    frame("frame"),
                    tuple(normal),
                    point("point"),
                    None if offset is None else self.number(offset, f"{key}.offset"),
                )
            if kind == "point_to_point":
                return PointToPoint(
                    frame("frame_a"), frame("frame_b"), point("point_a"), point("point_b")
                )
            if kind == "fixed_pose":
                T_ab = None
                if "xyz" in table or "rpy" in table:
                    T_ab = np.eye(4)
                    T_ab[:3, :3] = rpy_matrix(point("rpy"))
                    T_ab[:3, 3] = point("xyz")
                return FixedPose(frame("frame_a"), frame("frame_b"), T_ab)
            return JointCoupling(self.coupling(table, key))
        except ValueError as e:
            if isinstance(e, SceneError):
                raise
            self.fail(key, str(e))

    def coupling(self, table, key) -> np.ndarray:
        """joint_coupling: one row as a table {joint = coefficient}, or matrix = k lists of nv
        (every velocity coordinate, a floating base's six first)."""
        if ("coefficients" in table) == ("matrix" in table):
            self.fail(
                key,
                "give exactly one of coefficients = {joint = number} (one row: the sum of "
                "coefficient x joint velocity is 0) and matrix = [[nv numbers], ...]",
            )
        m = self.model
        nv = m.nv
        if "coefficients" in table:
            row = np.zeros((1, nv))
            row[0, m.v_index] = self.per_joint(
                table["coefficients"],
                f"{key}.coefficients",
                np.zeros(len(m.joint_names)),
                scalar=False,
            )
            return row
        rows = table["matrix"]
        if not isinstance(rows, list) or not rows:
            self.fail(f"{key}.matrix", f"expected a list of rows, found {what_is(rows)}")
        return np.array([self.vector(r, f"{key}.matrix[{i}]", nv) for i, r in enumerate(rows)])

    def _check_initial_state(self, constraints, q0, qd0):
        """Refuse an initial state that breaks a constraint: simulating it would start off the
        constraint manifold (and, without stabilisation, stay off it)."""
        estimate = f"about {CHECK_COMPILE_SECONDS} s"
        try:
            with compiling("the constraints' terms", 1, estimate) as done:
                broken = broken_constraint(self.model, q0, qd0, constraints)
                done()
        except ValueError as e:
            self.fail("constraints", str(e))
        if broken is not None:
            i, what, worst = broken
            self.fail(f"constraints[{i}]", broken_message(constraints[i], what, worst))

    def baumgarte(self, table, has_constraints) -> tuple[float, float] | None:
        if table is None:
            return None
        self.keys(table, "baumgarte", BAUMGARTE_KEYS)
        if not has_constraints:
            self.fail("baumgarte", "stabilises constraints, but the scene has no [[constraints]]")
        return (
            self.number(table.get("alpha", 0.0), "baumgarte.alpha", minimum=0.0),
            self.number(table.get("beta", 0.0), "baumgarte.beta", minimum=0.0),
        )
