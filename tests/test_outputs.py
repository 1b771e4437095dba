"""Results are never lost: every file is written atomically, so that Ctrl-C or a full disk during
a save leaves the earlier file whole, never a truncated one; Ctrl-C and SIGTERM during a run
write its partial record, and before it (importing, loading the robot) give one line."""

from __future__ import annotations

import errno
import os
import pathlib
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

import opendyn as od
from opendyn._files import atomic_write
from opendyn._signals import held_interrupt
from opendyn.cli import main

REPO = pathlib.Path(__file__).resolve().parents[1]


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


def test_ctrl_c_swallowed_by_a_dependency_still_stops_the_program():
    """held_interrupt keeps Ctrl-C from a dependency that catches BaseException (trimesh does,
    around its optional imports) and delivers it when the call is over."""
    reached_the_end = False
    with pytest.raises(KeyboardInterrupt):
        with held_interrupt():
            try:
                signal.raise_signal(signal.SIGINT)
            except BaseException:  # what trimesh does
                pass
            reached_the_end = True
    assert reached_the_end


def run_interrupted_at(module, argv, tmp_path):
    """Run `module.main` with `argv` in a new Python, Ctrl-C arriving as soon as `module` (a
    module it imports) is imported; returns the finished process."""
    script = (
        "import signal, sys\n"
        "class CtrlC:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        f"        if name == {module!r}:\n"
        "            signal.raise_signal(signal.SIGINT)\n"
        "sys.meta_path.insert(0, CtrlC())\n"
        f"sys.argv = {argv!r}\n"
        "import opendyn_launch\n"
        "sys.exit(opendyn_launch.main())\n"
    )
    path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
    env = dict(os.environ, PYTHONPATH=path)
    return subprocess.run(
        [sys.executable, "-c", script],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_ctrl_c_while_loading_the_robot_is_one_line(tmp_path):
    """Ctrl-C while yourdfpy imports trimesh, which would swallow it, stops the command."""
    proc = run_interrupted_at("trimesh.path", ["opendyn", "simulate"], tmp_path)
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr == (
        "opendyn simulate: interrupted (Ctrl-C) while loading the scene and its robot; "
        "nothing was run\n"
    )
    assert proc.stdout == "" and files_in(tmp_path) == []


def test_ctrl_c_while_importing_opendyn_is_one_line(tmp_path):
    proc = run_interrupted_at("numba", ["opendyn", "simulate"], tmp_path)
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr == "opendyn: interrupted (Ctrl-C) while starting\n"


@pytest.mark.parametrize("signum, name", [(signal.SIGINT, "Ctrl-C"), (signal.SIGTERM, "SIGTERM")])
def test_ctrl_c_or_sigterm_during_the_run_writes_the_partial_record_and_exits_1(
    signum, name, tmp_path
):
    out = tmp_path / "long.npz"
    # compiled ahead, so that the signal reaches the run and not numba compiling it
    assert main(["compile", "ur5_falling"]) == 0
    proc = subprocess.Popen(
        [sys.executable, "-m", "opendyn.cli", "simulate", "ur5_falling", "--duration", "3600"]
        + ["-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    watchdog = threading.Timer(300, proc.kill)
    watchdog.start()
    try:
        # the progress bar shows once the run has gone on for a second
        seen = ""
        while "simulating" not in seen and proc.poll() is None:
            seen += proc.stderr.read(1)
        proc.send_signal(signum)
        stdout, stderr = proc.communicate()
    finally:
        watchdog.cancel()
    assert proc.returncode == 1, seen + stderr
    assert f"interrupted ({name}) at t = " in stderr and "STOPPED EARLY" in stdout
    traj = od.Trajectory.load(out)
    assert not traj.complete and traj.message.startswith(f"interrupted ({name})")
    assert 0 < traj.t[-1] < 3600
