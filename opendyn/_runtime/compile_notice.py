"""Compiling opendyn's kernels, said out loud: a one-line notice before numba starts compiling,
a progress bar while it does, and the seconds it took.

numba compiles a kernel the first time it is called with a new combination of argument types,
then caches the machine code on disk (opendyn._runtime.kernel_cache), so a later process loads it in
milliseconds. A listener on numba's "numba:compile" events sees every real compilation (a cache
hit raises no event), so:
  - a warm cache prints nothing;
  - the first compilation of a call prints one line on stderr (what, why, about how long, that it
    happens once per machine and opendyn version) and a bar that counts the pieces compiled;
  - `compiling(what, pieces)` announces a planned compilation of known size (a simulation's
    loop, `opendyn compile` (opendyn.cli.cache)): the bar then moves over those pieces;
  - `expect(kernel, estimate)` gives the notice of a kernel called on its own (the collision
    queries) its measured time; any other such kernel compiles in seconds.
`compile_seconds()` is the total time spent compiling in this process. The listener is on from
this module's import, which opendyn._runtime.kernel_cache makes (every kernel module imports
that one), naming its folder (`cached_in`).
"""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

from numba.core import event

_lock = threading.RLock()


class _Watch(event.Listener):
    """Counts and times opendyn's compilations; draws the notice and the bar."""

    def __init__(self):
        self.depth = 0  # nested compilations in progress (a kernel compiles its callees)
        self.seconds = 0.0  # total seconds of top-level compilations
        self.started = 0.0
        self.bar = None
        self.plan = None  # (what, pieces, estimate) of an announced compilation
        self.quiet = False
        self.folder = None  # the cache folder the notice names (None: none is writable)
        self.estimates = {}  # {kernel's Python function: the notice's words} (expect)

    def on_start(self, ev):
        dispatcher = ev.data["dispatcher"]
        if not dispatcher.py_func.__module__.startswith("opendyn"):
            return
        with _lock:
            if self.depth == 0:
                self.started = time.perf_counter()
                if self.bar is None and not self.quiet:
                    self._announce(dispatcher)
            self.depth += 1
            if self.bar is not None:
                self.bar.set_postfix_str(dispatcher.py_func.__name__, refresh=False)

    def on_end(self, ev):
        dispatcher = ev.data["dispatcher"]
        if not dispatcher.py_func.__module__.startswith("opendyn"):
            return
        with _lock:
            self.depth -= 1
            if self.depth > 0:
                return
            self.seconds += time.perf_counter() - self.started
            if self.plan is None and self.bar is not None:
                self.bar.update(1)
                self.bar.close()
                self.bar = None

    def notice(self, dispatcher) -> tuple[str, int]:
        """(the notice line, the bar's pieces) of a compilation that starts with `dispatcher`:
        the planned one's, else that kernel's alone (its expected time, else a few seconds)."""
        if self.plan is not None:
            what, pieces, estimate = self.plan
            estimate = estimate() if callable(estimate) else estimate
        else:
            what, pieces = f"{dispatcher.py_func.__module__}.{dispatcher.py_func.__name__}", 1
            estimate = self.estimates.get(dispatcher.py_func, "a few seconds")
        where = f"cached in {self.folder}" if self.folder else "no writable cache: every process"
        line = (
            f"opendyn: compiling {what} for this machine ({estimate} on 2 cores; once per "
            f"machine and opendyn version, {where})"
        )
        return line, pieces

    def _announce(self, dispatcher):
        """The notice line, then a bar (planned pieces, or one kernel and its callees)."""
        from tqdm import tqdm

        line, pieces = self.notice(dispatcher)
        print(line, file=sys.stderr, flush=True)
        self.bar = tqdm(
            total=pieces,
            unit="piece",
            desc="compiling",
            file=sys.stderr,
            leave=False,
            disable=None,  # no bar when stderr is not a terminal; the notice line stays
            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n}/{total} pieces "
            "[{elapsed}<{remaining}{postfix}]",
        )


_watch = _Watch()
event.register("numba:compile", _watch)


def cached_in(folder):
    """The cache folder the notice names (None: no writable one)."""
    _watch.folder = folder


def expect(kernel, estimate: str):
    """The words on how long compiling `kernel` (a compiled function called on its own, with
    its callees) takes on 2 cores, e.g. "about 30 s", for its notice; returns `kernel`."""
    _watch.estimates[kernel.py_func] = estimate
    return kernel


def compile_seconds() -> float:
    """Seconds this process has spent compiling opendyn kernels so far."""
    return _watch.seconds


@contextmanager
def compiling(what: str, pieces: int, estimate):
    """Announce a compilation of `pieces` steps, each started by the block with `step()`:
    if any step compiles, one notice names `what` and its `estimate` (words, or a function
    that returns them when the notice is shown), and the bar moves by one per step; if
    everything loads from the cache, nothing is printed.

        with compiling("the simulation loop", 3, "about 15 s") as step:
            for piece in pieces:
                piece()
                step()
    """
    with _lock:
        outer = _watch.plan
        _watch.plan = (what, pieces, estimate)

    def step():
        with _lock:
            if _watch.bar is not None:
                _watch.bar.update(1)

    try:
        yield step
    finally:
        with _lock:
            _watch.plan = outer
            if outer is None and _watch.bar is not None:
                _watch.bar.close()
                _watch.bar = None


@contextmanager
def quiet():
    """No notice and no bar inside the block (the caller shows its own progress)."""
    with _lock:
        before = _watch.quiet
        _watch.quiet = True
    try:
        yield
    finally:
        with _lock:
            _watch.quiet = before
