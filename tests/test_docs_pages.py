"""The benchmark scripts' pages (scripts/docs_page.py): a header that says when, where and with
what a page was measured and the command that reproduces it, what the script printed below it,
and a page written only when asked (--docs). Nothing here runs a benchmark or times anything."""

from __future__ import annotations

import datetime
import importlib.util
import os
import pathlib
import platform
import stat
import subprocess
import sys

import numba
import numpy as np
import pytest

import opendyn as od

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "scripts"
PUBLISHED_STUDY = ROOT / "docs" / "study"
# each benchmark script, its page, and the modules it needs beyond opendyn's own
BENCHMARKS = {
    "bench_core.py": ("core.md", ("pinocchio",)),
    "bench_sim.py": ("simulation.md", ("pinocchio", "mujoco")),
    "bench_sweep.py": ("sweeps.md", ("mujoco",)),
    "bench_coldstart.py": ("startup.md", ()),
    "bench_scenes.py": ("scenes.md", ()),
    "bench_collision.py": ("collision.md", ("pinocchio",)),
    "bench_contact.py": ("contact.md", ("mujoco",)),
    "bench_hard_contact.py": ("hard-contact.md", ("mujoco", "pinocchio")),
}


def load_script(name):
    """The module of scripts/NAME.py, loaded from its file, with scripts/ on the path for its
    sibling imports (as when it is run)."""
    if str(SCRIPTS) not in sys.path:
        sys.path.insert(0, str(SCRIPTS))
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def docs_page():
    return load_script("docs_page")


@pytest.fixture(scope="module")
def study():
    return load_script("accuracy_vs_time")


def current_umask():
    """This process's umask."""
    umask = os.umask(0)
    os.umask(umask)
    return umask


def test_the_header_says_when_where_with_what_and_how(docs_page):
    pin = pytest.importorskip("pinocchio")
    when = datetime.datetime(2026, 11, 26, 14, 3, 12, tzinfo=datetime.timezone.utc)
    text = docs_page.header(
        "Core functions", "/any/folder/bench_core.py", ["--quick", "--docs"], ("pinocchio",), when
    )
    assert text.startswith("# Core functions\n\n")
    assert "`scripts/bench_core.py`" in text and "do not edit this page by hand" in text
    assert "2026-11-26 14:03:12 UTC" in text
    assert f"{os.cpu_count()} cores" in text and docs_page.cpu_model() in text
    assert platform.platform() in text and platform.python_version() in text
    for version in (
        f"opendyn {od.__version__}",
        f"numba {numba.__version__}",
        f"numpy {np.__version__}",
        f"Pinocchio {pin.__version__}",
    ):
        assert version in text
    assert "MuJoCo" not in text  # only the modules the script names
    assert "`python scripts/bench_core.py --quick --docs`" in text
    assert "/any/folder" not in text
    assert text.endswith("\n\n")


def test_the_command_is_quoted_for_a_shell(docs_page):
    command = docs_page.command("bench_scenes.py", ["--against", "a folder", "ur5_falling"])
    assert command == "python scripts/bench_scenes.py --against 'a folder' ur5_falling"


def test_a_module_that_is_not_installed_is_named_so(docs_page):
    assert "no_such_module not installed" in docs_page.versions(("no_such_module",))


def test_a_page_is_header_and_what_was_printed(docs_page, tmp_path, capsys):
    with docs_page.page(
        "core.md", "Core", enabled=True, script="bench_core.py", argv=["--docs"], folder=tmp_path
    ):
        print("| a | b |\n|---|---|\n| 1 | 2 |")
    assert capsys.readouterr().out == "| a | b |\n|---|---|\n| 1 | 2 |\n"  # printed as before
    text = (tmp_path / "core.md").read_text()
    assert text.startswith("# Core\n\n")
    table = "| a | b |\n|---|---|\n| 1 | 2 |\n"
    assert text.endswith("`python scripts/bench_core.py --docs`\n\n" + table)
    assert [p.name for p in tmp_path.iterdir()] == ["core.md"]  # no temporary file left
    # as open() would make it, readable by all under the usual umask, not mkstemp's 0600
    assert stat.S_IMODE((tmp_path / "core.md").stat().st_mode) == 0o666 & ~current_umask()


def test_printed_lines_stay_lines_on_the_page(docs_page, tmp_path, capsys):
    """Two plain lines printed one after the other are two paragraphs on the page (Markdown
    would join them into one); tables and lists are left as they are."""
    with docs_page.page("sim.md", "Sim", enabled=True, script="b.py", argv=[], folder=tmp_path):
        print("robot: ur5\nmass: 16.99 kg\n| a |\n|---|\n| 1 |\nsummary\n- one\n- two")
    assert capsys.readouterr().out.startswith("robot: ur5\nmass: 16.99 kg\n")  # the console
    text = (tmp_path / "sim.md").read_text()
    page = "robot: ur5\n\nmass: 16.99 kg\n\n| a |\n|---|\n| 1 |\n\nsummary\n- one\n- two\n"
    assert text.endswith(page)


def test_no_page_is_written_unless_asked(docs_page, tmp_path, capsys):
    stdout = sys.stdout
    with docs_page.page("core.md", "Core", enabled=False, folder=tmp_path):
        print("table")
    assert capsys.readouterr().out == "table\n"
    assert sys.stdout is stdout and list(tmp_path.iterdir()) == []


def test_a_run_that_fails_leaves_the_page_as_it_was(docs_page, tmp_path):
    (tmp_path / "core.md").write_text("the last complete run\n")
    stdout = sys.stdout
    with pytest.raises(RuntimeError):
        with docs_page.page("core.md", "Core", enabled=True, argv=[], folder=tmp_path):
            print("half a table")
            raise RuntimeError("interrupted")
    assert sys.stdout is stdout
    assert (tmp_path / "core.md").read_text() == "the last complete run\n"
    assert [p.name for p in tmp_path.iterdir()] == ["core.md"]


@pytest.mark.parametrize("script", sorted(BENCHMARKS))
def test_every_benchmark_takes_docs_and_names_its_page(script):
    page, modules = BENCHMARKS[script]
    for module in modules:
        pytest.importorskip(module)
    help_text = subprocess.run(
        [sys.executable, str(SCRIPTS / script), "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "--docs" in help_text and f"docs/performance/{page}" in help_text


def test_bench_core_refuses_docs_for_its_centroidal_table_alone(tmp_path):
    pytest.importorskip("pinocchio")
    proc = subprocess.run(
        [sys.executable, str(SCRIPTS / "bench_core.py"), "--centroidal", "--docs"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert proc.returncode == 2 and "--centroidal" in proc.stderr and proc.stdout == ""


@pytest.mark.parametrize(
    "argv, refusal",
    [
        (["--docs", "--quick"], "quick results must never replace it"),
        (["--docs", "--out", "x"], "not both"),
    ],
)
def test_the_study_refuses_to_publish_quick_results_or_elsewhere(study, argv, refusal, capsys):
    before = {p.name: p.read_bytes() for p in PUBLISHED_STUDY.iterdir()}
    with pytest.raises(SystemExit) as exit_:
        study.main(argv)
    assert exit_.value.code == 2 and refusal in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in PUBLISHED_STUDY.iterdir()} == before


def test_the_studys_trial_runs_go_to_the_current_folder(study):
    assert not pathlib.Path(study.DEFAULT_OUT).is_absolute()
    assert study.DOCS_OUT == PUBLISHED_STUDY


def test_bench_scenes_page_names_the_other_checkout_by_its_commit_not_its_path():
    """The other checkout's path is a path on the machine that ran it: the page's command says
    OTHER_CHECKOUT, and a line above the table names the checkout by its commit."""
    bench_scenes = load_script("bench_scenes")
    for argv in (["--against", "/home/me/old"], ["--against=/home/me/old"]):
        public = bench_scenes._public_argv([*argv, "--rounds", "3", "--docs"])
        assert "/home/me/old" not in " ".join(public)
        assert "OTHER_CHECKOUT" in " ".join(public) and public[-3:] == ["--rounds", "3", "--docs"]
    assert bench_scenes._described(pathlib.Path("/")) == "not a git checkout"
