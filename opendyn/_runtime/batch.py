"""Batches over the cores: a compiled batch kernel run on slices of its rows, one thread each."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

_MIN_ROWS_PER_THREAD = 64
_pool = None


def run_rows(batch_kernel, n, *args):
    """batch_kernel(*args, start, stop) over the rows [0, n) of a batch, one slice per core.

    The batch kernels are plain compiled loops that release the GIL, so threads run them in
    parallel; a plain loop compiles in a fraction of the time of a numba prange loop.
    """
    global _pool
    cores = os.cpu_count() or 1
    chunks = min(cores, max(1, n // _MIN_ROWS_PER_THREAD))
    if chunks == 1:
        batch_kernel(*args, 0, n)
        return
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=cores, thread_name_prefix="opendyn")
    bounds = np.linspace(0, n, chunks + 1).astype(int)
    futures = [
        _pool.submit(batch_kernel, *args, int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])
    ]
    for f in futures:
        f.result()
