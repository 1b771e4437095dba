"""`opendyn compile` and `opendyn info --cache`: the kernels compiled into the cache ahead of time,
and where that cache is."""

from __future__ import annotations

import sys
import time

from ..errors import SceneError
from ..io.scene.files import load_scene, shipped_scenes


def _compile_ahead(args) -> int:
    """opendyn compile: the scenes named (or, with --all or nothing named, every core function
    and every shipped scene whose robot is installed), compiled into the kernel cache."""
    from .._runtime.compile_notice import compile_ahead

    names = args.scenes or []
    everything = args.all or not names
    scenes, skipped = [], []
    for name in list(shipped_scenes()) if everything else names:
        try:
            scenes.append(load_scene(name))
        except SceneError as e:
            if not everything:
                raise
            skipped.append(f"{name} ({e})")
    t0 = time.perf_counter()
    done = compile_ahead(scenes, functions=everything)
    for name in skipped:
        print(f"skipped scene {name}", file=sys.stderr)
    print(f"compiled {len(done)} items in {time.perf_counter() - t0:.1f} s")
    return 0


def _cache_info() -> int:
    """opendyn info --cache: the kernel cache folder, why it is there, and its size."""
    import os

    from .._runtime.kernel_cache import CACHE_DIR, CACHE_WHERE

    print(f"kernel cache  {CACHE_DIR or 'none: kernels are compiled in every process'}")
    print(f"chosen as     {CACHE_WHERE} (first writable of NUMBA_CACHE_DIR, the package folder, "
          "the per-user cache)")
    if CACHE_DIR and os.path.isdir(CACHE_DIR):
        files = [os.path.join(d, f) for d, _, fs in os.walk(CACHE_DIR) for f in fs]
        size = sum(os.path.getsize(f) for f in files)
        print(f"holds         {len(files)} files, {size / 1e6:.1f} MB")
    return 0
