"""The compiled-kernel cache's folder is named by a hash of every source of the package, so that
no kernel is ever loaded stale: not after a helper in another file changes, and not after a
file moves or is renamed (numba keys its own cache on the kernel's file alone)."""

from __future__ import annotations

import pathlib
import shutil

import pytest

import opendyn
from opendyn._runtime.kernel_cache import CACHE_DIR, source_digest

PACKAGE = pathlib.Path(opendyn.__file__).resolve().parent


@pytest.fixture
def package_copy(tmp_path):
    """A copy of the package's Python sources, to change and move files in."""
    copy = tmp_path / "opendyn"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return copy


def test_the_cache_folder_is_named_by_the_installed_sources():
    assert source_digest(PACKAGE) in pathlib.Path(CACHE_DIR).name


def test_a_copy_of_the_same_sources_has_the_same_digest(package_copy):
    assert source_digest(package_copy) == source_digest(PACKAGE)


def test_every_compiled_source_is_covered(package_copy):
    """Changing any module that defines or calls kernels, at any depth of the tree, names a new
    folder."""
    compiled = [
        p for p in sorted(package_copy.rglob("*.py")) if "njit" in p.read_text(encoding="utf-8")
    ]
    assert len(compiled) >= 10
    before = source_digest(package_copy)
    for source in compiled:
        text = source.read_text(encoding="utf-8")
        source.write_text(text + "\n# changed\n", encoding="utf-8")
        assert source_digest(package_copy) != before, source.relative_to(package_copy)
        source.write_text(text, encoding="utf-8")
    assert source_digest(package_copy) == before


def test_a_moved_or_renamed_file_names_a_new_folder(package_copy):
    """Same bytes at another path: a kernel whose module moved must not find its old entry."""
    before = source_digest(package_copy)
    source = next(p for p in sorted(package_copy.rglob("*.py")) if "njit" in p.read_text())
    moved = package_copy / "moved_here" / source.name
    moved.parent.mkdir()
    source.rename(moved)
    after_move = source_digest(package_copy)
    assert after_move != before
    renamed = moved.with_name("renamed_" + moved.name)
    moved.rename(renamed)
    assert source_digest(package_copy) not in (before, after_move)


def test_a_new_module_names_a_new_folder(package_copy):
    before = source_digest(package_copy)
    (package_copy / "new_kernels.py").write_text("from numba import njit\n", encoding="utf-8")
    assert source_digest(package_copy) != before
