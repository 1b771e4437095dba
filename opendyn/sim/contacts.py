"""The contacts of a run between collision geometries, as a table: one row per contact point
per recorded sample (their number changes from sample to sample), as opendyn.algorithm.
geometry_contact finds them.

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
            values["t"] = np.asarray(t)[self.sample]
        values.update(pair=self.pair, a=self.a, b=self.b)
        for name, array in (("", self.point), ("n", self.normal), ("f", self.force)):
            for r, axis in enumerate("xyz"):
                values[f"{name}{axis}"] = array[:, r]
        values["depth"] = self.depth
        return values

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


def _cell(value) -> str:
    if isinstance(value, (np.floating, float)):
        return repr(float(value))
    return str(value)
