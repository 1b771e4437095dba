"""The accuracy-versus-time study runs end to end (its --quick mode) and measures what theory
predicts: convergence orders (Euler 1, RK4 4) and a reference whose own error is negligible;
on the constrained four-bar, Baumgarte stabilisation bounds the loop-closure violation that
grows without it, and the violation converges at the integrator's order; on ground contact, the
simulator refuses exactly the explicit steps beyond the contact's stability limit (sqrt(k/m) on
the ball, friction near zero slip on the quadruped), implicit Euler lands the quadruped at 1 ms
and converges at first order, and a stiffer contact needs a smaller RK4 step. The hard contact
model's rows: every step completes where the explicit parts of its step are stable, nothing is
deeper than the step can carry past the margin (nothing at the finest step), the ball and the
quadruped converge at first order, and the rigid ball stops where the compliant one bounces.

Timings are recorded by the study and never held to a bound here: the page must show the times
the study recorded, its growth exponents must be the fit of those times, and n RNEA calls must
cost more than one ABA on a 50-link chain. Each plot is read back: the figure's size, not blank,
each curve's colour on it, and each curve's data the recorded numbers.

The quick run is made as a new user would try it, without --out, from a temporary folder: it
writes there, never into the published study in docs/study/.
"""

import importlib.util
import json
import pathlib
import re

import numpy as np
import pytest
from plotcheck import assert_lines_shown, read_png, saved_figures

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


# the study's plots, in the order main() saves them
PLOTS = (
    "accuracy_vs_time.png",
    "convergence.png",
    "constraint.png",
    "algorithms.png",
    "contact.png",
)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory, published_study):
    """(output folder, study.json, {plot name: (figure, dpi)}) of `accuracy_vs_time.py --quick`
    run from a temporary folder without --out, as a new user would try it; the figures are
    captured as they are saved."""
    spec = importlib.util.spec_from_file_location("accuracy_vs_time", SCRIPT)
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    trial = tmp_path_factory.mktemp("trial")
    with pytest.MonkeyPatch.context() as patch, saved_figures() as saved:
        patch.chdir(trial)
        assert study.main(["--quick"]) == 0
    out = trial / "accuracy_study"
    assert len(saved) == len(PLOTS)
    return out, json.loads((out / "study.json").read_text()), dict(zip(PLOTS, saved)), study


@pytest.fixture(scope="module")
def quick_study(quick_run):
    """(output folder, study.json) of the quick run."""
    return quick_run[:2]


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


METHODS = ("aba", "crba", "newton_euler")


def markdown_table(text, heading):
    """The body rows (lists of cells) of the first Markdown table after `heading` in text."""
    rows = []
    for line in text.split(heading, 1)[1].splitlines():
        if line.startswith("|"):
            rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
        elif rows:
            break
    assert len(rows) > 2 and set(rows[1]) == {"---"}, rows[:2]
    return rows[2:]


def test_algorithm_page_shows_the_times_it_recorded(quick_study):
    """study.md's time tables hold study.json's per-call times, to their three digits, and the
    Pinocchio ratio is the quotient of the two recorded times."""
    out, record = quick_study
    text = (out / "study.md").read_text()
    algo = record["algorithms"]
    tables = [
        ("## Forward dynamics: time per call on random serial chains", algo["chains"], "n"),
        ("And on the bundled robots", algo["robots"], "robot"),
    ]
    assert [r["n"] for r in algo["chains"]] == [2, 10, 50]
    assert {r["robot"] for r in algo["robots"]} >= {"double_pendulum", "planar_3r", "four_bar"}
    for heading, recorded, key in tables:
        rows = markdown_table(text, heading)
        assert len(rows) == len(recorded), heading
        for cells, rec in zip(rows, recorded):
            assert cells[0].split(" ")[0] == str(rec[key])
            times = [rec[f"{m}_kernel_us"] for m in METHODS] + [rec["aba_public_us"]]
            assert [float(c) for c in cells[1:5]] == pytest.approx(times, rel=5e-3), cells
            assert min(times) > 0 and np.isfinite(times).all()
            if "pinocchio_aba_us" in rec:
                assert float(cells[5]) == pytest.approx(rec["pinocchio_aba_us"], rel=5e-3)
                ratio = rec["aba_public_us"] / rec["pinocchio_aba_us"]
                assert float(cells[6]) == pytest.approx(ratio, abs=5e-3 + 1e-9)


def test_growth_exponents_are_the_fit_of_the_recorded_times(quick_study):
    """The exponents study.json and study.md report are the least-squares slope of log(time)
    against log(n) over the recorded chains from fit_from_n on (refitted here by numpy); and
    n RNEA calls + Cholesky, n times the passes of one ABA (each about the cost of one RNEA),
    cost more than ABA on the largest chain."""
    out, record = quick_study
    algo = record["algorithms"]
    n = np.array([r["n"] for r in algo["chains"]], float)
    keep = n >= algo["fit_from_n"]
    assert keep.sum() >= 2
    text = (out / "study.md").read_text()
    shown = dict(re.findall(r"(\w+) n\^(-?\d+\.\d+)", text.split("Growth fitted for n >=", 1)[1]))
    assert set(algo["exponents"]) == set(METHODS) == set(shown)
    for m in METHODS:
        t = np.array([r[f"{m}_kernel_us"] for r in algo["chains"]])
        slope = np.polyfit(np.log(n[keep]), np.log(t[keep]), 1)[0]
        assert algo["exponents"][m] == pytest.approx(slope, rel=1e-9), m
        assert shown[m] == f"{slope:.2f}", m
    largest = max(algo["chains"], key=lambda r: r["n"])
    assert largest["n"] == 50
    assert largest["newton_euler_kernel_us"] > largest["aba_kernel_us"]


def _curves(ax):
    """{label: (x, y)} of the labelled lines of ax."""
    return {
        line.get_label(): (
            np.asarray(line.get_xdata(), float),
            np.asarray(line.get_ydata(), float),
        )
        for line in ax.get_lines()
        if not line.get_label().startswith("_")
    }


def _assert_curve(curves, label, x, y):
    assert label in curves, (label, sorted(curves))
    np.testing.assert_array_equal(curves[label][0], np.asarray(x, float), err_msg=label)
    np.testing.assert_array_equal(curves[label][1], np.asarray(y, float), err_msg=label)


def _floor(values):
    return [max(v, 1e-16) for v in values]  # the plots' floor under a zero error


def _error_plots(figure, results, label, x, y, names):
    """Each of results' axes shows, per integrator of `names` with complete runs, the curve
    label(name, res) through (x(run), y(run)) of those runs."""
    for ax, res in zip(figure.axes, results):
        curves = _curves(ax)
        for name in names:
            done = [r for r in res["runs"] if r["integrator"] == name and r["complete"]]
            if done:
                _assert_curve(curves, label(name, res), [x(r) for r in done], [y(r) for r in done])


def test_plots_show_the_recorded_data(quick_run):
    """Each of the five plots is read back from its PNG (the figure's size, not blank, every
    curve's colour on it), and each curve of the figure it was saved from holds the numbers of
    study.json it claims to show."""
    out, record, figures, study = quick_run
    label = study.LABEL
    for name, (figure, dpi) in figures.items():
        image = read_png(out / name, figure, dpi)
        drawn = [
            line
            for ax in figure.axes
            for line in ax.get_lines()
            if not line.get_label().startswith("_")
            and np.isfinite(np.asarray(line.get_ydata(), float)).sum() >= 2
        ]
        assert drawn, name
        assert_lines_shown(image, drawn)

    results = record["integrators"]
    pareto, _ = figures["accuracy_vs_time.png"]
    assert pareto.axes[0].get_xlabel() == "wall time (s)"
    _error_plots(
        pareto, results, lambda n, res: label[n], lambda r: r["wall_s"],
        lambda r: max(r["error_max"], 1e-16), label,
    )
    for ax, res in zip(pareto.axes, results):
        front = res["pareto"]
        _assert_curve(
            _curves(ax), "Pareto front", [r["wall_s"] for r in front],
            _floor(r["error_max"] for r in front),
        )

    convergence, _ = figures["convergence.png"]
    assert convergence.axes[0].get_xlabel() == "step dt (s)"

    def order_label(name, res):
        order = res["orders"][name]
        return label[name] + (f" (order {order:.2f})" if order is not None else "")

    _error_plots(
        convergence, results, order_label, lambda r: r["step"],
        lambda r: max(r["error_final"], 1e-16), study.FIXED,
    )

    constraint, _ = figures["constraint.png"]
    res = record["constrained"]
    by_step, by_wall = (_curves(ax) for ax in constraint.axes[:2])
    shown = 0
    for name in label:
        for stab, words in study.STABILISATION.items():
            done = [
                r for r in res["runs"]
                if r["integrator"] == name and r["stabilisation"] == stab and r["complete"]
            ]
            if not done:
                continue
            if name == "dopri5":
                x = [res["duration"] / r["steps"] for r in done]
                key = f"{label[name]}, mean step, {words}"
            else:
                x, key = [r["step"] for r in done], f"{label[name]}, {words}"
            y = _floor(r["violation_max"] for r in done)
            _assert_curve(by_step, key, x, y)
            wall = [line for line in constraint.axes[1].get_lines() if list(line.get_ydata()) == y]
            assert [list(line.get_xdata()) for line in wall] == [[r["wall_s"] for r in done]]
            shown += 1
    assert shown == len(by_step) >= 8

    algorithms, _ = figures["algorithms.png"]
    algo, chains = record["algorithms"], record["algorithms"]["chains"]
    n = [r["n"] for r in chains]
    times, residuals = (_curves(ax) for ax in algorithms.axes[:2])
    for m in METHODS:
        _assert_curve(
            times, f"{m} (n^{algo['exponents'][m]:.2f})", n, [r[f"{m}_kernel_us"] for r in chains]
        )
        cond = [r["cond_median"] for r in record["conditioning"]]
        y = [r[f"{m}_residual_max"] for r in record["conditioning"]]
        _assert_curve(residuals, m, cond, [np.nan if v is None else v for v in y])
    if "pinocchio_aba_us" in chains[0]:
        _assert_curve(times, "pinocchio aba (Python)", n, [r["pinocchio_aba_us"] for r in chains])

    contact, _ = figures["contact.png"]

    def contact_label(name, res):
        rows = [r for r in res["runs"] if r["integrator"] == name]
        refused = [r["step"] for r in rows if r["status"] == "refused"]
        return label[name] + (f" (refused >= {min(refused) * 1e3:g} ms)" if refused else "")

    _error_plots(
        contact, record["contact"]["scenes"], contact_label, lambda r: r["wall_s"],
        lambda r: max(r["error_max"], 1e-16), label,
    )
    stiffness = record["contact"]["stiffness"]
    curves = _curves(contact.axes[-1])
    k_values = [row["stiffness"] for row in stiffness["rows"]]
    for name in label:
        picks = [row["fastest"][name] for row in stiffness["rows"]]
        key = label[name] if any(picks) else f"{label[name]}: no step of the sweep"
        _assert_curve(curves, key, k_values, [np.nan if r is None else r["wall_s"] for r in picks])


def test_conditioning_residuals_stay_small(quick_study):
    _, record = quick_study
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
    text = (out / "study.md").read_text()
    assert "## Contact" in text and "What the contact stiffness costs" in text
    recommendations = text.split("## Convergence orders")[0]
    assert "Contact scenes" in recommendations
    scenes = record["contact"]["scenes"]
    assert [r["key"] for r in scenes] == ["ball_drop", "quadruped_drop", "box_drop"]
    integrators = {"euler", "semi_implicit_euler", "implicit_euler", "rk4", "dopri5"}
    for res in scenes:
        assert res["title"] in recommendations
        assert {r["integrator"] for r in res["runs"]} == integrators


def _contact_runs(record):
    """(duration, run) of every contact run: the scenes' (the compliant law's and the hard
    model's) and the stiffness study's."""
    for res in record["contact"]["scenes"]:
        for r in res["runs"] + res["hard"]["runs"]:
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


def test_every_contact_scene_has_the_hard_models_rows(quick_run):
    """Each contact scene runs the hard model (ADMM at its default settings) over the quick
    hard sweep; every complete run records finite errors, distances to the compliant reference,
    penetration, energy residual and solver statistics, a worst residual only with unconverged
    steps; none is refused (the stability check before a run is the compliant contact's)."""
    _, record, _, study = quick_run
    for res in record["contact"]["scenes"]:
        hard = res["hard"]
        assert hard["label"] == study.HARD_LABEL
        assert hard["settings"]["solver"] == "admm" and hard["settings"]["margin"] == 1e-3
        assert [r["step"] for r in hard["runs"]] == study.HARD_STEPS["quick"]
        assert hard["reference"]["step"] == min(study.HARD_STEPS["quick"])
        for r in hard["runs"]:
            assert r["integrator"] == "semi_implicit_euler" and r["status"] != "refused", r
            if not r["complete"]:
                continue
            measured = [r[k] for k in ("error_final", "error_max", "compliant_final")]
            measured += [r[k] for k in ("compliant_max", "penetration_max", "energy_error")]
            assert np.isfinite(measured).all() and min(measured) >= 0, r
            assert r["compliant_max"] >= r["compliant_final"], r
            assert r["unconverged_steps"] >= 0 and 0 <= r["worst_residual"] < 1e-3, r
            assert (r["worst_residual"] > 0) == (r["unconverged_steps"] > 0), r
        finest = next(r for r in hard["runs"] if r["step"] == hard["reference"]["step"])
        assert finest["error_max"] == 0.0  # the reference itself


def _hard_runs(record, key):
    """{step: run} of the hard model on contact scene `key`."""
    return {r["step"]: r for r in _contact_scene(record, key)["hard"]["runs"]}


def test_hard_runs_complete_where_the_explicit_part_of_the_step_is_stable(quick_study):
    """The ball and the box complete at every step; the quadruped at 2 ms and below. At 10 ms
    its PD damping (kd = 0.2 N m s/rad on the light hip joints), explicit in the step, is
    unstable (dt x rate above 2) and the run stops, saying so."""
    _, record = quick_study
    for key in ("ball_drop", "box_drop"):
        assert all(r["complete"] for r in _hard_runs(record, key).values()), key
    quadruped = _hard_runs(record, "quadruped_drop")
    assert all(r["complete"] for step, r in quadruped.items() if step <= 2e-3)
    assert quadruped[1e-2]["status"] == "failed"
    assert "PD damping" in quadruped[1e-2]["reason"]
    for key in ("ball_drop", "quadruped_drop", "box_drop"):
        stability = _contact_scene(record, key)["hard"]["stability"]
        assert stability["largest_usable"] >= 2e-3, key


def test_hard_contact_penetrates_only_what_a_step_carries_past_its_margin(quick_study):
    """The hard model leaves nothing deeper than 1e-6 m at its finest step. A contact farther
    than the margin at a step's start has no row in it, so the ball (falling 0.5 m, reaching
    the ground at up to sqrt(2 g h) + g dt) ends a step at most v dt - margin deep."""
    _, record = quick_study
    for res in record["contact"]["scenes"]:
        assert res["hard"]["reference"]["penetration_max"] < 1e-6, res["key"]
    g, h = 9.81, 0.5
    margin = _contact_scene(record, "ball_drop")["hard"]["settings"]["margin"]
    for step, r in _hard_runs(record, "ball_drop").items():
        reach = ((2 * g * h) ** 0.5 + g * step) * step - margin
        assert r["penetration_max"] <= max(reach, 0.0) + 1e-6, r
    # measured 18 mm at 10 ms, 0.7 mm at 1 ms: a step that crosses the margin sinks in
    assert _hard_runs(record, "ball_drop")[1e-2]["penetration_max"] > 1e-3


@pytest.mark.parametrize("scene", ["ball_drop", "quadruped_drop"])
def test_hard_model_converges_at_first_order(quick_study, scene):
    """The max error against the hard model's finest run, fitted from ten times that step up:
    the velocity-level step is first order (measured 1.15 on the ball, 1.06 on Solo12)."""
    _, record = quick_study
    assert _contact_scene(record, scene)["hard"]["order"] == pytest.approx(1.0, abs=0.2)


def test_the_rigid_ball_stops_where_the_compliant_one_bounces(quick_study):
    """The hard model's impact is inelastic: the ball stays on the ground, while on the
    undamped spring (k = 1e5) it leaves at its landing speed v after (pi + 2 atan(g / (w v))) / w
    (w = sqrt(k / m)) and rises. At the end they are that rise apart; on Solo12 and the box the
    two models land within 2 cm (or rad) of each other (measured 4.5e-3 and 1.7e-3)."""
    _, record = quick_study
    res = _contact_scene(record, "ball_drop")
    m, g, k, h = 1.0, 9.81, 1e5, 0.5
    v, w = (2 * g * h) ** 0.5, (k / m) ** 0.5
    lift_off = (2 * h / g) ** 0.5 + (np.pi + 2 * np.arctan(g / (w * v))) / w
    flight = res["duration"] - lift_off
    rise = v * flight - g * flight**2 / 2
    finest = _hard_runs(record, "ball_drop")[res["hard"]["reference"]["step"]]
    assert finest["compliant_final"] == pytest.approx(rise, rel=1e-6)
    for key in ("quadruped_drop", "box_drop"):
        hard = _contact_scene(record, key)["hard"]
        assert _hard_runs(record, key)[hard["reference"]["step"]]["compliant_max"] < 2e-2, key


def test_study_page_shows_the_hard_rows_it_recorded(quick_study):
    """Each contact scene's section of study.md has the hard model's table, one row per run
    with its step and recorded errors, and the usable-step table the recorded steps."""
    out, record = quick_study
    text = (out / "study.md").read_text()
    for res in record["contact"]["scenes"]:
        section = text.split(f"\n### {res['title']}, {res['duration']:g} s\n", 1)[1]
        rows = markdown_table(section, "#### The hard model")
        assert len(rows) == len(res["hard"]["runs"]), res["key"]
        for cells, r in zip(rows, res["hard"]["runs"]):
            assert cells[0] == f"dt {r['step'] * 1e3:g} ms"
            if r["complete"]:
                assert cells[1:4] == [
                    f"{r[key]:.1e}" for key in ("error_final", "error_max", "compliant_max")
                ]
                assert cells[6] == str(r["unconverged_steps"])
            else:
                assert cells[1].startswith("failed")
    usable = markdown_table(text, "### The largest usable step of each contact model")
    assert len(usable) == len(record["contact"]["scenes"])
    for cells, res in zip(usable, record["contact"]["scenes"]):
        assert cells[0].startswith(res["title"])
        assert cells[1] == f"{res['hard']['stability']['largest_usable'] * 1e3:g} ms"
