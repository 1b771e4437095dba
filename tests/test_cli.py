"""The `opendyn` command as a user runs it: demo, info, and errors that say what is wrong."""

from __future__ import annotations

import re

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.main import main
from opendyn.cli.simulate import summary as simulate_summary


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


def test_info_says_whether_the_base_floats_and_warns_on_a_welded_mobile_robot(capsys):
    # solo12's trunk carries mass and four legs leave it: it looks mobile
    assert main(["info", "solo12"]) == 0
    out, err = capsys.readouterr()
    assert "base: fixed" in out
    assert "warning: 'solo' looks like a mobile robot" in err and "--floating-base" in err
    assert main(["info", "solo12", "--floating-base"]) == 0
    out, err = capsys.readouterr()
    assert "base: floating" in out and "nq = 19" in out and "warning" not in err
    # an arm: the UR5 is attached to a world link, the Panda has one chain off its base link
    for arm in ("ur5", "panda"):
        assert main(["info", arm]) == 0
        out, err = capsys.readouterr()
        assert "base: fixed" in out and "warning" not in err
    # a single free body welded down: nothing moves at all
    assert main(["info", "t_handle"]) == 0
    assert "looks like a mobile robot" in capsys.readouterr().err


def test_unknown_robot_is_an_error_with_the_closest_names(capsys):
    assert main(["demo", "ur_5"]) == 2
    err = capsys.readouterr().err
    assert "'ur_5' is neither a URDF file nor a known robot name" in err and "ur5" in err


def test_invalid_inertia_points_to_the_option_that_keeps_it(capsys):
    assert main(["info", "pr2"]) == 2
    assert "--keep-inertia" in capsys.readouterr().err
    assert main(["info", "--keep-inertia", "pr2"]) == 0


def test_simulate_without_argument_runs_the_default_scene(capsys, tmp_path):
    out_npz = tmp_path / "dp.npz"
    assert main(["simulate", "-o", str(out_npz), "--plot", str(tmp_path / "dp.png")]) == 0
    out = capsys.readouterr().out
    assert "double pendulum" in out and "complete" in out
    for key in (
        "simulated   10 s",
        "real time",
        "10000 accepted",
        "40000 dynamics evaluations",
        "drift max |E - E(0)|",
    ):
        assert key in out
    traj = od.Trajectory.load(out_npz)
    assert traj.complete and traj.t[-1] == 10.0 and traj.q.shape == (1001, 2)
    assert (tmp_path / "dp.json").exists() and (tmp_path / "dp.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    "options, said",
    [
        (["--duration", "-1"], "--duration: expected a number > 0, found -1"),
        (["--dt", "0"], "--dt: expected a number > 0, found 0"),
        (["--output-dt", "0.00001"], "--output-dt: 1e-05 s is not a whole multiple of run.dt"),
        (["--integrator", "dopri5", "--rtol", "-1"], "--rtol: expected a number > 0"),
    ],
)
def test_a_bad_run_option_is_named_as_the_option_not_as_the_scene_files_key(
    capsys, options, said
):
    """The scene file does not hold the value an option gave: the error named `SCENE.toml:
    run.duration`."""
    assert main(["simulate", "--no-save", "-q", "double_pendulum_swing", *options]) == 2
    err = capsys.readouterr().err
    assert f"opendyn simulate: {said}" in err and ".toml" not in err, err


def test_simulate_options_change_the_run(capsys, tmp_path):
    csv = tmp_path / "run.csv"
    args = [
        "simulate",
        "ur5_falling",
        "--duration",
        "0.5",
        "--integrator",
        "dopri5",
        "--disable",
        "damping",
        "--csv",
        str(csv),
        "--no-save",
    ]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "effects     gravity\n" in out and "dopri5, rtol = 1e-06" in out
    assert "rejected" in out and len(csv.read_text().splitlines()) == 1 + 51


def test_simulate_profile_prints_each_stage_cost(capsys):
    args = ["simulate", "double_pendulum_push", "--duration", "0.5", "--profile", "--no-save"]
    assert main(args) == 0
    out = capsys.readouterr().out
    table = out[out.index("profile:") :]
    for stage in (
        "gravity",
        "damping",
        "wrench on tip",
        "forward dynamics (ABA)",
        "step (measured)",
    ):
        assert stage in table
    assert "friction" not in table and "control" not in table


def test_simulate_failure_writes_the_partial_record_and_exits_1(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "planar_3r_limits", "--integrator", "rk4"]) == 1
    captured = capsys.readouterr()
    assert "STOPPED EARLY" in captured.out
    assert "t = 0.275 s (step 55)" in captured.err and "implicit_euler" in captured.err
    (partial,) = tmp_path.glob("*-partial.npz")
    traj = od.Trajectory.load(partial)
    assert not traj.complete and "joint-limit stiffness" in traj.message
    assert np.all(np.isfinite(traj.q)) and traj.t[-1] == 0.275


def test_simulate_bad_input_is_exit_2_naming_the_problem(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[robot]\nname = "double_pendulum"\n[run]\nintegrater = "rk4"\n')
    assert main(["simulate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.toml" in err and "run.integrater" in err and "integrator" in err


def test_verify_prints_a_table_against_pinocchio(capsys):
    assert main(["verify", "double_pendulum", "--states", "2"]) == 0
    out = capsys.readouterr().out
    assert "mass_matrix" in out and "forward_dynamics[aba]" in out and "PASS" in out


def test_compile_ahead_runs_every_core_call_and_the_scenes_named(capsys):
    """`opendyn compile` runs the list of core calls (each must accept its arguments on any
    robot: a wrong call would only show on a user's machine) and simulates and rolls out each
    named scene (a sweep's workers roll its runs out)."""
    from opendyn.cli.cache import core_calls

    model = od.load_urdf("double_pendulum")
    names = []
    for name, call in core_calls(model, batch=3):
        call()
        names.append(name)
    assert "forward_dynamics newton_euler" in names and "constrained_forward_dynamics" in names
    assert main(["compile", "double_pendulum_swing"]) == 0
    assert "compiled 2 items" in capsys.readouterr().out


def test_info_cache_names_the_cache_folder(capsys):
    from opendyn._runtime.kernel_cache import CACHE_DIR

    assert main(["info", "--cache"]) == 0
    out = capsys.readouterr().out
    assert f"kernel cache  {CACHE_DIR}" in out and "chosen as" in out


def test_simulate_reports_contact_and_draws_the_ground_and_its_forces(tmp_path, capsys):
    """The ball drop (its first bounce at 0.32 s): the summary names the largest penetration
    and force, and the page has the ground and an arrow, its scale in the title."""
    pytest.importorskip("meshcat")
    page = tmp_path / "run.html"
    args = ["simulate", "ball_drop", "--duration", "0.4", "--html", str(page), "--no-save"]
    assert main(args) == 0
    out = capsys.readouterr().out
    line = re.search(r"contact +1 point on the ground z = 0 m: max penetration ([0-9.]+) mm "
                     r"\(ball at t = ([0-9.]+) s\), max force ([0-9.]+) N", out)
    assert line, out
    depth, t, force = (float(x) for x in line.groups())
    assert 9.9 < depth < 10.1 and 0.32 < t < 0.34 and force == pytest.approx(depth * 100, rel=1e-3)
    html = page.read_text()
    assert re.search(r"<title>ball - opendyn \(red arrows: contact forces, ", html)


def test_simulate_warns_on_a_welded_mobile_robot_and_floating_base_frees_it(capsys):
    """`opendyn simulate solo12` ran welded in mid-air without a word: it warns as `opendyn info`
    does, and --floating-base (for a robot and for a scene alike) makes the root link free."""
    assert main(["simulate", "solo12", "--duration", "0.01", "--no-save", "-q"]) == 0
    err = capsys.readouterr().err
    assert "looks like a mobile robot" in err and "--floating-base" in err
    assert main(["simulate", "solo12", "--floating-base", "--duration", "0.01", "--no-save"]) == 0
    out, err = capsys.readouterr()
    assert "floating base, nq = 19, nv = 18" in out and "looks like a mobile robot" not in err
    from opendyn.cli.simulate import scene_for

    freed = scene_for("double_pendulum_swing", floating_base=True)
    assert freed.model.floating_base and freed.model.nv == 8
    assert freed.settings["robot"]["floating_base"] is True
    assert not scene_for("double_pendulum_swing").model.floating_base
    with pytest.warns(od.SceneWarning, match="'solo' looks like a mobile robot"):
        od.default_scene("solo12")


@pytest.mark.parametrize(
    "argv, words",
    [
        (["simulate", "--duration", "0_2"], "argument --duration: invalid number: '0_2' (no digit"),
        (["verify", "ur5", "--states", "1_0"], "argument --states: invalid whole number: '1_0'"),
    ],
)
def test_numbers_with_digit_separators_are_refused(argv, words, capsys):
    """Python's float reads "0_2" as 2: --duration 0_2 ran 2 s without a word."""
    with pytest.raises(SystemExit) as refused:
        main(argv)
    assert refused.value.code == 2 and words in capsys.readouterr().err


def test_tolerances_for_a_fixed_step_run_are_refused(capsys):
    """--rtol with the default scene's rk4 was accepted and did nothing."""
    assert main(["simulate", "--rtol", "1e-6", "--no-save", "-q"]) == 2
    err = capsys.readouterr().err
    assert "--rtol: the tolerances of an adaptive step, but the run's integrator is rk4" in err


def test_a_scene_whose_robot_has_an_impossible_inertia_says_which_scene_key_keeps_it(
    tmp_path, capsys
):
    """The refusal named load_urdf's check_inertia=False, a Python argument, to a user of the
    command line; a scene's robot.check_inertia = false is what works there."""
    scene = tmp_path / "anymal.toml"
    scene.write_text('name = "a"\n[robot]\nname = "anymal"\nfloating_base = true\n')
    assert main(["simulate", str(scene), "--no-save"]) == 2
    err = capsys.readouterr().err
    assert "violates the triangle inequality" in err
    assert err.rstrip().endswith("(a scene with robot.check_inertia = false loads it anyway)")


def test_simulate_collision_draws_the_collision_geometry_and_needs_a_page(tmp_path, capsys):
    """--collision puts model.geometries on the page (the UR5's 8: 7 hulls and a box, as
    triangle-mesh and box objects); alone, without --html or --view, it is refused by name."""
    pytest.importorskip("meshcat")
    assert main(["simulate", "ur5", "--duration", "0.01", "--collision", "--no-save"]) == 2
    assert "--collision" in capsys.readouterr().err
    page = tmp_path / "run.html"
    args = ["simulate", "ur5", "--duration", "0.01", "--collision", "--html", str(page)]
    assert main([*args, "--no-save"]) == 0
    from test_viz import objects_by_path, page_commands

    objects = objects_by_path(page_commands(page.read_text()))
    kinds = sorted(o["geometries"][0]["type"] for p, o in objects.items() if "/visual_" in p)
    assert kinds == ["BoxGeometry"] + ["BufferGeometry"] * 7
    assert len(od.load_urdf("ur5").geometries) == 8


def test_an_energy_balance_off_by_more_than_five_percent_is_a_warning_naming_the_cause():
    """The double pendulum under explicit Euler at 30 ms gains 29% of its energy and the
    summary said nothing; past 5% of max |E| it warns, naming the integrator's part. RK4 at 1 ms
    (the shipped scene) keeps it to 1e-9 and warns of nothing."""
    scene = od.load_scene("double_pendulum_swing")
    coarse = scene.replace_run(integrator="euler", dt=0.03, duration=3.0, output_dt=0.03)
    text = simulate_summary(coarse, od.simulate(coarse))
    assert "run         complete, with the warning below" in text
    assert "WARNING     the energy balance is off by 0." in text
    assert "explicit Euler adds energy at every step" in text and "run.dt = 0.03 s" in text
    fine = scene.replace_run(duration=3.0)
    assert "WARNING" not in simulate_summary(fine, od.simulate(fine))
