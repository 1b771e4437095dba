"""The parts of numba's private API that opendyn's kernels and their cache rely on, probed at
import.

The kernel cache (opendyn._runtime.kernel_cache) is written for one minor version of numba,
`WRITTEN_FOR`, which pyproject.toml pins: it puts a locator of its own (a `_CacheLocator`) first
in numba's list (`CacheImpl._locator_classes`), counts on numba's source stamp being a hash of
the file's content (`_hash_source_file`, new in 0.68: with a stamp by modification time, copies
of the same sources would overwrite each other's entries), wraps the index and data readers and
writers of `IndexDataCacheFile`, and loads entries as `Cache.load_overload` does, without its
refresh of the target context; the kernels set numba's private `_nrt` option. `missing()` names
whatever of these this numba lacks, so that the cache can leave numba's caching as numba has it
instead of failing in the middle of a load.
"""

from __future__ import annotations

import numba
import numba.core.caching
import numba.core.cpu
import numba.core.runtime

VERSION = numba.__version__  # the numba of this process
WRITTEN_FOR = "0.68"  # the minor version of numba the cache is written for (pyproject.toml)
NRT = "numba.core.cpu.CPUTargetOptions._nrt"  # the kernels' option of reference counting

# every name the cache and the kernels' options use, under numba.core
USED = (
    "caching.CacheImpl._locator_classes",
    "caching._CacheLocator.get_suitable_cache_subpath",
    "caching._SourceFileBackedLocatorMixin.get_source_stamp",
    "caching._hash_source_file",
    "caching.IndexDataCacheFile.load",
    "caching.IndexDataCacheFile.save",
    "caching.IndexDataCacheFile._load_index",
    "caching.IndexDataCacheFile._load_data",
    "caching.IndexDataCacheFile._save_index",
    "caching.IndexDataCacheFile._data_path",
    "caching.Cache.load_overload",
    "caching.Cache._load_overload",
    "caching.Cache._guard_against_spurious_io_errors",
    "caching.Cache._index_key",
    "runtime.rtsys.initialize",
    "cpu.CPUTargetOptions._nrt",
)
# what an IndexDataCacheFile holds (read by the cache, which makes one for a shipped entry)
CACHE_FILE_FIELDS = ("_cache_path", "_index_name", "_index_path", "_source_stamp")
# the steps of Cache.load_overload, which the cache takes itself but for the first (refresh)
LOAD_STEPS = {"refresh", "_guard_against_spurious_io_errors", "_load_overload"}


def _find(path: str):
    """The object at `path` under numba.core, or None."""
    obj = numba.core
    for name in path.split("."):
        obj = getattr(obj, name, None)
    return obj


def _code_names(function) -> set[str]:
    """The global and attribute names `function`'s code uses (none for a builtin)."""
    return set(getattr(getattr(function, "__code__", None), "co_names", ()))


def missing() -> list[str]:
    """What of numba's internals that the cache uses (module docstring) this numba lacks, each
    by its full name, or with what it no longer does (NRT: the `_nrt` option). Empty when all
    are there. Asked before the cache wraps any of them (kernel_cache asks at import): after,
    load_overload is the cache's own."""
    lacking = ["numba.core." + path for path in USED if _find(path) is None]
    cache_file = _find("caching.IndexDataCacheFile")
    if cache_file is not None:
        made = vars(cache_file("", "probe", None))
        lacking += [
            f"numba.core.caching.IndexDataCacheFile().{name}"
            for name in CACHE_FILE_FIELDS
            if name not in made
        ]
    init = _find("caching.Cache.__init__")
    if init is not None and "_cache_file" not in _code_names(init):
        lacking.append("numba.core.caching.Cache()._cache_file")
    load = _find("caching.Cache.load_overload")
    if load is not None and _code_names(load) != LOAD_STEPS:
        lacking.append(
            f"numba.core.caching.Cache.load_overload as numba {WRITTEN_FOR} has it "
            "(refresh, then _load_overload)"
        )
    stamp = _find("caching._SourceFileBackedLocatorMixin.get_source_stamp")
    if stamp is not None and "_hash_source_file" not in _code_names(stamp):
        lacking.append(
            "a source stamp by content (_SourceFileBackedLocatorMixin."
            "get_source_stamp calling _hash_source_file)"
        )
    return lacking
