"""Shared fixtures."""

from __future__ import annotations

import os
import pathlib
import signal

import pytest

# first (it imports no layer): opendyn sets its portable compile target before numba is
# imported, which a test module imported earlier (import numba) would otherwise do first
import opendyn  # noqa: F401


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


@pytest.fixture
def read_only_folder(tmp_path):
    """A folder no file can be created in, whoever runs the suite: one without write
    permission, or, for root (whom permissions do not stop), /proc, where the kernel creates
    no file for anyone."""
    if os.geteuid() == 0:
        yield pathlib.Path("/proc")
        return
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    yield folder
    folder.chmod(0o755)


@pytest.fixture
def read_only_file(tmp_path):
    """An existing file nobody may write, whoever runs the suite: one without write
    permission, or, for root, a read-only kernel setting (/proc/sys/kernel/ostype, mode 0444,
    which binds root too)."""
    if os.geteuid() == 0:
        path = pathlib.Path("/proc/sys/kernel/ostype")
        if not path.is_file():
            pytest.skip("no /proc/sys/kernel/ostype: not Linux")
        return path
    path = tmp_path / "locked"
    path.write_text("")
    path.chmod(0o444)
    return path
