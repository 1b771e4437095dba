"""Witness points on their own shapes: for every pair of shapes, apart, touching and
penetrating, at random poses and in the poses that break witness points (exact touch, faces
coincident, a box across another's edge), pair_distance's p_A lies on a's surface and p_B on
b's, to 1e-9 m (a cylinder's curved side to 5e-7 m, GJK's and EPA's convergence on it), and
p_B - p_A = d n. The surfaces are measured by closed forms (a box's, a
cylinder's, a capsule's signed distance; a hull's face planes; a halfspace's plane), none of the
kernels' own code."""

from __future__ import annotations

import numpy as np
import pytest
from collision_shapes import distance, pose, random_shape, rot, shape, surface_distance
from scipy.spatial.transform import Rotation

from opendyn._runtime.status import Status
from opendyn.multibody.shapes import BOX, CAPSULE, CYLINDER, HALFSPACE, MESH, SHAPE_NAMES, SPHERE

ON_SURFACE = 1e-9  # metres
# a cylinder's curved side has no closed form here: GJK and EPA converge on it to their
# tolerances, and EPA's points near exact touch sit up to 2e-7 m off (measured: 1.9e-7 m, a
# cylinder touching a hull) and its normal is right to about 1e-5 (b moved along it to touch
# lands up to 1.1e-6 m off); every other shape's points are exact to rounding. These bounds
# hold what is reached; they are not the 1e-9 m the other shapes meet.
CURVED = 5e-7
CURVED_TOUCH = 3e-6
CODES = (SPHERE, BOX, CYLINDER, CAPSULE, MESH)
PAIRS = [(a, b) for a in CODES for b in CODES] + [(a, HALFSPACE) for a in CODES]
CUBE = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def tolerance(a, b):
    """How close to its shape a witness point must be (m): ON_SURFACE, or CURVED where a
    cylinder takes part."""
    return CURVED if CYLINDER in (a[0], b[0]) else ON_SURFACE


def assert_on_shapes(a, T_a, b, T_b, what):
    """pair_distance of (a, T_a) and (b, T_b): both points on their shapes, p_B - p_A = d n.
    Returns d and n."""
    status, d, p_a, p_b, n = distance(a, T_a, b, T_b)
    assert status == Status.OK or (status == Status.NO_CONVERGENCE and d < 0), what
    off_a, off_b = abs(surface_distance(a, T_a, p_a)), abs(surface_distance(b, T_b, p_b))
    assert max(off_a, off_b) <= tolerance(a, b), (what, d, off_a, off_b)
    np.testing.assert_allclose(p_b - p_a, d * n, atol=1e-9, err_msg=str(what))
    return d, n


def random_pair(code_a, code_b, rng):
    """Random shapes a and b at random poses, from deep inside each other to apart."""
    (a, ext_a), (b, ext_b) = random_shape(code_a, rng), random_shape(code_b, rng)
    T_a = pose(Rotation.random(random_state=rng).as_matrix(), rng.uniform(-0.5, 0.5, 3))
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    R_b = Rotation.random(random_state=rng).as_matrix()
    if code_b == HALFSPACE:  # its plane faces a: z_b = -direction
        R_b = Rotation.align_vectors([-direction], [(0.0, 0.0, 1.0)])[0].as_matrix() @ rot(
            (0, 0, 1), rng.uniform(0, 2 * np.pi)
        )
    reach = (ext_a + ext_b) * rng.uniform(0.0, 1.3)
    return a, T_a, b, pose(R_b, T_a[:3, 3] + reach * direction)


@pytest.mark.parametrize(
    "code_a, code_b", PAIRS, ids=[f"{SHAPE_NAMES[a]}-{SHAPE_NAMES[b]}" for a, b in PAIRS]
)
def test_witness_points_lie_on_their_shapes_apart_touching_and_penetrating(code_a, code_b):
    """60 random poses of random shapes, each also moved by -d n to exact touch (|d| under
    1e-9 m): every witness point on its own shape to 1e-9 m (5e-7 m where a cylinder's curved
    side takes part: CURVED), in all three regimes."""
    rng = np.random.default_rng(7 + 10 * code_a + code_b)
    regimes = {"apart": 0, "penetrating": 0, "touching": 0}
    for trial in range(60):
        a, T_a, b, T_b = random_pair(code_a, code_b, rng)
        d, n = assert_on_shapes(a, T_a, b, T_b, (trial, "random"))
        regimes["apart" if d > 0 else "penetrating"] += 1
        touching, d_touch = T_b.copy(), d
        for _ in range(3):  # b moved by -d n until it touches (a normal right to 1e-4 needs two)
            touching[:3, 3] -= d_touch * n
            d_touch, n = assert_on_shapes(a, T_a, b, touching, (trial, "touching", d))
            if abs(d_touch) <= 1e-12:
                break
        touch = CURVED_TOUCH if CYLINDER in (code_a, code_b) else ON_SURFACE
        assert abs(d_touch) <= touch, (trial, d, d_touch)
        regimes["touching"] += 1
    assert min(regimes.values()) >= 10, regimes


def flat_shapes():
    """Shapes with a flat face on z_g = -h (their bottom), named: a box, a cube hull (mesh) and
    a standing cylinder, each with h."""
    return {
        "box": (shape(BOX, (0.3, 0.2, 0.1)), 0.05),
        "mesh": (shape(MESH, (1, 1, 1), CUBE * (0.1, 0.15, 0.05)), 0.05),
        "cylinder": (shape(CYLINDER, (0.1, 0.1, 0)), 0.05),
    }


FLAT = list(flat_shapes())


@pytest.mark.parametrize("lower", FLAT)
@pytest.mark.parametrize("upper", FLAT)
@pytest.mark.parametrize("gap", [0.0, -1e-3, 1e-3])
def test_coincident_faces_give_points_on_both_faces(lower, upper, gap):
    """A flat face resting on another, turned about the vertical by 0-90 degrees and shifted
    sideways (so that corners of each overhang the other), touching exactly, 1 mm into and 1 mm
    apart: the points on both shapes and the distance the gap."""
    (a, h_a), (b, h_b) = flat_shapes()[lower], flat_shapes()[upper]
    rng = np.random.default_rng(3)
    for trial in range(20):
        yaw = np.radians(5.0 * (trial % 19))
        shift = rng.uniform(-0.08, 0.08, 2)
        T_a = pose(rot((0, 0, 1), rng.uniform(0, np.pi)), (0.1, -0.2, 0.3))
        T_b = pose(
            T_a[:3, :3] @ rot((0, 0, 1), yaw),
            T_a[:3, 3] + T_a[:3, :3] @ (*shift, h_a + h_b + gap),
        )
        d, n = assert_on_shapes(a, T_a, b, T_b, (trial, yaw, shift))
        assert d == pytest.approx(gap, abs=1e-9)
        np.testing.assert_allclose(n, T_a[:3, 2], atol=1e-6)


@pytest.mark.parametrize("gap", [0.0, -0.02, -0.0008])
def test_a_box_across_another_boxs_edge_gives_points_on_both(gap):
    """A small box lying across the edge of a large one (most of it beyond the edge, as a
    foot on a step), at exact touch and at the depths the robots gave (20 mm, 0.8 mm): box
    b's point on box b, a's on a (the separating axis' support vertex is off the other box)."""
    big, small = shape(BOX, (1.0, 1.0, 0.2)), shape(BOX, (0.3, 0.1, 0.05))
    T_a = pose()
    for yaw in np.radians([0.0, 10.0, 45.0, 80.0]):
        T_b = pose(rot((0, 0, 1), yaw), (0.55, 0.1, 0.1 + 0.025 + gap))
        d, n = assert_on_shapes(big, T_a, small, T_b, yaw)
        assert d == pytest.approx(gap, abs=1e-9)
        np.testing.assert_allclose(n, (0, 0, 1), atol=1e-12)
        d, n = assert_on_shapes(small, T_b, big, T_a, yaw)
        assert d == pytest.approx(gap, abs=1e-9)
