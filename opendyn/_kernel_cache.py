"""Where numba caches opendyn's compiled kernels: a folder named by a hash of every kernel source.

numba caches each compiled kernel on disk keyed on the kernel's own source file only, while the
kernels inline or call helpers from other files (_kernels.py, rnea.py, effects.py, ...); after such
a helper changes, a kernel would be loaded stale. Every module that defines kernels is therefore
imported inside `kernel_cache()`, which points numba at a folder named by a hash of all those
sources (numba reads the setting when a function is decorated) and restores it afterwards.
"""

from __future__ import annotations

import contextlib
import hashlib
import pathlib

from numba.core import config as _numba_config

_HERE = pathlib.Path(__file__).parent
_SOURCES = (
    "model.py",
    "constraints.py",
    "effects.py",
    "step.py",
    "integrators.py",
    "dynamics/*.py",
)


def _cache_dir() -> str:
    digest = hashlib.sha1()
    for source in sorted(p for pattern in _SOURCES for p in _HERE.glob(pattern)):
        digest.update(source.read_bytes())
    base = (
        pathlib.Path(_numba_config.CACHE_DIR)
        if _numba_config.CACHE_DIR
        else (_HERE / "__pycache__")
    )
    return str(base / f"opendyn-kernels-{digest.hexdigest()[:16]}")


@contextlib.contextmanager
def kernel_cache():
    """Import kernel modules inside this block so that they cache in the hashed folder."""
    user_cache_dir = _numba_config.CACHE_DIR
    _numba_config.CACHE_DIR = _cache_dir()
    try:
        yield
    finally:
        _numba_config.CACHE_DIR = user_cache_dir
