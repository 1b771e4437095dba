"""Models built from URDF files, kept on disk: a later load_urdf of the same files returns the
stored Model instead of reading the URDF again.

Reading a URDF imports its parser, yourdfpy, and with it trimesh and scipy (0.5-0.9 s on a
2-core machine, most of a warm `opendyn simulate`), then parses the XML and computes the
collision meshes' convex hulls. A Model is frozen arrays, so the one built is pickled beside the
compiled kernels (opendyn._runtime.kernel_cache's folder, per user and source version) and
loaded in under a millisecond.

An entry is named by a hash of everything the Model is made from:
  - opendyn's source digest (a new version names new entries);
  - the URDF's and the SRDF's absolute paths and load_urdf's other options;
  - the search path of package:// mesh names (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH).
It also lists the files read, each with its content's hash: the URDF, the SRDF and every mesh
the URDF names, as found now (io.meshes.mesh_files, which looks them up again, so that a mesh that
now resolves elsewhere is a change). An entry whose files changed is a miss: the Model is built
again and replaces it. A load that warned is not stored, so that its warnings are not lost on
the next. OPENDYN_MODEL_CACHE=0 switches the cache off (every load_urdf builds its Model).

A scene's [[world]] mesh is kept the same way (cached_world_mesh): its convex hull and its
hollow, named by a hash of opendyn's source digest, the file's bytes and the scale, so that a
large world mesh (a room scanned into hundreds of thousands of vertices: most of a minute) costs
its hull once.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pathlib
import pickle
import warnings

from .._runtime.files import atomic_write
from .._runtime.kernel_cache import CACHE_DIR, DIGEST
from .meshes import mesh_files

FORMAT = 1  # of an entry: (FORMAT, files, model)


def cached_model(file: str, srdf, options: tuple, build):
    """The Model that `build()` makes of the URDF `file` with the SRDF `srdf` (a path, or None)
    under load_urdf's other `options` (a tuple of plain values): the stored one when the cache
    holds an entry of the same files, else build()'s, stored for next time."""
    folder = _folder()
    read = [file, *([] if srdf is None else [srdf]), *mesh_files(file)]
    files = None if folder is None else _hashes(read)
    if files is not None:  # (a file that cannot be read: the build says what is wrong)
        path = folder / f"{_key(file, srdf, options)}.pkl"
        model = _read(path, files)
        if model is not None:
            return model
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = build()
    for warning in caught:  # raised again, as they were
        warnings.warn_explicit(
            warning.message, warning.category, warning.filename, warning.lineno
        )
    if files is not None and not caught:
        _write(path, files, model)
    return model


def cached_world_mesh(file: str, scale, build):
    """What `build()` makes of the world mesh `file` scaled by `scale` (3 floats): its hull's
    vertices and its hollow (sections_world), the stored ones when the cache holds an entry of
    the same bytes and scale, else build()'s, stored for next time."""
    folder = _folder()
    files = None if folder is None else _hashes([file])
    if files is None:  # (a file that cannot be read: the build says what is wrong)
        return build()
    h = hashlib.sha256()
    for part in (DIGEST, "world mesh", *files.values(), repr(tuple(map(float, scale)))):
        h.update(part.encode() + b"\0")
    path = folder / "world_meshes" / f"{h.hexdigest()[:32]}.pkl"
    kept = _read(path, files)
    if kept is not None:
        return kept
    kept = build()
    _write(path, files, kept)
    return kept


def _folder() -> pathlib.Path | None:
    """The cache's folder, None when it is switched off or no cache folder is writable."""
    if CACHE_DIR is None or os.environ.get("OPENDYN_MODEL_CACHE", "1") == "0":
        return None
    return pathlib.Path(CACHE_DIR) / "models"


def _key(file: str, srdf, options: tuple) -> str:
    """The entry's name: a hash of the sources, the URDF's and the SRDF's paths, the options and
    the package search path (the URDF's and the SRDF's bytes are among the entry's files)."""
    h = hashlib.sha256()
    for part in (
        DIGEST,
        os.path.abspath(file),
        "" if srdf is None else os.path.abspath(srdf),
        repr(options),
        os.environ.get("ROS_PACKAGE_PATH", ""),
        os.environ.get("AMENT_PREFIX_PATH", ""),
    ):
        h.update(part.encode("utf-8", "surrogateescape") + b"\0")
    return h.hexdigest()[:32]


def _hashes(paths) -> dict[str, str] | None:
    """{absolute path: sha256 of its bytes} of the files; None when one cannot be read (the
    build then says what is wrong with it)."""
    found = {}
    try:
        for path in paths:
            with open(path, "rb") as f:
                found[os.path.abspath(path)] = hashlib.sha256(f.read()).hexdigest()
    except OSError:
        return None
    return found


def _read(path: pathlib.Path, files: dict):
    """The Model of the entry `path` when it lists exactly `files`; None for a miss (no entry,
    another version's, other files, or one cut short)."""
    try:
        with open(path, "rb") as f:
            version, stored, model = pickle.load(f)
    except Exception:  # no entry, or one that cannot be read: built again
        return None
    return model if version == FORMAT and stored == files else None


def _write(path: pathlib.Path, files: dict, model) -> None:
    """Store the entry; a cache that cannot be written (a full disk, a read-only folder) is
    left as it is: the Model is built again next time."""
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_write(path) as f:
            pickle.dump((FORMAT, files, model), f, protocol=pickle.HIGHEST_PROTOCOL)
