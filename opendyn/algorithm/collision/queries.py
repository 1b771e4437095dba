"""Distances and contacts between a robot's geometries at a configuration q: ``distances`` and
``collisions``, the public queries on model.geometries.

One kinematics pass places every geometry (world.place_geometries); then, for each pair (a, b),

    distances:   d_ab = the signed distance of the two convex shapes (the narrow phase, for
                 every pair asked: a distance is wanted even when it is large)
    collisions:  the pairs whose bounding boxes, grown by the margin, overlap (the broad phase),
                 then those with d_ab <= margin, each with its contact points: up to four for
                 a face-on or edge-on contact (a box on a box, a cylinder on its cap or its side,
                 a mesh's face, anything on a halfspace), one otherwise

Every row follows the narrow phase's layout: d, p_A, p_B (world, m) and the unit normal n from a
towards b, with p_B - p_A = d n; d < 0 is a penetration of depth -d, p_A and p_B the deepest
points of each shape inside the other.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np
from numba import njit

from ..._runtime.compile_notice import expect
from ..._runtime.kernel_cache import JIT, UNCOUNTED
from ..._runtime.options import as_real
from ..._runtime.status import Status
from ...multibody.joints import configuration_status
from ...multibody.layout import body_count
from ...multibody.shapes import BOX, HALFSPACE
from ...multibody.work_views import world_poses
from .. import checks
from ..kinematics import forward_kinematics
from .box_manifold import box_contacts
from .closed_forms import DISTANCE, NORMAL, OUT_SIZE, POINT_A, POINT_B, swap_sides
from .face_contacts import face_contacts
from .manifold import MAX_CONTACTS, halfspace_contacts
from .narrow_phase import pair_distance, work_array
from .world import bounding_boxes, pair_near, place_geometries, shape_of


class Distances(NamedTuple):
    """The signed distances of geometry pairs (``od.distances``), P pairs:

      pairs     (P, 2) int, the pairs (a, b) of indices into model.geometries
      distance  (P,) signed distance (m); negative: the shapes overlap by that depth
      point_a   (P, 3) the point of geometry a nearest b, in the world frame (m); when they
                overlap, a's point deepest inside b
      point_b   (P, 3) the same for b
      normal    (P, 3) unit, from a towards b: point_b - point_a = distance * normal, and moving
                b by -distance * normal separates overlapping shapes
    """

    pairs: np.ndarray
    distance: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray


class Contacts(NamedTuple):
    """The contacts of the pairs within a margin (``od.collisions``), K contacts:

      pairs     (K, 2) int, the geometry pair (a, b) of each contact (indices into
                model.geometries); a pair in face-on contact has up to four rows
      distance  (K,) signed distance at the contact (m): its penetration depth is -distance
      point_a   (K, 3) the contact point on geometry a, in the world frame (m)
      point_b   (K, 3) the contact point on geometry b (point_b - point_a = distance * normal)
      normal    (K, 3) unit, from a towards b
    """

    pairs: np.ndarray
    distance: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray

    @property
    def depth(self) -> np.ndarray:
        """(K,) the penetration depth of each contact, -distance (m; negative: apart by that)."""
        return -self.distance


class CollisionWork(NamedTuple):
    """The arrays a query works in, made once per model (a Data keeps one):
    T_sg (G, 3, 4) the geometries' world poses [R p], hints (G,) int each hull's climbing start
    (support.py), boxes (G, 6) their bounding boxes, scratch the narrow phase's work array, rows
    (R, OUT_SIZE) the results, pair_of (R, 2) int each contact row's geometry pair
    (R = MAX_CONTACTS times the count of pairs)."""

    T_sg: np.ndarray
    hints: np.ndarray
    boxes: np.ndarray
    scratch: np.ndarray
    rows: np.ndarray
    pair_of: np.ndarray

    @classmethod
    def of(cls, model, pair_count=None) -> CollisionWork:
        count = len(model.geometries)
        P = len(model.collision_pairs) if pair_count is None else pair_count
        return cls(
            np.zeros((count, 3, 4)),
            np.zeros(count, dtype=np.int64),
            np.zeros((count, 6)),
            work_array(),
            np.zeros((MAX_CONTACTS * P, OUT_SIZE)),
            np.zeros((MAX_CONTACTS * P, 2), dtype=np.int64),
        )


@njit(**JIT)
def place(ibuf, fbuf, work, q, table, T_sg):
    """T_sg <- the geometries' world poses at q (one forward kinematics pass). Returns a Status:
    OK, Q_NOT_FINITE or Q_NOT_UNIT_QUATERNION. A counted kernel (kernel_cache.JIT): it takes the
    bodies' poses as views of the work buffer, which the uncounted queries must not hold."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    forward_kinematics(ibuf, fbuf, work, q)
    R_s, p_s = world_poses(work, body_count(ibuf))
    place_geometries(R_s, p_s, table, T_sg)
    return Status.OK.value


@njit(**UNCOUNTED)
def distances_kernel(ibuf, fbuf, work, q, table, pairs, geometry_work, rows):
    """rows[p] (OUT_SIZE,) <- the narrow phase's result for pairs[p] at q; geometry_work =
    (T_sg, hints, scratch). Returns a Status: a failing configuration's, else NO_CONVERGENCE when
    GJK or EPA stopped short of its tolerance for some pair (its row holds the last estimate)."""
    T_sg, hints, scratch = geometry_work
    status = place(ibuf, fbuf, work, q, table, T_sg)
    if status:
        return status
    for p in range(pairs.shape[0]):
        a = shape_of(table, hints, T_sg, pairs[p, 0])
        b = shape_of(table, hints, T_sg, pairs[p, 1])
        found = pair_distance(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], rows[p], scratch)
        if found:
            status = found
    return status


@njit(**UNCOUNTED)
def pair_contacts(a, b, margin, rows, scratch):
    """Up to MAX_CONTACTS contacts of shapes a and b within margin into rows (4, OUT_SIZE): the
    box-box manifold of overlapping boxes, a halfspace's, or the narrow phase's contact and
    the face or edge manifold clipped around it (face_contacts.py). Returns (count, status)."""
    if a[0] == BOX and b[0] == BOX:
        count = box_contacts(a, b, margin, rows, scratch)
        if count:
            return count, Status.OK.value
    elif b[0] == HALFSPACE and a[0] != HALFSPACE:
        return halfspace_contacts(a, b[3], margin, rows), Status.OK.value
    elif a[0] == HALFSPACE and b[0] != HALFSPACE:
        count = halfspace_contacts(b, a[3], margin, rows)
        for k in range(count):
            swap_sides(rows[k])
        return count, Status.OK.value
    status = pair_distance(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], rows[0], scratch)
    if rows[0, DISTANCE] > margin:
        return 0, status
    return face_contacts(a, b, margin, rows, scratch), status


@njit(**UNCOUNTED)
def pair_rows(placed, i, j, margin, rows, scratch):
    """pair_contacts of geometries i and j as placed = (table, hints, T_sg) holds them (the
    GeometryArrays, the hulls' climbing starts and the world poses): up to
    MAX_CONTACTS rows (OUT_SIZE each). Returns (count, status)."""
    table, hints, T_sg = placed
    a, b = shape_of(table, hints, T_sg, i), shape_of(table, hints, T_sg, j)
    return pair_contacts(a, b, margin, rows, scratch)


@njit(**UNCOUNTED)
def collisions_kernel(ibuf, fbuf, work, q, table, pairs, margin, geometry_work, rows, pair_of):
    """The contacts of the pairs within margin at q: rows[:count] (OUT_SIZE each) and
    pair_of[:count] (2,) their geometry pairs; geometry_work = (T_sg, hints, boxes, scratch).
    Returns (Status, count)."""
    T_sg, hints, boxes, scratch = geometry_work
    status = place(ibuf, fbuf, work, q, table, T_sg)
    if status:
        return status, 0
    bounding_boxes(table, hints, T_sg, boxes)
    count = 0
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        if not pair_near(table.code, T_sg, boxes, i, j, margin):
            continue
        found, pair_status = pair_rows(
            (table, hints, T_sg), i, j, margin, rows[count : count + MAX_CONTACTS], scratch
        )
        for k in range(found):
            pair_of[count + k, 0], pair_of[count + k, 1] = i, j
        count += found
        if pair_status:
            status = pair_status
    return status, count


# what compiling a query (and the narrow phase it calls) takes on a 2-core machine: 27-36 s the
# first one a process compiles, about 18 s the other (docs/performance/startup.md)
expect(distances_kernel, "20-35 s")
expect(collisions_kernel, "20-35 s")


def _table(model):
    """The model's GeometryTable as the kernels take it (GeometryArrays)."""
    return model.geometry_table.arrays()


def _pairs(model, pairs):
    """The pairs to check: model.collision_pairs, or `pairs` checked: (P, 2) ints, each a
    geometry index, the two different."""
    if pairs is None:
        return model.collision_pairs
    array = np.asarray(pairs)
    if array.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    if array.ndim != 2 or array.shape[1] != 2 or not np.issubdtype(array.dtype, np.integer):
        raise ValueError(
            f"pairs must be a (P, 2) array of geometry indices (ints), got shape {array.shape} "
            f"of {array.dtype}"
        )
    count = len(model.geometries)
    outside = np.any((array < 0) | (array >= count), axis=1)
    bad = np.flatnonzero(outside | (array[:, 0] == array[:, 1]))
    if bad.size:
        a, b = array[bad[0]]
        raise ValueError(
            f"pairs[{bad[0]}] = ({a}, {b}): a pair is two different geometry indices in "
            f"[0, {count}) (model.geometries has {count})"
        )
    return np.ascontiguousarray(array, dtype=np.int64)


def _checked(model, q, data, what):
    """(q as a float64 (nq,) array, the work buffer, the CollisionWork) of a query."""
    work = checks.work_of(model, data, what)
    (q,), batch = checks.as_states(model, q)
    if batch:
        raise ValueError(
            f"{what}: q must be one configuration (nq,) = ({model.nq},), got {q.shape}"
        )
    return q, work


def _collision_work(model, data, pair_count):
    """The Data's CollisionWork (made on its first query), or a fresh one without data=."""
    if data is None:
        return CollisionWork.of(model, pair_count)
    return data.kept(("collision work", pair_count), CollisionWork.of, model, pair_count)


def _raise(status, model, q, what):
    if status == Status.NO_CONVERGENCE.value:
        warnings.warn(
            f"{what}: GJK or EPA stopped short of its tolerance for a pair; its row holds the "
            f"last estimate",
            RuntimeWarning,
            stacklevel=3,
        )
    elif status:
        checks.raise_status(status, model, what, arguments={"q": q})


def distances(model, q, pairs=None, data=None) -> Distances:
    """The signed distances of pairs of the model's collision geometries at q.

    q: one configuration (nq,). pairs: (P, 2) int, indices into model.geometries; default
    model.collision_pairs. data: a Data of the model: the record's arrays are then the Data's
    (overwritten by its next query), and a call allocates nothing after its first.
    Returns a Distances record (pairs, distance, point_a, point_b, normal), in the world frame
    (the root link's), metres; each pair by the narrow phase (closed forms, GJK and EPA).
    """
    checks.check_model(model, "distances")
    q, work = _checked(model, q, data, "distances")
    pairs = _pairs(model, pairs)
    buffers = _collision_work(model, data, len(pairs))
    rows = buffers.rows[: len(pairs)]
    geometry_work = (buffers.T_sg, buffers.hints, buffers.scratch)
    status = distances_kernel(
        model._ibuf, model._fbuf, work, q, _table(model), pairs, geometry_work, rows
    )
    _raise(status, model, q, "distances")
    return Distances(
        pairs,
        rows[:, DISTANCE],
        rows[:, POINT_A : POINT_A + 3],
        rows[:, POINT_B : POINT_B + 3],
        rows[:, NORMAL : NORMAL + 3],
    )


def collisions(model, q, margin=0.0, data=None) -> Contacts:
    """The contacts of the model's default collision pairs (model.collision_pairs) within
    `margin` (m, >= 0) at q: a pair in face-on or edge-on contact (a box on a box or on a
    halfspace, a cylinder on its cap or its side, a mesh's face on another shape) gives up to
    four points, each with its own depth, so that a resting box is held at its corners; every
    other pair its nearest (or deepest) points.

    q: one configuration (nq,). data: a Data of the model: the record's arrays are then views of
    the Data's (overwritten by its next query), and a call allocates nothing after its first.
    Returns a Contacts record (pairs, distance, point_a, point_b, normal; depth = -distance).
    """
    checks.check_model(model, "collisions")
    q, work = _checked(model, q, data, "collisions")
    margin = as_real(margin, "collisions: margin")
    if not margin >= 0.0 or not np.isfinite(margin):
        raise ValueError(f"collisions: margin must be a finite distance >= 0 (m), got {margin}")
    pairs = model.collision_pairs
    buffers = _collision_work(model, data, len(pairs))
    status, count = collisions_kernel(
        model._ibuf,
        model._fbuf,
        work,
        q,
        _table(model),
        pairs,
        margin,
        (buffers.T_sg, buffers.hints, buffers.boxes, buffers.scratch),
        buffers.rows,
        buffers.pair_of,
    )
    _raise(status, model, q, "collisions")
    rows = buffers.rows[:count]
    return Contacts(
        buffers.pair_of[:count],
        rows[:, DISTANCE],
        rows[:, POINT_A : POINT_A + 3],
        rows[:, POINT_B : POINT_B + 3],
        rows[:, NORMAL : NORMAL + 3],
    )
