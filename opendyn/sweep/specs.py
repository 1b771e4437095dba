"""A sweep's specs: what each varied key takes (a list, a grid or a distribution), and the runs
they make.

    runs = lists x grids                  every combination (no samples)
    runs = N draws of (key_1, ..., key_m)   samples = N: each key drawn on its own from one seeded
                                          generator; a distribution draws a value, a list or a
                                          grid one of its values, uniformly
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import numbers

import numpy as np

from ..errors import SweepError

# more runs than this is a mistake in a spec (a grid of 1e3 points on each of 4 keys), not a sweep
MAX_RUNS = 10_000_000
# the distributions a spec can name, with their parameters
DISTRIBUTIONS = {"uniform": ("lo", "hi"), "normal": ("mu", "sigma")}
SPEC_FORMS = (
    "a list 'a,b,c', a grid 'lo:hi:n' or 'log:lo:hi:n', or a distribution 'uniform:lo:hi' or "
    "'normal:mu:sigma'"
)


@dataclasses.dataclass(frozen=True)
class Axis:
    """One varied key: values (a list or grid) or a distribution (kind, parameters).

    key: dotted scene key; spec: the spec as written (for the results' record); log: a
    logarithmic grid (plots use a log axis)."""

    key: str
    spec: str
    values: tuple = ()
    distribution: tuple = ()
    log: bool = False

    def draw(self, rng, n) -> list:
        """n values: a distribution's draws, or values picked uniformly from the list or grid."""
        if self.distribution:
            kind, a, b = self.distribution
            x = rng.uniform(a, b, n) if kind == "uniform" else rng.normal(a, b, n)
            return [float(v) for v in x]
        return [self.values[i] for i in rng.integers(len(self.values), size=n)]


def parse_axis(key, spec) -> Axis:
    """The Axis of `key` from a spec: a string in one of SPEC_FORMS, or a sequence of values."""
    if not isinstance(key, str) or not key or any(not part for part in key.split(".")):
        raise SweepError(f"vary: {key!r} is not a dotted scene key (e.g. 'control.kp')")
    if isinstance(spec, (list, tuple, np.ndarray)):
        values = tuple(_plain(v) for v in spec)
        if not values:
            raise SweepError(f"vary {key}: an empty list of values")
        return Axis(key, ",".join(map(str, values)), values=values)
    if isinstance(spec, (numbers.Real, bool)):
        return Axis(key, str(spec), values=(_plain(spec),))
    if not isinstance(spec, str):
        raise SweepError(f"vary {key}: expected {SPEC_FORMS}, found {spec!r}")
    fields = spec.split(":")
    head = fields[0].strip()

    def numbers_of(parts, names):
        if len(parts) != len(names):
            raise SweepError(
                f"vary {key}={spec}: expected {head}:{':'.join(names)}, found {len(parts)} "
                f"field(s) after '{head}:'"
            )
        out = []
        for name, text in zip(names, parts):
            x = _number(text)
            if x is None or not math.isfinite(x):
                raise SweepError(f"vary {key}={spec}: {name} = {text!r} is not a finite number")
            out.append(x)
        return out

    if head in DISTRIBUTIONS:
        a, b = numbers_of(fields[1:], DISTRIBUTIONS[head])
        if head == "uniform" and not a < b:
            raise SweepError(f"vary {key}={spec}: uniform needs lo < hi")
        if head == "normal" and not b > 0:
            raise SweepError(f"vary {key}={spec}: normal needs sigma > 0")
        return Axis(key, spec, distribution=(head, a, b))
    if head == "log" or len(fields) == 3:
        log = head == "log"
        lo, hi, n = numbers_of(fields[1:] if log else fields, ("lo", "hi", "n"))
        if n != int(n) or n < 1:
            raise SweepError(f"vary {key}={spec}: n = {n:g} must be a whole number >= 1")
        if n > MAX_RUNS:  # before the grid is made: 1e9 points would fill the memory
            raise SweepError(f"vary {key}={spec}: n = {n:,.0f} points, more than {MAX_RUNS:,}")
        if log and not (lo > 0 and hi > 0):
            raise SweepError(f"vary {key}={spec}: a log grid needs lo > 0 and hi > 0")
        grid = np.geomspace(lo, hi, int(n)) if log else np.linspace(lo, hi, int(n))
        return Axis(key, spec, values=tuple(float(v) for v in grid), log=log)
    if ":" in spec:
        raise SweepError(f"vary {key}={spec}: expected {SPEC_FORMS}")
    values = tuple(_value(text.strip()) for text in spec.split(","))
    if any(v == "" for v in values):
        raise SweepError(f"vary {key}={spec}: an empty value in the list")
    return Axis(key, spec, values=values)


def _number(text):
    """The number a spec's field writes, or None: "0_2" (Python's digit separators) is not
    one, as it is not in a scene file."""
    if "_" in text:
        return None
    try:
        return float(text)
    except ValueError:
        return None


def _value(text):
    """A list entry as the scene file would hold it: a number, true/false, or a string."""
    if text in ("true", "false"):
        return text == "true"
    x = _number(text)
    return text if x is None else x


def _plain(v):
    """A numpy scalar as the Python number it holds (the scene reader and Parquet want them)."""
    return v.item() if isinstance(v, np.generic) else v


def check_whole(value, key, minimum):
    """SweepError naming `key` unless value is a whole number (not a bool) >= minimum."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise SweepError(f"{key}: expected a whole number >= {minimum}, found {value!r}")


def combinations(axes, samples=None, seed=0) -> list[dict]:
    """The runs' values [{key: value}], in run order: every combination of the axes (their
    lists and grids multiply; the last axis varies fastest) or, with `samples` = N, N draws
    from np.random.default_rng(seed), one axis after another."""
    if samples is None:
        for axis in axes:
            if axis.distribution:
                raise SweepError(
                    f"vary {axis.key}={axis.spec} is a distribution: give samples=N "
                    f"(--samples N) for N random runs"
                )
        count = math.prod(len(a.values) for a in axes)
        if count > MAX_RUNS:
            raise SweepError(
                f"the grids multiply to {count:,} runs, more than {MAX_RUNS:,}; use fewer "
                f"points, or draw samples=N random combinations"
            )
        keys = [a.key for a in axes]
        return [dict(zip(keys, combo)) for combo in itertools.product(*(a.values for a in axes))]
    check_whole(samples, "samples", 1)
    if samples > MAX_RUNS:
        raise SweepError(f"samples: {samples:,} runs, more than {MAX_RUNS:,}")
    rng = np.random.default_rng(seed)
    columns = [axis.draw(rng, int(samples)) for axis in axes]
    return [dict(zip((a.key for a in axes), row)) for row in zip(*columns)]


def spans_decades(values) -> bool:
    """Whether a list of positive numbers spans more than a decade (drawn on a log axis)."""
    numbers_only = [v for v in values if isinstance(v, float)]
    return (
        len(numbers_only) == len(values) > 2
        and min(numbers_only) > 0
        and max(numbers_only) >= 10 * min(numbers_only)
    )
