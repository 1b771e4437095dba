"""The public dynamics functions' checked path: every call that the common call's fast path
does not finish.

A public function first hands its arguments, as they came, to its kernel's exact twin
(opendyn._runtime.entry), which runs only when they are float64 vectors of the model's sizes:

    try:
        if not twin(ibuf, fbuf, work, *states, *options, out):    # OK: done
            return out
    except TypeError:                                             # another type: convert below
        pass
    return checked_call(CALL, model, data, states, out, ...)     # here

Everything else comes here, once: the twin learns what the kernel has compiled, the states are
converted and checked (the error that names a bad one), and the kernel runs at a single state
(raising the error its Status names) or the batch kernel over the rows of a batch, over the
cores. A call the fast path refused for a failing Status (a non-finite argument, a singular M)
runs the kernel again here, to raise its error with the converted arguments.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from .._runtime.entry import learn
from . import checks


class Call(NamedTuple):
    """A public function's compiled code, as checked_call runs it.

    kernel: one state, kernel(ibuf, fbuf, work, *states, *options, *outs) -> Status.
    twin: exact(kernel), which the fast path calls with the same arguments.
    batch: the rows [start, stop) of a batch,
      batch(ibuf, fbuf, *states, *options, out (N, ...), status (N,), start, stop).
    states: the states' names, as errors name them: "q", then the velocity-like arguments
      ("qd", "qdd", "tau").
    packed: (kernel's, batch's) True where that kernel takes the states as one tuple (q, x, y),
      which keeps its arguments within ten.
    loads: whether the kernels take the external loads (checks.loads of the call's gravity and
      f_tip) as their first option, (rows, 6) for a state and (1 or N, rows, 6) for a batch.
    singular: for a kernel that solves with M(q), the diagnosis of a singular M
      (opendyn.algorithm.singular.singular_mass_matrix), which checks.raise_status raises.
    """

    kernel: Any
    twin: Any
    batch: Any
    states: tuple[str, ...]
    packed: tuple[bool, bool] = (False, False)
    loads: bool = False
    singular: Any = None


def checked_call(call, model, data, states, out, what, result, options=(), given=None):
    """The result of `call` at states = (q, ...) (as the user passed them: a single state, or
    a batch (N, nq), (N, nv) broadcast to one N), converted and checked.

    out: the single state's result array (a fresh one, or the Data's), or a tuple of them for
      a kernel with several results; the single state's answer is `out` itself.
    what, result: the function and its result, as errors name them (e.g. "inverse_dynamics",
      "tau").
    options: the kernels' arguments after the states (after the loads, with call.loads).
    given: {name: value} of the call's other arguments that errors may name as a likely cause
      ("gravity", "f_tip"); with call.loads its "gravity" and "f_tip" make the loads.
    Returns out, or for a batch (N, *shape) (a tuple of them for several results)."""
    given = given or {}
    arrays, batch = checks.as_states(model, states[0], *zip(call.states[1:], states[1:]))
    n = arrays[0].shape[0] if batch else None
    if call.loads:
        loads = checks.loads(model, given.get("gravity"), given.get("f_tip"), n)
        options = (loads, *options)
    outs = out if isinstance(out, tuple) else (out,)
    if not batch:
        work = checks.work_of(model, data, what)  # checks model and data
        inputs = (tuple(arrays),) if call.packed[0] else arrays
        status = call.kernel(model._ibuf, model._fbuf, work, *inputs, *options, *outs)
        learn(call.twin, call.kernel)  # the next such call takes the fast path
        if status:
            checks.raise_status(
                status, model, what, result, _named(call, arrays, given), call.singular
            )
        return out
    checks.single_state_only(data, what)
    several = () if len(outs) == 1 else (len(outs),)
    rows = np.empty((n, *several, *outs[0].shape))
    inputs = ((tuple(arrays),) if call.packed[1] else tuple(arrays)) + tuple(options)
    checks.run_batch(
        model, call.batch, inputs, rows, what, result, _named(call, arrays, given), call.singular
    )
    return tuple(rows[:, k] for k in range(len(outs))) if several else rows


def _named(call, arrays, given):
    """{name: value} of a call's converted states and its other arguments, for errors."""
    return {**dict(zip(call.states, arrays)), **given}
