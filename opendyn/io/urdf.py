"""load_urdf: a URDF file (parsed by yourdfpy) -> a frozen Model, with a fidelity report.

For each moving joint i (revolute, continuous, prismatic, floating) in depth-first order over
the tree:

    M_{lambda(i), i} = T_{body(parent link), parent link} T_origin(joint i)
    S_i = (a, 0) revolute / continuous,  (0, a) prismatic,  I_6 floating,   a = axis / |axis|
    G_i = sum over links L welded to body i of  Ad_{T_{L_com, i}}^T G_{L_com} Ad_{T_{L_com, i}}

Fixed joints are merged: a link hanging from a fixed joint becomes a frame of the body above it
and its inertia is lumped into that body. The root link and the links welded to it belong to the
fixed world, and their inertia plays no part (as in Pinocchio), unless the base floats: with
floating_base=True the root link is body 0 on a free joint ("root_joint", M = identity), so q
starts with the root link frame's pose in the world. Every URDF link stays a named frame.

The spheres and boxes of the links' <collision> elements become model.collision_spheres, each in
its own link's frame: a <sphere> gives one at the collision origin's xyz, a <box> of size
(sx, sy, sz) its 8 corners T_origin (+-sx/2, +-sy/2, +-sz/2), radius 0, in the order of
BOX_CORNERS; meshes and cylinders give none.

URDFs written for Bullet load as other robotics tools load them, each tolerance in the fidelity
report: an XML declaration of version "0.0" or after blank lines, NUL bytes after the document,
<collision> and <visual> geometry outside the spec (<plane>, <cdf>: ignored), and a <limit> with
lower > upper (Bullet's "no limit": unlimited).
"""

from __future__ import annotations

import collections
import dataclasses
import difflib
import importlib.metadata
import io
import itertools
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lxml import etree

from .._runtime.signals import held_interrupt
from ..errors import URDFError
from ..multibody.joints import FREE, PRISMATIC, REVOLUTE
from ..multibody.model import CollisionSphere, Frame, Model
from ..spatial.algebra import spatial_inertia

MOVING_TYPES = {
    "revolute": REVOLUTE,
    "continuous": REVOLUTE,
    "prismatic": PRISMATIC,
    "floating": FREE,
}
SUPPORTED_TYPES = set(MOVING_TYPES) | {"fixed"}
ROOT_JOINT = "root_joint"  # the name of the free joint that floating_base=True adds
# A box's corners as fractions of its size, in the order its collision spheres take: the signs
# (x, y, z) run (-,-,-), (-,-,+), (-,+,-), (-,+,+), (+,-,-), ..., (+,+,+) (z fastest, x slowest)
BOX_CORNERS = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))
URDF_GEOMETRIES = ("box", "cylinder", "sphere", "mesh")  # the shapes of the URDF spec
CONTACT_GEOMETRIES = ("sphere", "box")  # the <collision> geometries that give contact spheres


@dataclass
class FidelityReport:
    """What the loader did with each part of the URDF.

    honoured:    content that is part of the model exactly as written
    transformed: content that was changed on the way in (lumped links, normalised axes, ...)
    ignored:     content the model does not use (visuals, collision meshes, transmissions, ...)
    welded_mass: the mass (kg) of the links welded to the fixed world, whose inertia is unused
                 (0 with a floating base)
    """

    source: str
    honoured: list[str] = field(default_factory=list)
    transformed: list[str] = field(default_factory=list)
    ignored: list[str] = field(default_factory=list)
    welded_mass: float = 0.0

    def __str__(self) -> str:
        lines = [f"URDF fidelity report for {self.source}"]
        for title, items in (
            ("honoured", self.honoured),
            ("transformed", self.transformed),
            ("ignored", self.ignored),
        ):
            lines.append(f"  {title}: {len(items)}")
            lines.extend(f"    - {item}" for item in items)
        return "\n".join(lines)


def load_urdf(
    path, floating_base: bool = False, mimic: bool = False, check_inertia: bool = True
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

    Returns the Model; ``model.report`` is the fidelity report (honoured, transformed, ignored).
    Raises URDFError naming the file, the element and the problem for malformed input.
    """
    file = resolve_robot(path)
    report = FidelityReport(source=file)
    root, robot = read_urdf(file, report)
    return _Builder(file, root, robot, report, mimic, check_inertia, floating_base).build()


def read_urdf(file, report: FidelityReport | None = None):
    """(root, robot): a URDF file's checked XML tree (lxml) and its yourdfpy robot, read the way
    robotics tools read it (see _parse_xml and _drop_unknown_geometry); what was tolerated on
    the way goes into `report`. Raises URDFError naming the file, element and problem."""
    report = FidelityReport(source=file) if report is None else report
    root = _parse_xml(file, report)
    _drop_unknown_geometry(root, report)
    _check_numbers(file, root)
    return root, _parse_yourdfpy(file, root).robot


def looks_mobile(model) -> bool:
    """Whether a model loaded with a welded base looks like a robot meant to move freely (a
    legged robot, a humanoid, a drone): its root link and the links welded to it carry mass,
    none of them is a "world" link that the URDF attaches it to, and either two or more joints
    leave them (legs, arms and a torso: an arm on a pedestal has one) or nothing moves at all (a
    single free body). Such a robot is usually meant for load_urdf(..., floating_base=True)."""
    if model.floating_base or model.report.welded_mass <= 0:
        return False
    welded = [f.name for f in model.frames if f.body < 0]
    if any(name.lower() == "world" for name in welded):
        return False
    return model.nb == 0 or int(np.sum(model.parent < 0)) >= 2


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
    raise URDFError(
        f"{path!r} is neither a URDF file nor a known robot name"
        + (f"; closest names: {', '.join(close)}" if close else "")
        + f"; known robots: {known}{', ...' if len(robots) > 40 else ''}"
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


# the XML declaration, after an optional UTF-8 byte-order mark and whitespace
_DECLARATION = re.compile(rb"(?:\xef\xbb\xbf)?(\s*)(<\?xml\s.*?\?>)", re.DOTALL)
_VERSION = re.compile(rb"""(version\s*=\s*)(["'])(.*?)\2""")


def _parse_xml(file, report):
    """The <robot> element of a URDF file, comments removed. Three things that XML forbids but
    robotics tools read are tolerated and reported as transformed: whitespace before the XML
    declaration (moved after it, so that line numbers stay true), a declaration version other
    than 1.x (Bullet's files say "0.0"), read as 1.0, and NUL bytes after the document (where a
    C string ends)."""
    try:
        with open(file, "rb") as f:
            data = f.read()
    except OSError as e:
        raise URDFError(f"{file}: cannot be read: {e.strerror}") from None
    end = data.rstrip(b"\0 \t\r\n")
    if b"\0" in data[len(end) :]:
        data = end
        report.transformed.append("NUL bytes after the end of the document skipped")
    match = _DECLARATION.match(data)
    if match:
        blank, declaration = match.groups()
        version = _VERSION.search(declaration)
        if version and not version.group(3).startswith(b"1."):
            declaration = _VERSION.sub(rb"\1\g<2>1.0\2", declaration, count=1)
            report.transformed.append(
                f"XML declaration version {version.group(3).decode(errors='replace')!r} "
                f"read as 1.0"
            )
        if blank:
            lines = blank.count(b"\n")
            report.transformed.append(
                f"whitespace before the XML declaration ({lines} line{'s' * (lines != 1)}) "
                f"skipped"
            )
        data = declaration + blank + data[match.end() :]
    try:
        root = etree.fromstring(data, etree.XMLParser(remove_comments=True), base_url=file)
    except etree.XMLSyntaxError as e:
        raise URDFError(f"{file}: malformed XML: {e}") from None
    if root.tag != "robot":
        raise URDFError(f"{file}: the root element is <{root.tag}>, expected <robot>")
    if not root.get("name"):
        raise URDFError(f"{file}: <robot> has no name attribute")
    return root


def _drop_unknown_geometry(root, report) -> None:
    """Remove each link's <visual> and <collision> whose <geometry> holds no URDF shape (box,
    cylinder, sphere, mesh): Bullet's <plane> and <cdf>, or nothing at all. Like the other
    tools, load them as absent and list them in report.ignored, by element and shape."""
    dropped = collections.defaultdict(list)
    for link in root.iterchildren("link"):
        for el in list(link.iterchildren("visual", "collision")):
            geometry = el.find("geometry")
            shape = geometry[0].tag if geometry is not None and len(geometry) else None
            if shape not in URDF_GEOMETRIES:
                dropped[el.tag, shape].append(link.get("name"))
                link.remove(el)
    for (tag, shape), links in dropped.items():
        what = f"<geometry> <{shape}>" if shape else "no <geometry> shape"
        names = list(dict.fromkeys(links))
        report.ignored.append(
            f"{len(links)} <{tag}> element{'s' * (len(links) > 1)} with {what}, outside the "
            f"URDF spec ({', '.join(URDF_GEOMETRIES)}), not read: "
            f"link{'s' * (len(names) > 1)} {', '.join(map(repr, names))}"
        )


def _where(el) -> str:
    """'<tag name="..."> (line N)' for the nearest named ancestor of an element."""
    named = el
    while named is not None and named.get("name") is None:
        named = named.getparent()
    owner = f'<{named.tag} name="{named.get("name")}">' if named is not None else "<robot>"
    inner = "" if named is el else f" <{el.tag}>"
    return f"{owner}{inner} (line {el.sourceline})"


_NUMERIC = {  # element tag -> {attribute: number of values}
    "origin": {"xyz": 3, "rpy": 3},
    "axis": {"xyz": 3},
    "mass": {"value": 1},
    "inertia": {k: 1 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    "limit": {"lower": 1, "upper": 1, "effort": 1, "velocity": 1},
    "dynamics": {"damping": 1, "friction": 1},
    "mimic": {"multiplier": 1, "offset": 1},
    "sphere": {"radius": 1},
    "box": {"size": 3},
}


def _check_numbers(file, root) -> None:
    """Every numeric attribute of the kinematic and inertial elements, and of the <collision>
    elements that give contact spheres, parses and is finite."""
    for owner in root.iterchildren("link", "joint"):
        for el in owner.iter(*_NUMERIC):
            outer = next(el.iterancestors("visual", "collision"), None)
            if outer is not None and not _gives_contact_spheres(outer):
                continue
            for attr, count in _NUMERIC[el.tag].items():
                text = el.get(attr)
                if text is not None:
                    _check_values(file, el, attr, text, count)
            if el.tag in ("mass", "inertia") and el.getparent().tag == "inertial" and not el.attrib:
                raise URDFError(f"{file}: {_where(el)}: <{el.tag}> has no values")


def _gives_contact_spheres(el) -> bool:
    """Whether a <visual> or <collision> element is a <collision> whose shape is a sphere or box."""
    shape = el.find("geometry/*")
    return el.tag == "collision" and shape is not None and shape.tag in CONTACT_GEOMETRIES


def _check_values(file, el, attr, text, count):
    try:
        values = [float(t) for t in text.split()]
    except ValueError:
        xacro = " (an unexpanded xacro substitution: run xacro on the file)" if "$(" in text else ""
        raise URDFError(f"{file}: {_where(el)}: {attr}={text!r} is not a number{xacro}") from None
    if len(values) != count:
        raise URDFError(
            f"{file}: {_where(el)}: {attr}={text!r} must have {count} "
            f"value{'s' if count > 1 else ''}"
        )
    if not all(math.isfinite(v) for v in values):
        raise URDFError(f"{file}: {_where(el)}: {attr}={text!r} is not finite")


def _parse_yourdfpy(file, root):
    with held_interrupt():  # importing yourdfpy imports trimesh, which swallows Ctrl-C
        import yourdfpy

    for tag in ("link", "joint"):
        for el in root.iterchildren(tag):
            if not el.get("name"):
                raise URDFError(f"{file}: <{tag}> at line {el.sourceline} has no name")
    for el in root.iterchildren("joint"):
        for end in ("parent", "child"):
            sub = el.find(end)
            if sub is None or not sub.get("link"):
                raise URDFError(f"{file}: {_where(el)}: missing <{end} link=...>")
    try:
        return yourdfpy.URDF.load(
            io.BytesIO(etree.tostring(root)),
            build_scene_graph=False,
            load_meshes=False,
            build_collision_scene_graph=False,
            load_collision_meshes=False,
        )
    except Exception as e:  # yourdfpy raises bare KeyError/ValueError on content it rejects
        raise URDFError(f"{file}: yourdfpy could not parse the URDF: {e!r}") from None


class _Builder:
    """Walks the URDF tree depth-first and accumulates bodies, frames and the report."""

    def __init__(self, file, root, robot, report, mimic, check_inertia, floating_base):
        self.file, self.root, self.robot, self.report = file, root, robot, report
        self.use_mimic, self.check_inertia = mimic, check_inertia
        self.floating_base = floating_base

    def fail(self, what: str):
        raise URDFError(f"{self.file}: {what}")

    def build(self) -> Model:
        links = self._links_by_name()
        joints = self._joints_by_name(links)
        root_link, children = self._tree(links, joints)
        order = self._depth_first(root_link, children)
        coords, mimic_of = self._coordinates(order, joints)

        body_of = {root_link: -1}
        T_body_link = {root_link: np.eye(4)}
        parent, jtype, S, R_home, p_home, body_names, body_joints = [], [], [], [], [], [], []

        def add_body(link, joint, kind, parent_body, T_home, axes):
            body_of[link], T_body_link[link] = len(body_names), np.eye(4)
            parent.append(parent_body)
            jtype.append(kind)
            S.append(np.zeros((6, 6)))
            S[-1][: len(axes)] = axes
            R_home.append(T_home[:3, :3])
            p_home.append(T_home[:3, 3])
            body_names.append(link)
            body_joints.append(joint)

        if self.floating_base and not (order and order[0].type == "floating"):
            add_body(root_link, ROOT_JOINT, FREE, -1, np.eye(4), np.eye(6))
            self.report.transformed.append(
                f"floating base: root link {root_link!r} on a free joint {ROOT_JOINT!r}, "
                f"q = (p, quat (x, y, z, w), joints), v = (omega_b, v_b, joints)"
            )
        for j in order:
            plink = j.parent
            origin = j.origin if j.origin is not None else np.eye(4)
            T_pj = T_body_link[plink] @ origin
            if j.type == "fixed":
                body_of[j.child], T_body_link[j.child] = body_of[plink], T_pj
                continue
            if j.type == "floating":
                axes = np.eye(6)
            else:
                axis = self._unit_axis(j)
                axes = np.concatenate(
                    [axis, np.zeros(3)] if j.type != "prismatic" else [np.zeros(3), axis]
                )[None]
            add_body(j.child, j.name, MOVING_TYPES[j.type], body_of[plink], T_pj, axes)

        G = self._body_inertias(links, body_of, T_body_link, len(body_names))
        frames = [Frame(name, body_of[name], T_body_link[name]) for name in links]
        collision_spheres = self._collision_spheres(links)
        self._report_content(links, joints, body_of, collision_spheres)

        follows, mult, offset = {}, [], []
        for i, name in enumerate(body_joints):
            src, m, o = mimic_of.get(name, (name, 1.0, 0.0))
            if name in mimic_of:
                follows[i] = body_joints.index(src)
            mult.append(m)
            offset.append(o)
        limits = self._limits(coords, joints)
        return Model.build(
            name=self.robot.name,
            joint_names=coords,
            body_names=body_names,
            body_joints=body_joints,
            parent=parent,
            jtype=jtype,
            follows=follows,
            mult=mult,
            offset=offset,
            S=np.reshape(S, (-1, 6, 6)),
            G=G,
            R_home=np.reshape(R_home, (-1, 3, 3)),
            p_home=np.reshape(p_home, (-1, 3)),
            frames=frames,
            frame_aliases={
                **({ROOT_JOINT: root_link} if ROOT_JOINT in body_joints else {}),
                **{j.name: j.child for j in joints.values()},
            },
            report=self.report,
            source=self.file,
            collision_spheres=collision_spheres,
            **limits,
        )

    def _links_by_name(self):
        links = {}
        for link in self.robot.links:
            if link.name in links:
                self.fail(f'<link name="{link.name}">: duplicate link name')
            links[link.name] = link
        if not links:
            self.fail("the robot has no <link>")
        return links

    def _joints_by_name(self, links):
        joints = {}
        for j in self.robot.joints:
            where = f'<joint name="{j.name}">'
            if j.name in joints:
                self.fail(f"{where}: duplicate joint name")
            if j.type not in SUPPORTED_TYPES:
                self.fail(
                    f"{where}: joint type {j.type!r} is not supported; supported types: "
                    f"revolute, continuous, prismatic, floating, fixed"
                )
            for end, link in (("parent", j.parent), ("child", j.child)):
                if link not in links:
                    self.fail(f'{where}: {end} link "{link}" is not a <link> of the robot')
            if j.parent == j.child:
                self.fail(f'{where}: parent and child are the same link "{j.child}"')
            joints[j.name] = j
        return joints

    def _tree(self, links, joints):
        children = {name: [] for name in links}
        parent_joint = {}
        for j in joints.values():
            if j.child in parent_joint:
                self.fail(
                    f'<link name="{j.child}"> is the child of two joints, '
                    f'<joint name="{parent_joint[j.child].name}"> and '
                    f'<joint name="{j.name}"> (a URDF is a tree)'
                )
            parent_joint[j.child] = j
            children[j.parent].append(j)
        roots = [name for name in links if name not in parent_joint]
        if not roots:
            self.fail(
                f"the joints {self._cycle(parent_joint, next(iter(links)))} form a cycle: "
                f"every link is the child of a joint, so there is no root link"
            )
        if len(roots) > 1:
            named = ", ".join(f'<link name="{r}">' for r in roots)
            self.fail(
                f"the URDF has {len(roots)} root links ({named}); a robot has one root "
                f"(link the others to it with a joint)"
            )
        reached, stack = {roots[0]}, [roots[0]]
        while stack:
            for j in children[stack.pop()]:
                reached.add(j.child)
                stack.append(j.child)
        cut = [name for name in links if name not in reached]
        if cut:
            self.fail(
                f"the joints {self._cycle(parent_joint, cut[0])} form a cycle: links "
                f"{', '.join(cut)} cannot be reached from the root link {roots[0]!r}"
            )
        return roots[0], children

    @staticmethod
    def _cycle(parent_joint, link):
        """'<joint name="a">, <joint name="b">, ...': the cycle met walking up from a link that
        no root reaches (every link on the way has a parent joint)."""
        path, seen = [], set()
        while link not in seen:
            seen.add(link)
            path.append(parent_joint[link])
            link = path[-1].parent
        start = next(k for k, j in enumerate(path) if j.child == link)
        return ", ".join(f'<joint name="{j.name}">' for j in reversed(path[start:]))

    @staticmethod
    def _depth_first(root_link, children):
        order, stack = [], list(reversed(children[root_link]))
        while stack:
            j = stack.pop()
            order.append(j)
            stack.extend(reversed(children[j.child]))
        return order

    def _coordinates(self, order, joints):
        """Names of the generalized coordinates, and {joint: (source, multiplier, offset)}."""
        mimic_of = {}
        for j in order:
            if j.mimic is None or j.type == "fixed":
                continue
            if j.type == "floating" or joints.get(j.mimic.joint, j).type == "floating":
                self.fail(
                    f'<joint name="{j.name}"> <mimic>: a floating joint neither mimics nor is '
                    f"mimicked"
                )
            if not self.use_mimic:
                self.report.ignored.append(
                    f"mimic on joint {j.name!r} (follows {j.mimic.joint!r}): kept as an "
                    f"independent coordinate (load_urdf(..., mimic=True) couples it)"
                )
                continue
            if j.mimic.joint not in joints or joints[j.mimic.joint].type == "fixed":
                self.fail(
                    f'<joint name="{j.name}"> <mimic joint="{j.mimic.joint}">: not a '
                    f"moving joint of the robot"
                )
            mimic_of[j.name] = (
                j.mimic.joint,
                float(j.mimic.multiplier or 1.0),
                float(j.mimic.offset or 0.0),
            )
        for name in list(mimic_of):
            src, m, o = mimic_of[name]
            seen = {name}
            while src in mimic_of:
                if src in seen:
                    self.fail(
                        f'<joint name="{name}"> <mimic>: mimic joints form a cycle '
                        f"through {', '.join(sorted(seen))}"
                    )
                seen.add(src)
                src, m, o = mimic_of[src][0], m * mimic_of[src][1], m * mimic_of[src][2] + o
            mimic_of[name] = (src, m, o)
            self.report.transformed.append(
                f"mimic joint {name!r} = {m:g} * {src!r} + {o:g}: not a coordinate of the model "
                f"(its own <limit> and <dynamics> are not used)"
            )
        coords = [
            j.name for j in order if j.type not in ("fixed", "floating") and j.name not in mimic_of
        ]
        return coords, mimic_of

    def _unit_axis(self, j):
        axis = np.asarray(j.axis, dtype=float)  # yourdfpy gives (1, 0, 0) for a missing <axis>
        norm = float(np.linalg.norm(axis))
        if norm < 1e-12:
            self.fail(
                f'<joint name="{j.name}"> <axis xyz="{" ".join(map(str, axis))}">: the axis is zero'
            )
        if abs(norm - 1.0) > 1e-12:
            self.report.transformed.append(f"axis of joint {j.name!r} normalised (length {norm:g})")
        return axis / norm

    def _body_inertias(self, links, body_of, T_body_link, nb):
        """The bodies' spatial inertias G (nb, 6, 6), each the sum of its links' inertias.
        Raises one URDFError listing every link whose inertia no rigid body has."""
        G = np.zeros((nb, 6, 6))
        refused = []  # (where, what is wrong, whether check_inertia=False would keep it)
        for name, link in links.items():
            inertial = link.inertial
            if inertial is None:
                continue
            where = f'<link name="{name}"> <inertial>'
            mass = float(inertial.mass if inertial.mass is not None else 0.0)
            I = np.zeros((3, 3)) if inertial.inertia is None else inertial.inertia
            T_body_com = T_body_link[name] @ (
                inertial.origin if inertial.origin is not None else np.eye(4)
            )
            com, R_com = T_body_com[:3, 3], T_body_com[:3, :3]
            try:
                G_link = spatial_inertia(mass, com, I, R_com)
            except ValueError as e:
                if body_of[name] < 0 and mass >= 0:
                    self.report.welded_mass += mass
                    self.report.ignored.append(
                        f"{where}: not a rigid-body inertia ({e}), but "
                        f"welded to the fixed root, so unused"
                    )
                    continue
                if self.check_inertia or mass < 0:
                    refused.append((where, e, mass >= 0))
                    continue
                self.report.honoured.append(f"{where}: kept as written although {e}")
                G_link = spatial_inertia(mass, com, I, R_com, physical=False)
            if body_of[name] >= 0:
                G[body_of[name]] += G_link
            elif mass > 0:
                self.report.welded_mass += mass
                self.report.ignored.append(
                    f"inertia of link {name!r} ({mass:g} kg): welded to the fixed root"
                )
        if refused:
            self._refuse_inertias(refused)
        return G

    def _refuse_inertias(self, refused):
        """Raise one URDFError naming every (where, problem, keepable) in `refused`, and saying
        which of them load_urdf(..., check_inertia=False) would keep as written."""
        keepable = [keep for _, _, keep in refused]
        hint = ""
        if any(keepable):
            which = "it" if len(refused) == 1 else "them" if all(keepable) else "those of mass >= 0"
            hint = f" (load_urdf(..., check_inertia=False) keeps {which} as written)"
        if len(refused) == 1:
            where, problem, _ = refused[0]
            self.fail(f"{where}: {problem}; no rigid body has it{hint}")
        self.fail(
            f"{len(refused)} links have an inertia that no rigid body has{hint}:\n"
            + "\n".join(f"  {where}: {problem}" for where, problem, _ in refused)
        )

    def _collision_spheres(self, links):
        """The CollisionSpheres of the links' <collision> spheres and box corners, each in its
        link's frame: by link in URDF order, then by <collision> in document order."""
        spheres = []
        for name, link in links.items():
            for c in link.collisions:
                kind = _geometry_kind(c.geometry)
                if kind not in CONTACT_GEOMETRIES:
                    continue
                T = c.origin if c.origin is not None else np.eye(4)
                where = f'<link name="{name}"> <collision> <{kind}>'
                if kind == "sphere":
                    radius = float(c.geometry.sphere.radius)
                    if radius < 0:
                        self.fail(f"{where}: negative radius {radius:g}")
                    spheres.append(CollisionSphere(name, T[:3, 3], radius, "sphere"))
                    continue
                size = np.asarray(c.geometry.box.size, dtype=float)
                if np.any(size < 0):
                    self.fail(f"{where}: negative size {' '.join(f'{x:g}' for x in size)}")
                spheres.extend(
                    CollisionSphere(name, T[:3, :3] @ corner + T[:3, 3], 0.0, "box corner")
                    for corner in BOX_CORNERS * size
                )
        return spheres

    def _limits(self, coords, joints):
        n = len(coords)
        out = {
            k: np.full(n, v)
            for k, v in (
                ("lower", -np.inf),
                ("upper", np.inf),
                ("velocity_limit", np.inf),
                ("effort_limit", np.inf),
                ("damping", 0.0),
                ("friction", 0.0),
            )
        }
        out["continuous"] = np.zeros(n, dtype=bool)
        for k, name in enumerate(coords):
            j = joints[name]
            out["continuous"][k] = j.type == "continuous"
            lim = j.limit
            if lim is not None:
                if j.type != "continuous":
                    if lim.lower is not None:
                        out["lower"][k] = float(lim.lower)
                    if lim.upper is not None:
                        out["upper"][k] = float(lim.upper)
                    if out["lower"][k] > out["upper"][k]:
                        self.report.transformed.append(
                            f"joint {name!r}: <limit> lower {out['lower'][k]:g} > upper "
                            f"{out['upper'][k]:g}, Bullet's convention for no limit: taken as "
                            f"unlimited (its effort and velocity limits kept)"
                        )
                        out["lower"][k], out["upper"][k] = -np.inf, np.inf
                for key, val in (("velocity_limit", lim.velocity), ("effort_limit", lim.effort)):
                    if val is not None:
                        out[key][k] = float(val)
            dyn = j.dynamics
            if dyn is not None:
                for key in ("damping", "friction"):
                    val = getattr(dyn, key)
                    if val is None:
                        continue
                    out[key][k] = float(val)
                    if out[key][k] < 0:
                        self.fail(
                            f'<joint name="{name}"> <dynamics>: negative {key} {out[key][k]:g}'
                        )
        return out

    def _report_content(self, links, joints, body_of, collision_spheres):
        r = self.report
        moving = [j for j in joints.values() if j.type != "fixed"]
        fixed = [j for j in joints.values() if j.type == "fixed"]
        r.honoured.append(
            f"{len(moving)} moving joints (revolute, continuous, prismatic, floating) with "
            f"their origins, axes, limits and <dynamics>"
        )
        r.honoured.append(f"{len(links)} links kept as named frames, with their <inertial>")
        for j in fixed:
            where = "the fixed world" if body_of[j.child] < 0 else "the body above it"
            r.transformed.append(f"fixed joint {j.name!r}: link {j.child!r} merged into {where}")
        no_axis = [
            el.get("name")
            for el in self.root.iterchildren("joint")
            if el.get("type") in MOVING_TYPES and el.find("axis") is None
        ]
        if no_axis:
            r.transformed.append(
                f"joints without <axis> take the default (1, 0, 0): {', '.join(no_axis)}"
            )
        no_limit = [
            el.get("name")
            for el in self.root.iterchildren("joint")
            if el.get("type") in ("revolute", "prismatic") and el.find("limit") is None
        ]
        if no_limit:
            r.transformed.append(
                f"revolute/prismatic joints without the required <limit>, "
                f"taken as unlimited: {', '.join(no_limit)}"
            )
        massless = [n for n, l in links.items() if l.inertial is None and body_of[n] >= 0]
        if massless:
            r.transformed.append(
                f"links without <inertial> taken as massless: {', '.join(massless)}"
            )
        n_vis = sum(len(l.visuals) for l in links.values())
        if n_vis:
            r.ignored.append(f"{n_vis} <visual> elements (used only for playback)")
        kinds = collections.Counter(
            _geometry_kind(c.geometry) for l in links.values() for c in l.collisions
        )
        used = [(kinds[k], k) for k in CONTACT_GEOMETRIES if kinds[k]]
        unused = [(kinds[k], k) for k in sorted(kinds) if k not in CONTACT_GEOMETRIES]
        if used:
            corners = "; a box corner is one of radius 0" if kinds["box"] else ""
            r.honoured.append(
                f'contact points for [effects.contact] points = "urdf" from '
                f"{_collision_counts(used)}: {len(collision_spheres)} spheres in all "
                f"(model.collision_spheres{corners})"
            )
        if unused:
            r.ignored.append(
                f"{_collision_counts(unused)} (no contact points: only spheres and box "
                f"corners are used)"
            )
        for tag, what in (
            ("safety_controller", "soft limits"),
            ("calibration", "calibration"),
            ("transmission", "actuator transmissions"),
            ("gazebo", "simulator-specific settings"),
        ):
            count = sum(1 for _ in self.root.iter(tag))
            if count:
                r.ignored.append(f"{count} <{tag}> elements ({what})")
        known = {"link", "joint", "material", "transmission", "gazebo"}
        others = sorted({el.tag for el in self.root if isinstance(el.tag, str)} - known)
        if others:
            r.ignored.append(f"unknown top-level elements: {', '.join(others)}")


def _geometry_kind(geometry) -> str:
    """The shape of a yourdfpy Geometry: "sphere", "box", "cylinder" or "mesh"."""
    return next(
        f.name for f in dataclasses.fields(geometry) if getattr(geometry, f.name) is not None
    )


def _collision_counts(counts) -> str:
    """'4 <collision> spheres and 18 boxes' for [(4, "sphere"), (18, "box")]."""
    words = [
        f"{n} {'<collision> ' if k == 0 else ''}{kind}"
        + ("" if n == 1 else "es" if kind.endswith(("x", "sh")) else "s")
        for k, (n, kind) in enumerate(counts)
    ]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"
