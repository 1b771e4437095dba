"""The pictures of the collision guide's contact manifolds, drawn from what the kernels return:
a cylinder lying on the ground (its two ends) and a box resting on a box turned 20 degrees about
the vertical (four corners of their octagon, the support polygon's largest quadrilateral).

    python scripts/contact_pictures.py [--out docs/guides]

Writes manifold_lying_cylinder.png and manifold_turned_box.png, each a view from above and from
the side: the shapes' edges, the contact points (red) and, for the turned box, the octagon the
two squares overlap in (dashed).
"""

from __future__ import annotations

import argparse
import itertools
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import opendyn as od
from opendyn._runtime.kernel_cache import kernel_cache
from opendyn.multibody.shapes import CYLINDER

DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs" / "guides"


def box_geometry(name, size, yaw, z):
    """A URDF <collision> box on a prismatic z joint, turned by yaw about z."""
    return name, f'<box size="{size[0]} {size[1]} {size[2]}"/>', (0.0, 0.0, yaw), z


def two_bodies(tmp, lower, upper):
    """A model of two bodies on prismatic z joints from the world, each with one geometry:
    (name, geometry element, rpy, z)."""
    inertial = (
        '<inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    links, joints = [], []
    for name, element, rpy, _ in (lower, upper):
        origin = f'<origin rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
        links.append(
            f'<link name="{name}">{inertial}<collision>{origin}<geometry>{element}</geometry>'
            "</collision></link>"
        )
        joints.append(
            f'<joint name="{name}_z" type="prismatic"><parent link="world"/>'
            f'<child link="{name}"/><axis xyz="0 0 1"/>'
            '<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>'
        )
    path = tmp / "two.urdf"
    path.write_text(f'<robot name="two"><link name="world"/>{"".join(links + joints)}</robot>')
    return od.load_urdf(path)


def box_edges(size, yaw, z):
    """The 12 edges of a box (size, turned by yaw about z, centre at height z), (12, 2, 3)."""
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    corners = {k: R @ (np.array(k) * size / 2) + (0, 0, z) for k in itertools.product((-1, 1), repeat=3)}
    return [
        (corners[a], corners[b])
        for a, b in itertools.combinations(corners, 2)
        if sum(x != y for x, y in zip(a, b, strict=True)) == 1
    ]


def draw(views, edges, points, title, path, extra=None):
    """Two views (top: x-y, side: x-z) of the edges (pairs of points) and the contact points."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 4.2))
    for ax, (i, j, name) in zip(axes, views, strict=True):
        for p, q in edges:
            ax.plot([p[i], q[i]], [p[j], q[j]], color="0.35", lw=1)
        if extra is not None and name == "from above":
            ax.plot(extra[:, i], extra[:, j], "--", color="tab:blue", lw=1, label="overlap")
            ax.legend(loc="upper right", fontsize=8)
        ax.plot(points[:, i], points[:, j], "o", color="tab:red", ms=7, label="contacts")
        ax.set_title(name)
        ax.set_aspect("equal")
        ax.set_xlabel("xyz"[i] + " (m)")
        ax.set_ylabel("xyz"[j] + " (m)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


def lying_cylinder(out):
    """A cylinder r = 0.1, length 0.4 lying along y, 1 mm into the ground (the halfspace z <= 0),
    its contacts as the contact between collision geometries finds them (halfspace_contacts)."""
    with kernel_cache():
        from opendyn.algorithm.collision import halfspace_contacts, no_hull
    T = np.eye(4)
    T[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # its z axis along y
    T[:3, 3] = (0.0, 0.0, 0.099)
    rows = np.zeros((4, 10))
    cylinder = (CYLINDER, np.array([0.1, 0.4, 0.0]), no_hull(), T)
    count = halfspace_contacts(cylinder, np.eye(4), 0.0, rows)
    points = rows[:count, 1:4]
    angles = np.linspace(0, 2 * np.pi, 65)
    rims = [np.stack([0.1 * np.cos(angles), np.full(65, y), 0.099 + 0.1 * np.sin(angles)], 1)
            for y in (-0.2, 0.2)]
    edges = [(r[k], r[k + 1]) for r in rims for k in range(64)]
    edges += [((x, -0.2, z), (x, 0.2, z)) for x, z in ((0.0, -0.001), (0.0, 0.199), (0.1, 0.099), (-0.1, 0.099))]
    edges += [((-0.3, y, 0.0), (0.3, y, 0.0)) for y in (-0.3, 0.3)]
    print(f"lying cylinder: {len(points)} contacts at y = {np.round(points[:, 1], 6).tolist()}")
    draw(
        ((0, 1, "from above"), (1, 2, "from the side")),
        edges,
        points,
        f"A cylinder lying on the ground: {len(points)} contacts, its two ends",
        out / "manifold_lying_cylinder.png",
    )


def turned_box(out, tmp):
    """A 0.2 x 0.2 x 0.1 box on another, turned 20 degrees about z, 0.1 mm into it."""
    size, yaw = np.array([0.2, 0.2, 0.1]), np.radians(20.0)
    model = two_bodies(
        tmp, box_geometry("lower", size, 0.0, 0.0), box_geometry("upper", size, yaw, 0.0)
    )
    q = np.array([0.0, 0.1 - 1e-4])
    contacts = od.collisions(model, q)
    edges = box_edges(size, 0.0, 0.0) + box_edges(size, yaw, 0.1 - 1e-4)
    grid = np.linspace(-0.1, 0.1, 2001)
    c, s = np.cos(yaw), np.sin(yaw)
    rim = []  # the octagon: along each edge of one square, the part inside the other
    for a, b in ((0.0, (c, s)), (yaw, (1.0, 0.0))):
        ca, sa = np.cos(a), np.sin(a)
        for sign, along in itertools.product((-1, 1), (0, 1)):
            t = np.stack([grid, np.full_like(grid, sign * 0.1)], 1)[:, [along, 1 - along]]
            p = t @ np.array([[ca, sa], [-sa, ca]])
            u = p @ np.array([[b[0], -b[1]], [b[1], b[0]]])
            rim.append(p[np.all(np.abs(u) <= 0.1, axis=1)])
    rim = np.concatenate(rim)
    rim = rim[np.argsort(np.arctan2(rim[:, 1], rim[:, 0]))]
    octagon = np.column_stack([rim, np.full(len(rim), 0.1)])
    octagon = np.vstack([octagon, octagon[:1]])
    print(f"turned box: {len(contacts.distance)} contacts, depth {contacts.depth.round(9).tolist()}")
    draw(
        ((0, 1, "from above"), (0, 2, "from the side")),
        edges,
        contacts.point_b,
        "A box on a box turned 20 degrees: four corners of their octagon",
        out / "manifold_turned_box.png",
        extra=octagon,
    )


def main(argv=None):
    import tempfile

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=pathlib.Path, default=DOCS)
    args = parser.parse_args(argv)
    lying_cylinder(args.out)
    with tempfile.TemporaryDirectory() as tmp:
        turned_box(args.out, pathlib.Path(tmp))


if __name__ == "__main__":
    main()
