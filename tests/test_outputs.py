"""Results are never lost: every file is written atomically, so that Ctrl-C or a full disk during
a save leaves the earlier file whole, never a truncated one."""

from __future__ import annotations

import errno
import os
import pathlib

import numpy as np
import pytest

import opendyn as od
from opendyn._files import atomic_write


def small_trajectory(value=1.0):
    """A two-sample record of a one-joint robot, every array filled with `value`."""
    k = np.full(2, value)
    col = np.full((2, 1), value)
    return od.Trajectory(
        t=np.array([0.0, 0.1]),
        q=col,
        qd=col,
        tau=col,
        kinetic=k,
        potential=k,
        work_applied=k,
        work_passive=k,
        joint_names=("j",),
    )


def files_in(folder):
    return sorted(p.name for p in pathlib.Path(folder).iterdir())


@pytest.mark.parametrize("error", [KeyboardInterrupt(), OSError(errno.ENOSPC, "disk full")])
@pytest.mark.parametrize("writer", ["savez_compressed", "savetxt"])
def test_save_is_atomic_an_interrupted_save_leaves_no_truncated_file(
    writer, error, tmp_path, monkeypatch
):
    """Ctrl-C or a full disk halfway through a save leaves the earlier file whole, or, for a
    new file, nothing: never the half-written bytes."""
    name, save = {
        "savez_compressed": ("run.npz", lambda traj, path: traj.save(path)),
        "savetxt": ("run.csv", lambda traj, path: traj.to_csv(path)),
    }[writer]
    old = small_trajectory(1.0)
    save(old, tmp_path / name)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

    def write_half_then_fail(file, *args, **kwargs):
        file.write(b"PK\x03\x04 half of a file")
        raise error

    monkeypatch.setattr(np, writer, write_half_then_fail)
    for path in (tmp_path / name, tmp_path / "new" / name):
        path.parent.mkdir(exist_ok=True)
        with pytest.raises(type(error)):
            save(small_trajectory(2.0), path)
    assert files_in(tmp_path / "new") == []
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before
    monkeypatch.undo()
    if writer == "savez_compressed":
        np.testing.assert_array_equal(od.Trajectory.load(tmp_path / name).q, old.q)


def test_atomic_write_gives_the_usual_permissions_and_follows_links(tmp_path):
    umask = os.umask(0o022)
    os.umask(umask)
    with atomic_write(tmp_path / "new.txt") as f:
        f.write(b"new")
    assert (tmp_path / "new.txt").stat().st_mode & 0o777 == 0o666 & ~umask
    (tmp_path / "real.txt").write_text("old")
    (tmp_path / "link.txt").symlink_to("real.txt")
    with atomic_write(tmp_path / "link.txt") as f:
        f.write(b"through the link")
    assert (tmp_path / "link.txt").is_symlink()
    assert (tmp_path / "real.txt").read_text() == "through the link"
