"""The compiled-kernel cache's folder is named by a hash of every source of the package, so that
no kernel is ever loaded stale: not after a helper in another file changes, and not after a
file moves or is renamed (numba keys its own cache on the kernel's file alone). An entry that
cannot be read (cut short) is a miss: it compiles again, with one warning, and is cached afresh."""

from __future__ import annotations

import contextlib
import json
import os
import pathlib
import shutil
import subprocess
import sys

import pytest

import opendyn
from opendyn._runtime import kernel_target
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


def test_the_shipped_robots_and_kernels_are_not_sources(package_copy):
    """An installed copy holds the robots' example controllers (opendyn/robots, beside the
    package in a checkout) and a wheel's shipped kernels: neither changes the digest, so the
    checkout, the suite and the installed copy name the same folder."""
    before = source_digest(package_copy)
    for folder in ("robots", "_kernels", "_kernels/sim"):
        (package_copy / folder).mkdir()
        (package_copy / folder / "panda_push.py").write_text("KP = 1.0\n", encoding="utf-8")
    assert source_digest(package_copy) == before


def test_a_new_module_names_a_new_folder(package_copy):
    before = source_digest(package_copy)
    (package_copy / "new_kernels.py").write_text("from numba import njit\n", encoding="utf-8")
    assert source_digest(package_copy) != before


# a process that prints the UR5's M at one configuration: every run must print the same numbers
_MASS_MATRIX = (
    "import numpy as np, opendyn as od\n"
    "model = od.load_urdf('ur5')\n"
    "print(repr(od.mass_matrix(model, np.full(6, 0.3)).tolist()))\n"
)


def _run(cache, pythonpath=None, cwd=None):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONWARNINGS": "default"}
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    return subprocess.run(
        [sys.executable, "-c", _MASS_MATRIX],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        cwd=cwd,
    )


def test_two_copies_of_the_same_sources_share_one_cache(tmp_path, package_copy):
    """numba files a kernel under its source's absolute folder, so a checkout and an installed
    copy of the same sources compiled into caches of their own. opendyn's kernels are filed
    under their folder inside the package: a copy of the package elsewhere loads, without
    compiling, what this one compiled, and the entries live under package-relative folders."""
    from opendyn.io.urdf import shipped_robots_dir

    if not (package_copy / "robots").is_dir():  # a checkout: robots/ lies beside the package
        shutil.copytree(shipped_robots_dir(), package_copy / "robots")  # as installed
    cache = tmp_path / "cache"
    first = _run(cache, cwd=tmp_path, pythonpath=PACKAGE.parent)
    assert first.returncode == 0, first.stderr
    assert "compiling opendyn.algorithm.crba.crba_kernel" in first.stderr
    assert list(cache.glob("opendyn-kernels-*/algorithm/crba.crba_kernel-*.nbi"))
    elsewhere = _run(cache, cwd=tmp_path, pythonpath=package_copy.parent)
    assert elsewhere.returncode == 0, elsewhere.stderr
    assert elsewhere.stdout == first.stdout
    assert "compiling" not in elsewhere.stderr, elsewhere.stderr
    # and it was that copy that ran: its own opendyn, not this one
    probe = subprocess.run(
        [sys.executable, "-c", "import opendyn; print(opendyn.__file__)"],
        env={**os.environ, "PYTHONPATH": str(package_copy.parent)},
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert pathlib.Path(probe.stdout.strip()).parent == package_copy


def test_the_kernels_compile_for_the_portable_target():
    """A cache entry is keyed by the compile target; opendyn sets LLVM's portable baseline CPU,
    with no added features, before numba is imported, so a cache made here loads on any
    machine of this architecture (opendyn._runtime.kernel_target)."""
    from opendyn._runtime.kernel_target import PORTABLE, target

    if kernel_target.CHOSEN != kernel_target.PORTABLE_WORD:
        pytest.skip(f"the target was chosen otherwise: {kernel_target.CHOSEN}")
    assert target() == (PORTABLE, "")
    code = (
        "import json, opendyn; from opendyn._runtime import kernel_target as k; "
        "print(json.dumps([k.CHOSEN, k.target()]))"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CPU")}
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert json.loads(proc.stdout) == ["portable (any CPU of this architecture)", [PORTABLE, ""]]
    host = subprocess.run(
        [sys.executable, "-c", code], env={**env, "OPENDYN_CPU": "host"}, capture_output=True,
        text=True,
    )
    chosen, (name, features) = json.loads(host.stdout)
    assert "OPENDYN_CPU=host" in chosen and name != PORTABLE and features


def test_an_entry_cut_short_is_a_miss_that_compiles_again_with_one_warning(tmp_path):
    first = _run(tmp_path)
    assert first.returncode == 0, first.stderr
    entries = sorted(tmp_path.glob("opendyn-kernels-*/algorithm/crba.crba_kernel-*.nb[ic]"))
    assert {e.suffix for e in entries} == {".nbi", ".nbc"}, entries
    # as an interrupted copy leaves them: this kernel's first, then every other entry
    others = set(tmp_path.glob("opendyn-kernels-*/*/*.nb[ic]")) - set(entries)
    assert len(others) >= 4, others
    for entry in [*entries, *others]:
        entry.write_bytes(entry.read_bytes()[: entry.stat().st_size // 2])

    damaged = _run(tmp_path)
    assert damaged.returncode == 0, damaged.stderr
    assert damaged.stdout == first.stdout
    assert "Traceback" not in damaged.stderr
    assert "unreadable entry of the compiled-kernel cache (" in damaged.stderr
    assert "compiling opendyn.algorithm.crba.crba_kernel" in damaged.stderr
    # one warning, not one for each damaged entry (two lines each)
    assert damaged.stderr.count("unreadable entry") == 1, damaged.stderr

    again = _run(tmp_path)  # cached afresh: loaded without a word
    assert again.returncode == 0 and again.stdout == first.stdout
    assert "unreadable" not in again.stderr and "compiling" not in again.stderr, again.stderr


def test_another_folders_unreadable_entry_still_raises(tmp_path):
    """Outside opendyn's folder the entry is left to numba as it was: the error of unpickling
    it (what pickle itself raises on those bytes), not a miss, and the file kept."""
    import pickle

    from numba.core.caching import IndexDataCacheFile

    cut_short = b"\x80\x04\x95"  # a pickle cut short
    with pytest.raises(pickle.UnpicklingError) as unpickling:
        pickle.loads(cut_short)
    (tmp_path / "f.nbi").write_bytes(cut_short)
    cache_file = IndexDataCacheFile(str(tmp_path), "f", source_stamp=None)
    with pytest.raises(pickle.UnpicklingError) as error:
        cache_file._load_index()
    assert str(error.value) == str(unpickling.value)
    assert (tmp_path / "f.nbi").read_bytes() == cut_short


_UNDER_UNCOUNTED_KERNELS = r"""
import json, sys
import numpy as np
import opendyn as od
from numba.core.dispatcher import Dispatcher

model = od.load_urdf("ur5")
q = np.full(model.nq, 0.3)
od.distances(model, q)
od.collisions(model, q, margin=0.1)
od.mass_matrix(model, q)
checked, wrong = [], []
for name, module in list(sys.modules.items()):
    if not name.startswith("opendyn."):
        continue
    for attr, kernel in vars(module).items():
        if not isinstance(kernel, Dispatcher) or kernel.__module__ != name:
            continue
        for result in kernel.overloads.values():  # (compiled here: the cache is fresh)
            checked.append(f"{name}.{attr}")
            if result.target_context.enable_nrt != kernel.targetoptions.get("_nrt", True):
                wrong.append(f"{name}.{attr}")
print(json.dumps({"checked": sorted(set(checked)), "wrong": sorted(set(wrong))}))
"""


def test_a_kernel_compiled_under_an_uncounted_one_keeps_its_own_counting(tmp_path):
    """The collision queries are compiled without reference counting (kernel_cache.UNCOUNTED) and
    call counted kernels (forward kinematics, the work buffer's views). numba compiles a callee
    that does not name its setting with its caller's, and keys the result by signature alone,
    so that every later caller, and the cache, got an uncounted forward kinematics (a heap
    corruption in the contact scenes). In a fresh cache, after distances and collisions: every
    compiled version of every kernel has the counting its own options name."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    proc = subprocess.run(
        [sys.executable, "-c", _UNDER_UNCOUNTED_KERNELS],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout.strip().splitlines()[-1])
    for kernel in ("kinematics.forward_kinematics", "work_views.world_poses", "queries.place"):
        assert any(name.endswith(kernel) for name in found["checked"]), kernel
    assert found["wrong"] == []


def test_two_saves_at_once_keep_each_signature_with_its_own_code(tmp_path, monkeypatch):
    """Two processes (here two threads, each with its own file handle) that compile a kernel at
    once both read its index before either writes it. Unlocked, both pick data file 1: the index
    names one signature and the file holds the other's code, which crashes whoever loads it.
    Under the lock the second reads the index after the first wrote it, and picks file 2."""
    import threading

    from numba.core.caching import IndexDataCacheFile

    from opendyn._runtime import kernel_cache

    folder = tmp_path / "opendyn-kernels-0"
    folder.mkdir()
    monkeypatch.setattr(kernel_cache, "CACHE_DIR", str(tmp_path))
    both_read = threading.Barrier(2)
    load_index = IndexDataCacheFile._load_index

    def load_then_wait(self):
        overloads = load_index(self)
        with contextlib.suppress(threading.BrokenBarrierError):
            both_read.wait(timeout=1.0)  # unlocked: both have read; locked: the first times out
        return overloads

    monkeypatch.setattr(IndexDataCacheFile, "_load_index", load_then_wait)

    def save(key):
        IndexDataCacheFile(str(folder), "kernel", source_stamp="s").save(key, f"code of {key}")

    threads = [threading.Thread(target=save, args=(key,)) for key in ("f8", "i8")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    monkeypatch.setattr(IndexDataCacheFile, "_load_index", load_index)
    cache_file = IndexDataCacheFile(str(folder), "kernel", source_stamp="s")
    assert cache_file.load("f8") == "code of f8"
    assert cache_file.load("i8") == "code of i8"
