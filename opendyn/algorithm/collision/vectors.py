"""3-vectors as tuples (x, y, z), the collision kernels' small algebra: tuples live in registers,
so the narrow phase allocates nothing, and rows of arrays are read and written by `row` and
`put`. A pose is T, a (3, 4) or (4, 4) array [R p]: R (3, 3) the rotation and p (3,) the origin
of the shape's frame {g} in the world."""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED


@njit(**UNCOUNTED)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(**UNCOUNTED)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(**UNCOUNTED)
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@njit(**UNCOUNTED)
def axpy(s, x, y):
    """s x + y."""
    return (s * x[0] + y[0], s * x[1] + y[1], s * x[2] + y[2])


@njit(**UNCOUNTED)
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**UNCOUNTED)
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(**UNCOUNTED)
def norm(a):
    return math.sqrt(dot(a, a))


@njit(**UNCOUNTED)
def row(array, r, c):
    """(array[r, c], array[r, c + 1], array[r, c + 2])."""
    return (array[r, c], array[r, c + 1], array[r, c + 2])


@njit(**UNCOUNTED)
def put(array, r, c, a):
    """array[r, c:c + 3] = a."""
    array[r, c] = a[0]
    array[r, c + 1] = a[1]
    array[r, c + 2] = a[2]


@njit(**UNCOUNTED)
def axis(T, k):
    """The k-th axis of {g} in the world: column k of R."""
    return (T[0, k], T[1, k], T[2, k])


@njit(**UNCOUNTED)
def origin(T):
    """p: the origin of {g} in the world."""
    return (T[0, 3], T[1, 3], T[2, 3])


@njit(**UNCOUNTED)
def rotate(T, x):
    """R x: a direction of {g} in the world."""
    return (
        T[0, 0] * x[0] + T[0, 1] * x[1] + T[0, 2] * x[2],
        T[1, 0] * x[0] + T[1, 1] * x[1] + T[1, 2] * x[2],
        T[2, 0] * x[0] + T[2, 1] * x[1] + T[2, 2] * x[2],
    )


@njit(**UNCOUNTED)
def to_world(T, x):
    """R x + p: a point of {g} in the world."""
    return add(rotate(T, x), origin(T))


@njit(**UNCOUNTED)
def to_local(T, d):
    """R^T d: a world direction in {g}."""
    return (
        T[0, 0] * d[0] + T[1, 0] * d[1] + T[2, 0] * d[2],
        T[0, 1] * d[0] + T[1, 1] * d[1] + T[2, 1] * d[2],
        T[0, 2] * d[0] + T[1, 2] * d[1] + T[2, 2] * d[2],
    )


@njit(**UNCOUNTED)
def perpendicular(a):
    """A unit vector perpendicular to a (a != 0): a x e_k, e_k the axis least aligned with a."""
    if abs(a[0]) <= abs(a[1]) and abs(a[0]) <= abs(a[2]):
        p = (0.0, a[2], -a[1])
    elif abs(a[1]) <= abs(a[2]):
        p = (-a[2], 0.0, a[0])
    else:
        p = (a[1], -a[0], 0.0)
    return scale(p, 1.0 / norm(p))
