"""The package's public names, imported when first used.

`import opendyn` would otherwise import every layer, and with them numpy, numba, scipy and the
URDF reader, before a script has asked for any of it (about 0.9 s on a 2-core machine). The
package's __init__ instead lists its public names as imports under `if TYPE_CHECKING:` (which
type checkers and the documentation read as they are), and `attach` turns that list into the
module's `__getattr__` (PEP 562): `opendyn.mass_matrix` imports opendyn.algorithm.crba the first
time it is asked for, and is an ordinary attribute from then on.
"""

from __future__ import annotations

import ast
import importlib
import sys
import types


def _public_imports(init_file: str) -> dict[str, str]:
    """{name: its module, relative to the package} of the `from .module import name` lines
    inside the `if TYPE_CHECKING:` block of the file `init_file`."""
    with open(init_file, encoding="utf-8") as f:
        tree = ast.parse(f.read(), init_file)
    names = {}
    for node in tree.body:
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            for line in node.body:
                if isinstance(line, ast.ImportFrom) and line.level == 1:
                    names.update({alias.name: "." + line.module for alias in line.names})
    return names


class _Package(types.ModuleType):
    """A package whose public names win over its subpackages of the same name (opendyn.sweep is
    the function, opendyn/sweep/ the layer that defines it): the import system binds each
    subpackage it imports on its parent, which would hide the public name."""

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and name in self.__dict__["_public"]:
            return
        super().__setattr__(name, value)


def attach(namespace: dict):
    """(__getattr__, __dir__) for the package whose __init__ has the globals `namespace`: its
    public names (`_public_imports`) and its subpackages, each imported when first asked for."""
    package = namespace["__name__"]
    modules = _public_imports(namespace["__file__"])
    namespace["_public"] = modules
    sys.modules[package].__class__ = _Package

    def __getattr__(name: str):
        if name in modules:
            value = getattr(importlib.import_module(modules[name], package), name)
        else:
            try:  # a subpackage (opendyn.sim) not imported yet
                value = importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as error:
                if error.name != f"{package}.{name}":
                    raise
                raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(namespace) | set(modules))

    return __getattr__, __dir__
