"""The documentation works as written: every command of its ```bash blocks exits 0, its
```python blocks run in order (page by page), its ```toml scenes load; the README is short and
its quick start is the commands CI runs; CONTRIBUTING's layout is the package's tree; and the
site builds with `mkdocs build --strict`, its generated references hold every public name, scene
key and command, and headless Chromium finds a function by the site's search, draws a reference
page and shows a figure."""

from __future__ import annotations

import functools
import http.server
import os
import pathlib
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
import threading
import urllib.request

import matplotlib.image
import numpy as np
import pytest

import opendyn as od
from opendyn.cli.main import main
from opendyn.io.scene.files import tomllib
from opendyn.io.scene.keys import scene_keys
from opendyn.io.urdf import resolve_robot, shipped_robots_dir

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
# the pages whose examples run here; docs/developing.md's module is built and tested by
# tests/test_adding_an_effect.py
PAGES = ["README.md", "CONTRIBUTING.md"] + sorted(
    p.relative_to(ROOT).as_posix() for p in DOCS.rglob("*.md") if p.name != "developing.md"
)

# commands the pages show that this test does not run, and why; each must still be shown
NOT_RUN_HERE = {
    "pip install .": "installing: CI runs the quick start in a fresh virtual environment",
    'pip install ".[test]"': "installing: CI runs the quick start in a fresh virtual environment",
    'pip install ".[docs]"': "installing: the site is built below from this environment",
    'pip install -e ".[test,bench,docs]"': "installing, for development",
    "python -m pytest": "the test suite that runs this test",
    "python -m pytest -q tests/test_effects_registry.py": "a file of this test suite",
    "mkdocs serve": "a server that runs until stopped; the site fixture builds the site",
    "mkdocs build --strict": "run by the site fixture below",
    "python scripts/build_wheel.py": "building the whole wheel: tests/test_wheel.py builds one "
    "for the default scene, and CI builds and checks the whole",
    "pip install dist/opendyn-*.whl": "installing the wheel: tests/test_wheel.py and CI do",
    "python scripts/bench_core.py --quick": "a benchmark: timings are never taken by tests",
    "python scripts/bench_sim.py --quick": "a benchmark: timings are never taken by tests",
    "python scripts/bench_coldstart.py --quick": "a benchmark: timings are never taken by tests",
    "NUMBA_CACHE_DIR=$(mktemp -d) opendyn simulate --no-save -q": "a cold start in an empty "
    "cache, which the benchmarks measure; the same command warm runs in the other tests",
}


def text(page):
    return (ROOT / page).read_text(encoding="utf-8")


def blocks(page, language):
    """The fenced code blocks of a page in that language, in order, a block indented in a
    list item dedented."""
    found = re.findall(rf"^( *)```{language}\n(.*?)^\1```", text(page), re.M | re.S)
    return [textwrap.dedent(code) for _, code in found]


def bash_commands(page):
    """Every command of the page's bash blocks: one per line, comments dropped, `a && b`
    split."""
    commands = []
    for block in blocks(page, "bash"):
        for line in block.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            commands += [part.strip() for part in line.split("&&") if part.strip()]
    return commands


COMMANDS = sorted({c for page in PAGES for c in bash_commands(page) if c not in NOT_RUN_HERE})


def test_the_readme_is_short_and_its_quick_start_is_what_ci_runs():
    readme = text("README.md")
    assert len(readme.splitlines()) <= 200
    quick = blocks("README.md", "bash")[:2]
    assert quick == ["pip install . && opendyn simulate\n",
                     'pip install ".[test]" && python -m pytest\n']
    ci = (ROOT / ".ci" / "run").read_text()
    assert """'^pip install "\\.\\[test\\]"'""" in ci  # CI runs the README's line, verbatim


# run before the README's example: example-robot-data looks uninstalled, as after `pip install .`
_WITHOUT_EXAMPLE_ROBOT_DATA = """
import importlib.metadata as metadata
_distribution = metadata.distribution
def distribution(name):
    if name == "example-robot-data":
        raise metadata.PackageNotFoundError(name)
    return _distribution(name)
metadata.distribution = distribution
"""


def test_the_readme_example_needs_nothing_beyond_the_readmes_install(tmp_path):
    """The README's Python example and its commands (the playback included) run right after
    `pip install .` (and the viz extra): in a process where example-robot-data looks missing,
    they exit cleanly, so they name only the robots and scenes opendyn ships."""
    commands = [c for c in bash_commands("README.md") if c.split()[0] == "opendyn"]
    assert commands and any("--html" in c for c in commands), commands
    code = "\n".join(
        [_WITHOUT_EXAMPLE_ROBOT_DATA, *blocks("README.md", "python"), "import shlex",
         "from opendyn.cli.main import main"]
        + [f"assert main(shlex.split({c!r})[1:]) == 0, {c!r}" for c in commands]
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=900
    )
    assert proc.returncode == 0, proc.stderr
    assert od.Trajectory.load(tmp_path / "swing.npz").complete


def test_the_pages_show_the_commands_they_leave_to_ci_and_to_other_tests():
    shown = {c for page in PAGES for c in bash_commands(page)}
    assert set(NOT_RUN_HERE) <= shown, set(NOT_RUN_HERE) - shown
    assert all(c.split()[0] == "opendyn" for c in COMMANDS), COMMANDS


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_shown_exits_zero(command, tmp_path, monkeypatch, capsys):
    """Run as the pages show it, from a folder holding the repository's robots/ (the commands
    name robots/...): exit status 0 and nothing on stderr that says error."""
    (tmp_path / "robots").symlink_to(ROOT / "robots")
    monkeypatch.chdir(tmp_path)
    status = main(shlex.split(command)[1:])
    out, err = capsys.readouterr()
    assert status == 0, f"{command!r} exited {status}:\n{err}"
    assert "error" not in err.lower(), err


def run_page(page, tmp_path, monkeypatch):
    """Run the page's python blocks in order in one namespace, as a script, in tmp_path."""
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}  # as a script's, which the sweep example needs
    for code in blocks(page, "python"):
        exec(compile(code, page, "exec"), namespace)
    return namespace


# what some pages' examples leave behind, checked beyond running without an error
CHECKS = {
    "README.md": lambda ns, tmp: (
        od.Trajectory.load(tmp / "swing.npz").complete and (tmp / "swing.png").is_file()
    ),
    "docs/getting-started.md": lambda ns, tmp: (tmp / "run.npz").is_file(),
    "docs/guides/dynamics.md": lambda ns, tmp: ns["taus"].shape == (10_000, 6),
    "docs/guides/constraints.md": lambda ns, tmp: (
        ns["lam"].shape == (3,) and abs(ns["lam"][2]) < 1e-9  # "its z row is 0 (rank 2)"
    ),
    "docs/guides/sweeps.md": lambda ns, tmp: (
        ns["table"].num_rows == 6 and (tmp / "pendulum.png").is_file()
    ),
}


def _free_fall(ns, tmp):
    """centroidal.md: a free-falling robot's momentum changes by gravity alone, dh_G = (0, m g);
    the payload found is the one added; the base parameters are the loaded UR5's own (noise-free
    torques)."""
    m = float(np.sum(ns["solo"].mass))
    np.testing.assert_allclose(ns["dh_G"], [0, 0, 0, 0, 0, -9.81 * m], rtol=0, atol=1e-9 * m)
    found = ns["found"]
    assert abs(found.mass - 2.5) < 1e-8
    np.testing.assert_allclose(found.com, [0, 0, 0.05], atol=1e-8)
    base = ns["base"]
    truth = base.base @ ns["payload"].inertial_parameters()
    np.testing.assert_allclose(base.parameters, truth, rtol=1e-6, atol=1e-8)
    return True


def _held_still(ns, tmp):
    """controllers.md: gravity compensation plus PD about the start, from rest, holds the arm
    where it started (its gravity torque is met exactly, so qdd = 0)."""
    traj, q_ref = ns["traj"], ns["q_ref"]
    assert traj.t[-1] >= 1.0 - 1e-9
    assert np.abs(traj.q - q_ref).max() < 1e-9 and np.abs(traj.qd).max() < 1e-9
    return True


def _inverse_pairs(ns, tmp):
    """derivatives.md: dtau/dqdd = M and d qdd/d tau = M^-1 (two algorithms) are inverses; the
    discrete pendulum linearised upright is unstable (an eigenvalue outside the unit circle)
    and at rest in its own coordinates (x = 0 maps to 0: A's top right block is ~dt I)."""
    M, Minv = ns["M"], ns["Minv"]
    np.testing.assert_allclose(M @ Minv, np.eye(6), atol=1e-9)
    eigenvalues = np.linalg.eigvals(ns["A"])
    assert np.abs(eigenvalues).max() > 1.0 and np.abs(eigenvalues).min() < 1.0
    return True


def _summary(ns, tmp, out):
    """robots.md: the summary counts the URDF's moving joints (six revolute ones, read from the
    file by xml.etree) and names each."""
    import xml.etree.ElementTree as ET

    root = ET.parse(resolve_robot("ur5"))
    moving = [j.get("name") for j in root.findall("joint") if j.get("type") != "fixed"]
    assert len(moving) == 6 and "nq=6, nv=6" in out
    assert all(name in out for name in moving)
    return True


def _sag(ns, tmp):
    """rollouts.md: the runs settle towards the PD's static equilibrium under gravity,
    kp (q0 - q) = g(q), solved here by fixed-point iteration: the mean offset has its sign and
    size (to 10%: at 1 s the runs, started up to 0.5 rad away, are still settling)."""
    scene, sag = ns["scene"], ns["sag"]
    q = scene.q0.copy()
    for _ in range(50):
        q = scene.q0 - od.gravity_forces(scene.model, q) / 300.0
    expected = q - scene.q0
    assert np.abs(expected).max() > 0.1  # gravity does hold the arm off its setpoint
    assert np.abs(sag - expected).max() < 0.1 * np.abs(expected).max(), (sag, expected)
    return True


def _scene_run(ns, tmp):
    """scenes.md: the saved run is the run; the energy balance closes (E - E(0) = the work of
    the applied and passive forces); the plot is drawn."""
    traj = ns["traj"]
    loaded = od.Trajectory.load(tmp / "run.npz")
    np.testing.assert_array_equal(loaded.q, traj.q)
    balance = traj.energy - traj.energy[0] - traj.work_applied - traj.work_passive
    assert np.abs(balance).max() < 1e-6 * np.abs(traj.kinetic).max()
    image = matplotlib.image.imread(tmp / "run.png")[..., :3]
    assert (image < 0.95).any(axis=-1).mean() > 0.02  # not blank
    scene = ns["scene"]
    assert scene.run.integrator == "dopri5" and scene.run.duration == 2.0
    return True


def _exp_map(ns, tmp):
    """conventions.md: spinning at 1 rad/s about its own x axis for 1 ms, the base turns by
    1e-3 rad about x and stays where it was; in free fall its momentum changes by m g alone."""
    model, q, v, q_next = ns["model"], ns["q"], ns["v"], ns["q_next"]
    np.testing.assert_allclose(q_next[:3], [0, 0, 0.3], atol=1e-15)
    np.testing.assert_allclose(q_next[3:7], [np.sin(5e-4), 0, 0, np.cos(5e-4)], atol=1e-15)
    np.testing.assert_array_equal(q_next[7:], q[7:])
    dh = od.centroidal_momentum_matrix(model, q) @ ns["qdd"] + od.centroidal_momentum_rate_bias(
        model, q, v
    )
    m = float(np.sum(model.mass))
    np.testing.assert_allclose(dh, [0, 0, 0, 0, 0, -9.81 * m], rtol=0, atol=1e-9 * m)
    return True


def _nearest_pair(ns, tmp):
    """collision.md: the nearest pair's points are `distance` apart along the unit normal, and
    od.collisions gives every default pair closer than the margin (od.distances brute force).
    With its SRDF the Panda at q = 0 is in no self-collision (without it, the hand and link5
    were 41 mm into each other), and a mesh geometry prints as one line, not its vertices."""
    d, k = ns["d"], ns["k"]
    assert d.distance.min() > 0 and len(ns["model"].collision_pairs) == 44
    assert "\n" not in repr(ns["model"].geometries[0]) and "hull of" in repr(
        ns["model"].geometries[0]
    )
    np.testing.assert_allclose(d.point_b[k] - d.point_a[k], d.distance[k] * d.normal[k], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(d.normal[k]), 1.0, rtol=1e-12)
    near = {tuple(p) for p, x in zip(d.pairs, d.distance) if x < 0.005}
    return {tuple(p) for p in ns["contacts"].pairs} == near


CHECKS.update({
    "docs/guides/centroidal.md": _free_fall,
    "docs/guides/collision.md": _nearest_pair,
    "docs/guides/controllers.md": _held_still,
    "docs/guides/derivatives.md": _inverse_pairs,
    "docs/guides/rollouts.md": _sag,
    "docs/guides/scenes.md": _scene_run,
    "docs/reference/conventions.md": _exp_map,
})
PRINTING_CHECKS = {"docs/guides/robots.md": _summary}  # checks of what the page prints
PYTHON_PAGES = [page for page in PAGES if blocks(page, "python")]


@pytest.mark.parametrize("page", PYTHON_PAGES)
def test_every_pages_python_examples_run_in_order(page, tmp_path, monkeypatch, capsys):
    """Each page's examples run, and what they compute is checked: every page with python
    blocks has a check (CHECKS, or PRINTING_CHECKS of its printed text)."""
    namespace = run_page(page, tmp_path, monkeypatch)
    out = capsys.readouterr().out
    assert page in CHECKS or page in PRINTING_CHECKS, f"{page}: no check of its examples"
    if page in CHECKS:
        assert CHECKS[page](namespace, tmp_path)
    else:
        assert PRINTING_CHECKS[page](namespace, tmp_path, out)


def test_the_checked_pages_have_their_examples():
    assert set(CHECKS) <= set(PYTHON_PAGES)


def test_the_scene_examples_load_and_the_complete_one_runs():
    """The complete scene example runs (0.1 s); each fragment loads with the robot of its
    section: the floating base (Solo12, complete), the payload (UR5, complete), contact on
    Solo12, the objects and world of the contact between geometries (complete: a scene of
    objects alone), the hard model's run and contact on those objects, constraints on the
    shipped four-bar scene's initial state."""
    (full,) = (tomllib.loads(b) for b in blocks("docs/guides/scenes.md", "toml"))
    floating, payload = (tomllib.loads(b) for b in blocks("docs/guides/robots.md", "toml"))
    contact, hard, geometry = (
        tomllib.loads(b) for b in blocks("docs/guides/contact.md", "toml")
    )
    (constraints,) = (tomllib.loads(b) for b in blocks("docs/guides/constraints.md", "toml"))
    scene = od.scene_from_dict(full, base_dir=shipped_robots_dir())
    assert scene.effects == ("gravity", "damping", "wrench", "control")
    assert od.simulate(scene.replace_run(duration=0.1)).complete
    solo = od.scene_from_dict(floating)
    assert solo.model.floating_base and solo.q0[2] == 1.0
    loaded = od.scene_from_dict(payload).model
    assert loaded.mass.sum() == pytest.approx(od.load_urdf("ur5").mass.sum() + 2.5)
    on_ground = od.scene_from_dict({**floating, **contact})
    assert [p.frame for p in on_ground.contact.points] == ["FL_FOOT"]
    boxed = od.scene_from_dict(geometry)
    assert boxed.model.objects == ("box",) and boxed.model.world == ("table",)
    # gravity named: pasted alone, the box rests on the table instead of floating
    assert boxed.effects == ("gravity", "contact") and boxed.contact.pairs[0].law.friction == 0.2
    # the hard model's fragment, on the same objects: contact as constraints of the step
    effects = {**geometry["effects"], **hard["effects"]}
    held = od.scene_from_dict({**geometry, "run": hard["run"], "effects": effects})
    assert held.effects == ("gravity", "contact") and held.contact.hard is not None
    four_bar = tomllib.loads((shipped_robots_dir() / "four_bar.toml").read_text())
    del four_bar["constraints"], four_bar["baumgarte"]  # the fragment's, on the same state
    closed = od.scene_from_dict({**four_bar, **constraints}, base_dir=shipped_robots_dir())
    assert len(closed.constraints) == 1 and closed.baumgarte == (20.0, 20.0)


def layout_modules():
    """The Python files CONTRIBUTING's Layout section lists under opendyn/: its tree block, two
    spaces of indent a level, a folder ending in '/'; a line indented deeper than the level
    it could open continues the description above it."""
    section = text("CONTRIBUTING.md").split("## Layout", 1)[1]
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
    """One line per module: CONTRIBUTING's Layout is the package's tree."""
    package = ROOT / "opendyn"
    modules = {
        p.relative_to(ROOT).as_posix()
        for p in package.rglob("*.py")
        if "__pycache__" not in p.parts
    }
    listed = layout_modules()
    assert listed == modules, (
        f"in the package, not in CONTRIBUTING.md: {sorted(modules - listed)}; "
        f"in CONTRIBUTING.md, not in the package: {sorted(listed - modules)}"
    )


# --- the site ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site as `mkdocs build --strict` writes it: any warning (a broken link, a page the
    navigation names that is missing, a docstring mkdocstrings cannot read) fails the build."""
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert done.returncode == 0, done.stderr[-4000:]
    return out


def test_the_site_builds_strictly_with_every_page_of_its_navigation(site):
    for page in ("index.html", "getting-started/index.html", "guides/scenes/index.html",
                 "reference/api/index.html", "performance/core/index.html",
                 "study/study/index.html", "search/search_index.json"):
        assert (site / page).is_file(), page


def test_the_api_reference_holds_every_public_name(site):
    page = (site / "reference" / "api" / "index.html").read_text(encoding="utf-8")
    documented = set(re.findall(r'id="opendyn\.(\w+)"', page))
    assert set(od.__all__) <= documented, set(od.__all__) - documented


def test_the_scene_file_reference_holds_every_key_the_reader_takes(site):
    page = (site / "reference" / "scene-file" / "index.html").read_text(encoding="utf-8")
    # a key in the Keys lists; a table as its section's heading, [robot] or [effects.wrench]
    missing = [
        key for key in scene_keys()
        if f"<code>{key}</code>" not in page and f"<code>[{key}]</code>" not in page
    ]
    assert not missing, missing
    assert len(scene_keys()) > 80


def test_the_command_line_and_effects_references_are_generated(site):
    from opendyn.cli.main import command_line
    from opendyn.sim.effects import registry

    page = (site / "guides" / "cli" / "index.html").read_text(encoding="utf-8")
    commands = next(a for a in command_line()._actions if a.dest == "command").choices
    for name in commands:
        assert f"usage: opendyn {name}" in page, name
    scenes = (site / "guides" / "scenes" / "index.html").read_text(encoding="utf-8")
    for name in registry.names():
        assert f"<td>{name}</td>" in scenes, name


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if shutil.which(name):
            return shutil.which(name)
    pytest.skip("headless Chromium is not installed (no chromium on PATH; .ci/run installs it)")


@pytest.fixture(scope="module")
def served(site):
    """The built site over HTTP on a free local port (the search runs in a web worker, which
    a file:// page may not start)."""
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    handler = functools.partial(Quiet, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()


def in_browser(url, expression, profile, timeout_s=60):
    """The value of the JavaScript `expression` on the page at `url` in headless Chromium, as
    soon as it is truthy (it is evaluated every half second, in real time: the site's search
    runs in a web worker, which a virtual time budget does not advance), or None after
    timeout_s. Driven over the DevTools protocol (a websocket, tornado's client)."""
    import asyncio
    import json
    import socket
    import time

    import tornado.websocket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    browser = subprocess.Popen(
        [chromium(), "--headless", "--no-sandbox", "--disable-gpu",
         f"--remote-debugging-port={port}", "--remote-allow-origins=*",
         f"--user-data-dir={profile}", url],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    deadline = time.time() + timeout_s
    try:
        pages = []
        while not pages and time.time() < deadline:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/json") as response:
                    pages = [t for t in json.load(response) if t["type"] == "page"]
            except OSError:
                time.sleep(0.2)
        assert pages, "headless Chromium opened no page"

        async def poll():
            connection = await tornado.websocket.websocket_connect(
                pages[0]["webSocketDebuggerUrl"]
            )
            call = 0
            while time.time() < deadline:
                call += 1
                connection.write_message(json.dumps({
                    "id": call, "method": "Runtime.evaluate",
                    "params": {"expression": expression, "returnByValue": True},
                }))
                while (answer := json.loads(await connection.read_message())).get("id") != call:
                    pass
                value = answer["result"]["result"].get("value")
                if value:
                    return value
                await asyncio.sleep(0.5)
            return None

        return asyncio.run(poll())
    finally:
        browser.kill()
        browser.wait()


def test_the_built_site_in_a_browser_finds_draws_and_shows(served, tmp_path):
    """Search: the search box, given `mass_matrix` (?q=), lists the API reference's entry; the
    API reference draws its rendered docstrings; the playback guide shows its figure, decoded
    by the browser."""
    links = in_browser(
        f"{served}/?q=mass_matrix",
        "Array.from(document.querySelectorAll('.md-search-result__link')).map(a => a.href)",
        tmp_path / "search",
    )
    assert links and any("reference/api/" in a and "#opendyn.mass_matrix" in a for a in links)
    drawn = in_browser(
        f"{served}/reference/api/",
        "(e => e && e.closest('.doc-object').innerText)"
        "(document.getElementById('opendyn.inverse_dynamics'))",
        tmp_path / "api",
    )
    assert drawn and "inverse_dynamics" in drawn and "RNEA" in drawn
    width = in_browser(
        f"{served}/guides/playback/",
        "(i => i && i.complete ? i.naturalWidth : 0)(document.querySelector('article img'))",
        tmp_path / "figure",
    )
    assert width and width > 200


def test_formulas_are_drawn_and_code_wraps_without_the_network(site, served, tmp_path):
    """The dynamics guide's formulas are drawn by KaTeX, which the site serves itself (no page
    loads a script or a style from another host), and a code block's long line wraps within
    the page instead of being cut off."""
    for page in site.rglob("*.html"):
        html = page.read_text(encoding="utf-8")
        outside = re.findall(r'<(?:script|link)[^>]+(?:src|href)="(https?:[^"]+)"', html)
        assert not outside, (page.relative_to(site), outside)
    assert (site / "assets" / "katex" / "katex.min.js").is_file()
    guide = (site / "guides" / "dynamics" / "index.html").read_text(encoding="utf-8")
    assert guide.count('class="arithmatex"') >= 10
    drawn = in_browser(
        f"{served}/guides/dynamics/",
        "document.querySelectorAll('.arithmatex .katex').length",
        tmp_path / "math",
    )
    assert drawn and drawn >= 10
    wrapped = in_browser(
        f"{served}/guides/dynamics/",
        "(c => c && getComputedStyle(c).whiteSpace)(document.querySelector('pre > code'))",
        tmp_path / "wrap",
    )
    assert wrapped == "pre-wrap"
