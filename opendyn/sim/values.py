"""The basic values of a scene's settings, checked (by the scene reader, opendyn.io.scene, and by
each effect's module, which reads its own settings): tables and their keys, strings and choices,
booleans, numbers, vectors, per-joint arrays and frame names. Every section reader builds on
these, so every error (``SceneError``) names the source (the scene file, "<dict>" or
"<robot NAME>"), the dotted key (``effects.damping.coefficients``), what was expected and what
was found."""

from __future__ import annotations

import difflib
import math
import numbers
import pathlib

import numpy as np

from .._runtime.arrays import immutable
from ..errors import SceneError
from ..multibody.model import Model


class ValueReader:
    """Checks one scene's values; every error names ``source`` and the dotted key."""

    def __init__(self, source: str):
        self.source = source
        self.model: Model | None = None
        self.files: list[pathlib.Path] = []  # every file read (existing_file), in order

    def fail(self, key: str, what: str):
        where = f"{self.source}: {key}: " if key else f"{self.source}: "
        raise SceneError(where + what)

    # basic values

    def table(self, value, key) -> dict:
        if not isinstance(value, dict):
            self.fail(key, f"expected a table, found {what_is(value)}")
        return value

    def keys(self, table, key, valid):
        self.table(table, key or "(top level)")
        valid = tuple(dict.fromkeys(valid))  # two effects may read one key (contact)
        for k in table:
            if k not in valid:
                full = f"{key}.{k}" if key else str(k)
                level = f"in [{key}]" if key else "at the top level"
                self.fail(
                    full,
                    f"unknown key{suggest(str(k), valid)}; valid keys {level}: {', '.join(valid)}",
                )

    def string(self, value, key, choices=None) -> str:
        if not isinstance(value, str):
            expected = f"one of {', '.join(choices)}" if choices else "a string"
            self.fail(key, f"expected {expected}, found {what_is(value)}")
        if choices is not None and value not in choices:
            self.fail(
                key, f"{value!r} is not one of {', '.join(choices)}{suggest(value, choices)}"
            )
        return value

    def existing_file(self, value, key, kind, base_dir) -> pathlib.Path:
        """The file a string names, relative to `base_dir` (the scene's folder; None: the
        working folder), which must exist: "no such KIND file" otherwise ("a folder" for one).
        It joins the files read (`files`)."""
        path = pathlib.Path(self.string(value, key))
        if not path.is_absolute() and base_dir is not None:
            path = pathlib.Path(base_dir) / path
        if path.is_dir():
            self.fail(key, f"{path} is a folder, not a {kind} file: name the file in it")
        if not path.is_file():
            self.fail(key, f"no such {kind} file: {path}")
        self.files.append(path)
        return path

    def boolean(self, value, key) -> bool:
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, found {what_is(value)}")
        return value

    def number(self, value, key, minimum=None, positive=False) -> float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            self.fail(key, f"expected a number, found {what_is(value)}")
        try:
            x = float(value)
        except OverflowError:  # an integer of hundreds of digits
            self.fail(
                key,
                f"expected a finite number, found an integer of {len(str(abs(value)))} digits, "
                "beyond any float",
            )
        if not math.isfinite(x):
            self.fail(key, f"expected a finite number, found {x!r}")
        if positive and not x > 0:
            self.fail(key, f"expected a number > 0, found {x!r}")
        if minimum is not None and x < minimum:
            self.fail(key, f"expected a number >= {minimum:g}, found {x!r}")
        return x

    def vector(self, value, key, n, minimum=None) -> np.ndarray:
        if not isinstance(value, list):
            self.fail(key, f"expected a list of {n} numbers, found {what_is(value)}")
        if len(value) != n:
            self.fail(key, f"expected a list of {n} numbers, found a list of {len(value)}")
        return immutable([self.number(v, f"{key}[{i}]", minimum) for i, v in enumerate(value)])

    def per_joint(self, value, key, default, scalar=True, minimum=None) -> np.ndarray:
        """(n,) per joint from a number (every joint; if scalar), a list of n or a table
        {joint: value} (joints not named keep ``default``); None -> default."""
        names = self.model.joint_names
        nv = len(names)
        if value is None:
            return immutable(default)
        if isinstance(value, dict):
            out = np.array(default, dtype=float)
            for joint, v in value.items():
                if joint not in names:
                    self.fail(
                        f"{key}.{joint}",
                        f"{joint!r} is not a joint of {self.model.name!r}"
                        + (
                            f"{suggest(str(joint), names)}; joints: {', '.join(names)}"
                            if names else ", which has no joints"
                        ),
                    )
                out[names.index(joint)] = self.number(v, f"{key}.{joint}", minimum)
            return immutable(out)
        if isinstance(value, list):
            if len(value) != nv:
                self.fail(
                    key,
                    f"expected a list of {nv} numbers (one per joint: {', '.join(names)}), "
                    f"found a list of {len(value)}",
                )
            return self.vector(value, key, nv, minimum)
        if scalar and isinstance(value, numbers.Real) and not isinstance(value, bool):
            return immutable(np.full(nv, self.number(value, key, minimum)))
        shapes = "a number (every joint), " if scalar else ""
        sign = f" >= {minimum:g}" if minimum is not None else ""
        self.fail(
            key,
            f"expected {shapes}a list of {nv} numbers{sign} or a table {{joint = number}}, "
            f"found {what_is(value)}",
        )

    def coefficients(self, table, key, field, urdf_values, element) -> np.ndarray:
        """(n,) per-joint coefficients >= 0 from ``table[field]``: "urdf" (the default) takes
        ``urdf_values``, the URDF's <dynamics ELEMENT>, refused when all are 0; otherwise a
        number, a list or a table {joint = number}, as per_joint."""
        value = table.get(field, "urdf")
        full = f"{key}.{field}"
        if isinstance(value, str):
            if value != "urdf":
                self.fail(
                    full,
                    f'expected "urdf", a number, a list of {len(self.model.joint_names)} '
                    f"numbers or a table {{joint = number}}, found {what_is(value)}",
                )
            if not np.any(urdf_values > 0):
                self.fail(
                    full,
                    f'"urdf" asks for the URDF\'s <dynamics {element}>, but '
                    f"{self.model.source or self.model.name} gives none (all joints 0); give "
                    f"the coefficients: a number, a list of {len(self.model.joint_names)} or a "
                    f"table {{joint = number}}",
                )
            return immutable(urdf_values)
        return self.per_joint(value, full, np.zeros(len(self.model.joint_names)), minimum=0.0)

    def moving_frame(self, value, key, why) -> str:
        """A frame (`frame`) that moves: one welded to the fixed world is refused, saying `why`
        and listing the frames that move."""
        name = self.frame(value, key)
        m = self.model
        if m.frames[m.frame_index(name)].body < 0:
            moving = [f.name for f in m.frames if f.body >= 0]
            self.fail(
                key,
                f"{name!r} is welded to the fixed world (it is the root link or fixed to it), "
                f"so {why}; frames that move: {', '.join(moving)}",
            )
        return name

    def frame(self, value, key) -> str:
        name = self.string(value, key)
        try:
            self.model.frame_index(name)
        except KeyError:
            frames = self.model.frame_names
            self.fail(
                key,
                f"{name!r} is not a frame of {self.model.name!r}{suggest(name, frames)}; "
                f"frames: {', '.join(frames)} (a joint name also finds its child link)",
            )
        return name


def suggest(name: str, choices) -> str:
    close = difflib.get_close_matches(str(name), [str(c) for c in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def what_is(value) -> str:
    """What a TOML value is, for error messages: its text and its TOML type."""
    if isinstance(value, (bool, np.bool_)):
        kind = "a boolean"
    elif isinstance(value, str):
        kind = "a string"
    elif isinstance(value, numbers.Integral):
        kind = "an integer"
    elif isinstance(value, numbers.Real):
        kind = "a float"
    elif isinstance(value, list):
        kind = f"a list of {len(value)}"
    elif isinstance(value, dict):
        kind = "a table"
    elif value is None:
        return "nothing"
    else:
        kind = f"a {type(value).__name__}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({kind})"
