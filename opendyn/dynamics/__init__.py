"""Dynamics of open chains on kinematic trees: one algorithm per module, compiled kernels.

numba caches each compiled kernel on disk keyed on the kernel's own source file only, while the
kernels inline helpers from other files (_kernels.py, rnea.py); after such a helper changes, a
kernel would be loaded stale. The kernels are therefore cached in a folder named by a hash of all
the sources they are built from, set while these modules are imported (numba reads it when a
function is decorated) and restored afterwards.
"""

import hashlib
import pathlib

from numba.core import config as _numba_config


def _kernel_cache_dir() -> str:
    here = pathlib.Path(__file__).parent
    digest = hashlib.sha1()
    for source in sorted([*here.glob("*.py"), here.parent / "model.py"]):
        digest.update(source.read_bytes())
    base = (
        pathlib.Path(_numba_config.CACHE_DIR) if _numba_config.CACHE_DIR else (here / "__pycache__")
    )
    return str(base / f"opendyn-kernels-{digest.hexdigest()[:16]}")


_user_cache_dir = _numba_config.CACHE_DIR
_numba_config.CACHE_DIR = _kernel_cache_dir()
try:
    from . import aba, christoffel, crba, energy, forward, kinematics, rnea, task_space  # noqa: F401
finally:
    _numba_config.CACHE_DIR = _user_cache_dir
