"""Reading an SRDF file's ``<disable_collisions link1=... link2=...>``: the link pairs whose
geometries are not checked for collision by default (adjacent links, links that can never meet,
links always in contact), as Pinocchio's ``removeCollisionPairs`` reads them.
"""

from __future__ import annotations

import os

from lxml import etree

from ..errors import URDFError


def disabled_link_pairs(path, link_names, report=None) -> frozenset:
    """The link pairs (frozensets of two names) an SRDF file disables.

    link_names: the model's link names. A pair naming a link the model does not have is left out
    (as Pinocchio does: an SRDF often serves several variants of a robot) and, with a
    FidelityReport `report`, listed in report.ignored.
    Raises URDFError naming the file (and the element's line) for a missing or unreadable file,
    malformed XML, a root other than <robot>, or a <disable_collisions> without link1 or link2.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise URDFError(f"{path}: the SRDF file does not exist")
    try:
        root = etree.parse(path, etree.XMLParser(remove_comments=True)).getroot()
    except (OSError, etree.XMLSyntaxError) as e:
        raise URDFError(f"{path}: the SRDF file could not be read as XML: {e}") from None
    if root.tag != "robot":
        raise URDFError(f"{path}: the SRDF's root element is <{root.tag}>, not <robot>")
    known = set(link_names)
    pairs, unknown = set(), []
    for el in root.iter("disable_collisions"):
        link1, link2 = el.get("link1"), el.get("link2")
        if not link1 or not link2:
            raise URDFError(
                f"{path}: <disable_collisions> at line {el.sourceline} needs both link1 and link2"
            )
        missing = [name for name in (link1, link2) if name not in known]
        if missing:
            unknown.extend(missing)
            continue
        pairs.add(frozenset((link1, link2)))
    if unknown and report is not None:
        names = ", ".join(map(repr, dict.fromkeys(unknown)))
        report.ignored.append(
            f"SRDF {path}: <disable_collisions> of links the URDF does not have: {names}"
        )
    if report is not None:
        report.honoured.append(
            f"SRDF {path}: {len(pairs)} link pairs' collisions disabled (<disable_collisions>)"
        )
    return frozenset(pairs)
