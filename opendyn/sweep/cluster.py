"""The cluster a sweep runs on: the client it was given, or a local cluster of worker
processes that the terminal's Ctrl-C does not reach.

A terminal sends Ctrl-C (SIGINT) to every process of its foreground process group: the client
and its workers alike. The workers must ignore it, so that the client alone stops the sweep,
in order, keeping every finished row. A process inherits an ignored SIGINT through exec, but a
Ctrl-C the client ignores while it starts them is lost, and starting a local cluster takes a
second or more. So the workers are forked from multiprocessing's fork server, started (a few
milliseconds) while this process ignores SIGINT: the server ignores it, and so does every worker
it forks. Meanwhile, a Ctrl-C or SIGTERM that arrives while the cluster starts is held until it
is up (stopped halfway, Dask's exit handler trips over it: a traceback), then the cluster
closes and the signal goes to its handler.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import socket
import struct
import threading
import time

from .._runtime.signals import deliver
from ..errors import SweepError
from .specs import check_whole

# the local cluster's workers are new Python processes that import the __main__ module first
MAIN_GUARD = (
    "a script that calls od.sweep must do it under `if __name__ == \"__main__\":`, since each "
    "worker process of the local cluster imports the script"
)
_METHOD = "distributed.worker.multiprocessing-method"


def _start_fork_server():
    """Start multiprocessing's fork server, with Dask's modules preloaded, unless it runs: while
    it starts, SIGINT is ignored, and it keeps ignoring it. Returns the start method the
    workers use ("forkserver", or where there is none, Dask's default)."""
    import dask
    from distributed.utils import get_mp_context

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return dask.config.get(_METHOD)
    with dask.config.set({_METHOD: "forkserver"}):
        get_mp_context()  # sets the server's preload (Dask's modules), before the server starts
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        multiprocessing.forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)
    return "forkserver"


# seconds a scheduler has to answer
SCHEDULER_TIMEOUT = 10.0
# Dask's TCP messages open with their length in 8 bytes (little-endian), and both ends send a
# handshake of a few hundred bytes on connecting; a "length" beyond this is not Dask's
_HANDSHAKE_MAX = 1 << 20


def check_scheduler(address, timeout, what):
    """ValueError in one line unless the TCP service at `address` (tcp://HOST:PORT or
    HOST:PORT) opens as a Dask scheduler does within `timeout` seconds: with an 8-byte length
    of a plausible handshake (`what`: how the message names the address). Something else (an SSH banner) or silence is named here, where
    Dask would read the banner as a length of exabytes, or wait past its own timeout. Other
    schemes (tls://, ...) are left to Dask."""
    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        return
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit():
        raise ValueError(f"{what} {address}: expected tcp://HOST:PORT")
    deadline = time.monotonic() + timeout
    header = b""
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout) as peer:
            while len(header) < 8:
                peer.settimeout(max(deadline - time.monotonic(), 1e-3))
                chunk = peer.recv(8 - len(header))
                if not chunk:
                    break
                header += chunk
    except TimeoutError:
        raise ValueError(
            f"{what} {address}: no answer within {timeout:g} s; a Dask scheduler answers "
            "at once, so this is not one (or it is overloaded)"
        ) from None
    except OSError as e:
        raise ValueError(f"{what} {address}: cannot connect ({e.strerror or e})") from None
    if len(header) < 8:
        raise ValueError(
            f"{what} {address}: the service there closed the connection after "
            f"{len(header)} bytes; it is not a Dask scheduler"
        )
    (length,) = struct.unpack("<Q", header)
    if not 0 < length <= _HANDSHAKE_MAX:
        raise ValueError(
            f"{what} {address}: the service there is not a Dask scheduler (it opened with "
            f"{header!r})"
        )


def connect(address, what):
    """A dask.distributed Client of the scheduler at `address` (tcp://HOST:PORT), checked first
    by check_scheduler; ValueError in one line naming `what` and the address otherwise."""
    from dask.distributed import Client

    check_scheduler(address, SCHEDULER_TIMEOUT, what)
    try:
        return Client(address, timeout=f"{SCHEDULER_TIMEOUT}s")
    except (OSError, TimeoutError) as e:
        raise ValueError(f"{what} {address}: cannot connect ({e})") from None


class LocalOrGiven:
    """`with LocalOrGiven(client, workers) as dask_client`: `client` itself, or a local cluster
    of `workers` processes (default: one per core) for the duration of the block."""

    def __init__(self, client, workers):
        if workers is not None:
            check_whole(workers, "workers", 1)
        if client is not None and workers is not None:
            raise SweepError("workers: give workers for a local cluster, or a client, not both")
        if client is not None and not isinstance(client, str):
            from dask.distributed import Client

            if not isinstance(client, Client):
                raise TypeError(
                    "client: expected a dask.distributed Client or a scheduler's address "
                    f"'tcp://HOST:PORT', got {type(client).__name__} {client!r}"[:300]
                )
        self.client, self.workers = client, workers

    def __enter__(self):
        self.own = None
        if isinstance(self.client, str):  # a scheduler's address: a client of our own
            client = connect(self.client, "client")
            self.own, self.config = (None, client), contextlib.nullcontext()
            return client
        if self.client is not None:
            return self.client
        import logging

        import dask
        from dask.distributed import Client, LocalCluster

        if multiprocessing.parent_process() is not None:
            raise SweepError(f"a worker process started a sweep: {MAIN_GUARD}")
        held = []
        main = threading.current_thread() is threading.main_thread()
        if main:
            method = _start_fork_server()
            previous = {
                signum: signal.signal(signum, lambda *sig: held.append(sig))
                for signum in (signal.SIGINT, signal.SIGTERM)
            }
        else:  # no signal handlers here: the workers start as Dask starts them
            method = dask.config.get(_METHOD)
        # a worker restarted later (after one died) starts the same way
        self.config = dask.config.set({_METHOD: method})
        try:
            cluster = LocalCluster(
                n_workers=self.workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                silence_logs=logging.CRITICAL,
                env={"NUMBA_NUM_THREADS": "1"},
            )
            self.own = (cluster, Client(cluster))
        except BaseException as e:
            self.config.__exit__(None, None, None)
            if isinstance(e, RuntimeError):
                raise SweepError(
                    f"the local cluster's workers did not start ({e}); {MAIN_GUARD}"
                ) from None
            raise
        finally:
            if main:
                for signum, handler in previous.items():
                    signal.signal(signum, handler)
        held = [sig for sig in held if previous[sig[0]] != signal.SIG_IGN]
        if held:
            self.__exit__()
            signum, frame = held[0]
            if signum == signal.SIGTERM:
                signal.raise_signal(signal.SIGTERM)  # to its own handler now
            else:
                deliver(previous[signal.SIGINT], signum, frame)
            raise KeyboardInterrupt  # a handler that returned: the cluster is closed all the same
        return self.own[1]

    def __exit__(self, *exc):
        if self.own is not None:
            cluster, client = self.own
            self.own = None
            client.close()
            if cluster is not None:
                cluster.close()
            self.config.__exit__(None, None, None)
