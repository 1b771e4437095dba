"""Sweeps on a Dask LocalCluster of 2 worker processes: the rows equal the same runs done one by
one with simulate (bit for bit), a seeded Monte Carlo sweep is reproducible, a failing run is a
failed row, a worker killed mid-sweep loses and duplicates nothing, and a stopped sweep resumes
where it stopped."""

from __future__ import annotations

import os
import pathlib
import re
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pyarrow.parquet as pq  # the test extra installs the sweep extra
import pytest
from conftest import ctrl_c_default
from plotcheck import assert_lines_shown, read_png, saved_figures

import opendyn as od
from opendyn.errors import SweepError
from opendyn.sim.scene import thaw
from opendyn.sweep.specs import Axis, combinations, parse_axis

ROBOTS = os.path.join(os.path.dirname(__file__), "..", "robots")


@pytest.fixture(scope="module")
def client():
    import logging

    from dask.distributed import Client, LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
        silence_logs=logging.ERROR,
    ) as cluster, Client(cluster) as c:
        yield c


def limits_scene(duration=0.5):
    """The planar 3R arm against its stiff limits: cheap runs that fail for large steps."""
    return od.load_scene("planar_3r_limits").replace_run(duration=duration)


def one_by_one(scene, values):
    """The run's scene built by hand: the scene file's settings with the values written in."""
    settings = thaw(scene.settings)
    for key, value in values.items():
        *path, last = key.split(".")
        table = settings
        for part in path:
            table = table.setdefault(part, {})
        table[last] = value
    return od.simulate(od.scene_from_dict(settings, base_dir=ROBOTS), raise_on_failure=False)


# --- specs and combinations ---------------------------------------------------------------------


def test_specs_parse_to_their_values():
    assert parse_axis("k", "1,2.5,rk4,true").values == (1.0, 2.5, "rk4", True)
    assert parse_axis("k", "0:1:5").values == tuple(np.linspace(0, 1, 5))
    log = parse_axis("k", "log:1e-4:1e-2:3")
    assert log.log and np.allclose(log.values, [1e-4, 1e-3, 1e-2], rtol=1e-14)
    assert parse_axis("k", "uniform:-1:2").distribution == ("uniform", -1.0, 2.0)
    assert parse_axis("k", "normal:0:0.1").distribution == ("normal", 0.0, 0.1)
    assert parse_axis("k", [1, np.float64(2.0)]).values == (1, 2.0)


@pytest.mark.parametrize(
    "spec, words",
    [
        ("0:1:2.5", "whole number"),
        ("0:1:0", "whole number"),
        ("log:0:1:3", "lo > 0"),
        ("uniform:1:1", "lo < hi"),
        ("normal:0:-1", "sigma > 0"),
        ("normal:0", "expected normal:mu:sigma"),
        ("uniform:a:1", "'a' is not a finite number"),
        ("1,,2", "empty value"),
        ("beta:1:2:3:4", "expected a list"),
        ({"a": 1}, "expected a list"),
    ],
)
def test_bad_specs_name_the_key_and_the_problem(spec, words):
    with pytest.raises(SweepError, match="vary k") as e:
        parse_axis("k", spec)
    assert words in str(e.value)


def test_grids_multiply_with_the_last_key_fastest():
    runs = combinations([Axis("a", "", values=(1, 2)), Axis("b", "", values=("x", "y", "z"))])
    assert [(r["a"], r["b"]) for r in runs] == [
        (1, "x"), (1, "y"), (1, "z"), (2, "x"), (2, "y"), (2, "z")
    ]


def test_samples_draw_each_key_from_one_seeded_generator():
    axes = [parse_axis("a", "uniform:-1:1"), parse_axis("b", "normal:2:0.5"),
            parse_axis("c", "1,2,3")]
    runs = combinations(axes, samples=50, seed=7)
    rng = np.random.default_rng(7)  # the documented order: one key after another
    assert [r["a"] for r in runs] == list(rng.uniform(-1, 1, 50))
    assert [r["b"] for r in runs] == list(rng.normal(2, 0.5, 50))
    assert [r["c"] for r in runs] == [(1.0, 2.0, 3.0)[i] for i in rng.integers(3, size=50)]
    assert combinations(axes, samples=50, seed=7) == runs
    assert combinations(axes, samples=50, seed=8) != runs


def test_a_distribution_needs_samples():
    with pytest.raises(SweepError, match="is a distribution: give samples=N"):
        combinations([parse_axis("a", "uniform:0:1")])


# --- every run's scene is read before anything runs ---------------------------------------------


@pytest.mark.parametrize(
    "vary, words",
    [
        ({"control.kpp": "1,2"}, "unknown key"),  # the reader lists the valid keys
        ({"initial.q.joint9": "0,1"}, "joints: joint1, joint2, joint3"),
        ({"effects.limits.stiffness": "1e5,-1"}, "run 1 (effects.limits.stiffness = -1.0)"),
        ({"run.integrator": "rk4,rk5"}, "'rk5' is not one of"),
        ({"run.dt": "0.001,0.003"}, "run.output_dt"),
        ({"run.duration.x": "1"}, "run.duration is 0.5 in the scene, not a table"),
        ({"effects.contact.pairs.0.friction": "0.1"},
         "the scene gives no effects.contact.pairs, so it has no entry 0"),
    ],
)
def test_a_bad_key_or_value_is_refused_before_anything_runs(vary, words, tmp_path):
    with pytest.raises(SweepError) as e:
        od.sweep(limits_scene(), vary, parquet=tmp_path / "r.parquet", workers=1)
    assert words in str(e.value)
    assert not (tmp_path / "r.parquet").exists()


def test_an_unknown_key_lists_the_valid_keys(tmp_path):
    with pytest.raises(SweepError) as e:
        od.sweep(limits_scene(), {"run.dtt": "0.001"}, workers=1)
    assert "valid keys in [run]: duration, integrator, dt" in str(e.value)


# --- the done-when tests --------------------------------------------------------------------------


def test_rows_equal_the_runs_done_one_by_one(client, tmp_path):
    scene = limits_scene()
    vary = {"effects.limits.stiffness": "1e3,1e7", "effects.limits.damping": "5,50",
            "run.dt": "0.001,0.005", "run.integrator": "rk4"}
    table = od.sweep(scene, vary, client=client, parquet=tmp_path / "r.parquet",
                     trajectories=tmp_path / "runs", chunk_size=3)
    rows = table.to_pylist()
    assert [r["run"] for r in rows] == list(range(8))
    assert pq.read_table(tmp_path / "r.parquet").to_pylist() == rows
    for row in rows:
        values = {key: row[key] for key in vary}
        traj = one_by_one(scene, values)
        assert row["status"] == ("complete" if traj.complete else "failed")
        assert row["message"] == traj.message
        assert row["q_final"] == traj.q[-1].tolist()  # bit for bit
        assert row["qd_final"] == traj.qd[-1].tolist()
        assert row["energy_error_max"] == np.abs(traj.energy_error).max()
        assert row["steps"] == traj.stats["steps"]
        saved = od.Trajectory.load(tmp_path / "runs" / f"run-{row['run']:06d}.npz")
        assert np.array_equal(saved.q, traj.q) and np.array_equal(saved.qd, traj.qd)
    # RK4 goes unstable against limits of 1e7 N m/rad, and at 5 ms against the damping of 50
    failed = [r["run"] for r in rows if r["status"] == "failed"]
    assert failed == [3, 4, 5, 6, 7]
    assert all("exceeded max_speed" in rows[run]["message"] for run in failed)


def test_a_payload_sweep_loads_the_robot_once_and_adds_each_payload(client):
    scene = od.load_scene("panda_computed_torque").replace_run(duration=0.2)
    settings = thaw(scene.settings)
    settings["robot"]["payload"] = {"frame": "panda_hand", "mass": 0.0, "com": [0, 0, 0.1]}
    scene = od.scene_from_dict(settings, source=scene.source, base_dir=ROBOTS)
    table = od.sweep(scene, {"robot.payload.mass": "0,1.5,3"}, client=client)
    for row in table.to_pylist():
        traj = one_by_one(scene, {"robot.payload.mass": row["robot.payload.mass"]})
        assert row["q_final"] == traj.q[-1].tolist()
        assert row["energy_error_max"] == np.abs(traj.energy_error).max()
    finals = table.column("q_final").to_pylist()
    assert finals[0] != finals[1] != finals[2]  # each run carried its own payload


def test_a_sweep_varies_an_objects_entry(client):
    """Two boxes dropped from the heights each run gives the first: in free fall for 0.3 s,
    z = z0 - g t^2 / 2, whatever the other box does."""
    box = {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0}
    scene = od.scene_from_dict({
        "objects": [{"name": "a", "position": [0.0, 0.0, 1.0], **box},
                    {"name": "b", "position": [1.0, 0.0, 2.0], **box}],
        "run": {"duration": 0.3, "integrator": "rk4", "dt": 0.001},
        "effects": {"gravity": True},
    })
    table = od.sweep(scene, {"objects.0.position.2": "1,2.5"}, client=client)
    rows = table.to_pylist()
    assert [r["status"] for r in rows] == ["complete"] * 2
    drop = 0.5 * 9.81 * 0.3**2
    for row, z0 in zip(rows, (1.0, 2.5)):
        assert row["objects.0.position.2"] == z0
        np.testing.assert_allclose(row["q_final"][2], z0 - drop, atol=1e-12)
        np.testing.assert_allclose(row["q_final"][9], 2.0 - drop, atol=1e-12)


def test_a_seeded_monte_carlo_sweep_is_reproducible(client):
    scene = od.load_scene("double_pendulum_swing").replace_run(duration=0.2)
    vary = {"initial.q.shoulder": "uniform:-1:1", "initial.qd.elbow": "normal:0:0.5"}
    first = od.sweep(scene, vary, samples=12, seed=3, client=client)
    again = od.sweep(scene, vary, samples=12, seed=3, client=client)
    other = od.sweep(scene, vary, samples=12, seed=4, client=client)
    drop = ["wall_s"]
    assert first.drop(drop).equals(again.drop(drop))
    assert first.column("initial.q.shoulder").to_pylist() == list(
        np.random.default_rng(3).uniform(-1, 1, 12)
    )
    assert first.column("q_final").to_pylist() != other.column("q_final").to_pylist()


def test_a_run_that_raises_is_a_failed_row(client):
    # simulate refuses a start outside a limit that the scene enforces: a failed row, not a crash
    table = od.sweep(limits_scene(duration=0.1), {"initial.q.joint1": "0,3.5"}, client=client)
    first, second = table.to_pylist()
    assert first["status"] == "complete" and first["message"] == ""
    assert second["status"] == "failed" and "initial.q.joint1" in second["message"]
    assert second["q_final"] is None and second["steps"] is None


def test_a_killed_worker_loses_and_duplicates_no_row(tmp_path):
    import logging

    from dask.distributed import Client, LocalCluster

    scene = od.load_scene("double_pendulum_swing").replace_run(duration=2.0, dt=0.0002)
    vary = {"initial.q.shoulder": "0:1:24"}
    parquet = tmp_path / "r.parquet"
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
        silence_logs=logging.CRITICAL,
    ) as cluster, Client(cluster) as c:
        result = {}
        thread = threading.Thread(
            target=lambda: result.update(table=od.sweep(
                scene, vary, client=c, parquet=parquet, chunk_size=2)),
        )
        thread.start()
        parts = tmp_path / "r.parquet.parts"
        deadline = time.time() + 120
        while not (parts.is_dir() and any(parts.iterdir())) and time.time() < deadline:
            time.sleep(0.05)
        busy = [w for w, keys in c.processing().items() if keys]
        assert busy, "no worker was running a chunk"
        victim = busy[0]
        pid = c.run(os.getpid, workers=[victim])[victim]
        os.kill(pid, signal.SIGKILL)  # the worker dies mid-chunk
        thread.join(300)
        assert not thread.is_alive()
    runs = result["table"].column("run").to_pylist()
    assert runs == list(range(24))  # each run once
    assert set(result["table"].column("status").to_pylist()) == {"complete"}
    assert pq.read_table(parquet).num_rows == 24 and not parts.exists()


def test_a_sweep_resumes_and_skips_finished_runs(client, tmp_path):
    scene = limits_scene(duration=0.2)
    vary = {"effects.limits.stiffness": "1e3:1e5:6"}
    parquet = tmp_path / "r.parquet"
    full = od.sweep(scene, vary, client=client, parquet=parquet)
    # a stopped sweep: runs 0, 2, 3 in the file, run 5 in a part (a client killed before the
    # merge), runs 1 and 4 missing
    pq.write_table(full.filter(np.isin(np.arange(6), [0, 2, 3])), parquet)
    parts = tmp_path / "r.parquet.parts"
    parts.mkdir()
    pq.write_table(full.filter(np.arange(6) == 5), parts / "part-000000005.parquet")
    resumed = od.sweep(scene, vary, client=client, parquet=parquet)
    assert resumed.column("run").to_pylist() == list(range(6))
    wall = resumed.column("wall_s").to_pylist()
    before = full.column("wall_s").to_pylist()
    # the finished rows were kept as they were (a rerun would take another wall time)
    assert [wall[i] for i in (0, 2, 3, 5)] == [before[i] for i in (0, 2, 3, 5)]
    assert resumed.drop(["wall_s"]).equals(full.drop(["wall_s"]))
    assert not parts.exists()


def test_another_sweeps_results_file_is_refused(client, tmp_path):
    scene = limits_scene(duration=0.1)
    parquet = tmp_path / "r.parquet"
    od.sweep(scene, {"effects.limits.stiffness": "1e3,1e4"}, client=client, parquet=parquet)
    with pytest.raises(SweepError, match="holds another sweep \\(its vary differs\\)"):
        od.sweep(scene, {"effects.limits.damping": "1,2"}, client=client, parquet=parquet)
    (tmp_path / "x.parquet").write_text("not parquet")
    with pytest.raises(SweepError, match="not a Parquet file"):
        od.sweep(scene, {"effects.limits.damping": "1,2"}, client=client,
                 parquet=tmp_path / "x.parquet")


def test_ctrl_c_keeps_the_finished_rows_and_the_same_command_resumes(tmp_path):
    command = [
        sys.executable, "-m", "opendyn.cli", "sweep", "double_pendulum_swing",
        "--vary", "initial.q.shoulder=0:1:40", "--vary", "run.dt=0.0002", "--workers", "2",
        "--chunk", "2", "-o", "r.parquet",
    ]
    # in a session of its own, so that Ctrl-C goes to its whole process group, as a terminal
    # sends it: the client and the workers
    proc = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=ctrl_c_default,
                            start_new_session=True)
    parts = tmp_path / "r.parquet.parts"
    deadline = time.time() + 120
    # finished parts only: a part being written is a temporary file beside them until renamed
    while len(list(parts.glob("part-*.parquet"))) < 2 and time.time() < deadline:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "the same command resumes" in err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err  # nor a worker's
    kept = pq.read_table(tmp_path / "r.parquet").column("run").to_pylist()
    assert 4 <= len(kept) < 40 and len(set(kept)) == len(kept)
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    table = pq.read_table(tmp_path / "r.parquet")
    assert table.column("run").to_pylist() == list(range(40))


# --- metrics and plots ---------------------------------------------------------------------------


def test_tracking_error_follows_the_closed_loop_and_grows_with_friction(client):
    """Computed torque with the model's own dynamics leaves the error dynamics
    e'' + kd e' + kp e = 0; the scene's reference starts moving (q_r'(0) = A w) from rest, so
    e(0) = 0, e'(0) = -A w, and with kp = 400, kd = 40 (a double root at -20):
    e(t) = -A w t exp(-20 t). Coulomb friction, which the controller does not model, adds to it."""
    scene = od.load_scene("panda_computed_torque").replace_run(duration=0.3)
    scene = scene.without("damping")
    table = od.sweep(scene, {"effects.friction.coefficients": "0,0.5,2"}, client=client)
    rms = table.column("tracking_rms").to_pylist()
    c = scene.control
    t = np.linspace(0.0, 0.3, 31)[:, None]
    w = 2 * np.pi * c.frequency
    e = -c.amplitude * w * t * np.exp(-20.0 * t)
    assert rms[0] == pytest.approx(np.sqrt(np.mean(e**2)), rel=1e-6)
    assert rms[0] < rms[1] < rms[2]
    traj = one_by_one(scene, {"effects.friction.coefficients": 2.0})
    q_r = c.offset + c.amplitude * np.sin(2 * np.pi * c.frequency * traj.t[:, None] + c.phase)
    assert rms[2] == pytest.approx(np.sqrt(np.mean((traj.q - q_r) ** 2)), rel=1e-12)


def test_plots_draw_a_line_and_a_heat_map(client, tmp_path):
    """The line is the table's metric against the stiffness (log axis), in order; the heat map
    has one panel per integrator whose cells are the metric at (stiffness, dt), empty where
    the run failed; and each PNG is its figure, drawn (its line's colour shown)."""
    scene = limits_scene(duration=0.2)
    line = od.sweep(scene, {"effects.limits.stiffness": "log:1e3:1e6:4"}, client=client)
    grid = od.sweep(scene, {"effects.limits.stiffness": "log:1e3:1e6:3", "run.dt": "0.001,0.005",
                            "run.integrator": "rk4,implicit_euler"}, client=client)
    with saved_figures() as saved:
        od.plot_sweep(line, tmp_path / "line.png")
        od.plot_sweep(grid, tmp_path / "map.png", metric="energy_error_max")
    (line_fig, line_dpi), (map_fig, map_dpi) = saved

    (ax,) = line_fig.axes
    drawn = ax.lines[0]
    rows = line.to_pydict()
    metric = ax.get_ylabel()
    order = np.argsort(rows["effects.limits.stiffness"])
    np.testing.assert_allclose(drawn.get_xdata(), [1e3, 1e4, 1e5, 1e6])
    np.testing.assert_array_equal(drawn.get_ydata(), np.array(rows[metric], float)[order])
    assert ax.get_xscale() == "log" and ax.get_xlabel() == "effects.limits.stiffness"
    image = read_png(tmp_path / "line.png", line_fig, line_dpi)
    assert_lines_shown(image, [drawn])

    rows = grid.to_pydict()
    panels = [a for a in map_fig.axes if a.get_xlabel() == "effects.limits.stiffness"]
    assert len(panels) == 2 and len(map_fig.axes) == 3  # and the colour bar
    for panel in panels:
        integrator = panel.get_title().rpartition(" = ")[2]
        expected = np.full((2, 3), np.nan)  # rows: dt; columns: stiffness
        for k in range(grid.num_rows):
            if rows["run.integrator"][k] == integrator and rows["status"][k] == "complete":
                i = [0.001, 0.005].index(rows["run.dt"][k])
                j = int(np.argmin(np.abs(np.log10(rows["effects.limits.stiffness"][k]) - [3, 4.5, 6])))
                expected[i, j] = rows["energy_error_max"][k]
        cells = np.ma.filled(panel.collections[0].get_array(), np.nan).reshape(2, 3)
        np.testing.assert_array_equal(cells, expected)
    image = read_png(tmp_path / "map.png", map_fig, map_dpi)
    assert len(np.unique(np.round(image * 255).reshape(-1, 3), axis=0)) > 50  # a colour map
    with pytest.raises(ValueError, match="not a metric of this sweep"):
        od.plot_sweep(grid, tmp_path / "x.png", metric="tracking_rms")


def test_the_core_imports_without_the_sweep_extra():
    code = (
        "import sys\n"
        "for m in ('dask', 'distributed', 'pyarrow'): sys.modules[m] = None\n"
        "import opendyn as od\n"
        "od.simulate(od.load_scene('double_pendulum_swing').replace_run(duration=0.01))\n"
        "try:\n"
        "    od.sweep('double_pendulum_swing', {'run.dt': '0.001'})\n"
        "except ImportError as e:\n"
        "    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "pip install 'opendyn[sweep]'" in out.stdout


def test_the_command_refuses_bad_arguments_in_one_line(tmp_path, monkeypatch, capsys):
    from opendyn.cli.main import main

    monkeypatch.chdir(tmp_path)  # where the default results file would go

    for argv, words in [
        (["--vary", "control.kp"], "expected KEY=SPEC"),
        (["--vary", "run.dt=1", "--vary", "run.dt=2"], "given twice"),
        (["--vary", "run.dt=0.001", "-o", str(tmp_path / "no" / "r.parquet")], "does not exist"),
        (["--vary", "run.dt=0.001,0.002", "--vary", "run.duration=1,2", "--vary",
          "initial.q.joint1=0,1", "--plot", str(tmp_path / "p.png")], "one or two varied"),
    ]:
        assert main(["sweep", "planar_3r_limits", *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, err


def test_the_command_runs_on_an_existing_scheduler(client, tmp_path, monkeypatch, capsys):
    from opendyn.cli.main import main

    monkeypatch.chdir(tmp_path)
    argv = ["sweep", "planar_3r_limits", "--vary", "effects.limits.stiffness=1e3,1e4",
            "--vary", "run.duration=0.1", "--scheduler", client.scheduler.address, "-o", "r.parquet"]
    assert main(argv) == 0, capsys.readouterr().err
    table = pq.read_table(tmp_path / "r.parquet")
    assert table.column("status").to_pylist() == ["complete", "complete"]
    assert "2 runs (2 complete, 0 failed)" in capsys.readouterr().out
    unreachable = ["sweep", "planar_3r_limits", "--vary", "run.duration=0.1", "--scheduler",
                   "tcp://127.0.0.1:9"]
    assert main(unreachable) == 2
    assert "--scheduler tcp://127.0.0.1:9: cannot connect" in capsys.readouterr().err


def test_outputs_that_cannot_be_written_are_refused_before_anything_runs(
    tmp_path, read_only_folder, read_only_file
):
    """od.sweep checks its results file and trajectories' folder first, as the command does
    (it ran chunks and then failed, dropping them or naming a temporary file)."""
    scene = limits_scene(duration=0.1)
    vary = {"effects.limits.stiffness": "1e3"}
    a_file = tmp_path / "a-file"
    a_file.write_text("")
    cases = [
        (dict(parquet=tmp_path), "parquet", "is a folder, not a file"),
        (dict(parquet=tmp_path / "missing" / "r.parquet"), "parquet", "does not exist"),
        (dict(trajectories=a_file), "trajectories", "is a file, not a folder"),
        (dict(parquet=read_only_folder / "r.parquet"), "parquet", "no file can be written"),
        (dict(parquet=read_only_file), "parquet", "the file is read-only"),
        (dict(trajectories=read_only_folder), "trajectories", "no file can be written"),
    ]
    for kwargs, argument, words in cases:
        with pytest.raises(SweepError) as refused:
            od.sweep(scene, vary, **kwargs)
        assert str(refused.value).startswith(argument) and words in str(refused.value)


def test_a_trajectories_folder_of_another_sweep_is_refused(client, tmp_path):
    """Two sweeps, one --trajectories folder: the second overwrote the first's run files and
    left its others. Now the folder is marked by its sweep, and another sweep is refused; the
    same sweep again (a resume) is not."""
    scene = limits_scene(duration=0.1)
    runs = tmp_path / "runs"
    od.sweep(scene, {"effects.limits.stiffness": "1e3,1e4"}, client=client, trajectories=runs)
    assert sorted(p.name for p in runs.iterdir()) == [
        "run-000000.json", "run-000000.npz", "run-000001.json", "run-000001.npz", "sweep.json"
    ]
    od.sweep(scene, {"effects.limits.stiffness": "1e3,1e4"}, client=client, trajectories=runs)
    with pytest.raises(SweepError, match="holds the runs of another sweep"):
        od.sweep(scene, {"effects.limits.damping": "1,2"}, client=client, trajectories=runs)
    unmarked = tmp_path / "unmarked"
    unmarked.mkdir()
    (unmarked / "run-000000.npz").write_bytes(b"")
    with pytest.raises(SweepError, match="run files of a sweep that did not mark it"):
        od.sweep(scene, {"effects.limits.damping": "1,2"}, client=client, trajectories=unmarked)


def test_a_changed_robot_is_another_sweep_not_a_resume(client, tmp_path):
    """The fingerprint covers the robot: a link's mass edited between a stopped sweep and its
    resume made the table mix two robots; now the resume is refused, naming the robot."""
    import shutil

    folder = tmp_path / "robot"
    folder.mkdir()
    shutil.copy(os.path.join(ROBOTS, "planar_3r.urdf"), folder / "planar_3r.urdf")
    shutil.copy(os.path.join(ROBOTS, "planar_3r_limits.toml"), folder / "scene.toml")
    table = tmp_path / "r.parquet"
    vary = {"effects.limits.stiffness": "1e3,1e4"}
    scene = od.load_scene(folder / "scene.toml").replace_run(duration=0.1)
    od.sweep(scene, vary, client=client, parquet=table)
    urdf = (folder / "planar_3r.urdf").read_text()
    first_mass = re.search(r'<mass value="([^"]+)"', urdf)
    edited = urdf.replace(first_mass.group(0), f'<mass value="{float(first_mass.group(1)) * 2}"', 1)
    (folder / "planar_3r.urdf").write_text(edited)
    changed = od.load_scene(folder / "scene.toml").replace_run(duration=0.1)
    with pytest.raises(SweepError, match=r"another sweep \(its robot differ"):
        od.sweep(changed, vary, client=client, parquet=table)


def test_a_swept_integrator_that_simulate_refuses_is_a_failed_row(client):
    """Semi-implicit Euler takes no constraints: among the swept integrators it refused the
    whole sweep, where the sweeps guide says a run simulate refuses is a failed row."""
    scene = od.load_scene("four_bar").replace_run(duration=0.05)
    rows = od.sweep(scene, {"run.integrator": "rk4,semi_implicit_euler"}, client=client).to_pylist()
    assert [r["status"] for r in rows] == ["complete", "failed"]
    assert "semi_implicit_euler" in rows[1]["message"] and "constraints" in rows[1]["message"]


def _service(answer):
    """A TCP service on localhost that sends `answer` (bytes) to each connection, or nothing
    (None), and keeps it open: (address, stop)."""
    server = socket.create_server(("127.0.0.1", 0))
    held = []

    def serve():
        while True:
            try:
                peer, _ = server.accept()
            except OSError:
                return
            held.append(peer)
            if answer is not None:
                peer.sendall(answer)

    threading.Thread(target=serve, daemon=True).start()

    def stop():
        server.close()
        for peer in held:
            peer.close()

    return f"tcp://127.0.0.1:{server.getsockname()[1]}", stop


def _bounded_waits(monkeypatch, timeout):
    """The timeouts (s) of every connection to a scheduler and every read from it, as a list
    that fills as they are made; a connection or a read that could wait longer than `timeout`
    (or for ever: None) fails at once instead of waiting."""
    connect = socket.create_connection
    waits = []

    def bounded(wait):
        waits.append(wait)
        assert wait is not None and wait <= timeout, f"a wait of {wait} s, past {timeout} s"

    class Peer:
        def __init__(self, sock):
            self.sock = sock

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.sock.close()

        def settimeout(self, wait):
            self.sock.settimeout(wait)

        def recv(self, size):
            bounded(self.sock.gettimeout())
            return self.sock.recv(size)

    def create_connection(address, timeout=None, *args, **kwargs):
        bounded(timeout)
        return Peer(connect(address, timeout, *args, **kwargs))

    monkeypatch.setattr(socket, "create_connection", create_connection)
    return waits


@pytest.mark.parametrize(
    "answer, words",
    [
        (b"SSH-2.0-OpenSSH_9.6\r\n", "is not a Dask scheduler (it opened with b'SSH-2.0-'"),
        (None, "no answer within 1 s"),
    ],
    ids=["ssh banner", "silent"],
)
def test_a_scheduler_address_that_is_not_dask_is_one_line_within_the_timeout(
    answer, words, tmp_path, monkeypatch, capsys
):
    from opendyn.cli.main import main
    from opendyn.sweep import cluster

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(cluster, "SCHEDULER_TIMEOUT", 1.0)
    waits = _bounded_waits(monkeypatch, 1.0)
    address, stop = _service(answer)
    try:
        argv = ["sweep", "planar_3r_limits", "--vary", "run.duration=0.1", "--scheduler", address]
        assert main(argv) == 2
    finally:
        stop()
    # it connected and read, every wait bounded by the timeout (a read without one would
    # wait on the silent service for ever)
    assert len(waits) >= 2 and all(w is not None and 0 < w <= 1.0 for w in waits), waits
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--scheduler {address}: " in err and words in err, err
    assert not (tmp_path / "planar_3r_limits-sweep.parquet").exists()


def _disk_full_after(calls):
    """A stand-in for a writer that fills the disk: it lets `calls` writes through, then every
    later one raises ENOSPC as a full file system does."""
    import errno

    count = {"n": 0}

    def check():
        count["n"] += 1
        if count["n"] > calls:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    return check


def test_a_full_disk_names_the_file_keeps_the_rows_and_the_sweep_resumes(
    client, tmp_path, monkeypatch
):
    """A full disk while a sweep saved a trajectory or a part of its table was a bare
    "[Errno 28] No space left on device": no file named, nothing said of the rows. Now it is a
    SweepWriteError naming the file, the rows so far are in it and on disk, and the same sweep
    resumes to the same table."""
    from opendyn.sim.trajectory import Trajectory
    from opendyn.sweep import results as results_module

    scene = limits_scene(duration=0.1)
    vary = {"effects.limits.stiffness": "1e3:1e5:6"}
    full = od.sweep(scene, vary, client=client)
    parquet, runs = tmp_path / "r.parquet", tmp_path / "runs"
    # the disk fills at the third trajectory
    full_disk = _disk_full_after(2)
    save = Trajectory.save
    monkeypatch.setattr(Trajectory, "save", lambda self, path: (full_disk(), save(self, path))[1])
    with pytest.raises(od.SweepWriteError) as stopped:
        od.sweep(scene, vary, client=client, parquet=parquet, trajectories=runs, chunk_size=1)
    e = stopped.value
    assert isinstance(e, OSError) and e.strerror == os.strerror(28)
    assert re.fullmatch(re.escape(str(runs)) + r"/run-00000\d\.npz", e.filename)
    assert str(e).startswith(e.filename + ": No space left on device; the sweep stopped there")
    assert "the 2 rows so far are kept in" in str(e) and "the same sweep resumes" in str(e)
    on_disk = pq.read_table(tmp_path / "r.parquet.parts").column("run").to_pylist()
    assert sorted(on_disk) == e.table.column("run").to_pylist() and len(on_disk) == 2
    monkeypatch.setattr(Trajectory, "save", save)
    # the final table cannot be written: its parts stay, and it resumes again
    full_disk = _disk_full_after(0)
    atomic_write = results_module.atomic_write

    def table_write(path):
        if pathlib.Path(path) == parquet:
            full_disk()
        return atomic_write(path)

    monkeypatch.setattr(results_module, "atomic_write", table_write)
    with pytest.raises(od.SweepWriteError) as stopped:
        od.sweep(scene, vary, client=client, parquet=parquet, trajectories=runs)
    assert stopped.value.filename == str(parquet) and stopped.value.table.num_rows == 6
    assert not parquet.exists() and len(list((tmp_path / "r.parquet.parts").iterdir())) >= 2
    monkeypatch.setattr(results_module, "atomic_write", atomic_write)
    resumed = od.sweep(scene, vary, client=client, parquet=parquet, trajectories=runs)
    assert resumed.drop(["wall_s"]).equals(full.drop(["wall_s"]))
    assert len(list(runs.glob("run-*.npz"))) == 6


def test_the_command_on_a_full_disk_names_the_file_and_says_it_resumes(
    client, tmp_path, monkeypatch, capsys
):
    from opendyn.cli.main import main
    from opendyn.sim.trajectory import Trajectory

    monkeypatch.chdir(tmp_path)
    full_disk = _disk_full_after(1)
    save = Trajectory.save
    monkeypatch.setattr(Trajectory, "save", lambda self, path: (full_disk(), save(self, path))[1])
    argv = ["sweep", "planar_3r_limits", "--vary", "effects.limits.stiffness=1e3,1e4,1e5",
            "--vary", "run.duration=0.1", "--scheduler", client.scheduler.address, "-o",
            "r.parquet", "--trajectories", "runs", "--chunk", "1"]
    assert main(argv) == 3
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert re.fullmatch(
        r"opendyn sweep: runs/run-00000\d\.npz: No space left on device; 1 runs \(1 complete, "
        r"0 failed\) so far are kept: the same command resumes from them once the file can be "
        r"written",
        err,
    ), err
    monkeypatch.setattr(Trajectory, "save", save)
    assert main(argv) == 0
    assert pq.read_table(tmp_path / "r.parquet").column("run").to_pylist() == [0, 1, 2]


def test_a_results_name_whose_parts_folder_would_be_too_long_is_refused(tmp_path):
    most = os.pathconf(tmp_path, "PC_NAME_MAX")
    name = "r" * (most - 8) + ".parquet"  # fits; its folder of parts, NAME.parts, does not
    with pytest.raises(SweepError, match=rf"its folder of parts r+\.parquet\.parts: its name is "
                       rf"{most + 6} bytes, longer than the {most}"):
        od.sweep(limits_scene(0.1), {"effects.limits.stiffness": "1e3"}, parquet=tmp_path / name)


def test_a_grid_too_large_is_refused_before_it_is_made():
    """0:1:1000000000 made its billion points first, and the process filled the memory."""
    with pytest.raises(SweepError, match=r"n = 1,000,000,000 points, more than 10,000,000"):
        parse_axis("initial.q.shoulder", "0:1:1000000000")


def test_a_sweep_stopped_before_its_first_row_resumes(client, tmp_path):
    """A results file of no rows (Ctrl-C before the first arrived) made every later run of
    the same command fail in pyarrow ("Filter argument must be boolean type")."""
    scene = limits_scene(duration=0.1)
    vary = {"effects.limits.stiffness": "1e3,1e4"}
    parquet = tmp_path / "r.parquet"
    full = od.sweep(scene, vary, client=client, parquet=parquet)
    pq.write_table(full.slice(0, 0), parquet)
    resumed = od.sweep(scene, vary, client=client, parquet=parquet)
    assert resumed.drop(["wall_s"]).equals(full.drop(["wall_s"]))


def test_a_urdf_whose_values_the_scene_reads_edited_between_runs_is_another_sweep(
    client, tmp_path
):
    """coefficients = "urdf" takes the URDF's damping: editing it between a stopped sweep and
    its resume mixed two robots' rows in one table (the robot's own buffers do not hold it)."""
    import shutil

    shutil.copy(os.path.join(ROBOTS, "double_pendulum.urdf"), tmp_path / "dp.urdf")
    (tmp_path / "dp.toml").write_text(
        'name = "dp"\n[robot]\nurdf = "dp.urdf"\n[run]\nduration = 0.05\n'
        '[effects]\ngravity = true\n[effects.damping]\ncoefficients = "urdf"\n'
    )
    vary = {"initial.q.shoulder": "0,1"}
    parquet = tmp_path / "r.parquet"
    od.sweep(od.load_scene(tmp_path / "dp.toml"), vary, client=client, parquet=parquet)
    urdf = (tmp_path / "dp.urdf").read_text()
    assert 'damping="0.1"' in urdf
    (tmp_path / "dp.urdf").write_text(urdf.replace('damping="0.1"', 'damping="0.5"'))
    with pytest.raises(SweepError, match=r"another sweep \(its effects differs\)"):
        od.sweep(od.load_scene(tmp_path / "dp.toml"), vary, client=client, parquet=parquet)


def test_a_results_file_another_sweep_is_writing_is_refused(tmp_path):
    """Two sweeps started on one results file: each replaced the other's rows, and both said
    they wrote it. The file is locked while a sweep writes it."""
    import fcntl

    parquet = tmp_path / "r.parquet"
    with open(tmp_path / "r.parquet.lock", "a") as held:
        fcntl.flock(held.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(SweepError, match="another sweep is writing this results file now"):
            od.sweep(limits_scene(0.1), {"effects.limits.stiffness": "1e3"}, parquet=parquet)
    assert not parquet.exists()


def test_results_that_are_not_a_parquet_path_are_refused_naming_the_argument(tmp_path):
    scene, vary = limits_scene(0.1), {"effects.limits.stiffness": "1e3"}
    with pytest.raises(SweepError, match=r"parquet \(-o\) '.*res\.csv': a sweep's results are a "
                       r"Parquet table; name a \.parquet file \(not \.csv\)"):
        od.sweep(scene, vary, parquet=tmp_path / "res.csv")
    with pytest.raises(TypeError, match=r"^parquet must be a path \(a str or pathlib\.Path\), "
                       r"got int 123"):
        od.sweep(scene, vary, parquet=123)
    with pytest.raises(TypeError, match=r"^trajectories must be a path"):
        od.sweep(scene, vary, trajectories=["runs"])


def test_the_command_refuses_metric_without_plot(tmp_path, monkeypatch, capsys):
    from opendyn.cli.main import main

    monkeypatch.chdir(tmp_path)
    argv = ["sweep", "planar_3r_limits", "--vary", "run.duration=0.1", "--metric", "bogus"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--metric bogus: it picks the metric --plot draws; give --plot FILE.png" in err
    assert list(tmp_path.iterdir()) == []


def test_the_local_clusters_workers_ignore_ctrl_c(ctrl_c_raises):
    """A terminal's Ctrl-C goes to the workers too; they must leave it to the client, which
    stops the sweep in order."""
    from opendyn.sweep.cluster import LocalOrGiven

    with LocalOrGiven(None, 2) as dask_client:
        handlers = dask_client.run(signal.getsignal, signal.SIGINT)
    assert len(handlers) == 2
    assert all(h == signal.SIG_IGN for h in handlers.values()), handlers
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl_c", "sigterm"])
def test_a_signal_while_the_local_cluster_starts_closes_it_once_up_then_stops(
    monkeypatch, ctrl_c_raises, signum
):
    """Ctrl-C: the client ignored it while the cluster started (1-3 s), so that its workers
    would inherit the ignored signal; a Ctrl-C then was lost, and the sweep ran to its end.
    SIGTERM: it stopped the start halfway, and Dask's exit handler then printed a traceback
    after the command's one line. Both now close the cluster once it is up, then stop."""
    from opendyn._runtime.signals import SigtermAsInterrupt
    from opendyn.sweep.cluster import LocalOrGiven

    events = []

    class Starting:
        def __init__(self, **kwargs):
            os.kill(os.getpid(), signum)  # arrives while the cluster starts
            events.append("cluster up")

        def close(self):
            events.append("cluster closed")

    class Connecting:
        def __init__(self, cluster):
            events.append("client up")

        def close(self):
            events.append("client closed")

    monkeypatch.setattr("dask.distributed.LocalCluster", Starting)
    monkeypatch.setattr("dask.distributed.Client", Connecting)
    with SigtermAsInterrupt() as signals, pytest.raises(KeyboardInterrupt):
        with LocalOrGiven(None, 2):
            events.append("sweeping")
    assert signals.terminated == (signum == signal.SIGTERM)
    assert events == ["cluster up", "client up", "client closed", "cluster closed"]
