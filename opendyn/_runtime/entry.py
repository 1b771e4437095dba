"""Calling compiled functions from Python with less of numba's type dispatch.

Exact twins, for the public dynamics functions. A public function's common call passes
float64 arrays of the model's sizes straight to its kernel. Checking their types in Python
first costs more than the kernel on a small robot (measured on a UR5: 0.32 us for q, qd and
qdd, against 0.68 us for RNEA itself), while numba's dispatcher types every argument anyway, in
C, to choose the compiled version. The twin is a second dispatcher of the kernel's function
that shares the kernel's compiled versions and never compiles: an argument of another type (a
list, float32, a read-only or strided array, a batch) raises TypeError where the kernel would
compile a version for it. So the fast path, written at each public function, is one call:

    try:
        if not twin(ibuf, fbuf, work, *arguments, out):   # dtype, dimensions, layout checked in C
            return out                                    # Status.OK
    except TypeError:                                     # another type
        pass
    return checked_call(...)                              # everything else, in one function

and the kernel itself reports Status.CONVERT when a vector's length is not the model's (the
status helpers of opendyn.multibody.joints check lengths first), or another failing Status for
a bad value. Every public function then takes the same checked path
(opendyn.algorithm.calls.checked_call): it converts the arguments, which raises the error
naming a bad one, calls the kernel, which compiles what it needs, and `learn`s: copies that
version over to the twin, so that the next such call takes the fast path; or it runs the batch.
A try block costs nothing while nothing is raised, and the fast path adds no Python call to
the kernel's: an extra Python call on it was measured earlier at about 0.05 us, 4% of a UR5's
inverse_dynamics (a shared wrapper making the try for every site would add one).

Entry points, for a caller that makes the same call many times over (a control loop). For
named tuples of arrays (a simulation step's SceneData, State, Record) numba works out the
types in Python, several microseconds a call. `entry_for` does it once and returns the compiled
entry point for exactly those types: the caller must pass arguments of the same types every
time (the same arrays, or arrays of the same dtype, dimension, layout and writeability; ints as
ints, floats as floats), as nothing checks them.
"""

from __future__ import annotations

from numba import njit
from numba.core.typing.typeof import Purpose, typeof

from .status import Status

CONVERT = Status.CONVERT.value  # a module constant: Status.CONVERT.value is an enum look-up


def exact(kernel):
    """A dispatcher of kernel's Python function that runs the versions `kernel` has compiled
    (after `learn`) and compiles none: TypeError for arguments of any other type."""
    twin = njit(kernel.py_func)
    # what twin.disable_compile() sets, which numba allows only once a version exists
    twin._can_compile = False
    return twin


def learn(twin, kernel):
    """Give `twin` every version `kernel` has compiled so far; returns Status.CONVERT, the
    status of a call the twin refused (its arguments need converting). The twin holds only
    versions of the kernel, so equal counts mean it has them all: the test costs 0.1 us, where
    comparing the signatures (tuples of numba types, hashed) takes 8 us on a UR5's RNEA."""
    if len(twin.overloads) == len(kernel.overloads):
        return CONVERT
    for signature, compiled in kernel.overloads.items():
        if signature not in twin.overloads:
            twin.add_overload(compiled)
    return CONVERT


def entry_for(dispatcher, *args):
    """The entry point of `dispatcher` (an @njit function) compiled, or loaded from the cache,
    for the types of `args`, callable as dispatcher(*args) is."""
    signature = tuple(typeof(a, Purpose.argument) for a in args)
    return dispatcher.compile(signature)
