"""MkDocs hooks: the pages that are generated from the code, never kept by hand.

- `<!-- generated: api -->`: every public name of `opendyn` (its `__all__`), grouped by the
  layer it comes from, each rendered from its docstring by mkdocstrings.
- `<!-- generated: scene-file -->`: the scene file reference. The keys are every key the scene
  reader checks a file against (`opendyn.io.scene.keys.scene_keys`); each section shows its
  part of the reader's annotated file format. A key the format does not describe fails the
  build.
- `<!-- generated: command-line -->`: the `--help` of `opendyn` and of each of its commands.
- `<!-- generated: effects -->`: the table of effects, one row per effect of the registry.
"""

from __future__ import annotations

import contextlib
import io
import os
import re

from mkdocs.exceptions import PluginError

# the layers of the package, in the order of the reference page
_LAYERS = {
    "multibody": "Model, data and frames",
    "algorithm": "Dynamics and kinematics",
    "io": "Robots and scenes",
    "sim": "Simulation",
    "api": "Running a scene (a Scene, a scene file or a shipped scene's name)",
    "sweep": "Sweeps",
    "errors": "Errors and warnings",
}


def on_page_markdown(markdown, page, config, files):
    """Fill each placeholder of the page with its generated Markdown."""
    for name, generate in (
        ("api", _api),
        ("scene-file", _scene_file),
        ("command-line", _command_line),
        ("effects", _effects),
    ):
        placeholder = f"<!-- generated: {name} -->"
        if placeholder in markdown:
            markdown = markdown.replace(placeholder, generate())
    return markdown


def _api() -> str:
    """`::: opendyn.NAME` for every name of opendyn.__all__, under its layer's heading."""
    import opendyn

    by_layer = {layer: [] for layer in _LAYERS}
    for name in opendyn.__all__:
        module = getattr(opendyn, name).__module__.split(".")
        layer = module[1] if len(module) > 1 else "errors"
        if layer not in by_layer:
            raise PluginError(f"opendyn.{name} comes from {'.'.join(module)}: no layer for it")
        by_layer[layer].append(name)
    lines = []
    for layer, names in by_layer.items():
        if names:
            lines += [f"## {_LAYERS[layer]}", ""]
            lines += [f"::: opendyn.{name}\n" for name in sorted(names, key=str.lower)]
    return "\n".join(lines)


# a section header of the reader's file format: [robot], [[effects.wrench]], # [[...points]]
_HEADER = re.compile(r"^\s*(?:#\s*)?\[\[?([\w.]+)\]\]?")


def _format_sections():
    """{section: its lines} of the file format in opendyn.io.scene.reader's docstring; "" is
    the part before the first table."""
    from opendyn.io.scene import reader

    text = reader.__doc__.split("The file format", 1)[1].split("\n\n", 1)[1]
    sections, current = {"": []}, ""
    for line in text.splitlines():
        if line and not line.startswith("    "):
            break  # the prose after the format
        match = _HEADER.match(line)
        if match:
            current = match.group(1)
            sections.setdefault(current, [])
        sections[current].append(line[4:])
    return sections


def _scene_file() -> str:
    """Each section of the format with the keys it takes; PluginError for a key the reader
    takes that the format does not describe."""
    from opendyn.io.scene.keys import scene_keys

    sections = _format_sections()
    keys = {section: [] for section in sections}
    for key in scene_keys():
        if key in sections:
            continue  # a table: its header is in the format
        section = max((s for s in sections if key.startswith(f"{s}.") or s == ""), key=len)
        leaf = key[len(section) + 1 :] if section else key
        if not re.search(rf"\b{re.escape(leaf)}\b", "\n".join(sections[section])):
            raise PluginError(
                f"the scene reader takes {key}, which the file format in "
                f"opendyn/io/scene/reader.py does not describe"
            )
        keys[section].append(key)
    lines = []
    for section, text in sections.items():
        title = f"[{section}]" if section else "Top level"
        lines += [f"## `{title}`" if section else f"## {title}", ""]
        if keys[section]:
            lines += ["Keys: " + ", ".join(f"`{k}`" for k in keys[section]), ""]
        lines += ["```toml", *(line.rstrip() for line in text), "```", ""]
    return "\n".join(lines)


def _command_line() -> str:
    """The --help of `opendyn` and of each command, as the command prints it."""
    from opendyn.cli.main import command_line

    os.environ["COLUMNS"] = "100"  # argparse wraps at the terminal's width: the page's, fixed
    parser = command_line()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    lines = ["## `opendyn`", "", "```text", parser.format_help().rstrip(), "```", ""]
    for name, sub in commands.items():
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            sub.print_help()
        lines += [f"## `opendyn {name}`", "", "```text", out.getvalue().rstrip(), "```", ""]
    return "\n".join(lines)


def _effects() -> str:
    """The effects table: each effect's generalized force, from its module's DOC."""
    from opendyn.sim.effects import registry

    return registry.effects_table()
