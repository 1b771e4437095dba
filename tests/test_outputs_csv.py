"""The CSV files of a run: a name (an object's, a joint's) that holds a comma or a quote stays
one field, and a scene refuses an empty one."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import opendyn as od
from opendyn.errors import SceneError
from opendyn.sim.contacts import ContactTable


def rows_of(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


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
