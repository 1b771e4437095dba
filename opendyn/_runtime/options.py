"""Checks of the public functions' plain options (switches, counts, times) and numbers (a real,
an array of real numbers as float64), shared so that every function refuses a value of the
wrong kind the same way: a TypeError naming the function, the argument and what it got, or a
ValueError for a number out of its range. The dynamics functions' arrays of a model's sizes have
their own checks (opendyn.algorithm.checks)."""

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


F64 = np.dtype(np.float64)
# what an array holds, by numpy dtype kind, when it is not real numbers (kinds i, u, f)
NOT_NUMBERS = {
    "b": "booleans",
    "c": "complex numbers",
    "U": "text",
    "S": "bytes",
    "O": "Python objects",
    "M": "dates",
    "m": "time spans",
    "V": "raw records",
}


def short_repr(value, limit=40):
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def as_float_array(x, name, expected="an array of numbers (integers or floats)"):
    """x as a float64 array (no copy when it is one already). Its entries must be real
    numbers, integers or floats: booleans, complex numbers, text (['0.3', '-0.2']) or objects
    are a TypeError naming `name`, what was `expected` and what was found, never converted; a
    ragged nesting of lists is a ValueError."""
    try:
        a = np.asarray(x)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be an array of numbers, got {type(x).__name__} {short_repr(x)} "
            "(rows of different lengths?)"
        ) from None
    if a.dtype is F64:
        return a
    if a.dtype.kind not in "iuf":
        found = NOT_NUMBERS.get(a.dtype.kind, "something else")
        raise TypeError(
            f"{name} must be {expected}, got {found} (dtype {a.dtype}): {short_repr(x)}"
        )
    return a.astype(np.float64, copy=False)


def as_real(x, name):
    """x as a float: a real number (an int, a float or a 0-d array of one), else a TypeError
    (or, for an array of several, a ValueError) naming `name`."""
    a = as_float_array(x, name, "a real number (an int or a float)")
    if a.ndim != 0:
        raise ValueError(f"{name} must be a single number, got shape {a.shape}")
    return float(a)
