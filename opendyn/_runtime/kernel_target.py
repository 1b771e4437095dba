"""The CPU that opendyn's kernels are compiled for: one portable target, so that a kernel cache
made on one machine (a built wheel's, a CI run's, a worker image's) loads on every machine of
the same architecture and operating system.

numba compiles for the host's CPU by default, and keys every cache entry by that CPU's name and
feature list: a cache made on one CPU model is a miss on any other, and every fresh machine
compiles everything again. LLVM's `generic` CPU with no added features is the architecture's
baseline (on x86-64: SSE2, which every x86-64 CPU has); a cache made for it is read on any
machine of that architecture. It is not slower: the kernels work on 3- and 6-vectors and small
matrices, where wide vector units gain nothing, and measured with scripts/bench_sim.py --quick
(each run in a fresh cache, paired against MuJoCo's mj_step in the same run, two rounds each)
the UR5's RK4 step took 8.8 and 9.7 us for `generic` against 9.7 and 11.3 us for the host's
CPU on an AMD EPYC (ratios to mj_step 1.00 and 0.97 against 1.08 and 1.18), and 18.1 us
against 20.0 us on an Intel Xeon (Cascade Lake).

numba reads NUMBA_CPU_NAME and NUMBA_CPU_FEATURES when it is imported, and makes its code
generator then; `choose()`, run before opendyn imports numba, therefore sets them in the
environment (child processes, a sweep's workers among them, inherit them), unless
  - the user set NUMBA_CPU_NAME: that target stands;
  - OPENDYN_CPU=host: compile for this machine's CPU, as numba does by default;
  - numba was imported before opendyn: its code generator already has its target (usually the
    host's), and the kernels are compiled for that; a shipped cache is then not used.
It applies to every numba function of the process, the user's own included.
"""

from __future__ import annotations

import os
import sys

PORTABLE = "generic"  # LLVM's baseline CPU of the architecture (no added features)
PORTABLE_WORD = "portable (any CPU of this architecture)"


def choose() -> str:
    """Set the portable target in the environment when nothing else decides it (module
    docstring); returns a word on the outcome, for `opendyn info --cache`."""
    if "numba" in sys.modules:
        return "as numba was set when imported before opendyn"
    portable = os.environ.get("NUMBA_CPU_NAME") == PORTABLE and not os.environ.get(
        "NUMBA_CPU_FEATURES"
    )
    if portable:  # set by an opendyn that started this process (a test's, a sweep's worker)
        return PORTABLE_WORD
    if os.environ.get("NUMBA_CPU_NAME"):
        return "NUMBA_CPU_NAME, set by the user"
    if os.environ.get("OPENDYN_CPU", "").strip().lower() == "host":
        return "this machine's CPU (OPENDYN_CPU=host)"
    os.environ["NUMBA_CPU_NAME"] = PORTABLE
    os.environ["NUMBA_CPU_FEATURES"] = ""
    return PORTABLE_WORD


CHOSEN = choose()


def target() -> tuple[str, str]:
    """(CPU name, features) the kernels are compiled for, as numba's code generator has them."""
    from numba.core.registry import cpu_target

    codegen = cpu_target.target_context.codegen()
    _, name, features = codegen.magic_tuple()
    return name, features
