"""Ctrl-C (SIGINT) and SIGTERM: held while a dependency could swallow them, and SIGTERM taken as
Ctrl-C by the command line.

Python runs signal handlers in the main thread only; in any other thread these helpers change
nothing.
"""

from __future__ import annotations

import contextlib
import signal
import threading


def signal_name(signum) -> str:
    """How a message names the signal: "Ctrl-C" for SIGINT, else its name ("SIGTERM")."""
    return "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name


def _in_main_thread():
    return threading.current_thread() is threading.main_thread()


def deliver(handler, signum, frame):
    """Hand a signal to a SIGINT handler: call it; with no Python handler, stop the program by
    a KeyboardInterrupt, unless it was Ctrl-C and Ctrl-C is ignored."""
    if callable(handler):
        handler(signum, frame)
    elif not (signum == signal.SIGINT and handler == signal.SIG_IGN):
        raise KeyboardInterrupt


@contextlib.contextmanager
def held_interrupt():
    """Ctrl-C during the block is held, and delivered as soon as the block is over.

    For calls into dependencies that catch BaseException and so swallow the KeyboardInterrupt:
    trimesh does, around each of its optional imports, which `import yourdfpy` runs; a Ctrl-C
    there would be lost and the program would go on. Held, it reaches the caller once the call
    returns (or replaces the exception it raised).
    """
    if not _in_main_thread() or signal.getsignal(signal.SIGINT) is None:
        yield
        return
    held = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append((signum, frame)))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if held:
            deliver(previous, *held[0])


@contextlib.contextmanager
def unswallowed_interrupt():
    """Ctrl-C during the block raises KeyboardInterrupt as usual, and if something swallowed it
    (llvmlite prints "Exception ignored" for one raised in its callbacks while numba compiles or
    loads a kernel, and goes on), it is raised again when the block ends."""
    if not _in_main_thread() or signal.getsignal(signal.SIGINT) is None:
        yield
        return
    arrived = []
    previous = signal.getsignal(signal.SIGINT)

    def handler(signum, frame):
        arrived.append((signum, frame))
        deliver(previous, signum, frame)

    signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if arrived:
        deliver(previous, *arrived[0])


class SigtermAsInterrupt:
    """Within `with`, SIGTERM is handled like Ctrl-C: it goes to whatever handles SIGINT at that
    moment (Python's KeyboardInterrupt, or a running simulation's request to stop after its
    current chunk), with its own signal number. `terminated` tells whether it arrived;
    `exit_status` is the conventional 128 + the signal's number, for SIGTERM or else Ctrl-C."""

    terminated = False

    def __enter__(self):
        self._previous = None
        if _in_main_thread():
            self._previous = signal.signal(signal.SIGTERM, self._handler)
        return self

    def _handler(self, signum, frame):
        self.terminated = True
        deliver(signal.getsignal(signal.SIGINT), signum, frame)

    def __exit__(self, *exc):
        if self._previous is not None:
            signal.signal(signal.SIGTERM, self._previous)

    @property
    def signum(self):
        """SIGTERM once it arrived, else SIGINT (Ctrl-C)."""
        return signal.SIGTERM if self.terminated else signal.SIGINT

    @property
    def exit_status(self) -> int:
        """128 + signum: 143 after SIGTERM, 130 after Ctrl-C."""
        return 128 + self.signum
