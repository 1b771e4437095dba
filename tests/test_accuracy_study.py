"""The accuracy-versus-time study runs end to end (its --quick mode) and measures what theory
predicts: convergence orders (Euler 1, RK4 4) and a reference whose own error is negligible.

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
