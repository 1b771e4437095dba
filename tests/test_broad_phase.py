"""The broad phase's bounds: a hull's box in the world (from its box in its own frame, without a
climb over its vertices) holds every vertex, and a shape reaches a halfspace only when its box's
lowest corner along the plane's normal does."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import opendyn as od
from opendyn.algorithm.collision.world import LO, HI, hull_box_in_world, pair_near
from opendyn.multibody.shapes import BOX, HALFSPACE, MESH


def test_a_hulls_world_box_holds_its_vertices_and_is_its_own_box_unturned():
    model = od.load_urdf("panda")
    table = model.geometry_table
    rng = np.random.default_rng(1)
    meshes = np.flatnonzero(table.code == MESH)
    assert len(meshes) == 9
    for k in meshes:
        v0, v1 = table.vertex_range[k]
        vertices = table.vertices[v0:v1]
        np.testing.assert_array_equal(
            table.hull_box[k], np.concatenate([vertices.min(0), vertices.max(0)])
        )
        for turned in (False, True):
            R = Rotation.random(random_state=rng).as_matrix() if turned else np.eye(3)
            T_sg = np.column_stack([R, rng.uniform(-1, 1, 3)])
            box = np.zeros(6)
            hull_box_in_world(table.hull_box[k], T_sg, box)
            world = vertices @ R.T + T_sg[:, 3]
            assert np.all(world >= box[LO:LO + 3] - 1e-12)
            assert np.all(world <= box[HI:HI + 3] + 1e-12)
            if not turned:  # the hull's own box, moved
                np.testing.assert_allclose(box[LO:LO + 3], world.min(0), atol=1e-12)
                np.testing.assert_allclose(box[HI:HI + 3], world.max(0), atol=1e-12)


@pytest.mark.parametrize("height, near", [(0.011, False), (0.009, True), (-0.5, True)])
def test_a_box_reaches_a_tilted_plane_only_when_its_lowest_corner_does(height, near):
    """A plane through p = (0, 0, 0.3) tilted 0.4 rad about x; a box (lo, hi) whose lowest
    corner along the normal stands `height` above it; margin 0.01 m."""
    n_T = Rotation.from_euler("x", 0.4).as_matrix()
    T_plane = np.column_stack([n_T, [0.0, 0.0, 0.3]])
    n = n_T[:, 2]
    half = np.array([0.1, 0.2, 0.05])
    lowest = -np.sign(n) * half  # the corner furthest along -n, from the box's centre
    centre = T_plane[:, 3] - lowest + height * n / 1.0
    centre += np.cross(n, [1.0, 0.0, 0.0]) * 0.7  # anywhere along the plane
    centre -= (n @ (centre + lowest - T_plane[:, 3]) - height) * n
    boxes = np.zeros((2, 6))
    boxes[0, LO:LO + 3], boxes[0, HI:HI + 3] = -np.inf, np.inf
    boxes[1, LO:LO + 3], boxes[1, HI:HI + 3] = centre - half, centre + half
    T_sg = np.zeros((2, 3, 4))
    T_sg[0] = T_plane
    code = np.array([HALFSPACE, BOX])
    assert pair_near(code, T_sg, boxes, 0, 1, 0.01) is near
    assert pair_near(code, T_sg, boxes, 1, 0, 0.01) is near
