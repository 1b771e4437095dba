"""Seeded random URDF kinematic trees, for testing identities that hold for every robot.

A tree has several branches from the root and links with several children; joints are a mix of
revolute, continuous, prismatic and fixed (fixed joints inside chains, and tool flanges welded
to leaves). Joint origins have arbitrary rpy; axes are random, some of them not unit length
(the loader normalises them) and some left out (the URDF default (1, 0, 0)). Inertial frames
have arbitrary xyz and rpy, and inertias are physically valid: R diag(moments) R^T with
moments (s2 + s3, s1 + s3, s1 + s2), s_i > 0, which satisfy the triangle inequality strictly.
Some links have no <inertial> (massless), but every moving body (a moving joint's child link
and the links welded to it) has mass, so M(q) is positive definite. The root link has an
<inertial> too, which the loader ignores (it is welded to the fixed world).

Every number is written with repr(), so the loaded model is exactly the generated one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

MOVING = ("revolute", "continuous", "prismatic")
JOINT_TYPES = MOVING + ("fixed",)


def _num(value):
    """A float written in full (repr), so the URDF holds exactly the generated number."""
    return repr(float(value))


def _fmt(values):
    return " ".join(_num(v) for v in values)


def _random_rpy(rng):
    return rng.uniform(-np.pi, np.pi, 3)


def _random_axis(rng):
    """A random direction: unit, scaled to a non-unit length, or None (no <axis> element)."""
    kind = rng.choice(["unit", "scaled", "missing"], p=[0.5, 0.4, 0.1])
    if kind == "missing":
        return None
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return axis if kind == "unit" else axis * rng.uniform(0.2, 5.0)


def _random_inertia(rng, mass):
    """(3, 3) R diag(s2 + s3, s1 + s3, s1 + s2) R^T with s_i = mass * (extent_i)^2 > 0."""
    s = mass * rng.uniform(0.02, 0.3, 3) ** 2
    moments = np.array([s[1] + s[2], s[0] + s[2], s[0] + s[1]])
    R = Rotation.random(random_state=rng).as_matrix()
    I = R @ np.diag(moments) @ R.T
    return 0.5 * (I + I.T)


def _inertial_xml(rng):
    mass = rng.uniform(0.2, 3.0)
    I = _random_inertia(rng, mass)
    return (
        f"    <inertial>\n"
        f'      <origin xyz="{_fmt(rng.uniform(-0.3, 0.3, 3))}" '
        f'rpy="{_fmt(_random_rpy(rng))}"/>\n'
        f'      <mass value="{_num(mass)}"/>\n'
        f'      <inertia ixx="{_num(I[0, 0])}" ixy="{_num(I[0, 1])}" ixz="{_num(I[0, 2])}" '
        f'iyy="{_num(I[1, 1])}" iyz="{_num(I[1, 2])}" izz="{_num(I[2, 2])}"/>\n'
        f"    </inertial>\n"
    )


def _joint_xml(rng, name, jtype, parent, child, mimic=None):
    lines = [
        f'  <joint name="{name}" type="{jtype}">',
        f'    <parent link="{parent}"/>',
        f'    <child link="{child}"/>',
        f'    <origin xyz="{_fmt(rng.uniform(-0.5, 0.5, 3))}" rpy="{_fmt(_random_rpy(rng))}"/>',
    ]
    if jtype in MOVING:
        axis = _random_axis(rng)
        if axis is not None:
            lines.append(f'    <axis xyz="{_fmt(axis)}"/>')
        bound = 0.5 if jtype == "prismatic" else np.pi
        limits = "" if jtype == "continuous" else f'lower="{_num(-bound)}" upper="{_num(bound)}" '
        lines.append(
            f'    <limit {limits}effort="{_num(rng.uniform(10, 100))}" '
            f'velocity="{_num(rng.uniform(1, 10))}"/>'
        )
        lines.append(
            f'    <dynamics damping="{_num(rng.uniform(0, 1))}" '
            f'friction="{_num(rng.uniform(0, 0.5))}"/>'
        )
    if mimic is not None:
        leader, multiplier, offset = mimic
        lines.append(
            f'    <mimic joint="{leader}" multiplier="{_num(multiplier)}" offset="{_num(offset)}"/>'
        )
    lines.append("  </joint>")
    return "\n".join(lines) + "\n"


def random_tree_urdf(
    seed,
    n_links=12,
    root_branches=3,
    p_chain=0.5,
    p_fixed=0.2,
    p_massless=0.3,
    n_flanges=2,
    n_mimic=0,
):
    """URDF XML text of a random kinematic tree.

    Args:
      seed: seed of the generator; the same arguments give the same text.
      n_links: links of the tree proper (the root included), before the tool flanges.
      root_branches: joints out of the root link (the first links all hang from it).
      p_chain: probability that a later link hangs from the link just before it (long chains);
        otherwise from any earlier link (several children per link).
      p_fixed: probability that a joint inside the tree is fixed.
      p_massless: probability that a link has no <inertial>; a moving body left without any
        mass gets one on its moving joint's child link.
      n_flanges: leaves that get a massless tool flange on a fixed joint ("<leaf>_flange").
      n_mimic: at most this many revolute or prismatic joints mimic an earlier joint of their
        type (<mimic> with a random multiplier and offset); drawn from a generator of their
        own, so that the rest of the tree is the same for every n_mimic.
    Returns the XML text; the robot is named "random_tree_<seed>".
    """
    rng = np.random.default_rng(seed)
    parent = [-1]
    for k in range(1, n_links):
        if k <= root_branches:
            parent.append(0)
        elif rng.uniform() < p_chain:
            parent.append(k - 1)
        else:
            parent.append(int(rng.integers(0, k)))
    p_moving = (1.0 - p_fixed) / len(MOVING)
    jtype = [None] + [
        str(rng.choice(JOINT_TYPES, p=[p_moving] * 3 + [p_fixed])) for _ in range(1, n_links)
    ]
    massive = [True] + [bool(rng.uniform() >= p_massless) for _ in range(1, n_links)]

    # the body of link k is the nearest link at or above k whose joint moves (0: the world)
    def body(k):
        while k > 0 and jtype[k] == "fixed":
            k = parent[k]
        return k

    for b in {body(k) for k in range(1, n_links)} - {0}:
        if not any(massive[k] for k in range(1, n_links) if body(k) == b):
            massive[b] = True

    names = [f"link{k}" for k in range(n_links)]
    leaves = [k for k in range(1, n_links) if k not in parent]
    flanges = [int(k) for k in rng.choice(leaves, size=min(n_flanges, len(leaves)), replace=False)]

    mimic = _random_mimics(np.random.default_rng([seed, 1]), parent, jtype, n_mimic)
    out = [f'<?xml version="1.0"?>\n<robot name="random_tree_{seed}">\n']
    for k in range(n_links):
        out.append(f'  <link name="{names[k]}">\n')
        if massive[k]:
            out.append(_inertial_xml(rng))
        out.append("  </link>\n")
        if k > 0:
            out.append(
                _joint_xml(rng, f"joint{k}", jtype[k], names[parent[k]], names[k], mimic.get(k))
            )
    for k in flanges:
        out.append(f'  <link name="{names[k]}_flange"/>\n')
        out.append(_joint_xml(rng, f"joint{k}_flange", "fixed", names[k], f"{names[k]}_flange"))
    out.append("</robot>\n")
    return "".join(out)


def _random_mimics(rng, parent, jtype, n_mimic):
    """{k: (leader joint name, multiplier, offset)}: up to n_mimic revolute or prismatic joints
    that follow a joint of their type above them (as Pinocchio requires) which is itself no
    follower."""

    def above(k):
        k = parent[k]
        while k > 0:
            yield k
            k = parent[k]

    mimic = {}
    candidates = [k for k in range(1, len(jtype)) if jtype[k] in ("revolute", "prismatic")]
    for k in rng.permutation(candidates):
        k = int(k)
        leaders = [j for j in above(k) if jtype[j] == jtype[k] and j not in mimic]
        if len(mimic) == n_mimic or not leaders or any(v[0] == f"joint{k}" for v in mimic.values()):
            continue
        multiplier = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 2.0)
        mimic[k] = (f"joint{int(rng.choice(leaders))}", multiplier, rng.uniform(-0.5, 0.5))
    return mimic


def random_chain_urdf(seed, n):
    """URDF XML text of a random serial chain of n moving joints (one branch from the root, no
    fixed joints inside, every link with mass, a tool flange at the end)."""
    return random_tree_urdf(
        seed, n_links=n + 1, root_branches=1, p_chain=1.0, p_fixed=0.0, p_massless=0.0, n_flanges=1
    )


def write_random_tree(tmp_path, seed, **kw):
    """Write random_tree_urdf(seed, **kw) to tmp_path/random_tree_<seed>.urdf; return the path."""
    path = Path(tmp_path) / f"random_tree_{seed}.urdf"
    path.write_text(random_tree_urdf(seed, **kw))
    return path
