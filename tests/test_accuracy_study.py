"""The accuracy-versus-time study runs end to end (its --quick mode) and measures what theory
predicts: convergence orders (Euler 1, RK4 4) and a reference whose own error is negligible;
on the constrained four-bar, Baumgarte stabilisation bounds the loop-closure violation that
grows without it, and the violation converges at the integrator's order; on ground contact, the
simulator refuses exactly the explicit steps beyond the contact's stability limit (sqrt(k/m) on
the ball, friction near zero slip on the quadruped), implicit Euler lands the quadruped at 1 ms
and converges at first order, and a stiffer contact needs a smaller RK4 step.

Timings are recorded by the study but never asserted here. The quick run is made as a new user
would try it, without --out, from a temporary folder: it writes there, never into the published
study in docs/study/.
"""

import importlib.util
import json
import pathlib
import re

import pytest

pytest.importorskip("pinocchio")  # the UR5 and Panda come from example-robot-data with it

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "accuracy_vs_time.py"
PUBLISHED = ROOT / "docs" / "study"


def folder_bytes(folder):
    """{path relative to folder: bytes} of every file under folder."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def published_study():
    """The published study's files, read before the quick run."""
    return folder_bytes(PUBLISHED)


@pytest.fixture(scope="module")
def quick_study(tmp_path_factory, published_study):
    """(output folder, study.json) of `accuracy_vs_time.py --quick` run from a temporary
    folder without --out, as a new user would try it."""
    spec = importlib.util.spec_from_file_location("accuracy_vs_time", SCRIPT)
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    trial = tmp_path_factory.mktemp("trial")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(trial)
        assert study.main(["--quick"]) == 0
    out = trial / "accuracy_study"
    return out, json.loads((out / "study.json").read_text())


def test_quick_study_writes_where_it_is_run_and_leaves_the_published_study_alone(
    quick_study, published_study
):
    out, _ = quick_study
    assert sorted(p.name for p in out.iterdir()) == sorted(
        name for name in published_study if "/" not in name
    )
    assert folder_bytes(PUBLISHED) == published_study
    assert "do not edit this page" not in (out / "study.md").read_text()  # no --docs header


def test_quick_study_writes_its_plots_and_tables(quick_study):
    out, record = quick_study
    for name in ("accuracy_vs_time.png", "convergence.png", "algorithms.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    text = (out / "study.md").read_text()
    for heading in ("Recommendations", "Convergence orders", "Pareto front", "Residual", "effect"):
        assert heading in text
    # the page shows its five plots, each written beside it (the documentation's study page)
    shown = re.findall(r"!\[[^\]]+\]\(([\w.]+\.png)\)", text)
    assert sorted(shown) == sorted(p.name for p in out.glob("*.png")) and len(shown) == 5
    assert record["mode"] == "quick"
    assert [r["key"] for r in record["integrators"]] == [
        "double_pendulum",
        "ur5",
        "panda",
        "limits",
    ]


def test_reference_error_is_negligible_against_the_runs_it_judges(quick_study):
    _, record = quick_study
    for res in record["integrators"]:
        bound = res["reference"]["error_bound"]
        assert bound < 1e-9, res["key"]
        judged = [r["error_max"] for r in res["runs"] if r["complete"]]
        # every run studied is at least 10x less accurate than the reference's own error bound
        assert min(judged) > 10 * bound, res["key"]


@pytest.mark.parametrize("scene", ["double_pendulum", "ur5"])
def test_rk4_converges_at_fourth_order_on_smooth_scenes(quick_study, scene):
    _, record = quick_study
    res = next(r for r in record["integrators"] if r["key"] == scene)
    assert res["orders"]["rk4"] == pytest.approx(4.0, abs=0.5)


def test_first_order_integrators_converge_at_first_order(quick_study):
    _, record = quick_study
    panda = next(r for r in record["integrators"] if r["key"] == "panda")
    for name in ("euler", "semi_implicit_euler", "implicit_euler"):
        assert panda["orders"][name] == pytest.approx(1.0, abs=0.1), name


def test_stiff_limits_stop_rk4_and_not_implicit_euler_at_large_steps(quick_study):
    _, record = quick_study
    limits = next(r for r in record["integrators"] if r["key"] == "limits")
    runs = {(r["integrator"], r["step"]): r for r in limits["runs"]}
    assert not runs[("rk4", 0.01)]["complete"]
    assert runs[("implicit_euler", 0.01)]["complete"]


def test_algorithm_study_times_every_method_and_the_residual_stays_small(quick_study):
    _, record = quick_study
    for row in record["algorithms"]["chains"]:
        for m in ("aba", "crba", "newton_euler"):
            assert row[f"{m}_kernel_us"] > 0
    for row in record["conditioning"]:
        # ABA never factors M, so it answers at every conditioning with a small residual
        assert row["aba_residual_max"] < 1e-10
    assert record["conditioning"][-1]["cond_median"] > 1e10


def _constrained_runs(record):
    """{(stabilisation, integrator, step): run} of the four-bar section."""
    return {
        (r["stabilisation"], r["integrator"], r["step"]): r for r in record["constrained"]["runs"]
    }


def test_quick_study_writes_the_constrained_section_and_plot(quick_study):
    out, record = quick_study
    assert (out / "constraint.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = (out / "study.md").read_text()
    assert "## Constrained scene: four-bar" in text
    assert "Convergence order of the violation" in text
    res = record["constrained"]
    assert res["scene"] == "four_bar"
    assert res["baumgarte"] == [20.0, 20.0]  # robots/four_bar.toml
    combos = {(r["stabilisation"], r["integrator"]) for r in res["runs"]}
    integrators = ("euler", "semi_implicit_euler", "implicit_euler", "rk4", "dopri5")
    assert combos == {(s, n) for s in ("baumgarte", "none") for n in integrators}


def test_every_constrained_run_is_measured_or_recorded_as_not_supported(quick_study):
    _, record = quick_study
    for r in record["constrained"]["runs"]:
        if not r["supported"]:
            assert "constrain" in r["reason"] and "violation_max" not in r, r
        elif r["complete"]:
            assert r["evaluations"] > 0 and r["violation_max"] >= r["violation_final"] >= 0
            assert r["velocity_violation_max"] >= 0 and r["error_max"] >= r["error_final"]
        else:
            assert 0 <= r["failed_at"] < record["constrained"]["duration"], r


def test_constrained_reference_keeps_the_loop_closed_and_its_error_negligible(quick_study):
    _, record = quick_study
    res = record["constrained"]
    # dopri5 at 1e-12 with Baumgarte: the closure holds to round-off on a 0.8 m linkage
    assert res["reference"]["violation_max"] < 1e-12
    bound = res["reference"]["error_bound"]
    assert bound < 1e-9
    assert min(r["error_max"] for r in res["runs"] if r["complete"]) > 10 * bound


def test_baumgarte_keeps_the_rk4_violation_below_a_nanometre_at_one_millisecond(quick_study):
    _, record = quick_study
    rk4 = [r for r in record["constrained"]["runs"] if r["integrator"] == "rk4"]
    smallest = min(r["step"] for r in rk4)
    assert smallest == 1e-3
    run = next(r for r in rk4 if r["stabilisation"] == "baumgarte" and r["step"] == smallest)
    # measured 4.1e-10 m over the 2 s of the quick run (the peak comes on the first revolution)
    assert run["complete"] and run["violation_max"] < 1e-9


def test_without_stabilisation_the_violation_is_larger_for_the_same_integrator_and_step(
    quick_study,
):
    _, record = quick_study
    runs = _constrained_runs(record)
    compared = 0
    for (stab, name, step), stabilised in runs.items():
        free = runs[("none", name, step)]
        if stab != "baumgarte" or not (stabilised["complete"] and free["complete"]):
            continue
        assert free["violation_max"] > stabilised["violation_max"], (name, step)
        compared += 1
    assert compared >= 12  # euler, implicit_euler, rk4 over four steps at least


@pytest.mark.parametrize("stabilisation", ["baumgarte", "none"])
def test_violation_converges_at_the_integrators_order(quick_study, stabilisation):
    _, record = quick_study
    orders = record["constrained"]["orders"][stabilisation]
    assert orders["rk4"] == pytest.approx(4.0, abs=0.5)
    for name in ("euler", "implicit_euler"):
        assert orders[name] == pytest.approx(1.0, abs=0.1), name


def test_constrained_recommendations_are_the_fastest_runs_within_each_bound(quick_study):
    _, record = quick_study
    res = record["constrained"]
    for stab, by_target in res["recommendations"].items():
        for target, pick in by_target.items():
            within = [
                r
                for r in res["runs"]
                if r["stabilisation"] == stab
                and r["complete"]
                and r["violation_max"] <= float(target)
            ]
            if not within:
                assert pick is None
                continue
            assert pick["violation_max"] <= float(target)
            assert pick["wall_s"] == min(r["wall_s"] for r in within)
    assert res["recommendations"]["baumgarte"]["1e-06"] is not None


def _contact_scene(record, key):
    return next(r for r in record["contact"]["scenes"] if r["key"] == key)


def test_quick_study_writes_the_contact_section_plot_and_recommendations(quick_study):
    out, record = quick_study
    assert (out / "contact.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = (out / "study.md").read_text()
    assert "## Contact" in text and "What the contact stiffness costs" in text
    recommendations = text.split("## Convergence orders")[0]
    assert "Contact scenes" in recommendations
    scenes = record["contact"]["scenes"]
    assert [r["key"] for r in scenes] == ["ball_drop", "quadruped_drop"]
    integrators = {"euler", "semi_implicit_euler", "implicit_euler", "rk4", "dopri5"}
    for res in scenes:
        assert res["title"] in recommendations
        assert {r["integrator"] for r in res["runs"]} == integrators


def _contact_runs(record):
    """(duration, run) of every contact run: both scenes and the stiffness study."""
    for res in record["contact"]["scenes"]:
        for r in res["runs"]:
            yield res["duration"], r
    study = record["contact"]["stiffness"]
    for row in study["rows"]:
        for r in row["runs"]:
            yield study["duration"], r


def test_every_contact_run_is_measured_refused_or_failed(quick_study):
    _, record = quick_study
    for duration, r in _contact_runs(record):
        if r["status"] == "refused":
            assert "unstable for the contact" in r["reason"] and "wall_s" not in r, r
            assert r["integrator"] in ("euler", "semi_implicit_euler", "rk4"), r
        elif r["status"] == "complete":
            assert r["evaluations"] > 0 and r["error_max"] >= r["error_final"] >= 0, r
            assert r["energy_error"] >= 0 and r["penetration_max"] >= 0, r
        else:
            assert r["status"] == "failed" and 0 <= r["failed_at"] < duration, r


def test_contact_references_are_negligible_against_the_runs_they_judge(quick_study):
    _, record = quick_study
    references = [res["reference"] for res in record["contact"]["scenes"]]
    references += [row["reference"] for row in record["contact"]["stiffness"]["rows"]]
    for ref in references:
        assert ref["error_bound"] < 1e-8, ref
    for res in record["contact"]["scenes"]:
        judged = [r["error_max"] for r in res["runs"] if r["complete"]]
        assert min(judged) > 10 * res["reference"]["error_bound"], res["key"]


def test_ball_reference_keeps_the_energy_and_reaches_the_closed_form_depth(quick_study):
    _, record = quick_study
    ref = _contact_scene(record, "ball_drop")["reference"]
    # robots/ball_drop.toml: 1 kg, lowest point 0.5 m up, k = 1e5, undamped: a spring under
    # gravity reaches (m g + sqrt((m g)^2 + 2 k m g h)) / k = 10.0 mm
    m, g, k, h = 1.0, 9.81, 1e5, 0.5
    depth = (m * g + (m * m * g * g + 2 * k * m * g * h) ** 0.5) / k
    # sampled every 1 ms on a 10 ms contact: the deepest sample lies within 1 % of the peak
    assert ref["penetration_max"] == pytest.approx(depth, rel=1e-2)
    assert ref["penetration_max"] <= depth
    assert ref["energy_error"] < 1e-8


def test_first_order_integrators_converge_at_first_order_on_the_ball_drop(quick_study):
    _, record = quick_study
    orders = _contact_scene(record, "ball_drop")["orders"]
    for name in ("euler", "implicit_euler"):
        assert orders[name] == pytest.approx(1.0, abs=0.1), name


def test_explicit_steps_are_refused_exactly_beyond_the_contacts_stability_limit(quick_study):
    _, record = quick_study
    limits = {"euler": 2.0, "semi_implicit_euler": 2.0, "rk4": 2.8}
    checked = 0
    for row in record["contact"]["stiffness"]["rows"]:
        # the ball's contact rate is sqrt(k / m); Euler is stable for dt x rate < 2, RK4 2.8
        assert row["rate"] == pytest.approx((row["stiffness"] / 1.0) ** 0.5)  # 1 kg
        for r in row["runs"]:
            refused = r["status"] == "refused"
            if r["integrator"] in limits:
                assert refused == (r["step"] * row["rate"] >= limits[r["integrator"]]), r
                checked += refused
            else:
                assert not refused, r
    assert checked >= 6  # 10 ms at every k; 1, 2 and 5 ms on the stiffest


def test_friction_near_zero_slip_sets_the_quadrupeds_explicit_steps(quick_study):
    _, record = quick_study
    res = _contact_scene(record, "quadruped_drop")
    runs = {(r["integrator"], r["step"]): r for r in res["runs"]}
    # mu f_n / v_s over a foot's apparent mass: 1.7e5 1/s, so RK4 needs dt < 1.7e-5 s
    for name in ("euler", "semi_implicit_euler", "rk4"):
        refused = runs[(name, 2e-5)]
        assert refused["status"] == "refused", name
        assert "contact friction near zero slip" in refused["reason"], name
    assert runs[("rk4", 1e-5)]["complete"] and runs[("rk4", 1e-5)]["error_max"] < 1e-2
    assert res["stability"]["rk4"] == {
        "largest_run": 1e-5,
        "smallest_refused": 2e-5,
        "largest_complete": 1e-5,
        "largest_usable": 1e-5,
    }


def test_implicit_euler_lands_the_quadruped_at_one_millisecond(quick_study):
    _, record = quick_study
    res = _contact_scene(record, "quadruped_drop")
    run = next(r for r in res["runs"] if r["integrator"] == "implicit_euler" and r["step"] == 1e-3)
    # measured 7.6e-2 (the feet land and slip a little differently); first order below that
    assert run["complete"] and run["error_max"] < 0.1
    assert res["stability"]["implicit_euler"]["largest_usable"] >= 1e-3
    finer = [
        r["error_max"]
        for r in sorted(res["runs"], key=lambda r: -r["step"])
        if r["integrator"] == "implicit_euler" and r["complete"]
    ]
    assert finer == sorted(finer, reverse=True)


def test_a_stiffer_contact_needs_a_smaller_rk4_step(quick_study):
    _, record = quick_study
    study = record["contact"]["stiffness"]
    steps = []
    for row in study["rows"]:
        rk4 = row["fastest"]["rk4"]
        assert rk4 is not None and rk4["error_max"] <= study["target"]
        assert rk4["step"] < row["rk4_step"]  # the accurate step lies inside the stable one
        steps.append(rk4["step"])
        assert row["fastest"]["dopri5"]["error_max"] <= study["target"]
    assert steps == sorted(steps, reverse=True) and steps[0] > steps[-1]


def test_contact_recommendations_are_the_fastest_runs_within_each_bound(quick_study):
    _, record = quick_study
    for res in record["contact"]["scenes"]:
        for target, pick in res["recommendations"].items():
            within = [r for r in res["runs"] if r["complete"] and r["error_max"] <= float(target)]
            if not within:
                assert pick is None
                continue
            assert pick["wall_s"] == min(r["wall_s"] for r in within)
        assert res["recommendations"]["0.01"] is not None, res["key"]
