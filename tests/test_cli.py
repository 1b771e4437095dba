"""The `opendyn` command as a user runs it: demo, info, and errors that say what is wrong."""

from __future__ import annotations

import re

import numpy as np

import opendyn as od
from opendyn.cli import main


def test_demo_prints_the_model_report_and_a_checked_forward_dynamics(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "robot 'double_pendulum'" in out and "URDF fidelity report" in out
    assert "M(q) =" in out and "g(q) =" in out and "forward_dynamics" in out
    residual = float(re.search(r"tau\| = (\S+)", out).group(1))
    assert residual < 1e-10


def test_demo_prints_the_mass_matrix_of_the_robot_it_loaded(capsys):
    """The printed M(q) is the planar 3R arm's at the printed q (both rounded to 4 decimals,
    so they agree to about 1e-3)."""
    assert main(["demo", "planar_3r"]) == 0
    out = capsys.readouterr().out
    q = np.array([float(x) for x in re.search(r"q = \[([^\]]*)\]", out).group(1).split()])
    block = re.search(r"M\(q\) =\n(.*?)\ng\(q\)", out, re.S).group(1)
    printed = np.array([float(x) for x in re.findall(r"-?\d+\.\d*", block)]).reshape(3, 3)
    np.testing.assert_allclose(printed, od.mass_matrix(od.load_urdf("planar_3r"), q), atol=2e-3)


def test_info_lists_what_the_loader_did(capsys):
    assert main(["info", "ur5"]) == 0
    out = capsys.readouterr().out
    assert "shoulder_pan_joint" in out and "fixed joint 'ee_fixed_joint'" in out
    assert "<transmission>" in out


def test_unknown_robot_is_an_error_with_the_closest_names(capsys):
    assert main(["demo", "ur_5"]) == 2
    err = capsys.readouterr().err
    assert "'ur_5' is neither a URDF file nor a known robot name" in err and "ur5" in err


def test_invalid_inertia_points_to_the_option_that_keeps_it(capsys):
    assert main(["info", "pr2"]) == 2
    assert "--keep-inertia" in capsys.readouterr().err
    assert main(["info", "--keep-inertia", "pr2"]) == 0
