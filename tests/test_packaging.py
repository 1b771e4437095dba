"""The installed package holds every subpackage of the source tree: pyproject.toml lists each
one (a package left out would be missing from a fresh, non-editable install)."""

from __future__ import annotations

import pathlib

from opendyn.io.scene.files import tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_pyproject_lists_every_subpackage():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    listed = set(pyproject["tool"]["setuptools"]["packages"])
    found = {
        ".".join(p.parent.relative_to(ROOT).parts)
        for p in (ROOT / "opendyn").rglob("__init__.py")
        if "__pycache__" not in p.parts
    }
    assert found | {"opendyn.robots"} == listed, (sorted(found - listed), sorted(listed - found))
