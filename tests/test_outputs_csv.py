"""`--csv run.csv` writes more files than the one it names: with contacts between collision
geometries their table beside it (run.contacts.csv), and for a run that stopped early
run-partial.csv (and run-partial.contacts.csv) instead, never over a complete run's. Each of
those files is checked before the run as the named one is: against the run's inputs, the other
outputs, and what the file system allows. Inside them, a name (an object's, a joint's) that
holds a comma or a quote stays one field, and a scene refuses an empty one."""

from __future__ import annotations

import csv
import dataclasses
import importlib
import os
import shutil

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.main import main
from opendyn.errors import SceneError
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim.contacts import ContactTable

SIMULATE = importlib.import_module("opendyn.sim.simulate")
SHORT = ["--duration", "0.02", "-q"]
ROBOTS = shipped_robots_dir()


def files_in(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def rows_of(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


@pytest.fixture
def not_run(monkeypatch):
    """Running a scene fails the test: the checks after loading it must come before the run."""

    def refuse(*args, **kwargs):
        raise AssertionError("the scene ran before its outputs were checked")

    monkeypatch.setattr(SIMULATE, "simulate", refuse)


def after_the_run(monkeypatch, then):
    """The command's run as it is, followed by `then(traj)`, whose result is the run's."""
    run = SIMULATE.simulate
    monkeypatch.setattr(SIMULATE, "simulate", lambda *a, **kw: then(run(*a, **kw)))


# -- --csv's contact table is checked as the file it names is (before the run) ---------------


def crate_scene(folder, named):
    """A box robot and a crate object touching through their collision geometry, in `folder`:
    the scene, the robot's URDF, its SRDF and the crate's URDF, `named` (one of those four, as
    "scene", "robot", "srdf", "crate") a file name of its own. Returns the scene's path."""
    files = {
        "scene": "scene.toml",
        "robot": "robot.urdf",
        "srdf": "robot.srdf",
        "crate": "crate.urdf",
    }
    files[named[0]] = named[1]
    for key in ("robot", "crate"):
        shutil.copy(ROBOTS / "box.urdf", folder / files[key])
    (folder / files["srdf"]).write_text('<robot name="box"></robot>\n')
    (folder / files["scene"]).write_text(
        f'[robot]\nurdf = "{files["robot"]}"\nsrdf = "{files["srdf"]}"\n\n'
        f'[[objects]]\nname = "crate"\nurdf = "{files["crate"]}"\nposition = [0.0, 0.0, 0.5]\n\n'
        "[effects]\ngravity = true\n\n"
        '[effects.contact]\ngeometry = "collision"\nstiffness = 1e5\nfriction = 0.5\n'
    )
    return folder / files["scene"]


@pytest.mark.parametrize(
    "named, what",
    [(("scene", "run.contacts.csv"), "the scene file"),
     (("robot", "run.contacts.csv"), "the robot's URDF"),
     (("srdf", "run.contacts.csv"), "a file the scene names"),
     (("crate", "run.contacts.csv"), "a file the scene names"),
     (("crate", "run-partial.contacts.csv"), "a file the scene names"),
     (("crate", "run-partial.csv"), "a file the scene names")],
)  # fmt: skip
def test_a_file_that_csv_writes_beside_its_own_is_refused_where_it_is_an_input(
    named, what, tmp_path, monkeypatch, capsys, not_run
):
    """--csv run.csv was refused on an input, but the run.contacts.csv it writes beside it was
    not: a scene, a URDF or an SRDF of that name was replaced by the contact table."""
    scene = crate_scene(tmp_path, named)
    monkeypatch.chdir(tmp_path)
    before = files_in(tmp_path)
    assert main(["simulate", str(scene), "--no-save", "--csv", "run.csv"]) == 2
    err = capsys.readouterr().err
    assert f"--csv 'run.csv': {named[1]}: is {what}, an input of this run" in err, err
    assert files_in(tmp_path) == before


@pytest.mark.parametrize(
    "args, problem",
    [(["--html", "run.contacts.csv", "--csv", "run.csv"],
      "--csv 'run.csv': run.contacts.csv: is also the file of --html 'run.contacts.csv'"),
     (["--csv", "run.csv", "--html", "run-partial.csv"],
      "--html 'run-partial.csv': is also the file run-partial.csv of --csv 'run.csv'"),
     (["--html", "run-partial.contacts.csv", "--csv", "run.csv"],
      ("--csv 'run.csv': run-partial.contacts.csv: is also the file of --html "
       "'run-partial.contacts.csv'"))],
)  # fmt: skip
def test_two_outputs_on_one_file_through_csv_s_other_files_are_refused(
    args, problem, tmp_path, monkeypatch, capsys, not_run
):
    """--html run.contacts.csv --csv run.csv wrote the page and the table one over the other,
    and reported both as written."""
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "box_on_table", "--no-save", *args]) == 2
    err = capsys.readouterr().err
    assert err == f"opendyn simulate: {problem}\n"
    assert files_in(tmp_path) == {}


def test_csv_s_contact_table_that_cannot_be_written_is_refused_before_the_run(
    tmp_path, monkeypatch, capsys, not_run
):
    """A folder named like the contact table, or a name that fits where the table's does not:
    the error came after the run, named --csv's file, and that file was written."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "run.contacts.csv").mkdir()
    assert main(["simulate", "box_on_table", "--no-save", "--csv", "run.csv"]) == 2
    err = capsys.readouterr().err
    assert err == "opendyn simulate: --csv 'run.csv': run.contacts.csv: is a folder, not a file\n"
    most = os.pathconf(tmp_path, "PC_NAME_MAX")
    stem = "c" * (most - 12)  # STEM.csv and STEM-partial.csv fit; STEM.contacts.csv does not
    assert main(["simulate", "box_on_table", "--no-save", "--csv", f"{stem}.csv"]) == 2
    err = capsys.readouterr().err
    assert f"{stem}.contacts.csv: its name is {most + 1} bytes, longer than the {most}" in err
    assert files_in(tmp_path) == {}


def test_a_contact_table_that_fails_after_the_run_is_named_and_nothing_is_written(
    tmp_path, monkeypatch, capsys
):
    """The folder appears during the run: the message names the table's file, not --csv's,
    and the trajectory's CSV is not written without its table."""
    monkeypatch.chdir(tmp_path)

    def then_a_folder(traj):
        (tmp_path / "run.contacts.csv").mkdir()
        return traj

    after_the_run(monkeypatch, then_a_folder)
    assert main(["simulate", "box_on_table", *SHORT, "-o", "run.npz", "--csv", "run.csv"]) == 3
    err = capsys.readouterr().err
    assert "could not write --csv 'run.csv': run.contacts.csv: is a folder, not a file" in err, err
    assert sorted(files_in(tmp_path)) == ["run.json", "run.npz"]


# -- a run that stopped early writes its CSV files under partial names ------------------------


def test_a_run_that_stops_early_writes_its_csv_files_beside_a_complete_run_s(
    tmp_path, monkeypatch, capsys
):
    """The record went to SCENE-partial.npz, but the CSVs replaced the complete run's."""
    monkeypatch.chdir(tmp_path)
    complete = {"run.csv": b"a complete run\n", "run.contacts.csv": b"its contacts\n"}
    for name, content in complete.items():
        (tmp_path / name).write_bytes(content)
    stopped = []

    def then_stopped(traj):
        stopped.append(dataclasses.replace(traj, complete=False, message="stopped"))
        return stopped[0]

    after_the_run(monkeypatch, then_stopped)
    assert main(["simulate", "box_on_table", *SHORT, "--csv", "run.csv"]) == 1
    out = capsys.readouterr().out
    assert "wrote run-partial.csv\nwrote run-partial.contacts.csv\n" in out
    files = files_in(tmp_path)
    assert set(files) == {
        "box_on_table-partial.json",
        "box_on_table-partial.npz",
        "run-partial.contacts.csv",
        "run-partial.csv",
        *complete,
    }
    assert {name: files[name] for name in complete} == complete
    traj = stopped[0]
    rows = np.loadtxt(tmp_path / "run-partial.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(rows[:, 0], traj.t)
    table = rows_of(tmp_path / "run-partial.contacts.csv")
    assert len(traj.contacts) > 0 and len(table) == 1 + len(traj.contacts)


# -- names in CSV files -----------------------------------------------------------------------


def test_a_name_with_a_comma_or_a_quote_stays_one_field_of_the_csv(tmp_path):
    """An object named "box,1" gave 16 fields a row of the contact table, where the header
    has 15; a joint's name the same in the trajectory's header."""
    names = ("box,1", 'the "lid"')
    table = ContactTable(
        sample=np.array([0, 1]),
        pair=np.array([0, 0]),
        point=np.zeros((2, 3)),
        normal=np.tile([0.0, 0.0, 1.0], (2, 1)),
        force=np.ones((2, 3)),
        depth=np.array([1e-3, 2e-3]),
        pair_names=(names,),
    )
    header, *rows = rows_of(table.to_csv(tmp_path / "contacts.csv", t=[0.0, 0.1]))
    assert len(header) == 15 and all(len(row) == 15 for row in rows)
    assert [(row[3], row[4]) for row in rows] == [names, names]
    assert [float(row[-1]) for row in rows] == [1e-3, 2e-3]
    traj = od.Trajectory(
        t=np.array([0.0, 0.1]),
        q=np.ones((2, 1)),
        qd=np.ones((2, 1)),
        tau=np.ones((2, 1)),
        kinetic=np.ones(2),
        potential=np.ones(2),
        work_applied=np.ones(2),
        work_passive=np.ones(2),
        joint_names=("hinge,1",),
    )
    header, *rows = rows_of(traj.to_csv(tmp_path / "run.csv"))
    assert header[:4] == ["t", "q_hinge,1", "qd_hinge,1", "tau_hinge,1"]
    assert all(len(row) == len(header) for row in rows)


@pytest.mark.parametrize("section", ["objects", "world"])
@pytest.mark.parametrize("name", ["", " "])
def test_an_object_or_a_world_entry_without_a_name_is_refused(section, name, tmp_path):
    names = {"objects": "box", "world": "table", section: name}
    scene = tmp_path / "scene.toml"
    scene.write_text(
        f'[[objects]]\nname = "{names["objects"]}"\nshape = "box"\nsize = [0.1, 0.1, 0.1]\n'
        f'mass = 1.0\n\n[[world]]\nname = "{names["world"]}"\nshape = "plane"\n'
    )
    with pytest.raises(SceneError) as refused:
        od.load_scene(scene)
    assert f"{section}[0].name: {name!r} is empty: every entry needs a name" in str(refused.value)
