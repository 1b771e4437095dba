"""Checks of the public functions' plain options (switches, counts, times), shared so that every
function refuses a value of the wrong kind the same way: a TypeError naming the function, the
argument and what it got, or a ValueError for a number out of its range. The dynamics
functions' arrays have their own checks (opendyn.algorithm.checks)."""

from __future__ import annotations

import math
import numbers

import numpy as np


def flag(value, name: str) -> bool:
    """value as a bool when it is True or False (numpy's too); else a TypeError naming `name`
    ("identify: friction"): a switch given "no" or 0.5 would otherwise count as on."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError(f"{name} must be True or False, got {value!r}")


def whole(value, name: str, minimum: int = 1) -> int:
    """value as an int when it is a whole number (not a bool) of at least `minimum`; else a
    TypeError (not a whole number) or ValueError (too small) naming `name`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a whole number, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {value}")
    return int(value)


def finite(value, name: str) -> float:
    """value as a float when it is a finite real number (not a bool); else a TypeError (not a
    number) or ValueError (inf or NaN) naming `name`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return float(value)
