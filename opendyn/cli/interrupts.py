"""Ctrl-C and SIGTERM named by what the command was doing: the "while ..." of the one-line message
that `opendyn` prints when it is stopped."""

from __future__ import annotations

import contextlib


class _Interrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM, with what the command was doing (the message's "while ...")."""


@contextlib.contextmanager
def _doing(what):
    """Name what the block does in the message of a Ctrl-C or SIGTERM that stops it."""
    try:
        yield
    except _Interrupted:
        raise
    except KeyboardInterrupt:
        raise _Interrupted(what) from None
