"""The command's standard output when its reader leaves: `opendyn simulate | head -1` closes
the pipe after one line, and the command carries on quietly (the run, its files and its exit
status as without the pipe) instead of failing on the next print with "Broken pipe"."""

from __future__ import annotations

import contextlib
import os
import sys


class _ReaderMayLeave:
    """A stand-in for sys.stdout: writes go to it until its reader closes the pipe, then to
    nowhere (the file descriptor too, so that Python's own flush at exit finds no pipe)."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._gone()
            return len(text)

    def flush(self):
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._gone()

    def _gone(self):
        with contextlib.suppress(OSError, ValueError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        self._stream = open(os.devnull, "w")  # open as long as the command runs

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def reader_may_leave():
    """Within the block, sys.stdout carries on quietly once its reader has closed the pipe."""
    original = sys.stdout
    sys.stdout = _ReaderMayLeave(original)
    try:
        yield
    finally:
        with contextlib.suppress(BrokenPipeError):
            sys.stdout.flush()
        sys.stdout = original
