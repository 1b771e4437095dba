"""Results are never lost: `opendyn simulate` saves the trajectory by default, checks every output
before the run, writes each file atomically, saves the trajectory to a fallback file when a
write fails after the run, and answers Ctrl-C and SIGTERM with one line or a partial record."""

from __future__ import annotations

import errno
import importlib
import importlib.util
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import threading

import numpy as np
import pytest

import opendyn as od
from conftest import ctrl_c_default
from opendyn._runtime.files import atomic_write
from opendyn._runtime.signals import held_interrupt, unswallowed_interrupt
from opendyn.cli.main import main
from opendyn.io.urdf import shipped_robots_dir

REPO = pathlib.Path(__file__).resolve().parents[1]
# the module (the package's attribute `simulate` is the function)
SIMULATE = importlib.import_module("opendyn.sim.simulate")
SHORT = ["--duration", "0.1", "-q"]


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


@pytest.fixture
def no_run(monkeypatch):
    """Loading a scene or running one fails the test: the checks must come before either."""

    def refuse(*args, **kwargs):
        raise AssertionError("the scene was loaded or run before the outputs were checked")

    monkeypatch.setattr("opendyn.cli.simulate.scene_for", refuse)
    monkeypatch.setattr(SIMULATE, "simulate", refuse)


@pytest.mark.parametrize("how", ["shipped", "file"])
def test_the_default_record_is_named_after_the_scene_file_not_its_display_name(
    how, tmp_path, monkeypatch, capsys
):
    # planar_3r_limits.toml's name is "planar 3R arm against its limits"
    monkeypatch.chdir(tmp_path)
    target = "planar_3r_limits"
    if how == "file":
        target = str(shipped_robots_dir() / "planar_3r_limits.toml")
    assert main(["simulate", target, "--duration", "0.01", "--quiet"]) == 0
    assert files_in(tmp_path) == ["planar_3r_limits.json", "planar_3r_limits.npz"]


def test_simulate_saves_by_default_and_no_save_skips_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", *SHORT]) == 0
    out = capsys.readouterr().out
    assert "wrote double_pendulum_swing.npz\nwrote double_pendulum_swing.json" in out
    assert files_in(tmp_path) == ["double_pendulum_swing.json", "double_pendulum_swing.npz"]
    traj = od.Trajectory.load("double_pendulum_swing.npz")
    assert traj.complete and traj.t[-1] == pytest.approx(0.1)

    for path in tmp_path.iterdir():
        path.unlink()
    assert main(["simulate", *SHORT, "--no-save"]) == 0
    assert "wrote" not in capsys.readouterr().out and files_in(tmp_path) == []
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", "--no-save", "-o", "run.npz"])
    assert exit_.value.code == 2
    assert "not allowed with argument --no-save" in capsys.readouterr().err


@pytest.mark.parametrize(
    "make, args, problem",
    [
        (None, ["--csv", "missing/run.csv"], "the folder missing does not exist"),
        ("adir/", ["--plot", "adir"], "is a folder, not a file"),
        (None, ["--csv", "newdir/"], "names a folder, not a file"),
        ("afile", ["--html", "afile/run.html"], "afile is a file, not a folder"),
        (None, ["-o", ""], "-o: the file name is empty"),
        ("adir/", ["-o", "adir"], "-o adir: is a folder, not a file"),
        (None, ["--csv", " "], "--csv: the file name is empty"),
        ("run.json/", ["-o", "run.npz"], "-o 'run.npz': run.json: is a folder, not a file"),
        (None, ["-o", "x.npz", "--csv", "x.npz"], "--csv 'x.npz': is also the file of -o"),
        (None, ["--plot", "run.pgn"], "matplotlib writes no .pgn files"),
    ],
)
def test_unwritable_output_is_refused_before_the_run(
    make, args, problem, tmp_path, monkeypatch, capsys, no_run
):
    monkeypatch.chdir(tmp_path)
    if make is not None:
        if make.endswith("/"):
            (tmp_path / make).mkdir()
        else:
            (tmp_path / make).write_text("")
    before = files_in(tmp_path)
    assert main(["simulate", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("opendyn simulate: ") and problem in err and len(err.splitlines()) == 1
    assert files_in(tmp_path) == before  # nothing written, no probe left behind


@pytest.mark.parametrize("option", [["--html", "run.html"], ["--view"]])
def test_playback_without_meshcat_is_refused_before_the_run(
    option, tmp_path, monkeypatch, capsys, no_run
):
    find_spec = importlib.util.find_spec

    def without_meshcat(name, *args):
        return None if name == "meshcat" else find_spec(name, *args)

    monkeypatch.setattr(importlib.util, "find_spec", without_meshcat)
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", *option]) == 2
    err = capsys.readouterr().err
    assert f"opendyn simulate: {option[0]}: playback needs meshcat: pip install" in err


def test_every_name_the_file_system_allows_is_written(tmp_path, monkeypatch, capsys):
    """Spaces, quotes, a newline, shell and Windows specials, a leading dash (--output=), no
    suffix, unicode, and names at the file system's limit of bytes: a 255-byte name failed,
    because the temporary file written beside it took a longer name."""
    monkeypatch.chdir(tmp_path)
    most = os.pathconf(tmp_path, "PC_NAME_MAX")
    long_csv = "a" * (most - 12) + ".csv"  # as NAME-partial.csv (a stopped run's): the limit
    # its -partial.json (a stopped run's) is the limit, or one byte under
    long_npz = "é" * ((most - 13) // 2) + ".npz"
    names = ["with space.npz", 'quo"te\'s.npz', "new\nline.npz", "a:b*c?<>|.npz", "-dash.npz",
             "no-suffix", "ünïcødé 机器人.npz", ".hidden.npz", long_npz]
    for name in names:
        assert main(["simulate", *SHORT, f"--output={name}", f"--csv={long_csv}"]) == 0, name
        npz, record = od.Trajectory.load(name), tmp_path / pathlib.Path(name).with_suffix(".json")
        assert npz.complete and record.is_file() and (tmp_path / long_csv).is_file()
        assert len(np.loadtxt(long_csv, delimiter=",", skiprows=1)) == len(npz.t)
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_a_name_longer_than_the_file_system_allows_is_refused_before_the_run(
    tmp_path, monkeypatch, capsys, no_run
):
    monkeypatch.chdir(tmp_path)
    most = os.pathconf(tmp_path, "PC_NAME_MAX")
    cases = [
        (["--csv", "a" * (most - 3) + ".csv"], f"its name is {most + 1} bytes, longer than the "
         f"{most} this file system allows"),
        # the .npz fits; the .json record beside it does not
        (["-o", "b" * (most - 4) + ".npz"],
         f"{'b' * (most - 4)}.json: its name is {most + 1} bytes"),
        (["--plot", "é" * (most // 2) + ".png"], f"its name is {most // 2 * 2 + 4} bytes"),
        # the name fits; the one a run that stops early writes does not
        (["--csv", "d" * (most - 4) + ".csv"],
         f"{'d' * (most - 4)}-partial.csv: its name is {most + 8} bytes"),
    ]
    for args, problem in cases:
        assert main(["simulate", *args]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"opendyn simulate: {args[0]} ") and problem in err, err
        assert files_in(tmp_path) == []


def test_read_only_places_are_refused_before_the_run(
    read_only_folder, read_only_file, capsys, no_run
):
    target = str(read_only_folder / "run.csv")
    assert main(["simulate", "--csv", target]) == 2
    err = capsys.readouterr().err
    assert f"--csv {target!r}: no file can be written in the folder {read_only_folder}" in err
    assert main(["simulate", "--csv", str(read_only_file)]) == 2
    err = capsys.readouterr().err
    assert f"--csv {str(read_only_file)!r}: the file is read-only" in err, err


def test_default_save_place_is_checked_before_the_run(
    read_only_folder, monkeypatch, capsys
):
    monkeypatch.setattr(SIMULATE, "simulate", pytest.fail)
    monkeypatch.chdir(read_only_folder)
    assert main(["simulate"]) == 2
    err = capsys.readouterr().err
    assert "the trajectory 'double_pendulum_swing.npz': no file can be written" in err
    assert "-o names another file, --no-save skips saving" in err


@pytest.mark.parametrize(
    "case, args, vanish, fallback_in",
    [
        ("-o folder gone", ["-o", "out/run.npz", "--csv", "out/run.csv"], ["out"], "cwd"),
        ("-o folder and cwd gone", ["-o", "out/run.npz"], ["out", "cwd"], "temp"),
        ("--no-save, --csv folder gone", ["--no-save", "--csv", "out/run.csv"], ["out"], "cwd"),
        ("--csv folder gone, -o kept", ["-o", "run.npz", "--csv", "out/run.csv"], ["out"], None),
    ],
)
def test_failed_write_after_the_run_goes_to_a_fallback_file(
    case, args, vanish, fallback_in, tmp_path, monkeypatch, capsys
):
    """The folders are there when the outputs are checked and removed during the run."""
    for name in ("cwd", "cwd/out", "temp"):
        (tmp_path / name).mkdir()
    monkeypatch.chdir(tmp_path / "cwd")
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "temp"))
    run = SIMULATE.simulate

    def run_then_remove_folders(*a, **kw):
        traj = run(*a, **kw)
        for name in vanish:
            shutil.rmtree(tmp_path / "cwd" / name if name == "out" else tmp_path / name)
        return traj

    monkeypatch.setattr(SIMULATE, "simulate", run_then_remove_folders)
    assert main(["simulate", *SHORT, *args]) == 3
    captured = capsys.readouterr()
    failed = [line for line in captured.err.splitlines() if "could not write" in line]
    assert failed and all("out/run." in line for line in failed)
    if fallback_in is None:
        assert "saved to" not in captured.err
        assert od.Trajectory.load(tmp_path / "cwd" / "run.npz").complete
        return
    (saved,) = (tmp_path / fallback_in).glob("double_pendulum_swing-*.npz")
    assert f"the trajectory was saved to {saved} instead" in captured.err
    assert f"wrote {saved}" in captured.out and saved.with_suffix(".json").exists()
    traj = od.Trajectory.load(saved)
    assert traj.complete and traj.t[-1] == pytest.approx(0.1)


def test_ctrl_c_as_the_run_ends_waits_until_the_trajectory_is_saved(
    tmp_path, monkeypatch, capsys, ctrl_c_raises
):
    save = od.Trajectory.save

    def save_after_ctrl_c(self, path):
        signal.raise_signal(signal.SIGINT)
        return save(self, path)

    monkeypatch.setattr(od.Trajectory, "save", save_after_ctrl_c)
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", *SHORT, "--csv", "run.csv"]) == 130
    captured = capsys.readouterr()
    assert captured.err == "opendyn simulate: interrupted (Ctrl-C) while writing the outputs\n"
    assert "wrote double_pendulum_swing.npz" in captured.out
    assert files_in(tmp_path) == ["double_pendulum_swing.json", "double_pendulum_swing.npz"]
    assert od.Trajectory.load("double_pendulum_swing.npz").complete


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


def test_ctrl_c_swallowed_by_a_dependency_still_stops_the_program(ctrl_c_raises):
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


def test_ctrl_c_swallowed_while_a_kernel_loads_is_raised_again(ctrl_c_raises):
    """llvmlite prints "Exception ignored" for a KeyboardInterrupt raised in its callbacks while
    numba compiles or loads a kernel, and goes on: a sweep's Ctrl-C then was lost, and it ran
    to its end. Not swallowed, it stops the block as soon as it arrives."""
    steps = []
    with pytest.raises(KeyboardInterrupt):
        with unswallowed_interrupt():
            try:
                signal.raise_signal(signal.SIGINT)
            except KeyboardInterrupt:  # what a ctypes callback does with it
                steps.append("swallowed")
            steps.append("went on")
    assert steps == ["swallowed", "went on"]
    with pytest.raises(KeyboardInterrupt):
        with unswallowed_interrupt():
            signal.raise_signal(signal.SIGINT)
            steps.append("not swallowed")
    assert steps == ["swallowed", "went on"]


def run_interrupted_at(module, argv, tmp_path, signal_name="SIGINT"):
    """Run `module.main` with `argv` in a new Python, the signal (Ctrl-C unless named) arriving
    as soon as `module` (a module it imports) is imported; returns the finished process."""
    script = (
        "import signal, sys\n"
        "class CtrlC:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        f"        if name == {module!r}:\n"
        f"            signal.raise_signal(signal.{signal_name})\n"
        "sys.meta_path.insert(0, CtrlC())\n"
        f"sys.argv = {argv!r}\n"
        "import opendyn_launch\n"
        "sys.exit(opendyn_launch.main())\n"
    )
    path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
    # the robot read from its URDF (a Model kept on disk would not import the reader)
    env = dict(os.environ, PYTHONPATH=path, OPENDYN_MODEL_CACHE="0")
    return subprocess.run(
        [sys.executable, "-c", script],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=ctrl_c_default,
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


@pytest.mark.parametrize("signal_name, name, status", [("SIGINT", "Ctrl-C", 130),
                                                       ("SIGTERM", "SIGTERM", 143)])
def test_ctrl_c_or_sigterm_while_importing_opendyn_is_one_line(signal_name, name, status,
                                                               tmp_path):
    proc = run_interrupted_at("numba", ["opendyn", "simulate"], tmp_path, signal_name)
    assert proc.returncode == status, proc.stderr
    assert proc.stderr == f"opendyn: interrupted ({name}) while starting\n"


def signal_a_long_run(out, ctrl_c, signals):
    """Start `opendyn simulate ur5_falling` for an hour, writing `out`, with the child's Ctrl-C
    disposition `ctrl_c` (SIG_DFL or SIG_IGN); once it has run a second, send `signals`, each
    a (signal, seconds to wait after it) pair. Returns (returncode, stdout, stderr)."""
    # compiled ahead, so that the signal reaches the run and not numba compiling it
    assert main(["compile", "ur5_falling"]) == 0
    proc = subprocess.Popen(
        [sys.executable, "-m", "opendyn.cli", "simulate", "ur5_falling", "--duration", "3600"]
        + ["-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, ctrl_c),
    )
    watchdog = threading.Timer(300, proc.kill)
    watchdog.start()
    try:
        # the progress bar shows once the run has gone on for a second
        seen = ""
        while "simulating" not in seen and proc.poll() is None:
            seen += proc.stderr.read(1)
        for signum, wait in signals:
            proc.send_signal(signum)
            if wait:
                with pytest.raises(subprocess.TimeoutExpired):
                    proc.wait(timeout=wait)  # still running
        stdout, stderr = proc.communicate()
    finally:
        watchdog.cancel()
    return proc.returncode, stdout, seen + stderr


@pytest.mark.parametrize("signum, name", [(signal.SIGINT, "Ctrl-C"), (signal.SIGTERM, "SIGTERM")])
def test_ctrl_c_or_sigterm_during_the_run_writes_the_partial_record_and_exits_1(
    signum, name, tmp_path
):
    """The partial record goes to -o's partial name, long-partial.npz: a complete run's
    long.npz from before is kept as it was (the stopped run wrote over it)."""
    out = tmp_path / "long.npz"
    out.write_bytes(b"a complete run's record")
    status, stdout, stderr = signal_a_long_run(out, signal.SIG_DFL, [(signum, 0)])
    assert status == 1, stderr
    assert f"interrupted ({name}) at t = " in stderr and "STOPPED EARLY" in stdout
    assert out.read_bytes() == b"a complete run's record"
    assert f"wrote {tmp_path / 'long-partial.npz'}" in stdout
    traj = od.Trajectory.load(tmp_path / "long-partial.npz")
    assert not traj.complete and traj.message.startswith(f"interrupted ({name})")
    assert 0 < traj.t[-1] < 3600


def test_started_with_ctrl_c_ignored_a_run_ignores_it_and_stops_on_sigterm(tmp_path):
    """A background job of a script starts with SIGINT ignored: opendyn leaves it ignored, as
    Python does, and SIGTERM still stops the run and keeps its record."""
    out = tmp_path / "long.npz"
    signals = [(signal.SIGINT, 2.0), (signal.SIGTERM, 0)]
    status, _, stderr = signal_a_long_run(out, signal.SIG_IGN, signals)
    assert status == 1, stderr
    assert "interrupted (SIGTERM) at t = " in stderr and "Ctrl-C" not in stderr
    assert not od.Trajectory.load(tmp_path / "long-partial.npz").complete


def test_a_reader_that_closes_the_pipe_leaves_the_command_quiet_and_its_files_written(tmp_path):
    """`opendyn simulate ... | head -1`: the command carries on without its reader, writes its
    record and exits 0, with no "Broken pipe" and no traceback."""
    out = tmp_path / "run.npz"
    proc = subprocess.Popen(
        [sys.executable, "-m", "opendyn.cli", "simulate", "double_pendulum_swing"]
        + ["--duration", "0.1", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),  # each line reaches the pipe at once
    )
    assert proc.stdout.readline().startswith("scene")
    proc.stdout.close()  # what head does after its line
    stderr = proc.stderr.read()
    assert proc.wait(timeout=300) == 0, stderr
    assert "Broken pipe" not in stderr and "Traceback" not in stderr, stderr
    assert od.Trajectory.load(out).complete


# a file of the wrong kind handed to each reader: named with what it is, not with the parser's
# complaint about its first byte (nor numpy's advice to unpickle it)
PNG = b"\x89PNG\r\n\x1a\n" + bytes(range(256))


@pytest.mark.parametrize(
    "name, content, call, words",
    [
        ("scene.toml", PNG, lambda p: od.load_scene(p), "is a PNG image, not a scene file"),
        ("scene.toml", b"\x00\x01garbage", lambda p: od.load_scene(p),
         "is binary data, not a scene file"),
        ("robot.urdf", PNG, lambda p: od.load_urdf(p), "is a PNG image, not a URDF"),
        ("robot.urdf", b"PK\x03\x04" + bytes(64), lambda p: od.load_urdf(p),
         "is a ZIP archive, not a URDF"),
        ("run.npz", PNG, lambda p: od.Trajectory.load(p),
         "is a PNG image, not a trajectory saved by opendyn"),
        ("run.npz", b"t,q\n0,1\n", lambda p: od.Trajectory.load(p),
         "is a text file, not a trajectory saved by opendyn"),
    ],
)  # fmt: skip
def test_a_file_of_another_kind_is_named_with_what_it_is(tmp_path, name, content, call, words):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(ValueError) as refused:
        call(path)
    message = str(refused.value)
    assert str(path) in message and words in message
    assert "allow_pickle" not in message and "codec" not in message


def test_an_npz_of_other_arrays_names_the_trajectory_arrays_it_lacks(tmp_path):
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(ValueError, match="an .npz archive without the arrays of a trajectory") as e:
        od.Trajectory.load(tmp_path / "other.npz")
    assert "provenance" in str(e.value) and "joint_names" in str(e.value)
    np.save(tmp_path / "array.npy", np.zeros(3))
    with pytest.raises(ValueError, match="is a numpy array"):
        od.Trajectory.load(tmp_path / "array.npy")


def test_a_save_whose_record_name_is_too_long_writes_neither_file(tmp_path):
    most = os.pathconf(tmp_path, "PC_NAME_MAX")
    npz = tmp_path / ("t" * (most - 4) + ".npz")  # fits; its .json does not
    with pytest.raises(OSError) as refused:
        small_trajectory().save(npz)
    assert refused.value.errno == errno.ENAMETOOLONG
    assert refused.value.filename == str(npz.with_suffix(".json"))
    assert f"its name is {most + 1} bytes" in str(refused.value) and files_in(tmp_path) == []
    # a name at the limit itself is written (its temporary file takes a shorter name)
    at_limit = tmp_path / ("u" * (most - 4) + ".csv")
    small_trajectory().to_csv(at_limit)
    assert files_in(tmp_path) == [at_limit.name]


def test_a_save_into_a_missing_folder_or_onto_a_folder_names_the_path_given(tmp_path):
    """Trajectory.save into a missing folder named its hidden temporary file; onto an existing
    folder it wrote FOLDER.npz beside the folder."""
    traj = small_trajectory()
    with pytest.raises(FileNotFoundError) as missing:
        traj.save(tmp_path / "missing" / "run.npz")
    assert missing.value.filename == str(tmp_path / "missing" / "run.npz")
    folder = tmp_path / "runs"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match="is a folder; name the .npz to write in it"):
        traj.save(folder)
    with pytest.raises(IsADirectoryError, match="is a folder, not a file"):
        traj.to_csv(folder)
    assert files_in(tmp_path) == ["runs"] and files_in(folder) == []


def test_a_record_changed_after_it_was_saved_is_refused_naming_the_array(tmp_path):
    """q cut to one column loaded, saved again, and failed only in plot (IndexError)."""
    small_trajectory().save(tmp_path / "run.npz")
    arrays = dict(np.load(tmp_path / "run.npz"))
    arrays["qd"] = np.zeros((5, 1))
    np.savez(tmp_path / "changed.npz", **arrays)
    with pytest.raises(ValueError, match=r"changed\.npz: its array qd has shape \(5, 1\), where "
                       r"\(2, 1\) fits the record \(2 samples, 1 coordinates q, 1 velocities\): "
                       r"the file was changed after opendyn saved it"):
        od.Trajectory.load(tmp_path / "changed.npz")


def test_a_contact_table_with_too_few_times_is_refused_naming_both_lengths(tmp_path):
    """Rows of samples 0 and 2 need three times: two are a ValueError naming t's length and
    the samples', not numpy's IndexError, and nothing is written."""
    from opendyn.sim.contacts import ContactTable

    table = ContactTable(
        sample=np.array([0, 2]), pair=np.array([0, 0]), point=np.zeros((2, 3)),
        normal=np.zeros((2, 3)), force=np.zeros((2, 3)), depth=np.ones(2),
        pair_names=(("a", "ground"),),
    )
    for t in ([0.0, 0.1], np.zeros((3, 1))):
        with pytest.raises(ValueError) as e:
            table.to_csv(tmp_path / "c.csv", t=t)
        text = str(e.value)
        assert "t of shape" in text and "for the table's 3 samples" in text
        assert not (tmp_path / "c.csv").exists()
    written = table.to_csv(tmp_path / "c.csv", t=[0.0, 0.1, 0.2]).read_text().splitlines()
    assert [line.split(",")[1] for line in written[1:]] == ["0.0", "0.2"]


def ball(**run):
    """The shipped ball_drop scene (a 10 ms bounce on a 1e5 N/m spring ground) with run keys
    changed."""
    scene = od.load_scene("ball_drop")
    return scene.replace_run(**run)


@pytest.mark.parametrize("integrator", ["dopri5", "rk4"])
def test_ctrl_c_is_answered_after_a_handful_of_steps_however_long_the_chunk(
    integrator, monkeypatch
):
    """Ctrl-C was checked between chunks of simulated time (DOPRI5) or after a first chunk of
    64 steps: a stiff contact whose steps became tiny (2.9 million for 0.01 s) took 140 s to
    stop, a 200-box scene 7 s. Each chunk is now also a budget of steps, FIRST_CHUNK (a few)
    before the rate is known: a Ctrl-C that came before the run stops it after that many
    trial steps, though the first span is the whole run (output_dt = duration)."""
    from opendyn.sim import driver

    monkeypatch.setattr(driver.Interrupt, "requested", True)  # as if Ctrl-C came at once
    traj = od.simulate(ball(duration=0.5, output_dt=0.5, integrator=integrator, rtol=1e-10),
                       raise_on_failure=False)
    assert not traj.complete and traj.message.startswith("interrupted (Ctrl-C) at t = ")
    assert 0 < traj.stats["steps"] + traj.stats["rejected_steps"] <= driver.FIRST_CHUNK <= 8
    # od.Simulator's steps, likewise
    sim = od.Simulator(ball(integrator=integrator, rtol=1e-10))
    with pytest.raises(KeyboardInterrupt, match="interrupted"):
        sim.step(duration=0.5)
    assert 0 < sim.t < 0.5 and len(sim.trajectory().t) <= driver.FIRST_CHUNK + 1
