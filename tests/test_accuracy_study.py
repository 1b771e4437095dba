"""The accuracy-versus-time study runs end to end (its --quick mode) and measures what theory
predicts: convergence orders (Euler 1, RK4 4) and a reference whose own error is negligible;
on the constrained four-bar, Baumgarte stabilisation bounds the loop-closure violation that
grows without it, and the violation converges at the integrator's order.

Timings are recorded by the study but never asserted here.
"""

import importlib.util
import json
import pathlib

import pytest

pytest.importorskip("pinocchio")  # the UR5 and Panda come from example-robot-data with it

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / "scripts" / "accuracy_vs_time.py"


@pytest.fixture(scope="module")
def quick_study(tmp_path_factory):
    spec = importlib.util.spec_from_file_location("accuracy_vs_time", SCRIPT)
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    out = tmp_path_factory.mktemp("study")
    assert study.main(["--quick", "--out", str(out)]) == 0
    return out, json.loads((out / "study.json").read_text())


def test_quick_study_writes_its_plots_and_tables(quick_study):
    out, record = quick_study
    for name in ("accuracy_vs_time.png", "convergence.png", "algorithms.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    text = (out / "study.md").read_text()
    for heading in ("Recommendations", "Convergence orders", "Pareto front", "Residual", "effect"):
        assert heading in text
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
