"""The contact's running extremes over a run's steps: the deepest point, the largest force, the
most points at once and each pair's deepest, kept at every step and not only at the samples
(a bounce between two samples is seen).

The room is one array (3, HEAD + P) of three rows, each with the same layout:

    NOW    written by the contact stage at each evaluation of the forces (begin, then note for
           every point that overlaps)
    STEP   the evaluation at the state a step reports (keep_step: the start of a fixed step,
           the end of an accepted adaptive one)
    RUN    the largest over the steps done (fold_step, once per step that is kept)

and within a row

    DEEPEST, DEEPEST_PAIR, DEEPEST_T    the largest penetration delta (m), its pair (-1: none)
                                        and time (s)
    LARGEST, LARGEST_PAIR, LARGEST_T    the largest |f| at a point (N), its pair and time
    POINTS                              how many points overlap (NOW, STEP), the most (RUN)
    TIME                                the evaluation's time t (s)
    HEAD + p                            pair p's largest delta (m)

Every function takes the room or None (a scene without contact: nothing is kept) and allocates
nothing.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.kernel_cache import JIT

NOW, STEP, RUN = range(3)
DEEPEST, DEEPEST_PAIR, DEEPEST_T, LARGEST, LARGEST_PAIR, LARGEST_T, POINTS, TIME = range(8)
HEAD = 8


def extremes_room(pairs: int) -> np.ndarray:
    """(3, HEAD + pairs): an empty room for the extremes of `pairs` contact pairs (nothing
    touched: no pair, zero depth and force)."""
    room = np.zeros((3, HEAD + pairs))
    restart(room)
    return room


@njit(**JIT)
def restart(touch):
    """Forget every extreme (a run starts again)."""
    if touch is None:
        return
    for row in range(3):
        clear(touch, row)


@njit(**JIT)
def clear(touch, row):
    """Row `row` of the room as if nothing touched."""
    touch[row, :] = 0.0
    touch[row, DEEPEST_PAIR] = -1.0
    touch[row, LARGEST_PAIR] = -1.0


@njit(**JIT)
def begin(touch, t):
    """A new evaluation of the contact forces at time t (s): NOW starts empty."""
    if touch is None:
        return
    clear(touch, NOW)
    touch[NOW, TIME] = t


@njit(**JIT)
def note(touch, p, delta, force):
    """Pair p overlaps by delta (m) at a point, with |f| = force (N) there: NOW keeps it where
    it is the deepest or the largest of this evaluation."""
    if touch is None:
        return
    now = touch[NOW]
    now[POINTS] += 1.0
    now[HEAD + p] = max(now[HEAD + p], delta)
    if delta > now[DEEPEST]:
        now[DEEPEST], now[DEEPEST_PAIR], now[DEEPEST_T] = delta, p, now[TIME]
    if force > now[LARGEST]:
        now[LARGEST], now[LARGEST_PAIR], now[LARGEST_T] = force, p, now[TIME]


@njit(**JIT)
def keep_step(touch):
    """The evaluation just done (NOW) is the one at the state the step reports: STEP <- NOW."""
    if touch is None:
        return
    touch[STEP, :] = touch[NOW, :]


@njit(**JIT)
def fold_step(touch):
    """The step is kept: RUN <- the larger of RUN and STEP, field by field."""
    if touch is None:
        return
    step, run = touch[STEP], touch[RUN]
    for at in (DEEPEST, LARGEST):
        if step[at] > run[at]:
            run[at], run[at + 1], run[at + 2] = step[at], step[at + 1], step[at + 2]
    run[POINTS] = max(run[POINTS], step[POINTS])
    for p in range(HEAD, run.shape[0]):
        run[p] = max(run[p], step[p])
