"""Where numba caches opendyn's compiled kernels: one folder per machine and source version,
named by a hash of every kernel source, shared by every copy of those sources.

numba caches each compiled kernel on disk keyed on the kernel's own source file only, while the
kernels inline or call helpers from other files (spatial/compiled.py, algorithm/rnea.py,
sim/effects/, ...); after such a helper changes, or a file moves, a kernel would be loaded stale.
The hash therefore covers every Python source of the package, found by pattern (`SOURCES`), with
its path relative to the package: a new, changed, renamed or moved file names a new folder.

numba also files each kernel under a hash of its source's absolute folder, so that a source
checkout, the test suite and an installed copy of the same sources would each compile into a
cache of their own. opendyn's kernels are filed instead under their folder relative to the
package (`PackageLocator`, ahead of numba's own locators), so every copy of the same sources
on a machine reads and writes the same entries. The entries are keyed by the signature and the
compile target, which is portable (opendyn._runtime.kernel_target), so a folder made on one
machine loads on another: a built wheel ships one, read where this folder misses (below;
opendyn._runtime.shipped_kernels writes it).

The folder is the first writable one of:
  1. $NUMBA_CACHE_DIR/opendyn-kernels-HASH, when the user sets NUMBA_CACHE_DIR;
  2. the per-user cache, $XDG_CACHE_HOME (default ~/.cache)/opendyn/kernels-HASH;
  3. the package's own __pycache__/opendyn-kernels-HASH.
When none is writable, the kernels run uncached (compiled in every process), with one warning;
`import opendyn` never fails for want of a cache folder. Kernels defined outside the package
that call its kernels (the test suite's own) cache in the same folder when decorated inside
`kernel_cache()`.

numba unpickles each cache entry as it finds it, so an entry cut short (an interrupted copy of
the folder into a worker image, a full disk) would raise UnpicklingError or EOFError on every
later run. In opendyn's folder such an entry is a miss instead: it is removed, the kernel
compiles again and is cached afresh, and one warning names the folder (`unreadable_is_a_miss`).

Processes that compile the same kernel at once (the suite's workers, a sweep's) each add an entry
to its index: numba reads the index, picks the first unused data file number, writes the index
and then the data. Two that read the index before either writes it pick the same number, and the
index can end up naming one signature's entry with the other's machine code: every later process
that loads it crashes. Saves therefore take turns, under an exclusive lock on a file beside the
index (`saves_take_turns`, where the system has flock); loads need none, as each file is written
whole and renamed into place.

A process that only loads kernels need not set up numba's compiler: opendyn's cache loads skip
the refresh of numba's target context that numba makes before each (`loads_without_refresh`).

All of this reaches into numba's private API, as numba 0.68 has it (pyproject.toml pins that
minor version; opendyn._runtime.numba_internals lists what is used). Each name is probed at
import: where one is missing, numba caches the kernels by its own rules instead (`PLAIN`), and
one warning says what is missing and what that costs.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import pathlib
import tempfile
import warnings

# first: it sets the compile target, which numba reads when it is imported
from . import kernel_target  # noqa: F401

# isort: split
from numba.core import config as _numba_config

from . import compile_notice, numba_internals

# numba's internals that the cache uses, probed before any is imported: where one is missing,
# the kernels are cached as numba caches any function (PLAIN), with one warning (below)
MISSING = numba_internals.missing()
PLAIN = any(name != numba_internals.NRT for name in MISSING)
if not PLAIN:
    from numba.core.caching import (
        CacheImpl,
        IndexDataCacheFile,
        _CacheLocator,
        _SourceFileBackedLocatorMixin,
    )

_HERE = pathlib.Path(__file__).resolve().parents[1]  # the package: opendyn/
# every compiled source, and everything a kernel may inline or call: all of the package's Python
# files, wherever they live in it, but for the folders below
SOURCES = "*.py"
# not kernel sources: the caches themselves, a wheel's shipped kernels, and the shipped robots'
# example controllers (installed as opendyn/robots, beside the package in a source checkout)
NOT_SOURCES = ("__pycache__", "_kernels", "robots")


def _sources(package: pathlib.Path):
    """Every file matching SOURCES under `package`, outside the NOT_SOURCES folders."""
    for folder, subfolders, names in os.walk(package):
        subfolders[:] = [d for d in subfolders if d not in NOT_SOURCES]
        for name in names:
            if pathlib.PurePath(name).match(SOURCES):
                yield pathlib.Path(folder, name)


def source_digest(package: pathlib.Path = _HERE) -> str:
    """16 hex digits of a hash of every Python source under `package` (`_sources`): each
    file's path relative to the package, then its bytes, in path order."""
    digest = hashlib.sha1()
    for source in sorted(_sources(package), key=lambda p: p.relative_to(package).as_posix()):
        digest.update(source.relative_to(package).as_posix().encode() + b"\0")
        digest.update(source.read_bytes())
    return digest.hexdigest()[:16]


DIGEST = source_digest()


def _candidates(digest):
    """The cache folders to try, in order, with a word on each."""
    if _numba_config.CACHE_DIR:
        yield pathlib.Path(_numba_config.CACHE_DIR) / f"opendyn-kernels-{digest}", "NUMBA_CACHE_DIR"
    user = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    yield pathlib.Path(user) / "opendyn" / f"kernels-{digest}", "per-user cache"
    yield _HERE / "__pycache__" / f"opendyn-kernels-{digest}", "package folder"


def _writable(folder: pathlib.Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError:
        return False
    return True


def _choose():
    """(folder or None, where): the first writable candidate; None when there is none."""
    tried = []
    for folder, where in _candidates(DIGEST):
        if _writable(folder):
            return str(folder), where
        tried.append(str(folder))
    warnings.warn(
        "opendyn: no writable folder for the compiled-kernel cache (tried "
        + ", ".join(tried)
        + "); kernels are compiled in every process. Set NUMBA_CACHE_DIR to a writable folder "
        "to cache them.",
        RuntimeWarning,
        stacklevel=3,
    )
    return None, "none (uncached)"


CACHE_DIR, CACHE_WHERE = _choose()
# compiling said out loud (the notice listens from its import, made here, as every kernel
# module imports its options from this module), naming this folder
compile_notice.cached_in("numba's own cache folders" if PLAIN and CACHE_DIR else CACHE_DIR)
CACHING = CACHE_DIR is not None  # the kernels' `cache=` option


def _warn_missing():
    """One warning, where this numba lacks some of the internals the cache uses (MISSING):
    which, and what the kernels do without them."""
    costs = []
    if PLAIN:
        costs.append(
            "the kernels are cached by numba's own rules: each copy of opendyn's sources "
            "compiles its own, a wheel's shipped kernels are not used, an unreadable entry is "
            "an error, and a kernel is not compiled again when only a helper it calls from "
            "another file changes (delete numba's cache after editing opendyn's sources)"
        )
    if numba_internals.NRT in MISSING:
        costs.append("the collision kernels count references, as numba does by default (slower)")
    warnings.warn(
        f"opendyn: numba {numba_internals.VERSION} lacks what opendyn's kernel cache is written "
        f"for (numba {numba_internals.WRITTEN_FOR}): {', '.join(MISSING)}; "
        + "; ".join(costs)
        + f". Install numba {numba_internals.WRITTEN_FOR} "
        f"(pip install 'numba=={numba_internals.WRITTEN_FOR}.*') to have them back.",
        RuntimeWarning,
        stacklevel=3,
    )


if MISSING:
    _warn_missing()


def _ours(cache_file) -> bool:
    """Whether `cache_file` (an IndexDataCacheFile) is in opendyn's folder."""
    folder = pathlib.Path(cache_file._cache_path).resolve()
    return CACHE_DIR is not None and folder.is_relative_to(pathlib.Path(CACHE_DIR).resolve())


def _discard(cache_file, path, error):
    """Remove the unreadable cache file `path` of `cache_file` (an IndexDataCacheFile) if it
    is in opendyn's folder, with a warning for the first in this process; else re-raise
    `error`."""
    if not _ours(cache_file):
        raise error
    with contextlib.suppress(OSError):
        os.remove(path)
    if _discarded:
        return  # one warning a process: a damaged copy of the cache has many such entries
    _discarded.append(path)
    warnings.warn(
        f"opendyn: an unreadable entry of the compiled-kernel cache ({os.path.basename(path)}: "
        f"{type(error).__name__}) was removed and its kernel compiles again, as will any other "
        f"this process finds; if this repeats, delete the folder {CACHE_DIR}",
        RuntimeWarning,
        stacklevel=2,
    )


_discarded = []  # the first unreadable entry removed in this process


def unreadable_is_a_miss():
    """Make an unreadable entry of opendyn's kernel cache a cache miss (see the module
    docstring): numba's index and data readers, wrapped once per process (not with PLAIN
    caching); entries of any other folder (a user's own numba functions) behave exactly as
    before."""
    if PLAIN or getattr(IndexDataCacheFile, "_opendyn_guarded", False):
        return
    load_index, load_data = IndexDataCacheFile._load_index, IndexDataCacheFile._load_data

    def _load_index(self):
        try:
            return load_index(self)
        except Exception as error:  # unpickling a cut-short file raises several kinds
            _discard(self, self._index_path, error)
            return {}

    def _load_data(self, name):
        try:
            return load_data(self, name)
        except OSError:
            raise  # numba's own "no such entry": a miss
        except Exception as error:
            _discard(self, self._data_path(name), error)
            raise OSError(f"unreadable cache entry {name}") from error

    IndexDataCacheFile._load_index = _load_index
    IndexDataCacheFile._load_data = _load_data
    IndexDataCacheFile._opendyn_guarded = True


unreadable_is_a_miss()


@contextlib.contextmanager
def _turn(path):
    """Hold an exclusive lock on the file `path` (made if missing) for the block: the other
    processes and threads that ask for it wait (a no-op where the system has no flock)."""
    try:
        import fcntl
    except ImportError:  # Windows: numba's own behaviour
        yield
        return
    with open(path, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def saves_take_turns():
    """Make every save of a cache entry (numba's read of the index, choice of a data file,
    write of both) one turn under a lock beside the index (module docstring), in opendyn's
    folder; wrapped once per process (not with PLAIN caching). Any other folder's saves (a
    user's own kernels') are numba's as before."""
    if PLAIN or getattr(IndexDataCacheFile, "_opendyn_turns", False):
        return
    save = IndexDataCacheFile.save

    @functools.wraps(save)
    def _save(self, key, data):
        if not _ours(self):
            return save(self, key, data)
        with _turn(self._index_path + ".lock"):
            save(self, key, data)

    IndexDataCacheFile.save = _save
    IndexDataCacheFile._opendyn_turns = True


saves_take_turns()


# A built wheel ships kernels in the package's _kernels/ (opendyn._runtime.shipped_kernels
# writes them), a folder of this cache's layout with a file DIGEST naming the sources they were
# compiled from and the numba that compiled them. It is read-only: a kernel that misses in the
# cache folder is looked up there, and one found is loaded from it, as numba loads any entry:
# checked against its source's content and its compile target (portable,
# opendyn._runtime.kernel_target). A kernel compiled later, for a signature the wheel does not
# carry, goes to the cache folder as before. A shipped folder of other sources (left in a
# checkout by an older build) is not used; nor is one of another numba, whose every entry numba
# would refuse, and that one says so.
SHIPPED = _HERE / "_kernels"
DIGEST_FILE = "DIGEST"  # in the shipped folder: the source digest and numba's version


def shipped_stamp() -> str:
    """The DIGEST file's text for kernels compiled in this process: the source digest, then
    "numba VERSION"."""
    return f"{DIGEST}\nnumba {numba_internals.VERSION}\n"


def _shipped_folder() -> pathlib.Path | None:
    """The package's shipped kernels, when there are some, of these sources and of this numba
    (above); one warning, naming both versions, for kernels of these sources compiled by
    another numba. None with PLAIN caching, which cannot read them."""
    if PLAIN:
        return None
    try:
        stamp = (SHIPPED / DIGEST_FILE).read_text(encoding="ascii")
    except OSError:
        return None
    digest, _, built_with = stamp.partition("\n")
    if digest.strip() != DIGEST:
        return None
    built_with = built_with.strip().removeprefix("numba ") or "(not recorded)"
    if built_with != numba_internals.VERSION:
        warnings.warn(
            f"opendyn: the compiled kernels shipped in {SHIPPED} were built with numba "
            f"{built_with}, and this is numba {numba_internals.VERSION}, whose cache refuses "
            "them: they are not used, and each kernel compiles on its first use into the kernel "
            f"cache ({CACHE_DIR or 'none: in every process'}). Install the numba they were built "
            "with, or a wheel built with this one (scripts/build_wheel.py), to load them.",
            RuntimeWarning,
            stacklevel=3,
        )
        return None
    return SHIPPED


SHIPPED_FOLDER = _shipped_folder()


def _twin(cache_file, root) -> IndexDataCacheFile:
    """The IndexDataCacheFile of `cache_file`'s kernel (an entry of opendyn's cache folder) in
    the folder `root` of the same layout."""
    subfolder = os.path.relpath(cache_file._cache_path, CACHE_DIR)
    base = cache_file._index_name[: -len(".nbi")]
    return IndexDataCacheFile(os.path.join(root, subfolder), base, cache_file._source_stamp)


def shipped_is_a_fallback():
    """Make a miss in opendyn's cache folder look in the shipped kernels (above);
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


def loads_without_refresh():
    """Load opendyn's cached kernels without refreshing numba's whole target context first.

    numba refreshes it before every cache load: that imports each of its lowering registries
    (array math, with scipy's BLAS; linear algebra; three random number generators), about
    0.3 s of a process that only loads kernels, and loading needs none of it. What the loaded
    code does need is numba's runtime (NRT), whose functions it links to: that is initialized
    here. A compile still refreshes both contexts (numba's compiler does, before typing), so a
    kernel that misses the cache compiles as before. Not with PLAIN caching."""
    if PLAIN:
        return
    from numba.core.caching import Cache
    from numba.core.runtime import rtsys

    if getattr(Cache, "_opendyn_lazy", False):
        return
    load_overload = Cache.load_overload

    def _load_overload(self, sig, target_context):
        if not _ours(self._cache_file):
            return load_overload(self, sig, target_context)
        rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    Cache.load_overload = _load_overload
    Cache._opendyn_lazy = True


loads_without_refresh()


def cache_subfolder(py_file) -> str | None:
    """The folder, inside the cache folder, of the kernels of the source `py_file`: its folder
    relative to the package ("sim/effects", "." at the top), the same for every copy of the
    package; for a source outside it decorated inside `kernel_cache()`, "outside/" and numba's
    own name for its folder; None for any other source (numba's own locators file it)."""
    inside = _package_subfolder(py_file)
    if inside is None and _outside:
        return "outside/" + _CacheLocator.get_suitable_cache_subpath(py_file)
    return inside


@functools.lru_cache(maxsize=None)
def _package_subfolder(py_file) -> str | None:
    """`py_file`'s folder relative to the package, or None outside it; once per file (numba
    asks for each of its kernels, twice)."""
    path = pathlib.Path(py_file).resolve()
    return path.parent.relative_to(_HERE).as_posix() if path.is_relative_to(_HERE) else None


_outside = []  # non-empty inside kernel_cache(): kernels outside the package cache with ours


if not PLAIN:  # its bases are numba's private classes

    class PackageLocator(_SourceFileBackedLocatorMixin, _CacheLocator):
        """numba's cache locator for opendyn's kernels: CACHE_DIR/`cache_subfolder(py_file)`,
        checked against the source's content (numba's stamp: a hash of the file's bytes)."""

        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = os.path.join(CACHE_DIR, cache_subfolder(py_file))

        def get_cache_path(self):
            return self._cache_path

        @classmethod
        def from_function(cls, py_func, py_file):
            if not CACHING or cache_subfolder(py_file) is None:
                return None
            return super().from_function(py_func, py_file)

    if PackageLocator not in CacheImpl._locator_classes:
        CacheImpl._locator_classes.insert(0, PackageLocator)


@contextlib.contextmanager
def kernel_cache():
    """Kernels decorated inside this block, outside the package (the test suite's helpers that
    call opendyn's kernels), cache in opendyn's folder, so that they too follow its sources."""
    _outside.append(True)
    try:
        yield
    finally:
        _outside.pop()


def _counting(on: bool) -> dict:
    """numba's private option of reference counting, `_nrt`, set to `on`; none where this numba
    lacks it (MISSING), so that every kernel counts, as numba does by default."""
    return {} if numba_internals.NRT in MISSING else {"_nrt": on}


# the options of every kernel's @njit. Reference counting (numba's runtime, NRT) is switched on
# by name: a compiled function whose own options leave it unset takes its caller's setting when
# a caller compiles it, and numba keys a compiled version (in the process and in the cache) by
# its signature alone. A kernel first compiled under an UNCOUNTED one (below) would then be
# counted nowhere, for every later caller and process: a view it returns was freed by a counting
# caller while still in use (a heap corruption, met as a crash of the contact scenes).
JIT = dict(cache=CACHING, **_counting(True))
# batch loops release the GIL so that threads run them in parallel (see run_rows); single-state
# kernels keep it, which saves the release and re-acquisition on every call
BATCH = dict(JIT, nogil=True)
# helpers that take views of the per-body arrays are inlined into the kernels at the numba IR
# level (measured: RNEA on a UR5 1.46 -> 1.10 us per call inside a compiled loop; called as
# compiled functions instead, 1.2 -> 2.1 us). IR inlining is what costs numba's front end most
# when a kernel compiles, so the loop helpers (all_finite, copy_into, fill, zero_matrix, dot6)
# are plain compiled functions, which LLVM inlines anyway: ABA compiles in 4.6 s instead of
# 5.6 s at the same speed.
INLINE = dict(JIT, inline="always")
# the collision kernels hand shapes (tuples of arrays) down many small functions, and allocate
# nothing: they are compiled without numba's reference counting (its runtime, NRT), which
# otherwise increments and decrements, atomically, every array a compiled function binds, at
# each call and each inlined support point (measured in the same process against
# pin.computeDistances: od.distances on the Panda 1.45x -> 0.98x, Solo12 1.16x -> 0.75x, Talos
# 1.20x -> 0.68x). Such a kernel cannot make an array: numba refuses to compile one that does.
# It calls counted kernels only for what returns no array (its references would never be
# released), and none of them is compiled in its place (JIT above).
UNCOUNTED = dict(JIT, **_counting(False))
UNCOUNTED_INLINE = dict(INLINE, **_counting(False))
