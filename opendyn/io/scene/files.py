"""Where scenes come from: TOML scene files (``load_scene``, with the scenes shipped in robots/
found by name), dicts in the same layout (``scene_from_dict``) and a robot alone
(``default_scene``, its plainest scene); telling a scene file from a URDF (``is_scene_file``)."""

from __future__ import annotations

import os
import pathlib

import numpy as np

from ..._runtime.files import kind_of
from ...errors import SceneError, URDFError
from ...multibody.model import Model
from ..urdf import available_robots, load_urdf, shipped_robots_dir
from .reader import _build
from ...sim.scene import Scene, thaw
from ...sim.values import suggest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

DEFAULT_SCENE = "double_pendulum_swing"


def load_scene(path) -> Scene:
    """Read a TOML scene file (or a shipped scene by name, e.g. ``"double_pendulum_swing"``).

    A relative ``robot.urdf`` is found from the scene file's folder. Raises SceneError naming
    the file (and the line, for malformed TOML) on any problem.
    """
    file = _resolve_scene(path)
    try:
        # utf-8-sig: a byte-order mark, as some Windows editors write, is not part of the TOML
        data = tomllib.loads(file.read_bytes().decode("utf-8-sig"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        kind = kind_of(file)
        if kind != "a text file":
            raise SceneError(f"{file}: is {kind}, not a scene file (TOML text)") from None
        if isinstance(e, UnicodeDecodeError):
            raise SceneError(f"{file}: not a UTF-8 text file: {e}") from None
        raise SceneError(f"{file}: malformed TOML: {e}") from None
    except OSError as e:
        raise SceneError(f"{file}: cannot read the scene file: {e.strerror or e}") from None
    return _build(data, source=str(file), base_dir=file.parent, default_name=file.stem)


def scene_from_dict(data: dict, source: str = "<dict>", base_dir=None) -> Scene:
    """A scene from a dict with the layout of the TOML file (numpy arrays are accepted where
    the file has lists). ``base_dir`` is the folder a relative ``robot.urdf`` is found from
    (default: the current directory). Raises SceneError naming ``source`` and the key."""
    base = pathlib.Path(base_dir) if base_dir is not None else pathlib.Path.cwd()
    return _build(thaw(data), source=source, base_dir=base, default_name=None)


def default_scene(robot, **run) -> Scene:
    """The plainest scene of a robot: the model's gravity and nothing else, at rest at q0 = 0
    (for a joint whose limits exclude 0, the nearer limit), no control. robot: a Model, a URDF
    path or a robot name; run: Run fields (e.g. duration=2.0).
    """
    if isinstance(robot, Model):
        model = robot
        spec = {"urdf": model.source} if model.source else {"name": model.name}
        if model.floating_base:
            spec["floating_base"] = True
    else:
        try:
            model = load_urdf(robot)
        except (URDFError, TypeError) as e:
            raise SceneError(f"<robot {robot}>: robot: {e}") from None
        spec = {"urdf": model.source}
    data = {"name": model.name, "robot": spec, "effects": {"gravity": True}, "run": thaw(run)}
    nearest = np.clip(0.0, model.lower, model.upper)
    if np.any(nearest):
        data["initial"] = {
            "q": {name: float(x) for name, x in zip(model.joint_names, nearest) if x}
        }
    return _build(data, source=f"<robot {model.name}>", base_dir=None, model=model)


def is_scene_file(path) -> bool:
    """Whether the file at `path` is a scene (TOML) rather than a URDF (XML): by its extension
    when it is .toml or .urdf/.xml in any case, otherwise by its content (a URDF's first
    character, after a byte-order mark and blank space, is '<'; a TOML file's never is)."""
    suffix = pathlib.Path(path).suffix.lower()
    if suffix in (".toml", ".urdf", ".xml"):
        return suffix == ".toml"
    with open(path, "rb") as f:
        head = f.read(4096)
    return not head.removeprefix(b"\xef\xbb\xbf").lstrip().startswith(b"<")


def shipped_scenes() -> dict[str, pathlib.Path]:
    """The scenes shipped with opendyn: name (file stem) -> path of each robots/*.toml."""
    return {p.stem: p for p in sorted(shipped_robots_dir().glob("*.toml"))}


def _resolve_scene(path) -> pathlib.Path:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"load_scene: path must be a file path or a scene name, not {path!r}")
    file = pathlib.Path(path)
    if file.is_file():
        return file
    shipped = shipped_scenes()
    if isinstance(path, str) and path in shipped:
        return shipped[path]
    if file.is_dir():
        raise SceneError(f"{path}: is a folder, not a scene file; name the .toml in it")
    robot = (
        f"; {path!r} is a robot: od.default_scene({path!r}) is its plainest scene"
        if path in available_robots()
        else ""
    )
    raise SceneError(
        f"{path}: no such scene file{suggest(str(path), shipped)}; "
        f"shipped scenes: {', '.join(shipped) or '(none)'}{robot}"
    )
