"""The kernel cache is written for one minor version of numba and reaches into its private API:
pyproject.toml pins that minor version; a wheel's shipped kernels record the numba that
compiled them, and under another numba are one warning and a compile, never a silent miss; a
numba that lacks one of the internals leaves the kernels to numba's own caching, with one
warning, and they still run."""

from __future__ import annotations

import ast
import os
import pathlib
import shutil
import subprocess
import sys

import numba
import numpy as np
import pytest
from packaging.requirements import Requirement
from packaging.version import Version

import opendyn
from opendyn._runtime import kernel_cache, numba_internals
from opendyn._runtime.kernel_cache import DIGEST, DIGEST_FILE

PACKAGE = pathlib.Path(opendyn.__file__).resolve().parent
PYPROJECT = PACKAGE.parent / "pyproject.toml"
NUMBA = Version(numba.__version__)

# a process that prints the UR5's M at one configuration (crba and forward kinematics)
_MASS_MATRIX = (
    "import numpy as np, opendyn as od\n"
    "model = od.load_urdf('ur5')\n"
    "print(repr(od.mass_matrix(model, np.full(6, 0.3)).tolist()))\n"
)
_COMPILING = "compiling opendyn.algorithm.crba.crba_kernel"


def _run(code, cache, pythonpath, cwd):
    """`code` in a new process with the kernel cache under `cache` and warnings shown."""
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(cache),
        "PYTHONPATH": str(pythonpath),
        "PYTHONWARNINGS": "default",
    }
    proc = subprocess.run(
        [sys.executable, "-c", code],
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    return proc


def _expected_mass_matrix():
    import opendyn as od

    return od.mass_matrix(od.load_urdf("ur5"), np.full(6, 0.3))


def test_numba_is_pinned_to_the_minor_version_the_cache_is_written_for():
    """pyproject.toml admits the installed numba and no other minor version: at least
    WRITTEN_FOR, below the next minor."""
    if not PYPROJECT.exists():
        pytest.skip("not a source checkout: pyproject.toml is missing")
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    dependencies = tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))["project"]["dependencies"]
    (pin,) = [Requirement(d) for d in dependencies if Requirement(d).name == "numba"]
    major, minor = (int(part) for part in numba_internals.WRITTEN_FOR.split("."))
    assert (NUMBA.major, NUMBA.minor) == (major, minor), numba.__version__
    assert NUMBA in pin.specifier, (str(pin), numba.__version__)
    assert {(s.operator, s.version) for s in pin.specifier} == {
        (">=", f"{major}.{minor}"),
        ("<", f"{major}.{minor + 1}"),
    }, str(pin)


def test_this_numba_has_every_internal_the_cache_uses():
    """Probed at import, before the cache wrapped any of them."""
    assert kernel_cache.MISSING == [] and not kernel_cache.PLAIN


def test_a_changed_load_path_is_named_as_missing(monkeypatch):
    """The cache loads entries as numba's Cache.load_overload does but for its refresh: a
    load_overload with other steps is a change the probe names."""
    from numba.core.caching import Cache

    load = Cache.load_overload

    def load_overload(self, sig, target_context):
        numba.core.caching._cache_log("[cache] loading %s", sig)
        return load(self, sig, target_context)

    monkeypatch.setattr(Cache, "load_overload", load_overload)
    (named,) = numba_internals.missing()
    assert named.startswith("numba.core.caching.Cache.load_overload as numba 0.68 has it")


@pytest.fixture
def package_copy(tmp_path):
    """A copy of the package with its robots, as installed, to ship kernels in."""
    from opendyn.io.urdf import shipped_robots_dir

    copy = tmp_path / "site" / "opendyn"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    if not (copy / "robots").is_dir():  # a checkout: robots/ lies beside the package
        shutil.copytree(shipped_robots_dir(), copy / "robots")
    return copy


_EXPORT = (
    _MASS_MATRIX
    + "import sys\n"
    + "from opendyn._runtime.shipped_kernels import export_used\n"
    + "export_used(sys.argv[1])\n"
)
_ANOTHER_NUMBA = "opendyn: the compiled kernels shipped in"


def test_kernels_shipped_by_another_numba_are_one_warning_and_a_compile(tmp_path, package_copy):
    """The DIGEST file records the numba that compiled the shipped kernels. Under that numba
    they load (nothing compiles); under another, whose cache would refuse every entry, one
    warning names both versions, and the kernels compile and run."""
    shipped = package_copy / "_kernels"
    site = package_copy.parent
    subprocess.run(  # the kernels the test ships: compiled (or loaded) in a cache of its own
        [sys.executable, "-c", _EXPORT, str(shipped)],
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "build"), "PYTHONPATH": str(site)},
        cwd=tmp_path,
        check=True,
        capture_output=True,
        timeout=600,
    )
    stamp = (shipped / DIGEST_FILE).read_text(encoding="ascii")
    assert stamp == f"{DIGEST}\nnumba {numba.__version__}\n"
    expected = _expected_mass_matrix()

    same = _run(_MASS_MATRIX, tmp_path / "same", site, tmp_path)
    assert np.array_equal(ast.literal_eval(same.stdout), expected)
    assert "compiling" not in same.stderr and "Warning" not in same.stderr, same.stderr

    (shipped / DIGEST_FILE).write_text(f"{DIGEST}\nnumba 0.67.0\n", encoding="ascii")
    other = _run(_MASS_MATRIX, tmp_path / "other", site, tmp_path)
    assert np.array_equal(ast.literal_eval(other.stdout), expected)
    assert other.stderr.count(_ANOTHER_NUMBA) == 1, other.stderr
    assert other.stderr.count("Warning") == 1, other.stderr
    assert f"built with numba 0.67.0, and this is numba {numba.__version__}" in other.stderr
    assert _COMPILING in other.stderr


_WITHOUT = {
    # a numba that lacks a private class the cache's locator is made from
    "_CacheLocator": "import numba.core.caching as c\ndel c._CacheLocator\n",
    # a numba whose load path takes another step than 0.68's
    "load_overload": (
        "import numba.core.caching as c\n"
        "load = c.Cache.load_overload\n"
        "def load_overload(self, sig, target_context):\n"
        "    c._cache_log('[cache] loading %s', sig)\n"
        "    return load(self, sig, target_context)\n"
        "c.Cache.load_overload = load_overload\n"
    ),
}


@pytest.mark.parametrize("lacking", sorted(_WITHOUT))
def test_a_numba_without_an_internal_caches_as_numba_does_with_one_warning(tmp_path, lacking):
    """Where numba lacks (or changed) a private name the cache uses, the kernels are cached by
    numba's own rules, in numba's own folders, and run: one warning names what is missing and
    what that costs; a second process loads what the first compiled."""
    expected = _expected_mass_matrix()
    cache = tmp_path / "cache"
    runs = [
        _run(_WITHOUT[lacking] + _MASS_MATRIX, cache, PACKAGE.parent, tmp_path) for _ in range(2)
    ]
    for proc in runs:
        assert np.array_equal(ast.literal_eval(proc.stdout), expected)
        assert proc.stderr.count("Warning") == 1, proc.stderr
        assert proc.stderr.count("lacks what opendyn's kernel cache is written for") == 1
        assert lacking in proc.stderr and "cached by numba's own rules" in proc.stderr
    assert _COMPILING in runs[0].stderr
    assert "compiling" not in runs[1].stderr, runs[1].stderr
    # in numba's folders (one per source folder), none in opendyn's
    assert not list(cache.glob("opendyn-kernels-*/**/*.nbi"))
    assert list(cache.glob("algorithm_*/crba.crba_kernel-*.nbi")), sorted(cache.iterdir())
