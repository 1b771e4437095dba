"""load_urdf: a URDF file (parsed by yourdfpy) -> a frozen Model, with a fidelity report.

The URDF is read (and what was tolerated reported) by opendyn.io.urdf_xml and its tree made into
the Model's arrays by opendyn.io.urdf_model; a robot can also be named, among the robots shipped
with opendyn and, when installed, example-robot-data's.
"""

from __future__ import annotations

import difflib
import importlib.metadata
import os
from pathlib import Path

import numpy as np

from .._runtime.options import flag
from ..errors import URDFError
from ..multibody.model import Model
from .model_cache import cached_model
from .urdf_model import _Builder
from .urdf_xml import FidelityReport, read_urdf


def load_urdf(
    path,
    floating_base: bool = False,
    mimic: bool = False,
    check_inertia: bool = True,
    srdf=None,
) -> Model:
    """Load a URDF file, or a robot by name, into a frozen Model.

    Args:
      path: a URDF file path, or a robot name (``"ur5"``, ``"panda"``, ``"double_pendulum"``)
        resolved among the robots shipped with opendyn and, when installed, example-robot-data.
      floating_base: True makes the root link a free body (a free joint named "root_joint"):
        q = (p, quat, q_joints) with p (3,) the root link frame's origin in the world (m) and
        quat (4,) its orientation (x, y, z, w); v = (omega_b, v_b, qd_joints), the root's twist
        in its own frame, angular first. A URDF whose root joint is type="floating" has a free
        joint of its own, with either value.
      mimic: False (default) keeps mimic joints as independent coordinates; True couples them,
        q_joint = multiplier * q_mimicked + offset, so they are not coordinates of the model.
      check_inertia: True (default) rejects inertias that no rigid body can have (not positive
        semi-definite, or violating the triangle inequality I_a + I_b >= I_c of the principal
        moments); False keeps them as written and lists them in the fidelity report.
      srdf: an SRDF file whose ``<disable_collisions link1 link2>`` take those link pairs out of
        ``model.collision_pairs`` (as Pinocchio's ``removeCollisionPairs``); None: none. A URDF
        given here is refused.

    Returns the Model; ``model.report`` is the fidelity report (honoured, transformed, ignored).
    A Model built once is kept on disk and returned by later loads of the same files
    (opendyn.io.model_cache); a load that warned is built again each time, warning again.
    Warns (URDFWarning, naming the file and the element; the report lists each too) for what
    loads but probably not as meant: a ``<collision>`` mesh that cannot be found or read (left
    out), one far from convex (used as its convex hull: opendyn.io.concavity), a ``<geometry>``
    of several shapes (its first is used), an SRDF pair of a link with itself.
    Raises URDFError naming the file, the element and the problem for malformed input.
    """
    floating_base = flag(floating_base, "load_urdf: floating_base")
    mimic = flag(mimic, "load_urdf: mimic")
    check_inertia = flag(check_inertia, "load_urdf: check_inertia")
    file = resolve_robot(path)
    if srdf is not None and not isinstance(srdf, (str, os.PathLike)):
        raise TypeError(f"load_urdf: srdf must be a file path, got {type(srdf).__name__}")

    def build():
        report = FidelityReport(source=file)
        root, robot = read_urdf(file, report)
        return _Builder(
            file, root, robot, report, mimic, check_inertia, floating_base, srdf
        ).build()

    return cached_model(file, srdf, (floating_base, mimic, check_inertia), build)


def looks_mobile(model) -> bool:
    """Whether a model loaded with a welded base looks like a robot meant to move freely (a
    legged robot, a humanoid, a drone): its root link and the links welded to it carry mass,
    none of them is a "world" link that the URDF attaches it to, and either two or more joints
    leave them (legs, arms and a torso: an arm on a pedestal has one) or nothing moves at all (a
    single free body). A scene's objects are not the robot's. Such a robot is usually meant for
    load_urdf(..., floating_base=True)."""
    if model.floating_base or model.report is None or model.report.welded_mass <= 0:
        return False
    welded = [f.name for f in model.frames if f.body < 0]
    if any(name.lower() == "world" for name in welded):
        return False
    roots = [i for i in np.flatnonzero(model.parent < 0) if not model._is_object(i)]
    return model.nb == len(model.objects) or len(roots) >= 2


def welded_mobile_warning(model, how) -> str | None:
    """The warning for a model that looks_mobile (None otherwise): it is welded to the world,
    and `how` lets it move (e.g. "--floating-base")."""
    if not looks_mobile(model):
        return None
    return (
        f"{model.name!r} looks like a mobile robot (its root link carries "
        f"{model.report.welded_mass:.4g} kg and nothing attaches it to a world link), but its "
        f"base is welded to the world; {how} to let it move"
    )


def resolve_robot(path) -> str:
    """The URDF file for a path or a robot name; URDFError listing known names if neither."""
    if isinstance(path, os.PathLike) or (
        isinstance(path, str)
        and (os.sep in path or "/" in path or path.endswith(".urdf") or os.path.exists(path))
    ):
        if os.path.isdir(path):
            raise URDFError(f"{path}: is a folder, not a URDF file")
        if not os.path.isfile(path):
            raise URDFError(f"{path}: no such URDF file")
        return os.fspath(path)
    if not isinstance(path, str):
        raise TypeError(f"load_urdf: path must be a file path or a robot name, not {path!r}")
    robots = available_robots()
    if path in robots:
        return robots[path]
    close = difflib.get_close_matches(path, robots, n=5)
    known = ", ".join(sorted(robots)[:40])
    try:
        importlib.metadata.distribution("example-robot-data")
        more = ""
    except importlib.metadata.PackageNotFoundError:
        more = (
            "; the UR5, Panda, Solo12, Talos and the other robots of example-robot-data need "
            "`pip install example-robot-data` (opendyn's test extra installs it)"
        )
    raise URDFError(
        f"{path!r} is neither a URDF file nor a known robot name"
        + (f"; closest names: {', '.join(close)}" if close else "")
        + f"; known robots: {known}{', ...' if len(robots) > 40 else ''}{more}"
    )


def available_robots() -> dict[str, str]:
    """Robot names -> URDF paths: opendyn's own robots first, then example-robot-data's.

    A robot is named by its file stem (``ur5_robot``) and, where unambiguous, by the stem
    without a ``_robot`` suffix (``ur5``).
    """
    found: dict[str, str] = {}
    paths = sorted(str(p) for p in shipped_robots_dir().glob("*.urdf"))
    try:
        dist = importlib.metadata.distribution("example-robot-data")
        paths += sorted(
            str(dist.locate_file(f)) for f in (dist.files or []) if str(f).endswith(".urdf")
        )
    except importlib.metadata.PackageNotFoundError:
        pass
    for p in paths:
        found.setdefault(Path(p).stem, p)
    for p in paths:
        stem = Path(p).stem
        if stem.endswith("_robot"):
            found.setdefault(stem[: -len("_robot")], p)
    return found


def shipped_robots_dir() -> Path:
    """The robots/ folder shipped with opendyn: inside the installed package, or at the top of
    the source tree when opendyn is imported from a checkout."""
    here = Path(__file__).resolve().parents[1]  # the package: opendyn/
    for candidate in (here / "robots", here.parent / "robots"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"opendyn's robots folder is missing beside {here}")
