"""Reading an SRDF file's ``<disable_collisions link1=... link2=...>``: the link pairs whose
geometries are not checked for collision by default (adjacent links, links that can never meet,
links always in contact), as Pinocchio's ``removeCollisionPairs`` reads them.

An SRDF's root is ``<robot>``, as a URDF's: a file with ``<link>`` or ``<joint>`` elements at the
top and none of the SRDF's own (``<disable_collisions>``, ``<group>``, ...) is a URDF, and
refused as one.
"""

from __future__ import annotations

import os

from lxml import etree

from ..errors import URDFError

# the SRDF's own top-level elements (MoveIt's SRDF format)
SRDF_ELEMENTS = (
    "disable_collisions", "enable_collisions", "disable_default_collisions", "group",
    "group_state", "end_effector", "virtual_joint", "passive_joint",
    "link_sphere_approximation", "joint_property",
)


def disabled_link_pairs(path, link_names, report) -> frozenset:
    """The link pairs (frozensets of two names) an SRDF file disables, what was read and not in
    the FidelityReport `report`.

    link_names: the model's link names. A pair naming a link the model does not have is left out
    (as Pinocchio does: an SRDF often serves several variants of a robot) and listed in
    report.ignored; a pair of a link with itself disables nothing and is a URDFWarning naming
    the SRDF's line.
    Raises URDFError naming the file (and the element's line) for a missing or unreadable file,
    malformed XML, a root other than <robot>, a URDF given for the SRDF, or a
    <disable_collisions> without link1 or link2.
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        raise URDFError(f"{path}: is a folder, not an SRDF file: name the .srdf file in it")
    if not os.path.isfile(path):
        raise URDFError(f"{path}: the SRDF file does not exist")
    try:
        root = etree.parse(path, etree.XMLParser(remove_comments=True)).getroot()
    except (OSError, etree.XMLSyntaxError) as e:
        raise URDFError(f"{path}: the SRDF file could not be read as XML: {e}") from None
    if root.tag != "robot":
        raise URDFError(f"{path}: the SRDF's root element is <{root.tag}>, not <robot>")
    tags = {el.tag for el in root}
    urdf_tags = [f"<{tag}>" for tag in ("link", "joint") if tag in tags]
    if urdf_tags and not tags & set(SRDF_ELEMENTS):
        raise URDFError(
            f"{path}: is a URDF, not an SRDF: its <robot> holds {' and '.join(urdf_tags)} "
            f"elements and none of an SRDF's (such as <disable_collisions> or <group>); the "
            f"SRDF is the file of <disable_collisions> that goes with the URDF"
        )
    known = set(link_names)
    pairs, unknown = set(), []
    for el in root.iter("disable_collisions"):
        link1, link2 = el.get("link1"), el.get("link2")
        if not link1 or not link2:
            raise URDFError(
                f"{path}: <disable_collisions> at line {el.sourceline} needs both link1 and link2"
            )
        if link1 == link2:
            report.warn(
                "ignored",
                f"SRDF {path}: <disable_collisions> at line {el.sourceline} pairs link "
                f"{link1!r} with itself: a link's geometries are never a pair (they move "
                f"together), so it disables nothing",
            )
            continue
        missing = [name for name in (link1, link2) if name not in known]
        if missing:
            unknown.extend(missing)
            continue
        pairs.add(frozenset((link1, link2)))
    if unknown:
        names = ", ".join(map(repr, dict.fromkeys(unknown)))
        report.ignored.append(
            f"SRDF {path}: <disable_collisions> of links the URDF does not have: {names}"
        )
    report.honoured.append(
        f"SRDF {path}: {len(pairs)} link pairs' collisions disabled (<disable_collisions>)"
    )
    return frozenset(pairs)
