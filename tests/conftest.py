"""Shared fixtures."""

from __future__ import annotations

import signal

import pytest


@pytest.fixture
def ctrl_c_raises():
    """Ctrl-C (SIGINT) raises KeyboardInterrupt in this process during the test, as in an
    interactive Python: tests that send it set it, because a suite started from a background
    job of a script inherits it ignored, and opendyn then leaves it ignored."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def ctrl_c_default():
    """preexec_fn of a child process that a test sends Ctrl-C: the default disposition, so
    that the child's Python turns it into KeyboardInterrupt however the suite was started."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
