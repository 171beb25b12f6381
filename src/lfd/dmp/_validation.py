"""Boundary checks for the public DMP API: clear ``ValueError`` messages naming the argument."""

from __future__ import annotations

import math
import numbers

import numpy as np


def positive_int(name: str, value) -> int:
    """``value`` as an ``int >= 1``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def positive_float(name: str, value) -> float:
    """``value`` as a finite ``float > 0``."""
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Real)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def open_unit_float(name: str, value) -> float:
    """``value`` as a ``float`` strictly between 0 and 1."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0.0 < value < 1.0:
        raise ValueError(f"{name} must be a number in (0, 1), got {value!r}")
    return float(value)


def finite_array(name: str, value, ndims: tuple[int, ...], *, copy: bool = True) -> np.ndarray:
    """``value`` as a float64 array with one of ``ndims`` dimensions and no NaN/inf: a new one,
    or with ``copy=False`` ``value`` itself when it already is a writeable float64 array (for
    callers that only read it)."""
    try:
        array = np.array(value, dtype=np.float64) if copy else np.asarray(value, dtype=np.float64)
        if not array.flags.writeable:  # torch.from_numpy warns on read-only memory
            array = array.copy()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array, got {type(value).__name__}") from exc
    if array.ndim not in ndims:
        expected = " or ".join(f"{n}-D" for n in ndims)
        raise ValueError(f"{name} must be {expected}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or inf")
    return array


def time_grid(t, *, min_samples: int, name: str = "t") -> np.ndarray:
    """Sample times in seconds: 1-D, finite, strictly increasing, at least ``min_samples`` long."""
    times = finite_array(name, t, (1,))
    if times.shape[0] < min_samples:
        raise ValueError(f"{name} needs at least {min_samples} samples, got {times.shape[0]}")
    if np.any(np.diff(times) <= 0):
        raise ValueError(f"{name} must be strictly increasing")
    return times


def demonstration(t, y) -> tuple[np.ndarray, np.ndarray]:
    """A demonstration ``(t (T,), y (T, D) or (B, T, D))`` with ``T >= 3``."""
    times = time_grid(t, min_samples=3)
    positions = finite_array("y", y, (2, 3))
    if positions.shape[-2] != times.shape[0]:
        raise ValueError(
            f"y must have shape (T, D) or (B, T, D) with T = len(t) = {times.shape[0]}, got {positions.shape}"
        )
    return times, positions
