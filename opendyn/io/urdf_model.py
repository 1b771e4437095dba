"""A URDF's links and joints (as yourdfpy reads them) -> the arrays of a frozen Model.

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
"""

from __future__ import annotations

import collections
import dataclasses
import itertools

import numpy as np

from ..errors import URDFError
from ..multibody.joints import FREE, PRISMATIC, REVOLUTE
from ..multibody.model import CollisionSphere, Frame, Model
from ..spatial.algebra import spatial_inertia
from .srdf import disabled_link_pairs
from .urdf_collision import read_geometries
from .urdf_xml import CONTACT_GEOMETRIES

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


class _Builder:
    """Walks the URDF tree depth-first and accumulates bodies, frames and the report."""

    def __init__(self, file, root, robot, report, mimic, check_inertia, floating_base, srdf):
        self.file, self.root, self.robot, self.report = file, root, robot, report
        self.srdf = srdf
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
        geometries = read_geometries(self.file, self.root, self.report)
        disabled = (
            frozenset()
            if self.srdf is None
            else disabled_link_pairs(self.srdf, list(links), self.report)
        )
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
            geometries=geometries,
            disabled_links=disabled,
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
                f"corners are used for [effects.contact] points = \"urdf\")"
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
