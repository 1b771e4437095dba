"""The step's dispatch over a StageTable's effects tuple, derived from the registry:

    run_stages(which, effects, ctx, out)    the effect of slot `which` (EVERY: every slot, in
                                            order) adds its generalized force to out

numba builds it when it compiles a caller, for the tuple's types: slot k calls
registry.stages()[k].apply(effects[k], ctx, out), unless effects[k] is None. The test
`is not None` on a None-typed slot is a constant, so the call of an effect the scene does not
name is dropped (its apply is compiled for None only, where it is a bare return: a call left
in, with its array arguments, cost about 60 ns per empty slot and evaluation). Nothing here is
made at run time: the implementation is numba's own extension mechanism (`overload`), chosen
when a caller compiles, and the compiled callers cache on disk as any kernel.
"""

from __future__ import annotations

from numba.extending import overload

from .interface import OK
from .registry import stages

EVERY = -1  # run_stages' `which` that runs every slot


def run_stages(which, effects, ctx, out):
    """Run the effect of slot `which` of `effects` (EVERY: every slot, in order): the
    effects' parameters (one slot per registry.stages(), None where the scene does not name
    it), ctx an interface.Context, out an interface.Out. Compiled code only. Returns the first
    failing Status, or OK."""
    raise NotImplementedError("run_stages runs in compiled code (numba) only")


def _none_left(which, effects, ctx, out):
    return OK


@overload(run_stages)
def _run_stages(which, effects, ctx, out):
    """run_stages for the type of `effects`, the tuple of the slots from len(stages) -
    len(effects) on: the first one's effect, then run_stages on the rest of the tuple."""
    if len(effects) == 0:
        return _none_left
    slot = len(stages()) - len(effects)
    apply = stages()[slot].apply

    def first_then_rest(which, effects, ctx, out):
        if (which == EVERY or which == slot) and effects[0] is not None:
            status = apply(effects[0], ctx, out)
            if status:
                return status
        return run_stages(which, effects[1:], ctx, out)

    return first_then_rest
