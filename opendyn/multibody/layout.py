"""The model's flat buffers, laid out once: the table of per-body fields, how a Model packs them
and the compiled kernels' views of them.

All per-body numbers of a Model live in two flat buffers (``_ibuf`` ints, ``_fbuf`` float64) that
the compiled kernels receive as two arguments. INT_FIELDS and FLOAT_FIELDS say what each holds
per body; `tree`, `rigid_inertias` and `spatial_inertias` are the kernels' named views of them.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .._runtime.arrays import immutable, shaped
from .._runtime.kernel_cache import INLINE

# The kernels' flat buffers, defined once: (field, shape per body). Field k of _fbuf starts at
# start_k * nb; field k of _ibuf at INT_HEADER + start_k * nb, after the header [nb, nv, nq].
# S holds each joint's motion subspace as nv_i rows of 6 (rows past nv_i are zero).
INT_HEADER = 3
# The int buffer's dtype says, to the compiler, whether the model has free joints: the kernels
# compile the free joint's code (its transform, its configuration check, ABA's multi-dof passes,
# the exponential map) only for int32 buffers, so a fixed-base model compiles none of it.
FIXED_JOINTS_INT = np.int64
FREE_JOINTS_INT = np.int32
INT_FIELDS = (("parent", ()), ("jtype", ()), ("nv_j", ()), ("iq", ()), ("iv", ()))
FLOAT_FIELDS = (
    ("mult", ()),
    ("offset", ()),
    ("S", (6, 6)),
    ("G", (6, 6)),
    ("mass", ()),
    ("h", (3,)),
    ("I_o", (3, 3)),
    ("R_home", (3, 3)),
    ("p_home", (3,)),
)
def field_starts(fields) -> dict[str, tuple[int, int, tuple[int, ...]]]:
    """{field: (start, size, shape)}: start and size in units of nb (numbers per body)."""
    out, start = {}, 0
    for name, shape in fields:
        size = int(np.prod(shape))
        out[name] = (start, size, shape)
        start += size
    return out


INT_AT = field_starts(INT_FIELDS)
FLOAT_AT = field_starts(FLOAT_FIELDS)


def buffer_size(at: dict, nb: int) -> int:
    """Numbers in a buffer laid out by `at` for nb bodies."""
    return sum(size for _, size, _ in at.values()) * nb


def write_field(buf, at, name, nb, values, header=0):
    """Write (nb, *shape) `values` into one field of a flat buffer laid out by `at`."""
    start, size, _ = at[name]
    buf[header + start * nb : header + (start + size) * nb] = np.asarray(
        values, dtype=buf.dtype
    ).ravel()


def rigid_body_form(G):
    """G = [[I_o, [h]], [[h]^T, m 1]] -> (m (nb,), h = m c (nb, 3), I_o (nb, 3, 3)): the
    inertias G (nb, 6, 6), each about the origin of {i} in {i}, as mass (kg), first moment
    (kg m) and rotational inertia about {i}'s origin (kg m^2)."""
    mass = G[:, 3, 3]
    h = np.stack([G[:, 2, 4], G[:, 0, 5], G[:, 1, 3]], axis=-1)
    I_o = G[:, :3, :3]
    return mass, h, I_o


def field_copy(buf, at, name, nb, header=0):
    """An immutable (nb, *shape) copy of one field of a flat buffer (the buffer itself stays
    writeable and private, so the compiled kernels see one array type)."""
    start, size, shape = at[name]
    field = buf[header + start * nb : header + (start + size) * nb].reshape((nb, *shape))
    return immutable(field, buf.dtype)



def _where(at, name, header=0):
    """(header, first, last) of one field, first and last in units of nb: a tuple, which numba
    freezes as a compile-time constant."""
    start, size, _ = at[name]
    return (header, start, start + size)


_PARENT, _JTYPE, _NV_J, _IQ, _IV = (
    _where(INT_AT, n, INT_HEADER) for n in ("parent", "jtype", "nv_j", "iq", "iv")
)
_MULT, _OFFSET, _S, _G, _MASS, _H, _I_O, _R_HOME, _P_HOME = (
    _where(FLOAT_AT, n)
    for n in ("mult", "offset", "S", "G", "mass", "h", "I_o", "R_home", "p_home")
)


@njit(**INLINE)
def field(buf, nb, where):
    """The flat slice of one field of a buffer; where = (header, first, last) from the layout
    table in opendyn.multibody.layout (first, last in units of nb)."""
    header, first, last = where
    return buf[header + first * nb : header + last * nb]


@njit(**INLINE)
def body_count(ibuf):
    """nb from the model's int buffer, as int64 whatever the buffer's dtype
    (opendyn.multibody.layout.FREE_JOINTS_INT), so that shapes built from it type alike."""
    return np.int64(ibuf[0])


@njit(**INLINE)
def dof_count(ibuf):
    """nv from the model's int buffer, as int64 (see body_count)."""
    return np.int64(ibuf[1])


@njit(**INLINE)
def config_count(ibuf):
    """nq from the model's int buffer, as int64 (see body_count)."""
    return np.int64(ibuf[2])


# The kinematic tree as the kernels see it, each field a view of the model's buffers (nb bodies):
#   parent (nb,) int, -1 = the fixed world; jtype (nb,) int joint type; nv_j, iq, iv (nb,) int
#   joint i's velocity size and first indices in q and v; mult, offset (nb,) the mimic law;
#   S (nb, 6, 6) motion subspaces by rows; R_home (nb, 3, 3), p_home (nb, 3) M_{lambda(i), i}.
BodyTree = namedtuple(
    "BodyTree", ("parent", "jtype", "nv_j", "iq", "iv", "mult", "offset", "S", "R_home", "p_home")
)


@njit(**INLINE)
def tree(ibuf, fbuf):
    """The model's kinematic tree: a BodyTree of views of its buffers (fields of INT_FIELDS and
    FLOAT_FIELDS), read by name (`body_tree.parent[i]`)."""
    nb = body_count(ibuf)
    return BodyTree(
        field(ibuf, nb, _PARENT),
        field(ibuf, nb, _JTYPE),
        field(ibuf, nb, _NV_J),
        field(ibuf, nb, _IQ),
        field(ibuf, nb, _IV),
        field(fbuf, nb, _MULT),
        field(fbuf, nb, _OFFSET),
        shaped(field(fbuf, nb, _S), (nb, 6, 6)),
        shaped(field(fbuf, nb, _R_HOME), (nb, 3, 3)),
        shaped(field(fbuf, nb, _P_HOME), (nb, 3)),
    )


@njit(**INLINE)
def rigid_inertias(ibuf, fbuf):
    """Views of the body inertias in rigid-body form: mass (nb,), h = m c (nb, 3),
    I_o (nb, 3, 3)."""
    nb = body_count(ibuf)
    return (
        field(fbuf, nb, _MASS),
        shaped(field(fbuf, nb, _H), (nb, 3)),
        shaped(field(fbuf, nb, _I_O), (nb, 3, 3)),
    )


@njit(**INLINE)
def spatial_inertias(ibuf, fbuf):
    """View of the (nb, 6, 6) spatial inertias G_i."""
    nb = body_count(ibuf)
    return shaped(field(fbuf, nb, _G), (nb, 6, 6))

