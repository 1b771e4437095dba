"""Kernels to ship inside the package: a built wheel carries, in `opendyn/_kernels/`, the
compiled kernels its scenes and public functions need, so that its first run loads them
instead of compiling (opendyn._runtime.kernel_cache reads them where its folder misses).

`export_used(folder)` writes such a folder: the entries of every kernel this process has
compiled or loaded, in the cache folder's layout (one subfolder per source folder of the
package), and a file DIGEST naming the sources they were compiled from and the numba that
compiled them (scripts/build_wheel.py runs the shipped scenes and the public functions, then
exports what they used).
"""

from __future__ import annotations

import gc
import os
import pathlib
import shutil

from numba.core.caching import IndexDataCacheFile
from numba.core.dispatcher import Dispatcher

from .kernel_cache import DIGEST_FILE, MISSING, PLAIN, _ours, _twin, shipped_stamp


def _used_kernels():
    """(dispatcher, signatures) of every opendyn kernel of this process cached in opendyn's
    folder that has compiled or loaded versions."""
    for obj in gc.get_objects():
        # by type, not isinstance: a weak proxy among the objects, whose referent is gone,
        # raises on any question asked of it
        if not issubclass(type(obj), Dispatcher) or not obj.overloads:
            continue
        cache = getattr(obj, "_cache", None)
        cache_file = getattr(cache, "_cache_file", None)
        if isinstance(cache_file, IndexDataCacheFile) and _ours(cache_file):
            yield obj, list(obj.overloads)


def export_used(folder) -> tuple[int, int]:
    """Write into `folder` (made if missing) the cache entries of every kernel version this
    process has compiled or loaded, in the cache folder's layout, and the DIGEST file: a
    folder to ship as opendyn/_kernels. Returns (entries, bytes) written. A version missing
    from the cache folder (saved nowhere) is left out. With PLAIN caching (numba lacks the
    cache's internals) there is nothing to export: RuntimeError."""
    if PLAIN:
        raise RuntimeError(
            "cannot export compiled kernels: this numba lacks what opendyn's kernel cache uses "
            f"({', '.join(MISSING)})"
        )
    folder = pathlib.Path(folder)
    entries = size = 0
    for dispatcher, signatures in _used_kernels():
        cache = dispatcher._cache
        source = cache._cache_file
        index = source._load_index()
        codegen = dispatcher.targetctx.codegen()
        keep = {}
        for signature in signatures:
            key = cache._index_key(signature, codegen)
            name = index.get(key)
            if name is not None and os.path.exists(source._data_path(name)):
                keep[key] = name
        if not keep:
            continue
        target = _twin(source, folder)
        os.makedirs(target._cache_path, exist_ok=True)
        for name in keep.values():
            shutil.copyfile(source._data_path(name), target._data_path(name))
            size += os.path.getsize(target._data_path(name))
        merged = {**target._load_index(), **keep}  # an export into a folder made before
        target._save_index(merged)
        size += os.path.getsize(target._index_path)
        entries += len(keep)
    (folder / DIGEST_FILE).write_text(shipped_stamp(), encoding="ascii")
    return entries, size
