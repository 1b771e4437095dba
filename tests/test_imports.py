"""The package's levels, as the design states them, read from every module's imports (at the top
and inside functions alike): a module imports only modules of its own folder or of a lower
level, never the package's __init__ (which re-exports only), and no module is part of an import
cycle.

    _runtime, errors -> spatial -> multibody -> algorithm -> sim -> io -> api
        -> {sweep, viz, verify} -> cli

(a level imports the ones before it; sweep, viz and verify do not import each other)."""

from __future__ import annotations

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "opendyn"

LEVELS = {
    "_runtime": 0,
    "errors": 0,
    "spatial": 1,
    "multibody": 2,
    "algorithm": 3,
    "sim": 4,
    "io": 5,
    "api": 6,
    "sweep": 7,
    "viz": 7,
    "verify": 7,
    "cli": 8,
}


def module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports_of(name: str) -> set[str]:
    """The opendyn modules that module `name` imports anywhere in its body: `from X import y`
    counts as X.y when that is a module, else as X."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names if alias.name.split(".")[0] == "opendyn"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "opendyn":
                continue
            for alias in node.names:
                child = f"{target}.{alias.name}"
                found.add(child if child in MODULES else target)
    return found


GRAPH = {name: imports_of(name) for name in MODULES}


def level_of(name: str) -> str | None:
    """The level of an opendyn module: its folder (or top-level module) under opendyn; None for
    the package's __init__."""
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else None


def test_every_folder_has_a_level():
    assert {level_of(name) for name in MODULES} - {None} == set(LEVELS)


@pytest.mark.parametrize("name", sorted(MODULES))
def test_a_module_imports_only_its_own_level_or_lower_ones(name):
    own = level_of(name)
    for target in sorted(GRAPH[name]):
        assert target in MODULES, f"{name} imports {target}, which is no module of opendyn"
        level = level_of(target)
        if own is None:  # the package's __init__ re-exports from every level
            continue
        assert level is not None, f"{name} imports the package's __init__ (re-exports only)"
        if level == own:
            continue
        assert LEVELS[level] < LEVELS[own], (
            f"{name} (level {own}) imports {target} (level {level}): "
            + ("a level above it" if LEVELS[level] > LEVELS[own] else "a folder beside it")
        )


def cycles(graph) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph.get(v, ()):
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_is_part_of_an_import_cycle():
    assert cycles(GRAPH) == []


def test_the_checks_catch_what_they_are_for():
    """A planted cycle and a planted import up a level are found."""
    planted = {name: set(targets) for name, targets in GRAPH.items()}
    planted["opendyn.algorithm.rnea"].add("opendyn.sim.step")
    planted["opendyn.sim.step"].add("opendyn.algorithm.rnea")
    assert any({"opendyn.algorithm.rnea", "opendyn.sim.step"} <= set(c) for c in cycles(planted))
    assert LEVELS[level_of("opendyn.sim.step")] > LEVELS[level_of("opendyn.algorithm.rnea")]
    assert imports_of("opendyn.sim.simulate") >= {"opendyn.sim.driver", "opendyn.sim.simulator"}
