"""The table: constraint objects (opendyn.multibody.constraint_objects) bound to a model at a
configuration, as the flat arrays the compiled kernels read.

Compiled interface:
  constraint_table(model, constraints, q0 (nq,)) -> rows (n_c, 5) int64, params (p,) float64
      row: (kind, offset into params, m rows of A, body_a, body_b), body -1 = the fixed world;
      its columns by name: KIND, OFFSET, ROW_COUNT, BODY_A, BODY_B
  ConstraintTable(rows, params, gains): what the constrained solve takes, the table and the
      Baumgarte gains (alpha, beta) (2,) 1/s of A qdd + Adot qd + 2 alpha A qd + beta^2 phi = 0
      (NO_STABILISATION, zeros: none)
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ...multibody.constraint_objects import (
    CONSTRAINT_TYPES,
    FixedPose,
    PointOnPlane,
    PointToPoint,
    PointToWorld,
)
from .. import checks
from ..kinematics import frame_pose
from .arguments import _configuration

# The columns of the table's rows (n_c, 5), by name: the constraint's kind, the offset of its
# numbers in params, its count of rows of A, and the bodies of its frames a and b (-1: the world).
KIND, OFFSET, ROW_COUNT, BODY_A, BODY_B = range(5)
# The constraints as the compiled solve reads them: rows (n_c, 5) int64 and params (p,) float64
# of constraint_table, and the Baumgarte gains (alpha, beta) (2,) float64, 1/s.
ConstraintTable = namedtuple("ConstraintTable", ("rows", "params", "gains"))


def _as_list(constraints):
    if isinstance(constraints, CONSTRAINT_TYPES):
        return [constraints]
    if constraints is None or isinstance(constraints, (str, bytes, dict)):
        raise ValueError(
            "constraints must be a constraint (PointToWorld, PointOnPlane, PointToPoint, "
            f"FixedPose, JointCoupling) or a sequence of them, got {constraints!r}"
        )
    try:
        out = list(constraints)
    except TypeError:
        raise ValueError(
            "constraints must be a constraint or a sequence of constraints, got "
            f"{type(constraints).__name__}"
        ) from None
    for n, c in enumerate(out):
        if not isinstance(c, CONSTRAINT_TYPES):
            raise ValueError(
                f"constraints[{n}] must be one of "
                f"{', '.join(t.__name__ for t in CONSTRAINT_TYPES)}, got {type(c).__name__}"
            )
    return out


def _frame(model, label, name):
    """(body, T_body_frame) of a frame, or KeyError naming the constraint and the frame."""
    try:
        k = model.frame_index(name)
    except KeyError as e:
        raise KeyError(f"{label}: {e.args[0]}") from None
    fr = model.frames[k]
    return fr.body, np.asarray(fr.T_body_frame, dtype=np.float64)


def _bound_at(label, field, q0, q0_name):
    if q0 is None:
        raise ValueError(
            f"{label}: {field} is None (to be bound at a configuration) and no configuration "
            f"to bind it at was given: give {field} explicitly or pass {q0_name}"
        )
    return q0


def _point_in_body(T_bf, point):
    return T_bf[:3, :3] @ np.asarray(point) + T_bf[:3, 3]


def _world_point(model, q0, name, point):
    return _point_in_body(frame_pose(model, q0, name), point)


def _table(model, constraints, q0, q0_name="q0"):
    constraints = _as_list(constraints)
    if q0 is not None:
        q0 = _configuration(model, q0, q0_name, "constraints")
    rows = np.zeros((len(constraints), 5), dtype=np.int64)
    params = []
    offset = 0
    for n, c in enumerate(constraints):
        label = f"constraints[{n}] {c!r}"
        body_a = body_b = -1
        if isinstance(c, (PointToWorld, PointOnPlane)):
            body_a, T_af = _frame(model, label, c.frame)
            if body_a < 0:
                raise ValueError(
                    f"{label}: frame {c.frame!r} belongs to the fixed world, so the constraint "
                    f"is between two world frames and holds nothing"
                )
            r_a = _point_in_body(T_af, c.point)
            if isinstance(c, PointToWorld):
                target = c.target
                if target is None:
                    q = _bound_at(label, "target", q0, q0_name)
                    target = _world_point(model, q, c.frame, c.point)
                p = np.concatenate([r_a, target])
            else:
                off = c.offset
                if off is None:
                    q = _bound_at(label, "offset", q0, q0_name)
                    off = float(np.dot(c.normal, _world_point(model, q, c.frame, c.point)))
                p = np.concatenate([r_a, c.normal, [off]])
        elif isinstance(c, (PointToPoint, FixedPose)):
            body_a, T_af = _frame(model, label, c.frame_a)
            body_b, T_bf = _frame(model, label, c.frame_b)
            if body_a < 0 and body_b < 0:
                raise ValueError(
                    f"{label}: frames {c.frame_a!r} and {c.frame_b!r} both belong to the fixed "
                    f"world: a constraint between two world frames holds nothing"
                )
            if isinstance(c, PointToPoint):
                p = np.concatenate(
                    [_point_in_body(T_af, c.point_a), _point_in_body(T_bf, c.point_b)]
                )
            else:
                T_ab = c.T_ab
                if T_ab is None:
                    q = _bound_at(label, "T_ab", q0, q0_name)
                    T_ab = np.linalg.solve(
                        frame_pose(model, q, c.frame_a), frame_pose(model, q, c.frame_b)
                    )
                T_ab = np.asarray(T_ab, dtype=np.float64)
                p = np.concatenate(
                    [
                        T_af[:3, :3].ravel(),
                        T_af[:3, 3],
                        T_bf[:3, :3].ravel(),
                        T_bf[:3, 3],
                        T_ab[:3, :3].ravel(),
                        T_ab[:3, 3],
                    ]
                )
        else:  # JointCoupling
            C = c.matrix
            if C.shape[1] != model.nv:
                raise ValueError(
                    f"{label}: A must have nv={model.nv} columns for model {model.name!r} "
                    f"(one per joint: {', '.join(model.joint_names)}), got shape {C.shape}"
                )
            q_ref = c.q_ref
            if q_ref is None:
                q_ref = _bound_at(label, "q_ref", q0, q0_name)
            else:
                q_ref = _configuration(model, q_ref, "q_ref", label)
            p = np.concatenate([C.ravel(), q_ref])
        rows[n, KIND], rows[n, OFFSET] = c.kind, offset
        rows[n, ROW_COUNT] = c.n_rows(model.nv)
        rows[n, BODY_A], rows[n, BODY_B] = body_a, body_b
        params.append(np.asarray(p, dtype=np.float64))
        offset += len(p)
    params = np.ascontiguousarray(np.concatenate(params) if params else np.zeros(0))
    return rows, params


def constraint_table(model, constraints, q0):
    """The compiled form of constraints: (rows (n_c, 5) int64, params (p,) float64).

    rows[n] = (kind, offset into params, m (its rows of A), body_a, body_b), the columns KIND,
    OFFSET, ROW_COUNT, BODY_A, BODY_B; body -1 = the fixed world, kind one of
    opendyn.multibody.constraint_objects.POINT_TO_WORLD, POINT_ON_PLANE, POINT_TO_POINT,
    FIXED_POSE, JOINT_COUPLING. params per kind, from the offset (points in body
    coordinates, i.e. T_{body,frame} applied; world vectors in the world frame; m, rad):
      POINT_TO_WORLD  r_a (3), target (3)
      POINT_ON_PLANE  r_a (3), unit normal (3), offset (1)
      POINT_TO_POINT  r_a (3), r_b (3)                      (a world frame's r is a world point)
      FIXED_POSE      R_{body_a,frame_a} (9, row-major), p (3), R_{body_b,frame_b} (9), p (3),
                      target R_ab (9), p_ab (3)
      JOINT_COUPLING  C (m * nv, row-major), q_ref (nq)
    Every None default (target, offset, T_ab, q_ref) is resolved at q0 (nq,), the configuration
    the constraints are bound at; q0 None is allowed when none is left None.

    Raises KeyError naming the constraint and the frame for an unknown frame, ValueError for a
    constraint between two world frames, a JointCoupling whose A is not (k, nv) or whose q_ref
    is not (nq,), a bad q0 (shape, NaN, a quaternion far from unit norm).
    """
    checks.check_model(model, "constraint_table")
    return _table(model, constraints, q0, "q0")
