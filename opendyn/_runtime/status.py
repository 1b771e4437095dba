"""What a compiled kernel or a simulation loop reports: one enumeration, zero for success.

    status = OK (0) | a failure below | SINGULAR + k (M singular at coordinate k)

Every kernel returns a Status code as a plain int64, written `Status.X.value`: returned to Python,
a member itself would be boxed by constructing the enum (measured: 0.81 us a call against
0.16 us for the int). `decode` turns any status back into its member and, for SINGULAR + k, the
coordinate k; Python compares codes with members directly (an IntEnum equals its int).
"""

from __future__ import annotations

from enum import IntEnum


class Status(IntEnum):
    """Outcome of a kernel or a simulation loop."""

    OK = 0
    Q_NOT_FINITE = 1  # an argument or state q has NaN or inf
    QD_NOT_FINITE = 2
    QDD_NOT_FINITE = 3
    TAU_NOT_FINITE = 4  # a torque argument, or a generalized force in a simulation
    DIVERGED = 5  # a joint velocity beyond the run's max_speed
    STEP_UNDERFLOW = 6  # the adaptive step fell below what float64 time can resolve
    NO_CONVERGENCE = 7  # the symplectic Euler momentum update did not converge
    INTERRUPTED = 8  # Ctrl-C: the run stopped after its current chunk
    Q_NOT_UNIT_QUATERNION = 9  # a free joint's quaternion in q is not of unit norm
    RESULT_NOT_FINITE = 10  # finite arguments, a result with inf or NaN: float64 overflowed
    SINGULAR_TASK_SPACE = 11  # J_b M^-1 J_b^T of a frame is singular: it has no task-space inertia
    # a vector argument's length is not the model's nq or nv, or (in Python) an argument is not
    # of a type the kernel was compiled for: the public function converts and checks it
    CONVERT = 12
    UNBOUNDED = 13  # a collision pair with no finite distance (two halfspaces)
    SINGULAR = 100  # + k: nothing with mass or inertia moves with coordinate k


# the argument each "not finite" status names
NOT_FINITE_ARGUMENT = {
    Status.Q_NOT_FINITE: "q",
    Status.QD_NOT_FINITE: "qd",
    Status.QDD_NOT_FINITE: "qdd",
    Status.TAU_NOT_FINITE: "tau",
}


def decode(status: int) -> tuple[Status, int | None]:
    """(member, coordinate): SINGULAR + k gives (SINGULAR, k); any other status (member, None).
    Raises ValueError for a number that is no status."""
    status = int(status)
    if status >= Status.SINGULAR:
        return Status.SINGULAR, status - Status.SINGULAR
    return Status(status), None
