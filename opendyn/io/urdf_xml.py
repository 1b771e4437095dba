"""Reading a URDF file: its checked XML tree (lxml) and its yourdfpy robot, and the fidelity
report that says what the loader did with each part of it.

URDFs written for Bullet load as other robotics tools load them, each tolerance in the fidelity
report: an XML declaration of version "0.0" or after blank lines, NUL bytes after the document,
<collision> and <visual> geometry outside the spec (<plane>, <cdf>: ignored), and a <limit> with
lower > upper (Bullet's "no limit": unlimited; read so by opendyn.io.urdf_model).
"""

from __future__ import annotations

import collections
import copy
import io
import math
import re
import warnings
from dataclasses import dataclass, field

from lxml import etree

from .._runtime.files import kind_of
from .._runtime.signals import held_interrupt
from ..errors import URDFError, URDFWarning

URDF_GEOMETRIES = ("box", "cylinder", "sphere", "mesh")  # the shapes of the URDF spec
# <collision> shapes read: the URDF's and Pinocchio's <capsule radius length> (yourdfpy does not
# know it: the copy of the URDF it parses leaves capsules out)
COLLISION_GEOMETRIES = (*URDF_GEOMETRIES, "capsule")
CONTACT_GEOMETRIES = ("sphere", "box")  # the <collision> geometries that give contact spheres


@dataclass
class FidelityReport:
    """What the loader did with each part of the URDF.

    honoured:    content that is part of the model exactly as written
    transformed: content that was changed on the way in (lumped links, normalised axes, ...)
    ignored:     content the model does not use (visuals, collision meshes, transmissions, ...)
    welded_mass: the mass (kg) of the links welded to the fixed world, whose inertia is unused
                 (0 with a floating base)
    unread_meshes: each <collision> mesh that could not be found or read (left out of
                 model.geometries): where it is and why, also among `ignored`
    hollow_meshes: each <collision> mesh far from convex (opendyn.io.concavity), also among
                 `transformed`: a scene whose contact uses the collision geometry warns of them
    """

    source: str
    honoured: list[str] = field(default_factory=list)
    transformed: list[str] = field(default_factory=list)
    ignored: list[str] = field(default_factory=list)
    welded_mass: float = 0.0
    unread_meshes: list[str] = field(default_factory=list)
    hollow_meshes: list[str] = field(default_factory=list)

    def warn(self, kind: str, line: str) -> None:
        """Add `line` to the list `kind` ("transformed" or "ignored") and issue it as a
        URDFWarning naming the file: what a user should not miss."""
        getattr(self, kind).append(line)
        warnings.warn(f"{self.source}: {line}", URDFWarning, stacklevel=2)

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


def read_urdf(file, report: FidelityReport | None = None):
    """(root, robot): a URDF file's checked XML tree (lxml) and its yourdfpy robot, read the way
    robotics tools read it (see _parse_xml and _drop_unknown_geometry); what was tolerated on
    the way goes into `report`. Raises URDFError naming the file, element and problem."""
    report = FidelityReport(source=file) if report is None else report
    root = _parse_xml(file, report)
    _drop_unknown_geometry(root, report)
    _check_numbers(file, root)
    _check_shapes(file, root)
    return root, _parse_yourdfpy(file, root).robot


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
        kind = kind_of(file)
        if kind != "a text file":
            raise URDFError(f"{file}: is {kind}, not a URDF (XML text)") from None
        raise URDFError(f"{file}: malformed XML: {e}") from None
    if root.tag != "robot":
        raise URDFError(f"{file}: the root element is <{root.tag}>, expected <robot>")
    if not root.get("name"):
        raise URDFError(f"{file}: <robot> has no name attribute")
    return root


def _drop_unknown_geometry(root, report) -> None:
    """Remove each link's <visual> and <collision> whose <geometry> holds no URDF shape (box,
    cylinder, sphere, mesh; a <collision> also Pinocchio's <capsule>): Bullet's <plane> and
    <cdf>, or nothing at all. Like the other tools, load them as absent and list them in
    report.ignored, by element and shape."""
    dropped = collections.defaultdict(list)
    for link in root.iterchildren("link"):
        for el in list(link.iterchildren("visual", "collision")):
            geometry = el.find("geometry")
            shape = geometry[0].tag if geometry is not None and len(geometry) else None
            known = COLLISION_GEOMETRIES if el.tag == "collision" else URDF_GEOMETRIES
            if shape not in known:
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


def where(el) -> str:
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
                    check_values(file, el, attr, text, count)
            if el.tag in ("mass", "inertia") and el.getparent().tag == "inertial" and not el.attrib:
                raise URDFError(f"{file}: {where(el)}: <{el.tag}> has no values")


_SHAPES = {  # a <visual> or <collision> shape -> the attributes that yourdfpy reads as numbers
    "box": ("size",),
    "cylinder": ("radius", "length"),
    "sphere": ("radius",),
    "mesh": (),
}


def _check_shapes(file, root) -> None:
    """Every <visual> and <collision> shape that yourdfpy reads has its sizes, and they and a
    <mesh scale> are numbers (m; the scale's factors): yourdfpy's own error would name neither
    the link nor the element. Counts and values are checked where the geometry is used
    (opendyn.io.urdf_collision)."""
    for link in root.iterchildren("link"):
        for outer in link.iterchildren("visual", "collision"):
            shape = outer.find("geometry")[0]
            if shape.tag not in _SHAPES:
                continue  # Pinocchio's <capsule>: yourdfpy does not read it
            label = f'<link name="{link.get("name")}"> <{outer.tag}> <{shape.tag}>'
            for attr in _SHAPES[shape.tag]:
                if shape.get(attr) is None:
                    needs = " and ".join(_SHAPES[shape.tag])
                    raise URDFError(
                        f"{file}: {label} (line {shape.sourceline}): no {attr}: a "
                        f"<{shape.tag}> needs {needs} (m)"
                    )
            for attr in (*_SHAPES[shape.tag], "scale"):
                text = shape.get(attr)
                try:
                    for word in (text or "").replace(",", " ").split():
                        float(word)
                except ValueError:
                    raise URDFError(
                        f"{file}: {label} (line {shape.sourceline}): {attr}={text!r} holds "
                        f"what is not a number"
                    ) from None


def _gives_contact_spheres(el) -> bool:
    """Whether a <visual> or <collision> element is a <collision> whose shape is a sphere or box."""
    shape = el.find("geometry/*")
    return el.tag == "collision" and shape is not None and shape.tag in CONTACT_GEOMETRIES


def check_values(file, el, attr, text, count):
    try:
        values = [float(t) for t in text.split()]
    except ValueError:
        xacro = " (an unexpanded xacro substitution: run xacro on the file)" if "$(" in text else ""
        raise URDFError(f"{file}: {where(el)}: {attr}={text!r} is not a number{xacro}") from None
    if len(values) != count:
        raise URDFError(
            f"{file}: {where(el)}: {attr}={text!r} must have {count} "
            f"value{'s' if count > 1 else ''}"
        )
    if not all(math.isfinite(v) for v in values):
        raise URDFError(f"{file}: {where(el)}: {attr}={text!r} is not finite")


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
                raise URDFError(f"{file}: {where(el)}: missing <{end} link=...>")
    capsules = root.xpath("link/collision[geometry/capsule]")
    if capsules:  # yourdfpy reads the URDF's shapes only
        root = copy.deepcopy(root)
        for el in root.xpath("link/collision[geometry/capsule]"):
            el.getparent().remove(el)
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
