"""A sweep's results table: one Parquet row per run, written as the rows arrive and read back to
resume.

    PARQUET.parts/part-RUN.parquet   each arriving batch of rows, written whole (atomic rename)
    PARQUET                          every row, sorted by run, written when the sweep ends or
                                     stops (Ctrl-C); the parts are then removed

A sweep that was stopped, or whose client was killed, leaves its rows in PARQUET and in the
parts; the same sweep run again reads both and skips their runs. The sweep's record (its scene,
varied keys and specs, samples, seed, outputs, and their fingerprint) is in the Parquet schema's
metadata under b"opendyn.sweep": rows of another sweep are never mixed in.
"""

from __future__ import annotations

import contextlib
import json
import numbers
import os
import pathlib
import shutil

from .._runtime.files import atomic_write, kind_of

METADATA_KEY = b"opendyn.sweep"
# the columns of every row after the run's index and its values, with their Arrow types
_STATS = (
    ("status", "string"),
    ("message", "string"),
    ("warnings", "string"),
    ("simulated_s", "float64"),
    ("wall_s", "float64"),
    ("steps", "int64"),
    ("rejected_steps", "int64"),
    ("evaluations", "int64"),
)


def schema(axes, runs, outputs, record):
    """The table's Arrow schema: run, a column per varied key (float64 for numbers, bool for
    true/false, string otherwise), the stats, a float64 column per metric, q_final and qd_final
    (lists of float64), and the sweep's record as metadata."""
    import pyarrow as pa

    fields = [pa.field("run", pa.int64())]
    for axis in axes:
        column = [values[axis.key] for values in runs]
        fields.append(pa.field(axis.key, _arrow_type(column)))
    fields += [pa.field(name, getattr(pa, kind)()) for name, kind in _STATS]
    fields += [pa.field(name, pa.float64()) for name in outputs]
    fields += [pa.field(name, pa.list_(pa.float64())) for name in ("q_final", "qd_final")]
    return pa.schema(fields, metadata={METADATA_KEY: json.dumps(record, default=str)})


def _arrow_type(values):
    import pyarrow as pa

    if all(isinstance(v, bool) for v in values):
        return pa.bool_()
    if all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in values):
        return pa.float64()
    return pa.string()


class Unwritten(Exception):
    """A file of the sweep (`path`) could not be written: `error` is the OSError."""

    def __init__(self, path, error):
        super().__init__(path, error)
        self.path, self.error = path, error


@contextlib.contextmanager
def written(path):
    """The block that writes `path`; an OSError inside it (a full disk) is Unwritten(path)."""
    try:
        yield
    except OSError as e:
        raise Unwritten(path, e) from None


class Results:
    """The rows of one sweep: those read back from `path` (and its parts), then those added.

    finished: the runs that have a row; complete, failed: how many rows have that status.
    """

    def __init__(self, path, record, axes, runs, outputs):
        import pyarrow as pa

        self.schema = schema(axes, runs, outputs, record)
        self.record = record
        self.path = pathlib.Path(path) if path is not None else None
        self.text_keys = [a.key for a in axes if self.schema.field(a.key).type == pa.string()]
        self.tables, self.finished = [], set()
        self.complete = self.failed = 0
        self.wall_s = 0.0
        self._lock = None
        if self.path is not None:
            self.parts = self.path.with_name(self.path.name + ".parts")
            self._lock = _lock_file(self.path)
            try:
                for table in self._saved():
                    self._count(table)
            except BaseException:  # another sweep's file: refused, and the lock let go
                self.release()
                raise

    def _saved(self):
        """The tables already on disk for this sweep: PARQUET, then its parts."""
        files = [self.path] if self.path.is_file() else []
        if self.parts.is_dir():
            files += sorted(self.parts.glob("part-*.parquet"))
        import pyarrow as pa

        for file in files:
            table = self._read(file)
            keep = [run not in self.finished for run in table.column("run").to_pylist()]
            # typed: a file of no rows (a sweep stopped before its first) gives an empty list
            yield table.filter(pa.array(keep, type=pa.bool_()))

    def _read(self, file):
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(file)
        except (pa.ArrowInvalid, OSError) as e:
            kind = kind_of(file)
            why = f"it is {kind}" if kind != "a Parquet table" else f"it cannot be read ({e})"
            raise _foreign(file, f"{why}, not a Parquet file") from None
        raw = (table.schema.metadata or {}).get(METADATA_KEY)
        if raw is None:
            raise _foreign(file, "it holds no opendyn sweep")
        theirs, ours = json.loads(raw), json.loads(self.schema.metadata[METADATA_KEY])
        if theirs.get("fingerprint") != ours["fingerprint"]:
            keys = ("scene", "robot", "effects", "vary", "samples", "seed", "outputs")
            differ = [k for k in keys if theirs.get(k) != ours[k]] or ["record"]
            verb = "differs" if len(differ) == 1 else "differ"
            raise _foreign(file, f"it holds another sweep (its {', '.join(differ)} {verb})")
        return table.select(self.schema.names).cast(self.schema)

    def _count(self, table):
        self.tables.append(table)
        self.finished.update(table.column("run").to_pylist())
        complete, failed = status_counts(table)
        self.complete += complete
        self.failed += failed

    def add(self, rows):
        """Append rows (dicts; a key without a value is null) and, with a file, write them to
        a new part at once."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        for row in rows:
            for key in self.text_keys:
                row[key] = str(row[key])
        table = pa.Table.from_pylist(rows, schema=self.schema)
        if self.path is not None:
            part = self.parts / f"part-{rows[0]['run']:09d}.parquet"
            with written(part):
                self.parts.mkdir(exist_ok=True)
                with atomic_write(part) as f:
                    pq.write_table(table, f)
        self._count(table)

    def table(self):
        """Every row added or read back, sorted by run, as one table (nothing written)."""
        import pyarrow as pa

        table = pa.concat_tables(self.tables) if self.tables else self.schema.empty_table()
        return table.sort_by("run").replace_schema_metadata(self.schema.metadata)

    def close(self):
        """Every row, sorted by run, as one table; with a file, written there (atomically) and
        the parts removed (Unwritten, the parts kept, when the file cannot be written). Returns
        the table."""
        import pyarrow.parquet as pq

        table = self.table()
        if self.path is not None:
            with written(self.path), atomic_write(self.path) as f:
                pq.write_table(table, f)
            if self.parts.is_dir():
                shutil.rmtree(self.parts)
        self.release()
        return table

    def release(self):
        """Let another sweep write this results file (the lock taken when the rows were read
        back); called by close, and by the sweep whatever stopped it."""
        if self._lock is not None:
            lock, self._lock = self._lock, None
            with contextlib.suppress(OSError):
                os.unlink(lock.name)
            lock.close()


def _lock_file(path):
    """The open lock file PATH.lock, locked (flock, released when it is closed or the process
    ends); SweepError when another sweep holds it: two sweeps writing one results file would
    each replace the other's rows. None where the system has no flock."""
    try:
        import fcntl
    except ImportError:  # not a POSIX system: no lock
        return None
    from ..errors import SweepError

    name = path.with_name(path.name + ".lock")
    try:
        lock = open(name, "a")
    except OSError:
        return None  # a folder where no lock can be made: the outputs' check names it
    try:
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        lock.close()
        raise SweepError(
            f"{path}: another sweep is writing this results file now (it holds {name}); let it "
            "finish, or name another results file (-o)"
        ) from None
    return lock


def _foreign(file, why):
    from ..errors import SweepError

    return SweepError(
        f"{file}: {why}; name another results file (-o), or remove it to start over"
    )


def status_counts(table) -> tuple[int, int]:
    """(complete, failed): how many rows of a results table have each status."""
    statuses = table.column("status").to_pylist()
    complete = statuses.count("complete")
    return complete, len(statuses) - complete


def read_record(table) -> dict:
    """The sweep's record (scene, vary, log, samples, seed, outputs, fingerprint, opendyn
    version) from a results table's metadata."""
    return json.loads(table.schema.metadata[METADATA_KEY])
