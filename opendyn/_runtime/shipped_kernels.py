"""Kernels shipped inside the package: a built wheel carries, in `opendyn/_kernels/`, the
compiled kernels its scenes and public functions need, so that its first run loads them
instead of compiling.

The shipped folder has the layout of the kernel cache (opendyn._runtime.kernel_cache: one
subfolder per source folder of the package) and a file DIGEST naming the sources it was
compiled from. It is read-only: a kernel that misses in the machine's cache folder is looked
up there (`shipped_is_a_fallback`), and one found is loaded from it, as numba loads any entry:
checked against its source's content and its compile target (a wheel's are compiled for the
portable target, opendyn._runtime.kernel_target). A kernel compiled later, for a signature the
wheel does not carry, goes to the machine's cache folder as before. A shipped folder of other
sources (left in a checkout by an older build) is not used.

`export_used(folder)` writes such a folder: the entries of every kernel this process has
compiled or loaded (scripts/build_wheel.py runs the shipped scenes and the public functions,
then exports what they used).
"""

from __future__ import annotations

import gc
import os
import pathlib
import shutil

from numba.core.caching import IndexDataCacheFile
from numba.core.dispatcher import Dispatcher

from .kernel_cache import _HERE, CACHE_DIR, DIGEST, _ours

SHIPPED = _HERE / "_kernels"
DIGEST_FILE = "DIGEST"  # in the shipped folder: the source digest it was compiled from


def _shipped_folder() -> pathlib.Path | None:
    """The package's shipped kernels, when there are some and they are of these sources."""
    try:
        digest = (SHIPPED / DIGEST_FILE).read_text(encoding="ascii").strip()
    except OSError:
        return None
    return SHIPPED if digest == DIGEST else None


SHIPPED_FOLDER = _shipped_folder()


def _twin(cache_file, root) -> IndexDataCacheFile:
    """The IndexDataCacheFile of `cache_file`'s kernel (an entry of opendyn's cache folder) in
    the folder `root` of the same layout."""
    subfolder = os.path.relpath(cache_file._cache_path, CACHE_DIR)
    base = cache_file._index_name[: -len(".nbi")]
    return IndexDataCacheFile(os.path.join(root, subfolder), base, cache_file._source_stamp)


def shipped_is_a_fallback():
    """Make a miss in opendyn's cache folder look in the shipped kernels (module docstring);
    numba's reader wrapped once per process, and only when the package ships kernels."""
    if SHIPPED_FOLDER is None or getattr(IndexDataCacheFile, "_opendyn_shipped", False):
        return
    load = IndexDataCacheFile.load

    def _load(self, key):
        data = load(self, key)
        if data is None and _ours(self):
            try:
                data = load(_twin(self, SHIPPED_FOLDER), key)
            except Exception:  # a damaged shipped entry: a miss, compiled into the cache
                data = None
        return data

    IndexDataCacheFile.load = _load
    IndexDataCacheFile._opendyn_shipped = True


shipped_is_a_fallback()


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
    from the cache folder (saved nowhere) is left out."""
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
    (folder / DIGEST_FILE).write_text(DIGEST + "\n", encoding="ascii")
    return entries, size
