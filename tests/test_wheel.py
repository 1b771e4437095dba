"""A wheel built by scripts/build_wheel.py carries its compiled kernels: installed on a machine
whose kernel cache is empty, its first run loads them and compiles nothing.

The suite builds a wheel that ships the default scene only (the whole wheel, every shipped
scene and public function, is built and checked the same way by .ci/run after the suite)."""

from __future__ import annotations

import importlib.util
import pathlib
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENE = "double_pendulum_swing"  # the default scene
OTHER = "double_pendulum_push"  # a scene the test wheel does not ship


def _build_wheel_script():
    script = ROOT / "scripts" / "build_wheel.py"
    spec = importlib.util.spec_from_file_location("build_wheel", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    if not (ROOT / "scripts" / "build_wheel.py").exists():
        pytest.skip("not a source checkout: scripts/ is missing")
    out = tmp_path_factory.mktemp("dist")
    return _build_wheel_script().build(out, [SCENE])


def test_the_wheel_carries_kernels_of_these_sources_for_its_platform(wheel):
    """Its DIGEST names the sources and the numba that compiled the kernels."""
    import numba

    from opendyn._runtime.kernel_cache import DIGEST

    assert wheel.name.startswith("opendyn-") and not wheel.name.endswith("-any.whl"), wheel.name
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        stamp = archive.read("opendyn/_kernels/DIGEST").decode()
        assert stamp == f"{DIGEST}\nnumba {numba.__version__}\n"
    kernels = [n for n in names if n.startswith("opendyn/_kernels/") and n.endswith(".nbc")]
    indexes = [n for n in names if n.startswith("opendyn/_kernels/") and n.endswith(".nbi")]
    assert kernels and indexes, names
    # filed by their folder inside the package, as the machine's cache files them
    assert any(n.startswith("opendyn/_kernels/sim/") for n in kernels), kernels


def test_the_wheels_first_run_compiles_nothing_in_an_empty_cache(wheel):
    """Installed into a new folder, with an empty per-user cache and no NUMBA_CACHE_DIR: the
    shipped scene's first `opendyn simulate` compiles for 0 s; a scene the wheel does not ship
    still runs, compiling as a source install does (the check sees the difference)."""
    results = {r["scene"]: r for r in _build_wheel_script().check(wheel, [SCENE, OTHER])}
    shipped = results[SCENE]
    assert shipped["status"] == 0
    assert shipped["shipped"].endswith("opendyn/_kernels"), shipped
    assert shipped["compiled_s"] == 0.0, shipped
    assert results[OTHER]["status"] == 0 and results[OTHER]["compiled_s"] > 0, results[OTHER]
