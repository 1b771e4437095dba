"""The step's dispatch over a StageTable's effects tuple, derived from the registry:

    run_stages(which, effects, ctx, out)    the effect of slot `which` (EVERY: every slot, in
                                            order) adds its generalized force to out

numba builds it when it compiles a caller, for the tuple's types: for each slot k whose
parameters are not None, a call registry.stages()[k].apply(effects[k], ctx, out). A slot the
scene does not name (None) gets no line at all, so its effect is neither compiled nor run. The
body is written out, one `if` per named slot, when the caller compiles (numba's extension
mechanism, `overload`): a recursion over the tuple's tail, effects[1:], copied the tuple's
arrays at every level, about 1.2 us an evaluation on the UR5 with a PD controller. Nothing
here is made at run time, and the compiled callers cache on disk as any kernel.
"""

from __future__ import annotations

from numba.core import types
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


@overload(run_stages, inline="always")
def _run_stages(which, effects, ctx, out):
    """run_stages for the type of `effects`: one call per slot that is not None, in order."""
    named = [k for k, kind in enumerate(effects.types) if not isinstance(kind, types.NoneType)]
    lines = ["def run_named(which, effects, ctx, out):"]
    for k in named:
        lines += [
            f"    if which == EVERY or which == {k}:",
            f"        status = apply_{k}(effects[{k}], ctx, out)",
            "        if status:",
            "            return status",
        ]
    lines.append("    return OK")
    scope = {"__name__": __name__, "EVERY": EVERY, "OK": OK}
    scope.update({f"apply_{k}": stages()[k].apply for k in named})
    exec("\n".join(lines), scope)  # noqa: S102 (the lines above, nothing from outside)
    return scope["run_named"]
