"""Files written whole or not at all, the checks before writing one, and CSV fields."""

from __future__ import annotations

import contextlib
import csv
import errno
import io
import os
import pathlib
import secrets
import tempfile


@contextlib.contextmanager
def atomic_write(path):
    """Yield a binary file to write `path`'s new content to; when the block ends, `path` holds
    all of it, or, on any error (a full disk, Ctrl-C), its old content or nothing: never a part.

    The content goes to a temporary file in the same folder (named `.NAME.XXXX.tmp`, created with
    the usual permissions), is flushed to the disk and then renamed onto `path` in one step
    (os.replace); on an error the temporary file is removed. A symbolic link is followed, and
    the file it points to replaced. A path that is no regular file (/dev/stdout, a named pipe)
    is written in place: it cannot be replaced, and nothing on a disk can be left truncated.
    """
    target = pathlib.Path(os.path.realpath(path))
    if target.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a folder, not a file", str(path))
    if target.exists() and not target.is_file():
        with open(target, "wb") as f:
            yield f
        return
    f, tmp = _create_beside(target)
    try:
        with f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _create_beside(target):
    """A new temporary file in `target`'s folder, opened for writing: (file, its path). Opened
    with open(), not mkstemp, so that it gets the permissions of any new file (0o666 less the
    umask) rather than mkstemp's 0o600."""
    while True:
        token = secrets.token_hex(4)
        tmp = target.with_name(f".{target.name}.{token}.tmp")
        if name_too_long(tmp) is not None:  # a name near the limit: a short temporary one
            tmp = target.with_name(f".opendyn-{token}.tmp")
        try:
            return open(tmp, "xb"), tmp
        except FileExistsError:
            continue
        except OSError as e:  # no such folder, no permission: name the file asked for
            raise type(e)(e.errno, e.strerror, str(target)) from None


def unwritable(name, path):
    """Why a file cannot be written at `path` (`name` as the user wrote it), or None: a name
    that ends like a folder's, a folder in its place, a folder that is missing or is a file, a
    read-only file, a folder where no file can be created (tried: a temporary file is created
    there and removed)."""
    if name.endswith(tuple(sep for sep in (os.sep, os.altsep) if sep)):
        return "names a folder, not a file"
    too_long = name_too_long(path)
    if too_long is not None:
        return too_long
    try:
        path.exists()
    except OSError as e:  # a path longer than the system's limit, a loop of links
        return f"cannot be written ({e.strerror or e})"
    if path.is_dir():
        return "is a folder, not a file"
    if path.exists() and not path.is_file():  # a device or a pipe: written in place
        return None if os.access(path, os.W_OK) else "cannot be written (permission denied)"
    folder = path.parent
    if not folder.is_dir():
        blocking = next((p for p in (folder, *folder.parents) if p.exists()), None)
        if blocking is not None and not blocking.is_dir():
            return f"{blocking} is a file, not a folder"
        return f"the folder {folder} does not exist"
    if path.exists() and not os.access(path, os.W_OK):
        return "the file is read-only"
    real_folder = os.path.dirname(os.path.realpath(path))  # where atomic_write writes
    try:
        with tempfile.NamedTemporaryFile(dir=real_folder, prefix=".opendyn-check-"):
            pass
    except OSError as e:
        return f"no file can be written in the folder {folder} ({e.strerror})"
    return None


def name_too_long(path):
    """Why `path`'s last component is longer than its folder's file system allows (in bytes,
    os.pathconf's PC_NAME_MAX, 255 where the system does not say), or None."""
    folder = next((p for p in (path.parent, *path.parent.parents) if p.is_dir()), None)
    try:
        most = os.pathconf(folder or ".", "PC_NAME_MAX")
    except (OSError, ValueError):
        most = 255
    size = len(os.fsencode(path.name))
    if size > most:
        return f"its name is {size} bytes, longer than the {most} this file system allows"
    return None


def csv_field(text) -> str:
    """`text` (a name) as one field of a CSV line, as the csv module writes it (RFC 4180): in
    double quotes, its own doubled, where it holds a comma, a double quote or a line break (a
    name "box,1" stays one field); else as it is (an empty one as "")."""
    line = io.StringIO()
    # ended by \r\n, so that a carriage return in `text` is quoted too (the csv module quotes
    # the characters of its line ending); the line's own ending is cut off
    csv.writer(line, lineterminator="\r\n").writerow([text])
    return line.getvalue()[:-2]


# the first bytes of the files a user may hand opendyn by mistake, and what they are
_SIGNATURES = (
    (b"\x89PNG", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"GIF8", "a GIF image"),
    (b"%PDF", "a PDF document"),
    (b"PK\x03\x04", "a ZIP archive"),
    (b"\x1f\x8b", "a gzip archive"),
    (b"\x7fELF", "a program (ELF)"),
    (b"PAR1", "a Parquet table"),
    (b"\x93NUMPY", "a numpy array (.npy)"),
    (b"SQLite format 3", "an SQLite database"),
)


def kind_of(path) -> str:
    """What the file at `path` is, from its first bytes, as a message says it ("a PNG image",
    "a ZIP archive", "a text file", "binary data", "empty"), for the errors that refuse a file
    of the wrong kind."""
    try:
        with open(path, "rb") as f:
            head = f.read(512)
    except OSError as e:
        return f"unreadable ({e.strerror or e})"
    if not head:
        return "empty"
    for signature, kind in _SIGNATURES:
        if head.startswith(signature):
            return kind
    if b"\0" in head:
        return "binary data"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as e:
        if e.start < len(head) - 4:  # not merely a character cut at the 512th byte
            return "binary data"
    return "a text file"
