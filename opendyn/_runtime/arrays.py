"""Array plumbing shared by every layer: immutable arrays, the compiled views of a flat buffer
with a shape (`shaped`), and the compiled loops that fill, copy and check 1-D and 2-D arrays
without numba's slice-assignment error paths."""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from .kernel_cache import JIT
from .status import Status


def immutable(x, dtype=np.float64) -> np.ndarray:
    """x as a C-contiguous array that can never be written. Its memory is a bytes object, so
    numpy refuses even ``flags.writeable = True`` (a read-only view of writeable memory, or a
    read-only array that owns its memory, can be made writeable again)."""
    a = np.ascontiguousarray(x, dtype=dtype)
    return np.frombuffer(a.tobytes(), dtype=a.dtype).reshape(a.shape)


@intrinsic
def shaped(typingctx, flat, shape):
    """shaped(flat, shape): a C-contiguous view of the C-contiguous array `flat` with the
    given shape (a tuple of integers whose product is flat's size; not checked: the callers
    slice `flat` from a layout table). What `flat.reshape(shape)` gives, without its call to
    numba's run-time reshape helper (about 18 ns a view, opaque to LLVM): the kernels make
    20-odd views of their buffers on every call. Any other argument type is a typing error."""
    if not (isinstance(flat, types.Array) and flat.layout == "C"):
        return None
    if not (isinstance(shape, types.UniTuple) and isinstance(shape.dtype, types.Integer)):
        return None
    ndim = shape.count
    view_type = flat.copy(ndim=ndim, layout="C")

    def codegen(context, builder, signature, args):
        src = make_array(flat)(context, builder, args[0])
        view = make_array(view_type)(context, builder)
        dims = [
            context.cast(builder, d, shape.dtype, types.intp)
            for d in cgutils.unpack_tuple(builder, args[1], ndim)
        ]
        # C order: the last axis has stride itemsize, each axis before it the product after
        strides = [None] * ndim
        step = src.itemsize
        for k in range(ndim - 1, -1, -1):
            strides[k] = step
            step = builder.mul(step, dims[k])
        populate_array(
            view, data=src.data, shape=dims, strides=strides, itemsize=src.itemsize,
            meminfo=src.meminfo, parent=src.parent,
        )
        return impl_ret_borrowed(context, builder, view_type, view._getvalue())

    return view_type(flat, shape), codegen



@njit(**JIT)
def copy_into(src, dst):
    """dst[k] = src[k] for 1-D arrays of one length. An explicit loop: a slice assignment
    `dst[:] = src` makes numba compile a shape-mismatch error path into every kernel."""
    for k in range(dst.shape[0]):
        dst[k] = src[k]


@njit(**JIT)
def fill(x, value):
    """x[k] = value for every entry of the 1-D array x (see copy_into)."""
    for k in range(x.shape[0]):
        x[k] = value


@njit(**JIT)
def zero_matrix(X):
    """X[r, c] = 0 for a 2-D array (see copy_into)."""
    for r in range(X.shape[0]):
        for c in range(X.shape[1]):
            X[r, c] = 0.0


@njit(**JIT)
def all_finite(x):
    """True when every entry of the 1-D array x is finite."""
    for k in range(x.shape[0]):
        if not np.isfinite(x[k]):
            return False
    return True


@njit(**JIT)
def result_status(x):
    """OK when every entry of the C-contiguous result x is finite, else RESULT_NOT_FINITE: a
    kernel's last check, after its finite arguments (float64 overflowed on the way)."""
    return Status.OK.value if all_finite(shaped(x, (x.size,))) else Status.RESULT_NOT_FINITE.value

