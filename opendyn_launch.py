"""The `opendyn` command's entry point, outside the opendyn package on purpose.

Importing the command takes about half a second (numpy, numba, the layers it runs), and Python
runs the package's __init__ before any module inside it; only a module outside the package can
turn a Ctrl-C or SIGTERM during that time into a one-line message instead of a traceback.
"""

from __future__ import annotations

import signal
import sys


class _Terminated(BaseException):
    """SIGTERM while opendyn is imported (the command answers it itself once it runs)."""


def _terminate(signum, frame):
    raise _Terminated


def main() -> int:
    """Run `opendyn.cli.main` (which answers Ctrl-C and SIGTERM itself once it runs); Ctrl-C or
    SIGTERM while opendyn is imported exits with one line and the status 130 or 143."""
    signal.signal(signal.SIGTERM, _terminate)
    try:
        from opendyn.cli.main import main as opendyn_main
    except KeyboardInterrupt:
        print("opendyn: interrupted (Ctrl-C) while starting", file=sys.stderr)
        return 130
    except _Terminated:
        print("opendyn: interrupted (SIGTERM) while starting", file=sys.stderr)
        return 143
    return opendyn_main()


if __name__ == "__main__":
    sys.exit(main())
