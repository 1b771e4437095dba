"""The collision narrow phase (opendyn.algorithm.collision.pair_distance), every check independent
of its own output: closed forms worked out by hand (two spheres, sphere-box on a face, an edge, a
vertex and inside, box-box on a face and edge to edge, capsules parallel and skew, a cylinder on a
halfspace standing and tilted), the exact distance from a point to a cylinder (GJK converging on
the rim), coal's distance on every pair of shapes at random poses (separated, shallow and deep),
the witness points on their own shapes' surfaces, the swap of a and b, and not one allocation a
call."""

from __future__ import annotations

import importlib.metadata
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from numba import njit
from scipy.spatial.transform import Rotation

import opendyn  # (also sets the kernel cache's folder)
from opendyn._runtime.kernel_cache import kernel_cache
from opendyn._runtime.status import Status
from opendyn.multibody.hulls import convex_hull
from opendyn.multibody.shapes import BOX, CAPSULE, CYLINDER, HALFSPACE, MESH, SHAPE_NAMES, SPHERE

with kernel_cache():
    from opendyn.algorithm.collision.support import climb

from collision_shapes import (
    NO_VERTICES,
    depth_by_directions,
    distance,
    hull,
    overlap,
    pose,
    random_shape,
    rot,
    shape,
    surface_distance,
)

try:  # the reference of test_pairs_against_coal alone: the closed forms need nothing but opendyn
    import coal
except ImportError:
    coal = None

# ---- closed forms ------------------------------------------------------------------------------


def expect(result, d, p_a=None, p_b=None, n=None, tol=1e-12):
    status, d_, p_a_, p_b_, n_ = result
    assert status == Status.OK
    assert d_ == pytest.approx(d, abs=tol)
    for got, want in ((p_a_, p_a), (p_b_, p_b), (n_, n)):
        if want is not None:
            np.testing.assert_allclose(got, want, atol=tol)


def test_two_spheres():
    """d = |c_B - c_A| - r_A - r_B, n along c_B - c_A, the points r along n from the centres."""
    a, b = shape(SPHERE, (0.3, 0, 0)), shape(SPHERE, (0.2, 0, 0))
    c = np.array([0.3, 0.4, 1.2])  # |c| = 1.3
    n = c / 1.3
    expect(distance(a, pose(), b, pose(p=c)), 0.8, 0.3 * n, c - 0.2 * n, n)
    expect(distance(a, pose(), b, pose(p=0.3 * c)), 0.39 - 0.5, 0.3 * n, 0.3 * c - 0.2 * n, n)


@pytest.mark.parametrize(
    "centre, d, nearest",
    [
        ((0.0, 0.0, 1.0), 1.0 - 0.5 - 0.25, (0.0, 0.0, 0.5)),  # over the face z = +c/2
        ((1.0, 0.0, 1.0), np.hypot(0.75, 0.5) - 0.25, (0.25, 0.0, 0.5)),  # over the edge x, z
        ((1.0, 1.5, 1.0), np.linalg.norm([0.75, 1.0, 0.5]) - 0.25, (0.25, 0.5, 0.5)),  # vertex
        ((0.1, 0.05, 0.4), -(0.1 + 0.25), (0.1, 0.05, 0.5)),  # inside, nearest the top face
    ],
)
def test_sphere_box(centre, d, nearest):
    """Box 0.5 x 1 x 1 (half sizes 0.25, 0.5, 0.5) turned and moved, sphere r = 0.25: the
    distance from the centre to the box's nearest point (by hand) less r; inside, the nearest
    face's depth plus r."""
    R, p = rot((1, 2, 3) / np.sqrt(14), 0.7), np.array([0.2, -0.1, 0.3])
    c, q = R @ centre + p, R @ nearest + p
    n = (q - c) / np.linalg.norm(q - c) if d > 0 else -R[:, 2]
    sphere, box = shape(SPHERE, (0.25, 0, 0)), shape(BOX, (0.5, 1.0, 1.0))
    expect(distance(sphere, pose(p=c), box, pose(R, p)), d, c + 0.25 * n, q, n)
    expect(distance(box, pose(R, p), sphere, pose(p=c)), d, q, c + 0.25 * n, -n)


def test_box_box_face_and_edge():
    """Unit cubes: (1) B moved 0.9 along x: depth 0.1 on A's face x = 1/2; (2) B turned 45
    degrees about z, its vertical edge 0.1 into A's face: depth 0.1; (3) A turned 45 degrees
    about x (top edge along x at z = sqrt(2)/2), B turned 45 degrees about y (bottom edge along
    y), B's centre at sqrt(2) - 0.1: the edges cross, depth 0.1 along z; (4) B 0.3 above A's
    top: distance 0.3 (GJK)."""
    cube = shape(BOX, (1.0, 1.0, 1.0))
    s = np.sqrt(2.0)
    expect(distance(cube, pose(), cube, pose(p=(0.9, 0.2, 0.1))), -0.1, n=(1, 0, 0))
    _, _, p_a, p_b, _ = result = distance(
        cube, pose(), cube, pose(rot((0, 0, 1), np.pi / 4), (0.5 + s / 2 - 0.1, 0.0, 0.0))
    )
    expect(result, -0.1, n=(1, 0, 0), p_a=(0.5, 0.0, p_a[2]), p_b=(0.4, 0.0, p_b[2]))
    expect(
        distance(
            cube,
            pose(rot((1, 0, 0), np.pi / 4)),
            cube,
            pose(rot((0, 1, 0), np.pi / 4), (0, 0, s - 0.1)),
        ),
        -0.1,
        (0, 0, s / 2),
        (0, 0, s / 2 - 0.1),
        (0, 0, 1),
    )
    expect(distance(cube, pose(), cube, pose(p=(0.2, 0.1, 1.3))), 0.3, n=(0, 0, 1), tol=1e-10)


def test_capsules_parallel_and_skew():
    """Parallel capsules 0.5 apart (r 0.1 and 0.15): d = 0.25 along x; skew ones, one along x at
    the origin and one along y at z = 0.5: d = 0.5 - 0.25 at the common perpendicular (0, 0, z);
    crossing cores: depth r_A + r_B along their common perpendicular."""
    a, b = shape(CAPSULE, (0.1, 1.0, 0)), shape(CAPSULE, (0.15, 0.6, 0))
    _, _, p_a, p_b, _ = result = distance(a, pose(), b, pose(p=(0.5, 0.0, 0.1)))
    expect(result, 0.25, n=(1, 0, 0))  # any height where the cores face each other
    assert (
        -0.2 <= p_a[2] <= 0.4 and p_b[2] == pytest.approx(p_a[2]) and p_a[0] == pytest.approx(0.1)
    )
    along_x, along_y = rot((0, 1, 0), np.pi / 2), rot((1, 0, 0), np.pi / 2)
    expect(
        distance(a, pose(along_x), b, pose(along_y, (0, 0, 0.5))),
        0.25,
        (0, 0, 0.1),
        (0, 0, 0.35),
        (0, 0, 1),
    )
    _, _, p_a, p_b, n = result = distance(a, pose(along_x), b, pose(along_y, (0, 0, 0)))
    side = n[2]  # the cores cross at their centres: +z and -z are equally deep
    expect(result, -0.25, (0, 0, 0.1 * side), (0, 0, -0.15 * side), (0, 0, side))
    assert abs(side) == pytest.approx(1.0)


@pytest.mark.parametrize("tilt", [0.0, 0.3, 1.2])
def test_cylinder_on_a_halfspace(tilt):
    """Cylinder r = 0.2, length 0.6, centre at height h, tilted by theta about x: its lowest rim
    point is at h - (L/2) cos theta - r sin theta, offset by (L/2) sin theta - r cos theta along
    y (the cap's centre when standing)."""
    cylinder, ground = shape(CYLINDER, (0.2, 0.6, 0)), shape(HALFSPACE, (0, 0, 0))
    R = rot((1, 0, 0), tilt)
    for h in (0.5, 0.25):
        low = h - 0.3 * np.cos(tilt) - 0.2 * np.sin(tilt)
        y = 0.2 + (0.3 * np.sin(tilt) - 0.2 * np.cos(tilt) if tilt else 0.0)
        expect(
            distance(cylinder, pose(R, (0.1, 0.2, h)), ground, pose()),
            low,
            (0.1, y, low),
            (0.1, y, 0.0),
            (0, 0, -1),
        )


def test_point_to_cylinder_converges_on_the_rim():
    """GJK between a point (a sphere of radius 0) and a cylinder, stopped on its duality gap,
    equals the exact distance to the rim, a circle's, to 1e-9 m at random points beyond it."""
    rng = np.random.default_rng(1)
    cylinder, point = shape(CYLINDER, (0.3, 0.5, 0)), shape(SPHERE, (0, 0, 0))
    for _ in range(200):
        x = rng.uniform(-1, 1, 3)
        x[2] = np.copysign(0.25 + rng.uniform(0.01, 0.5), x[2])
        radial = np.hypot(x[0], x[1])
        if radial < 0.31:
            continue
        exact = np.hypot(radial - 0.3, abs(x[2]) - 0.25)
        status, d, *_ = distance(cylinder, pose(), point, pose(p=x))
        assert status == Status.OK and abs(d - exact) < 1e-9


def test_two_halfspaces_are_unbounded():
    h = shape(HALFSPACE, (0, 0, 0))
    assert distance(h, pose(), h, pose(p=(0, 0, 1)))[0] == Status.UNBOUNDED


# ---- against coal --------------------------------------------------------------------------------


def coal_geometry(code, size, vertices):
    if code == SPHERE:
        return coal.Sphere(size[0])
    if code == BOX:
        return coal.Box(*size)  # full side lengths (coal's halfSide is half of them)
    if code == CYLINDER:
        return coal.Cylinder(size[0], size[1])
    if code == CAPSULE:
        return coal.Capsule(size[0], size[1])
    if code == MESH:
        points = coal.StdVec_Vec3s()
        for v in vertices:
            points.append(v)
        return coal.Convex.convexHull(points, False, None)
    return coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)


def coal_distance(a, T_a, b, T_b):
    """coal's (d, p_1, p_2, n) at tolerances far below the test's."""
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    request.gjk_tolerance, request.epa_tolerance = 1e-12, 1e-12
    request.gjk_max_iterations, request.epa_max_iterations = 1000, 1000
    d = coal.distance(
        coal_geometry(*a),
        coal.Transform3s(T_a[:3, :3], T_a[:3, 3]),
        coal_geometry(*b),
        coal.Transform3s(T_b[:3, :3], T_b[:3, 3]),
        request,
        result,
    )
    return d, result.getNearestPoint1(), result.getNearestPoint2(), np.array(result.normal)


CODES = (SPHERE, BOX, CYLINDER, CAPSULE, MESH)
PAIRS = [(a, b) for a in CODES for b in CODES if a <= b] + [(a, HALFSPACE) for a in CODES]


@pytest.mark.skipif(coal is None, reason="needs coal (pip install pin)")
@pytest.mark.parametrize(
    "code_a, code_b", PAIRS, ids=[f"{SHAPE_NAMES[a]}-{SHAPE_NAMES[b]}" for a, b in PAIRS]
)
def test_pairs_against_coal(code_a, code_b):
    """At 60 random poses of random shapes, from far apart to deep inside each other: the signed
    distance equals coal's (1e-6 m separated, 1e-5 m penetrating) or, where coal errs (it does on
    deep contacts of cylinders: depths too large, or -DBL_MAX), the least overlap of the two
    shapes' projections over all directions, min_u h_A(u) + h_B(-u) (a search of its own, to
    1e-6 m); our normal n realises our depth, h_A(n) + h_B(-n) = -d (to 5e-5 m); p_B - p_A = d n
    with n a unit vector; p_A and p_B on their own shapes' surfaces; n equals coal's where coal's
    depth is right, its points agree with its distance and normal, and the normal is determined;
    swapping a and b swaps the points and negates n. EPA may stop at its cap (NO_CONVERGENCE) on
    a deep contact whose nearest boundary is nearly a circle's (a sphere's centre near a
    cylinder's axis): its estimate must then pass the same checks."""
    rng = np.random.default_rng(1000 * code_a + code_b)
    for _ in range(60):
        (a, ext_a), (b, ext_b) = random_shape(code_a, rng), random_shape(code_b, rng)
        T_a = pose(Rotation.random(random_state=rng).as_matrix(), rng.uniform(-0.5, 0.5, 3))
        direction = rng.normal(size=3)
        reach = (ext_a + ext_b if code_b != HALFSPACE else ext_a) * rng.uniform(0.0, 1.3)
        T_b = pose(
            Rotation.random(random_state=rng).as_matrix(),
            T_a[:3, 3] + reach * direction / np.linalg.norm(direction),
        )
        status, d, p_a, p_b, n = distance(a, T_a, b, T_b)
        assert status == Status.OK or (status == Status.NO_CONVERGENCE and d < 0)
        assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(p_b - p_a, d * n, atol=1e-9)
        for s, T, p in ((a, T_a, p_a), (b, T_b, p_b)):
            gap = abs(surface_distance(s, T, p))
            assert gap < 1e-6
        if d < 0 and code_b != HALFSPACE:
            # 1e-6 for EPA's face normals; GJK's normal between a flat face and a rounded core
            # is first-order in its points' error along the face, O(sqrt(2 d_core tol))
            assert abs(overlap(a, T_a, b, T_b, n) + d) < 5e-5
        d_c, p1, p2, n_c = coal_distance(a, T_a, b, T_b)
        kind = "separated" if d_c > 0 else "penetrating"
        tolerance = 1e-6 if d_c > 0 else 1e-5
        coal_right = abs(d - d_c) < tolerance
        if not coal_right:
            assert d < 0 and d_c < 0, (d, d_c)  # coal errs only on penetrations
            reference = -depth_by_directions(a, T_a, b, T_b, [n, n_c])
            assert abs(d - reference) < 1e-6, (d, reference, d_c)
        # the normal is determined where coal's does worse than ours: where both realise the
        # depth to 1e-9 m, the minimum is flat (a sphere's centre near a cylinder's axis)
        determined = (
            code_b == HALFSPACE
            or abs(overlap(a, T_a, b, T_b, n_c) - overlap(a, T_a, b, T_b, n)) > 1e-9
        )
        consistent = np.linalg.norm(p2 - p1 - d_c * n_c) < 1e-6
        if status == Status.OK and coal_right and abs(d_c) > 1e-4 and consistent and determined:
            assert np.linalg.norm(n - n_c) < 1e-4, (n, n_c)
        swapped_status, d_s, p_a_s, p_b_s, n_s = distance(b, T_b, a, T_a)
        assert swapped_status == status
        if code_a != code_b:
            assert d_s == d
            np.testing.assert_array_equal(p_a_s, p_b)
            np.testing.assert_array_equal(p_b_s, p_a)
            np.testing.assert_array_equal(n_s, -n)
        else:
            assert abs(d_s - d) < 1e-6


def _hull_point_clouds():
    """Point clouds whose hulls the climb must search exactly: round, a cube with points inside
    and on its faces (not hull vertices), a needle, a flat grid (no volume: a polygon), a mesh."""
    rng = np.random.default_rng(3)
    sphere = rng.normal(size=(800, 3))
    sphere /= np.linalg.norm(sphere, axis=1)[:, None]
    corners = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    cube = np.concatenate([corners, rng.uniform(-1, 1, (50, 3)), [(1, 0, 0), (0, 1, 0.5)]])
    needle = rng.normal(size=(60, 3)) * (0.001, 0.001, 1.0)
    grid = np.array([(x, y, 0.0) for x in range(6) for y in range(4)], float)
    clouds = {"sphere": sphere, "cube": cube, "needle": needle, "flat grid": grid}
    try:
        importlib.metadata.distribution("example-robot-data")  # the mesh's package
    except importlib.metadata.PackageNotFoundError:
        return clouds
    clouds["panda link 3"] = opendyn.load_urdf("panda").geometries[3].vertices
    return clouds


@pytest.mark.parametrize("name, points", list(_hull_point_clouds().items()))
def test_a_hull_climb_finds_the_farthest_point(name, points):
    """The support of a hull by hill climbing from any start (support.climb) is the farthest of
    all the points along every direction: max_p d . p by brute force over the cloud, in 2,000
    random directions and along the axes (ties on faces). The flat grid's hull is its polygon:
    its 4 corners, each joined to the two beside it, and 2 faces, one each side."""
    hull = convex_hull(points)
    vertices, start, neighbors, seeds = hull[:4]
    if name == "flat grid":
        assert len(vertices) == 4 and np.all(np.diff(start) == 2)
        normals = hull.face_normal[np.argsort(hull.face_normal[:, 2])]
        np.testing.assert_allclose(normals, [(0, 0, -1), (0, 0, 1)], atol=1e-12)
    rng = np.random.default_rng(4)
    directions = np.concatenate([rng.normal(size=(2000, 3)), np.eye(3), -np.eye(3)])
    hints = rng.integers(0, len(vertices), len(directions))
    found = _climbs(vertices, start, neighbors, seeds, directions, hints)
    farthest = (directions @ points.T).max(axis=1)
    reached = np.einsum("ij,ij->i", directions, vertices[found])
    np.testing.assert_allclose(reached, farthest, rtol=0, atol=1e-12 * np.abs(points).max())


@njit
def _climbs(vertices, start, neighbors, seeds, directions, hints):
    """The vertex climb(...) finds from hints[i] along directions[i], for each i."""
    found = np.empty(directions.shape[0], np.int64)
    hint = np.zeros(1, np.int64)
    for i in range(directions.shape[0]):
        hint[0] = hints[i]
        d = (directions[i, 0], directions[i, 1], directions[i, 2])
        found[i] = climb(vertices, start, neighbors, seeds, hint, d)
    return found


# ---- allocations ---------------------------------------------------------------------------------

_ALLOCATIONS = r"""
import json
import numpy as np
from numba import njit
from numba.core.runtime import rtsys
import opendyn
from opendyn._runtime.kernel_cache import kernel_cache
with kernel_cache():
    from opendyn.algorithm.collision import (
        box_contacts, face_contacts, halfspace_contacts, mesh_hull, no_hull, pair_distance,
        work_array,
    )

rng = np.random.default_rng(0)
codes = np.array([0, 1, 2, 3, 4, 5])
sizes = np.array([[0.2, 0, 0], [0.3, 0.4, 0.5], [0.2, 0.5, 0], [0.1, 0.4, 0], [1, 1, 1], [0, 0, 0]])
cube = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * 0.1
vertices = mesh_hull(np.concatenate([cube, rng.uniform(-0.09, 0.09, (20, 3))]))
none = no_hull()
poses = np.zeros((6, 4, 4))
for k in range(6):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    poses[k, :3, :3] = q * np.sign(np.linalg.det(q))
    poses[k, :3, 3], poses[k, 3, 3] = rng.uniform(-0.3, 0.3, 3), 1
standing = np.eye(4)  # face-on on the box at poses[1]: each shape's bottom 1 mm into its top
out, work, rows = np.zeros(10), work_array(), np.zeros((4, 10))


@njit
def every_pair(codes, sizes, vertices, none, poses, standing, work, rows, n):
    status = 0
    box = (codes[1], sizes[1], none, poses[1])
    for _ in range(n):
        for i in range(6):
            vi = vertices if codes[i] == 4 else none
            for j in range(5):
                vj = vertices if codes[j] == 4 else none
                a, b = (codes[i], sizes[i], vi, poses[i]), (codes[j], sizes[j], vj, poses[j])
                out = rows[0]
                status |= pair_distance(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], out, work)
                if i < 5:
                    face_contacts(a, b, 0.1, rows, work)
            if codes[i] != 5:
                halfspace_contacts((codes[i], sizes[i], vi, poses[i]), poses[5], 0.1, rows)
            if i == 1 or i == 2 or i == 4:  # a box, a cylinder, a cube mesh on the box's top
                standing[:3, :] = poses[1][:3, :]
                lift = 0.25 + (0.1 if i == 4 else 0.25) - 0.001
                for r in range(3):
                    standing[r, 3] += lift * poses[1][r, 2]
                a = (codes[i], sizes[i], vi, standing)
                pair_distance(a[0], a[1], a[2], a[3], box[0], box[1], box[2], box[3], rows[0], work)
                status |= 8 * (face_contacts(a, box, 0.0, rows, work) < 4)
        box_contacts((1, sizes[1], none, poses[1]), (1, sizes[1], none, poses[2]), 0.0, rows, work)
    return status


def allocations(n):
    before = rtsys.get_allocation_stats().alloc
    status = every_pair(codes, sizes, vertices, none, poses, standing, work, rows, n)
    assert status & 8 == 0, "a shape standing on a box's face touches it at fewer than 4 points"
    return rtsys.get_allocation_stats().alloc - before

every_pair(codes, sizes, vertices, none, poses, standing, work, rows, 1)
print(json.dumps({"per pair": (allocations(11) - allocations(1)) / (10 * 30)}))
"""


def test_pair_distance_allocates_nothing():
    """Every pair of shapes (30 of them, GJK and EPA among them) with its face or edge manifold,
    each shape's contacts with a halfspace, two boxes' contacts and a box, a cylinder and a mesh
    standing face-on on a box (four contacts each), called 10 more times in a compiled loop:
    numba's runtime counts not one more allocation (a fresh process with its statistics on)."""
    env = dict(os.environ, NUMBA_NRT_STATS="1")
    proc = subprocess.run(
        [sys.executable, "-c", _ALLOCATIONS],
        check=False,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == {"per pair": 0.0}


def test_a_shape_code_no_branch_knows_is_an_error():
    """A shape code beyond the known ones (a shape added to shapes.py and forgotten in a
    branch) raises ValueError naming the shape code where the kernels first meet it, in the
    narrow phase and in the halfspace manifold, instead of being a sphere (manifold.py) or a
    point (support.py); a Geometry of an unknown shape is refused by name."""
    from opendyn.multibody.geometry import Geometry

    unknown = shape(HALFSPACE + 1, (0.1, 0.1, 0.1))
    box = shape(BOX, (0.2, 0.2, 0.2))
    for a, b in ((unknown, box), (box, unknown)):
        with pytest.raises(ValueError, match="shape code"):
            distance(a, pose(), b, pose(p=(0.0, 0.0, 0.1)))
    with kernel_cache():
        from opendyn.algorithm.collision import halfspace_contacts
    rows = np.zeros((4, 10))
    with pytest.raises(ValueError, match="shape code"):
        halfspace_contacts(
            (unknown[0], unknown[1], hull(NO_VERTICES), pose()), pose(), 0.0, rows
        )
    with pytest.raises(ValueError, match="'torus' is not one of"):
        Geometry("g", "link", "torus", (1.0,), np.eye(4))
