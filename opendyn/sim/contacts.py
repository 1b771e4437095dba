"""The contacts of a run between collision geometries, as a table: one row per contact point
per recorded sample (their number changes from sample to sample), as opendyn.algorithm.
contact finds them; and any contact's extremes over every step of a run
(ContactExtremes, below the table).

    sample  (C,) int    the sample's index into the trajectory's t
    pair    (C,) int    the pair's index into pair_names
    point   (C, 3) m    the contact point x, midway between the two shapes' deepest points
    normal  (C, 3)      the unit normal n from a towards b
    force   (C, 3) N    the force a applies to b at x (b applies -force to a)
    depth   (C,) m      the penetration delta > 0

all in the world frame; pair_names (P, 2) names the pair's geometries a and b (each
Geometry's name: a robot's <collision name=...> or LINK_k, an object's or a world entry's own,
"ground").
"""

from __future__ import annotations

import pathlib
from dataclasses import dataclass, field

import numpy as np

from .._runtime.files import atomic_write, csv_field
from ..algorithm.contact_extremes import (
    DEEPEST,
    DEEPEST_PAIR,
    DEEPEST_T,
    HEAD,
    LARGEST,
    LARGEST_PAIR,
    LARGEST_T,
    POINTS,
    RUN,
    extremes_room,
)
from ..algorithm.contact import DEPTH, FORCE, NORMAL_AT, PAIR, POINT

COLUMNS = (
    "sample", "pair", "a", "b", "x", "y", "z", "nx", "ny", "nz", "fx", "fy", "fz", "depth",
)


@dataclass
class ContactTable:
    """A run's contact points (module docstring)."""

    sample: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    pair: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    point: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    normal: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    force: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    depth: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pair_names: tuple[tuple[str, str], ...] = ()

    def __len__(self) -> int:
        return len(self.sample)

    @property
    def a(self) -> np.ndarray:
        """(C,) the name of each row's geometry a."""
        return np.array([a for a, _ in self.pair_names] or [""], dtype=str)[self.pair]

    @property
    def b(self) -> np.ndarray:
        """(C,) the name of each row's geometry b."""
        return np.array([b for _, b in self.pair_names] or [""], dtype=str)[self.pair]

    @classmethod
    def of_rows(cls, sample, rows, pair_names) -> ContactTable:
        """The table of rows (C, ROW) in opendyn.algorithm.contact's record layout
        (pair, point, normal, force, depth), each of the sample in sample (C,)."""
        return cls(
            sample=sample,
            pair=rows[:, PAIR].astype(np.int64),
            point=rows[:, POINT : POINT + 3],
            normal=rows[:, NORMAL_AT : NORMAL_AT + 3],
            force=rows[:, FORCE : FORCE + 3],
            depth=rows[:, DEPTH],
            pair_names=pair_names,
        )

    def at(self, k) -> ContactTable:
        """The rows of sample k."""
        keep = self.sample == k
        return ContactTable(
            self.sample[keep], self.pair[keep], self.point[keep], self.normal[keep],
            self.force[keep], self.depth[keep], self.pair_names,
        )

    def deepest(self) -> tuple[float, str]:
        """(the largest depth over the rows, m; "a-b", its pair), (0, "") without rows."""
        if not len(self):
            return 0.0, ""
        k = int(np.argmax(self.depth))
        return float(self.depth[k]), self._pair_label(k)

    def largest_force(self) -> tuple[float, str]:
        """(the largest |force| over the rows, N; "a-b", its pair), (0, "") without rows."""
        if not len(self):
            return 0.0, ""
        magnitude = np.linalg.norm(self.force, axis=1)
        k = int(np.argmax(magnitude))
        return float(magnitude[k]), self._pair_label(k)

    def _pair_label(self, k) -> str:
        a, b = self.pair_names[self.pair[k]]
        return f"{a}-{b}"

    def slots(self, samples, static=()) -> tuple[np.ndarray, np.ndarray]:
        """(points (K, S, 3) m, forces (K, S, 3) N) for K = `samples`: the table as fixed
        slots, one per contact point of each pair (a pair's k-th point of a sample in its k-th
        slot, so that a slot follows one point from sample to sample), zero where a sample has
        none. A slot's force is the one on its pair's moving body: -force (b's on a) when b is
        in `static` (geometry names that never move: the ground, the world's, links welded to
        the world), else force (a's on b). An empty sample's slot holds the point of the slot's
        next sample that has one (else its last), so that playback's arrows shrink in place."""
        rank = np.zeros(len(self), dtype=np.int64)  # a row's index among its pair's at its sample
        seen: dict = {}
        for r, key in enumerate(zip(self.sample.tolist(), self.pair.tolist())):
            rank[r] = seen[key] = seen.get(key, -1) + 1
        pairs = len(self.pair_names)
        width = np.zeros(pairs, dtype=np.int64)
        np.maximum.at(width, self.pair, rank + 1)
        first = np.concatenate([[0], np.cumsum(width)])
        slot = first[self.pair] + rank
        points = np.zeros((samples, int(first[-1]), 3))
        forces = np.zeros_like(points)
        points[self.sample, slot] = self.point
        filled = np.zeros(points.shape[:2], dtype=bool)
        filled[self.sample, slot] = True
        for k in range(points.shape[1]):  # an empty sample holds its slot's nearest point
            at = np.flatnonzero(filled[:, k])
            nearest = at[np.clip(np.searchsorted(at, np.arange(samples)), 0, len(at) - 1)]
            points[:, k] = points[nearest, k]
        flip = np.array([b in static for _, b in self.pair_names] or [False])[self.pair]
        forces[self.sample, slot] = np.where(flip[:, None], -self.force, self.force)
        return points, forces

    def arrays(self) -> dict:
        """The table as named arrays, as a trajectory's .npz keeps them (contacts_*)."""
        return {
            "contacts_sample": self.sample,
            "contacts_pair": self.pair,
            "contacts_point": self.point,
            "contacts_normal": self.normal,
            "contacts_force": self.force,
            "contacts_depth": self.depth,
            "contacts_pair_names": np.array(self.pair_names, dtype=str).reshape(-1, 2),
        }

    @classmethod
    def from_arrays(cls, data) -> ContactTable:
        """The table of a trajectory's .npz (arrays' inverse)."""
        return cls(
            data["contacts_sample"], data["contacts_pair"], data["contacts_point"],
            data["contacts_normal"], data["contacts_force"], data["contacts_depth"],
            tuple((str(a), str(b)) for a, b in data["contacts_pair_names"]),
        )

    def columns(self, t=None) -> dict:
        """{column: (C,) values} in COLUMNS' order, with t (s) after sample when the samples'
        times t (K,) are given."""
        values = {"sample": self.sample}
        if t is not None:
            values["t"] = self._times(t)[self.sample]
        values.update(pair=self.pair, a=self.a, b=self.b)
        for name, array in (("", self.point), ("n", self.normal), ("f", self.force)):
            for r, axis in enumerate("xyz"):
                values[f"{name}{axis}"] = array[:, r]
        values["depth"] = self.depth
        return values

    def _times(self, t) -> np.ndarray:
        """t (K,) s, the samples' times, checked: one per sample the rows name. ValueError
        naming t's length and the samples' otherwise."""
        times = np.asarray(t, dtype=float)
        samples = int(self.sample.max()) + 1 if len(self) else 0
        if times.ndim != 1 or len(times) < samples:
            raise ValueError(
                f"t: expected the samples' times, one per sample (the trajectory's t); found "
                f"t of shape {times.shape}, {times.size} times for the table's {samples} "
                f"samples (its rows name samples 0 to {samples - 1})"
            )
        return times

    def to_csv(self, path, t=None) -> pathlib.Path:
        """One row per contact point (columns: sample, t when given, pair, a, b, x, y, z, nx,
        ny, nz, fx, fy, fz, depth; SI units, world frame), written atomically. A geometry's
        name that holds a comma, a double quote or a line break is quoted (csv_field)."""
        path = pathlib.Path(path)
        values = self.columns(t)
        values["a"], values["b"] = ([csv_field(n) for n in values[s]] for s in ("a", "b"))
        lines = [",".join(values)]
        for k in range(len(self)):
            lines.append(",".join(_cell(column[k]) for column in values.values()))
        with atomic_write(path) as f:
            f.write(("\n".join(lines) + "\n").encode())
        return path

    def to_parquet(self, path, t=None) -> pathlib.Path:
        """The same columns as to_csv, as a Parquet file (pyarrow: pip install
        "opendyn[sweep]"), written atomically."""
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise ImportError(
                'ContactTable.to_parquet needs pyarrow: pip install "opendyn[sweep]"'
            ) from None
        path = pathlib.Path(path)
        table = pa.table(self.columns(t))
        with atomic_write(path) as f:
            pq.write_table(table, f)
        return path


@dataclass
class ContactExtremes:
    """A run's contact at its worst, over every state the integrator stepped through (each
    accepted step, opendyn.algorithm.contact_extremes) and every recorded sample: the samples
    alone miss a contact that begins and ends between two of them.

    pairs (P,): each pair's name, "a-b" of its geometries' names (the geometry contact's
      pairs, as ContactTable.pair_names), or a contact point's name (the spheres' contact:
      each point with the ground)
    depth (P,) m: each pair's largest penetration delta
    limit (P,) m: the depth past which a pair's contact no longer describes two bodies
      touching: half the smaller of its geometries' smallest dimensions (a sphere's radius;
      inf where it has none, as the ground). Deeper, the shortest way out of the overlap may
      lie through the far side of the thinner body, its normal flips, and the spring pulls
      it through instead of pushing it out
    deepest m, deepest_pair, deepest_t s: the largest penetration, its pair (-1: none) and time
    largest_force N, largest_pair, largest_t s: the largest |force| at a contact point, its
      pair and time
    most_points: the most points in contact at once
    every_step: True when the extremes are of every step; False when of the samples alone (a
      rollout's trajectories)
    """

    pairs: tuple[str, ...] = ()
    depth: np.ndarray = field(default_factory=lambda: np.zeros(0))
    limit: np.ndarray = field(default_factory=lambda: np.zeros(0))
    deepest: float = 0.0
    deepest_pair: int = -1
    deepest_t: float = 0.0
    largest_force: float = 0.0
    largest_pair: int = -1
    largest_t: float = 0.0
    most_points: int = 0
    every_step: bool = False

    @classmethod
    def of(cls, touch, rows, t, pairs, limit) -> ContactExtremes:
        """The extremes of a run: its steps' (touch: the step's running extremes, or None
        where it kept none) and its samples' (rows = (sample, pair (C,) int, depth (C,) m,
        force (C,) N) of every point that overlaps at a sample, t (K,) s the samples' times),
        the largest of both; pairs and limit as the fields."""
        run = extremes_room(len(pairs))[RUN] if touch is None else np.array(touch[RUN])
        sample, pair, depth, force = rows
        if len(sample):
            np.maximum.at(run[HEAD:], pair, depth)
            run[POINTS] = max(run[POINTS], np.bincount(sample).max())
            for at, values in ((DEEPEST, depth), (LARGEST, force)):
                k = int(np.argmax(values))
                if values[k] > run[at]:
                    run[at : at + 3] = values[k], pair[k], t[sample[k]]
        return cls(
            pairs=tuple(pairs),
            depth=run[HEAD:],
            limit=np.asarray(limit, dtype=np.float64),
            deepest=float(run[DEEPEST]),
            deepest_pair=int(run[DEEPEST_PAIR]),
            deepest_t=float(run[DEEPEST_T]),
            largest_force=float(run[LARGEST]),
            largest_pair=int(run[LARGEST_PAIR]),
            largest_t=float(run[LARGEST_T]),
            most_points=int(run[POINTS]),
            every_step=touch is not None,
        )

    @property
    def touched(self) -> bool:
        """Whether any pair touched (overlapped) at any step or sample."""
        return self.deepest > 0.0

    def too_deep(self) -> np.ndarray:
        """The pairs (indices) that went deeper than their limit."""
        return np.flatnonzero(self.depth > self.limit)

    def warning(self) -> str:
        """What too_deep's pairs mean, in a sentence; "" when there are none."""
        deep = self.too_deep()
        if not len(deep):
            return ""
        worst = int(deep[np.argmax(self.depth[deep] / self.limit[deep])])
        others = f" (and {len(deep) - 1} other pairs)" if len(deep) > 1 else ""
        return (
            f"contact {self.pairs[worst]!r}{others} went {self.depth[worst]:.3g} m deep, more "
            f"than half its thinner geometry ({self.limit[worst]:.3g} m): past that the "
            "bodies sink through each other rather than touch (the way out of the overlap can "
            "flip), so the run is no contact's. The contact's stiffness is likely too low for "
            "the weight it carries (k delta = m g): raise effects.contact.stiffness (with a "
            "smaller step), or lighten the body"
        )

    def arrays(self) -> dict:
        """The extremes as named arrays, as a trajectory's .npz keeps them (extremes_*)."""
        head = (self.deepest, self.deepest_pair, self.deepest_t, self.largest_force,
                self.largest_pair, self.largest_t, self.most_points, self.every_step)
        return {
            "extremes_head": np.array(head, dtype=np.float64),
            "extremes_depth": self.depth,
            "extremes_limit": self.limit,
            "extremes_pairs": np.array(self.pairs, dtype=str),
        }

    @classmethod
    def from_arrays(cls, data) -> ContactExtremes:
        """The extremes of a trajectory's .npz (arrays' inverse)."""
        deepest, deep_pair, deep_t, largest, large_pair, large_t, most, every = data[
            "extremes_head"
        ]
        return cls(
            tuple(str(name) for name in data["extremes_pairs"]), data["extremes_depth"],
            data["extremes_limit"], float(deepest), int(deep_pair), float(deep_t),
            float(largest), int(large_pair), float(large_t), int(most), bool(every),
        )


def _cell(value) -> str:
    if isinstance(value, (np.floating, float)):
        return repr(float(value))
    return str(value)
