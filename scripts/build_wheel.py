"""Build opendyn's wheel with its compiled kernels inside, so that its first run compiles nothing.

    python scripts/build_wheel.py [--out dist] [SCENE ...]

It copies the sources (pyproject.toml, the README, opendyn/, robots/, opendyn_launch.py) into a
temporary folder, runs `opendyn compile --all --export` there (every public core function and
every shipped scene, so example-robot-data must be installed: the UR5, Panda, Solo12 and G1
scenes use its robots), which compiles into this machine's kernel cache, or loads what is
already there, and writes the kernels these used into the copy's opendyn/_kernels; then
`pip wheel` builds the wheel from the copy into --out. Named SCENEs instead of all: a wheel
that ships only their kernels (the test suite builds one for the default scene).

The kernels are compiled for the portable target (opendyn._runtime.kernel_target), so the
wheel's first run loads them on any machine of this architecture and operating system; the
wheel is tagged for that platform. Check a built wheel with `--check WHEEL`: it installs the
wheel into a new folder and runs `opendyn simulate` of each shipped scene (or of the named
ones) there, in a process with an empty kernel cache, and fails if any of them compiles.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCES = ("pyproject.toml", "README.md", "opendyn_launch.py", "opendyn", "robots")
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "_kernels", "*.egg-info")


def _run(command, **kwargs):
    print("+", " ".join(str(c) for c in command), flush=True)
    return subprocess.run(command, check=True, **kwargs)


def _opendyn(*args):
    """The `opendyn` command as a Python call, for a process that has no entry point script."""
    launch = "import sys, opendyn_launch; sys.exit(opendyn_launch.main())"
    return [sys.executable, "-c", launch, *args]


def build(out: pathlib.Path, scenes: list[str]) -> pathlib.Path:
    """Build the wheel into `out` (module docstring); returns its path."""
    with tempfile.TemporaryDirectory(prefix="opendyn-wheel-") as tmp:
        copy = pathlib.Path(tmp) / "opendyn-src"
        copy.mkdir()
        for name in SOURCES:
            source = ROOT / name
            if source.is_dir():
                shutil.copytree(source, copy / name, ignore=IGNORE)
            else:
                shutil.copy2(source, copy / name)
        env = dict(os.environ, PYTHONPATH=str(copy))
        what = scenes or ["--all"]
        _run(_opendyn("compile", *what, "--export", str(copy / "opendyn" / "_kernels")),
             cwd=tmp, env=env)
        # the kernels are of this platform: tag the wheel for it (py3, any ABI of this OS/CPU)
        platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
        (copy / "setup.cfg").write_text(f"[bdist_wheel]\nplat_name = {platform}\n")
        before = set(out.glob("*.whl")) if out.exists() else set()
        _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(out),
              str(copy)])
        built = sorted(set(out.glob("opendyn-*.whl")) - before) or sorted(out.glob("opendyn-*.whl"))
        return built[-1]


# what the check runs in the installed copy: each scene's first `opendyn simulate`, then the
# seconds it compiled for (opendyn._runtime.compile_notice), one JSON line a scene
_FIRST_RUN = r"""
import json, sys, time
tic = time.perf_counter()
from opendyn.cli.main import main
from opendyn._runtime.compile_notice import compile_seconds
from opendyn._runtime.kernel_cache import SHIPPED_FOLDER
status = main(["simulate", sys.argv[1], "--no-save", "-q"])
print(json.dumps({"scene": sys.argv[1], "status": status, "compiled_s": compile_seconds(),
                  "seconds": time.perf_counter() - tic, "shipped": str(SHIPPED_FOLDER)}))
"""


def check(wheel: pathlib.Path, scenes: list[str]) -> list[dict]:
    """Install `wheel` into a new folder and run each scene's first `opendyn simulate` there
    with an empty kernel cache (module docstring). Returns one dict a scene: scene, status,
    compiled_s (seconds compiling), seconds (the whole process), shipped (the folder)."""
    import json

    with tempfile.TemporaryDirectory(prefix="opendyn-check-") as tmp:
        site = pathlib.Path(tmp) / "site"
        _run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target",
              str(site), str(wheel)])
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
        env.update(PYTHONPATH=str(site), XDG_CACHE_HOME=str(pathlib.Path(tmp) / "cache"))
        if not scenes:
            listing = subprocess.run(
                [sys.executable, "-c", "from opendyn.io.scene.files import shipped_scenes;"
                 "print('\\n'.join(shipped_scenes()))"],
                env=env, cwd=tmp, capture_output=True, text=True, check=True)
            scenes = listing.stdout.split()
        results = []
        for scene in scenes:
            proc = subprocess.run([sys.executable, "-c", _FIRST_RUN, scene], env=env, cwd=tmp,
                                  capture_output=True, text=True, timeout=900)
            if proc.returncode != 0 or not proc.stdout.strip():
                raise RuntimeError(f"opendyn simulate {scene} failed:\n{proc.stderr}")
            results.append(json.loads(proc.stdout.strip().splitlines()[-1]))
            print(results[-1], flush=True)
        return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", help="ship only these scenes' kernels (default: all)")
    parser.add_argument("--out", default=str(ROOT / "dist"), help="the wheel's folder (dist/)")
    parser.add_argument("--check", metavar="WHEEL", help="check a built wheel instead (above)")
    args = parser.parse_args()
    if args.check:
        results = check(pathlib.Path(args.check), args.scenes)
        compiled = [r["scene"] for r in results if r["compiled_s"] > 0 or r["status"] != 0]
        if compiled:
            print(f"FAILED: the wheel's first run compiled (or failed) for {compiled}")
            return 1
        print(f"the wheel's first run compiled nothing for {len(results)} scenes")
        return 0
    wheel = build(pathlib.Path(args.out).resolve(), args.scenes)
    print(f"built {wheel} ({wheel.stat().st_size / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
