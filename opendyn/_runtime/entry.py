"""Calling a compiled function without numba's type dispatch, for a caller that makes the same
call many times over (a control loop).

numba's dispatcher works out the type of every argument on every call; for named tuples of
arrays (a simulation step's SceneData, State, Record) it does so in Python, several
microseconds a call. `entry_for` does it once and returns the compiled entry point for exactly
those types: the caller must pass arguments of the same types every time (the same arrays, or
arrays of the same dtype, dimension, layout and writeability; ints as ints, floats as floats).
"""

from __future__ import annotations

from numba.core.typing.typeof import Purpose, typeof


def entry_for(dispatcher, *args):
    """The entry point of `dispatcher` (an @njit function) compiled, or loaded from the cache,
    for the types of `args`, callable as dispatcher(*args) is."""
    signature = tuple(typeof(a, Purpose.argument) for a in args)
    return dispatcher.compile(signature)
