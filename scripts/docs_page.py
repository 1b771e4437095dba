"""The pages that the benchmark scripts write into the documentation (their --docs option).

A page is a title, a header block that says when, where and with what the numbers were measured
and which command reproduces them, then what the script printed. Used as

    with docs_page.page("core.md", "Core functions", enabled=args.docs, modules=("pinocchio",)):
        main_part()  # prints as before

which, when enabled, tees everything printed to stdout into a buffer and, when the block ends
without an exception, writes header + buffer to docs/performance/core.md. A run that fails or is
interrupted leaves the page as it was. Without enabled it does nothing: only --docs writes into
the repository.
"""

from __future__ import annotations

import contextlib
import datetime
import importlib
import io
import os
import pathlib
import platform
import shlex
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
PERFORMANCE = ROOT / "docs" / "performance"

# the modules whose versions every header gives, and how a header names each module
ALWAYS = ("opendyn", "numba", "numpy")
NAMES = {"pinocchio": "Pinocchio", "mujoco": "MuJoCo"}


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo, else platform.processor(), else 'unknown'."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def versions(modules=()) -> str:
    """'opendyn 0.1.0, numba 0.60.0, numpy 1.26.4' and the version of each of `modules`
    (module names, e.g. 'pinocchio'), each read from the imported module's __version__; 'not
    installed' for a module that cannot be imported (a script that uses it only if present)."""
    parts = []
    for name in ALWAYS + tuple(m for m in modules if m not in ALWAYS):
        try:
            version = importlib.import_module(name).__version__
        except ImportError:
            version = "not installed"
        parts.append(f"{NAMES.get(name, name)} {version}")
    return ", ".join(parts)


def command(script, argv) -> str:
    """The command that reproduces the run, from the repository's root: 'python
    scripts/NAME.py' and the arguments `argv` (sys.argv[1:]), quoted for a POSIX shell."""
    return "python " + shlex.join([f"scripts/{pathlib.Path(script).name}", *argv])


def header(title, script, argv, modules=(), when=None) -> str:
    """A page's Markdown title and header block: the date and time (UTC) of the run (`when`, a
    datetime, default now), the machine (CPU model, cores), the OS, Python's version, the
    versions of opendyn, numba, numpy and `modules`, the command that reproduces it (`script`,
    the script's path, with `argv`), and that the page is the script's output, not to be edited."""
    when = when or datetime.datetime.now(datetime.timezone.utc)
    name = pathlib.Path(script).name
    return (
        f"# {title}\n\n"
        f"Written by `scripts/{name}`; do not edit this page by hand: rerun the command below "
        "to update it.\n\n"
        f"- **Run:** {when.astimezone(datetime.timezone.utc):%Y-%m-%d %H:%M:%S} UTC\n"
        f"- **Machine:** {cpu_model()}, {os.cpu_count()} cores\n"
        f"- **OS:** {platform.platform()}\n"
        f"- **Python:** {platform.python_version()}\n"
        f"- **Versions:** {versions(modules)}\n"
        f"- **Command:** `{command(script, argv)}`\n\n"
    )


def write_atomic(path, text) -> pathlib.Path:
    """Write `text` to `path` (its folder made if missing) through a temporary file in the same
    folder renamed over it, so that a reader never sees half a page; the file gets the
    permissions that open() would give it (mkstemp's are the owner's alone). Returns the path."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    umask = os.umask(0)
    os.umask(umask)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
    return path


class Tee:
    """A text stream that writes to `stream` and keeps a copy of everything written."""

    def __init__(self, stream):
        self.stream = stream
        self.buffer = io.StringIO()

    def write(self, text):
        """Write `text` to the stream and to the copy."""
        self.buffer.write(text)
        return self.stream.write(text)

    def flush(self):
        """Flush the stream."""
        self.stream.flush()

    def text(self) -> str:
        """Everything written so far."""
        return self.buffer.getvalue()

    def __getattr__(self, name):
        """The stream's other attributes (encoding, isatty, fileno, ...)."""
        return getattr(self.stream, name)


def _kind(line):
    """"row" for a table row, "text" for plain text, None for anything else (a blank line, a
    heading, a list item, code)."""
    if line.startswith("|"):
        return "row"
    if not line.strip() or line.startswith(("#", "- ", "* ", "```", "    ")):
        return None
    return "text"


def as_markdown(printed) -> str:
    """The printed text as the page's Markdown: a blank line between two lines of text, which
    Markdown would otherwise join into one paragraph (the console shows them as lines), and
    between a table and a line of text next to it, which it would read as one more row."""
    lines = printed.split("\n")
    out = lines[:1]
    for before, line in zip(lines, lines[1:]):
        kinds = _kind(before), _kind(line)
        if None not in kinds and kinds != ("row", "row"):
            out.append("")
        out.append(line)
    return "\n".join(out)


@contextlib.contextmanager
def page(name, title, *, enabled, modules=(), script=None, argv=None, folder=PERFORMANCE):
    """With `enabled`, tee sys.stdout for the block and, when it ends without an exception,
    write header(title, ...) + what it printed (as_markdown) to folder/name (docs/performance/
    by default) and say so on stderr. `script` is the script's path (default sys.argv[0]),
    `argv` its arguments (default sys.argv[1:]); `modules` as in versions(). The header's time
    is the block's start. Without `enabled` it does nothing."""
    if not enabled:
        yield
        return
    when = datetime.datetime.now(datetime.timezone.utc)
    tee = Tee(sys.stdout)
    sys.stdout = tee
    try:
        yield
    finally:
        sys.stdout = tee.stream
    script = sys.argv[0] if script is None else script
    argv = sys.argv[1:] if argv is None else argv
    printed = as_markdown(tee.text().rstrip("\n"))
    text = header(title, script, argv, modules, when) + printed + "\n"
    path = write_atomic(pathlib.Path(folder) / name, text)
    print(f"wrote {path}", file=sys.stderr)
