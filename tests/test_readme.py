"""Every example in the README works as written: each command of its ```bash blocks exits 0, its
```python blocks run in order, and its ```toml scenes load (the fragments with the robot their
section is about)."""

from __future__ import annotations

import pathlib
import re
import shlex

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.main import main
from opendyn.io.scene.files import tomllib
from opendyn.io.urdf import shipped_robots_dir

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")

# commands the README shows that this test does not run, and why; each must still be in it
NOT_RUN_HERE = {
    "pip install .": "installing: CI runs the quick start in a fresh virtual environment",
    'pip install ".[test]"': "installing: CI runs the quick start in a fresh virtual environment",
    "python -m pytest": "the test suite that runs this test",
    "python scripts/accuracy_vs_time.py --docs": "the full study, 4.5 min, written into docs/; "
    "its --quick mode runs the same code on small sweeps, in tests/test_accuracy_study.py",
    "python scripts/accuracy_vs_time.py --quick": "run, and its output checked, by "
    "tests/test_accuracy_study.py",
}


def blocks(language):
    """The fenced code blocks of the README in that language, in order."""
    return re.findall(rf"^```{language}\n(.*?)^```", README, re.M | re.S)


def bash_commands():
    """Every command of the bash blocks: one per line, comments dropped, `a && b` split."""
    commands = []
    for block in blocks("bash"):
        for line in block.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            commands += [part.strip() for part in line.split("&&") if part.strip()]
    return commands


COMMANDS = [c for c in bash_commands() if c not in NOT_RUN_HERE]


def test_the_readme_shows_the_commands_it_leaves_to_ci_and_to_other_tests():
    shown = bash_commands()
    assert set(NOT_RUN_HERE) <= set(shown), set(NOT_RUN_HERE) - set(shown)
    assert all(c.split()[0] == "opendyn" for c in COMMANDS), COMMANDS
    study_test = (ROOT / "tests" / "test_accuracy_study.py").read_text()
    assert '"--quick"' in study_test and "accuracy_vs_time.py" in study_test


@pytest.mark.parametrize("command", COMMANDS)
def test_every_readme_command_exits_zero(command, tmp_path, monkeypatch, capsys):
    """Run as the README shows it, from a folder holding the repository's robots/ (the commands
    name robots/...): exit status 0 and nothing on stderr that says error."""
    (tmp_path / "robots").symlink_to(ROOT / "robots")
    monkeypatch.chdir(tmp_path)
    argv = shlex.split(command)
    status = main(argv[1:])
    out, err = capsys.readouterr()
    assert status == 0, f"{command!r} exited {status}:\n{err}"
    assert "error" not in err.lower(), err


def test_the_readme_python_examples_run_in_order(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}  # as a script's, which the sweep example needs
    for code in blocks("python"):
        exec(compile(code, "README.md", "exec"), namespace)
    assert namespace["taus"].shape == (10_000, 6)
    assert (tmp_path / "run.npz").is_file() and (tmp_path / "run.png").is_file()
    assert od.Trajectory.load(tmp_path / "run.npz").complete
    lam = namespace["lam"]
    assert lam.shape == (3,) and np.all(np.isfinite(lam))
    assert abs(lam[2]) < 1e-9  # "its z row is 0 (planar, rank 2)", as its comment says
    assert namespace["table"].num_rows == 6 and (tmp_path / "pendulum.png").is_file()


def test_the_readme_scenes_load_and_the_full_example_runs():
    """The complete scene example runs (0.1 s); each fragment loads with the robot of its
    section: the floating base (Solo12, complete), the payload (UR5, complete), contact on
    Solo12, constraints on the shipped four-bar scene's initial state."""
    floating, payload, contact, full, constraints = (tomllib.loads(b) for b in blocks("toml"))
    scene = od.scene_from_dict(full, base_dir=shipped_robots_dir())
    assert scene.effects == ("gravity", "damping", "wrench", "control")
    assert od.simulate(scene.replace_run(duration=0.1)).complete
    solo = od.scene_from_dict(floating)
    assert solo.model.floating_base and solo.q0[2] == 1.0
    loaded = od.scene_from_dict(payload).model
    assert loaded.mass.sum() == pytest.approx(od.load_urdf("ur5").mass.sum() + 2.5)
    on_ground = od.scene_from_dict({**floating, **contact})
    assert [p.frame for p in on_ground.contact.points] == ["FL_FOOT"]
    four_bar = tomllib.loads((shipped_robots_dir() / "four_bar.toml").read_text())
    del four_bar["constraints"], four_bar["baumgarte"]  # the fragment's, on the same state
    closed = od.scene_from_dict({**four_bar, **constraints}, base_dir=shipped_robots_dir())
    assert len(closed.constraints) == 1 and closed.baumgarte == (20.0, 20.0)


def layout_modules():
    """The Python files the README's Layout section lists under opendyn/: its tree block, two
    spaces of indent a level, a folder ending in '/'; a line indented deeper than the level
    it could open continues the description above it."""
    section = README.split("## Layout", 1)[1]
    tree = re.search(r"^```\n(opendyn/\n.*?)^```", section, re.M | re.S).group(1)
    listed, folders = set(), []
    for line in tree.splitlines():
        if not line.strip():
            continue
        depth = (len(line) - len(line.lstrip())) // 2
        if depth > len(folders):
            continue  # a description's second line
        name = line.split()[0]
        if depth == 0 and name != "opendyn/":
            break  # past the package: robots/, tests/, ...
        del folders[depth:]
        if name.endswith("/"):
            folders.append(name.rstrip("/"))
        elif name.endswith(".py"):
            listed.add("/".join(folders + [name]))
    return listed


def test_the_layout_section_lists_every_module_of_the_package_and_no_other():
    """One line per module: the README's Layout is the package's tree."""
    package = ROOT / "opendyn"
    modules = {
        p.relative_to(ROOT).as_posix()
        for p in package.rglob("*.py")
        if "__pycache__" not in p.parts
    }
    listed = layout_modules()
    assert listed == modules, (
        f"in the package, not in the README: {sorted(modules - listed)}; "
        f"in the README, not in the package: {sorted(listed - modules)}"
    )
